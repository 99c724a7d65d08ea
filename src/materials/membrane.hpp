// Triangle FEM membrane (cloth stretching and shearing): a linear triangle x0, x1, x2 in 3D with
// the 3x2 deformation gradient F = [x1 - x0, x2 - x0] Dm^-1, Dm the rest edges in an orthonormal
// frame of the rest plane. The energy is A psi(F), A the rest area, psi written in the invariants
// I1 = tr C and J = sqrt(det C) of C = F^T F, so no SVD is needed. J = |n| / (2A) with
// n = (x1 - x0) x (x2 - x0) is never negative: a membrane cannot invert, it folds in 3D.
// Dofs are stacked x = (x0, x1, x2). Per-element math only (no PETSc).
#pragma once
#include <Eigen/Dense>
#include <array>

#include "materials/cloth_models.hpp"
#include "materials/material.hpp"

namespace hyperqn {
namespace membrane {

using Vec9 = Eigen::Matrix<double, 9, 1>;
using Mat3x2 = Eigen::Matrix<double, 3, 2>;

struct TriangleRest {
  Eigen::Matrix2d Dm_inv;  // inverse of the 2x2 rest edge matrix (upper triangular, det > 0)
  double area;             // rest area A
};

// Rest data. Throws std::invalid_argument if the rest area is not positive, or collinear up to
// roundoff (area <= 1e-14 * longest edge^2); the caller, which knows the element's index, reports it.
TriangleRest rest(const Vec3& X0, const Vec3& X1, const Vec3& X2);

// psi(I1, J), mu and lambda the 2D (plane-stress) Lame constants:
// stvk:       E = (C - I)/2, psi = mu tr(E^2) + lambda/2 (tr E)^2
// corotated:  psi = mu ||F - R||^2 + lambda/2 (tr(R^T F) - 2)^2 = mu (I1 - 2 s + 2) + lambda/2 (s - 2)^2,
//             s = sigma1 + sigma2 = sqrt(I1 + 2J)
// neohookean: psi = mu/2 (I1 - 2) - mu log J + lambda/2 (log J)^2, +inf at J = 0 (a collapsed triangle)

Mat3x2 deformation_gradient(const TriangleRest& r, const Vec9& x);

// E = A psi. neohookean: +inf (never NaN) for a collapsed triangle (J = 0).
double energy(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x);
// Returns E and fills g = dE/dx. For a collapsed neohookean triangle the energy is +inf and g is
// the (finite) gradient at J floored to 1e-12: the caller's line search rejects the point anyway.
double energy_gradient(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x, Vec9& g);
// d2E/dx2 (symmetric). psd: negative eigenvalues clamped to 0 (the Newton definiteness fix).
Mat9 hessian(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x, bool psd);

// The membrane's Cauchy stress sigma = P F^T / J at x (P = dpsi/dF, 3 x 2; J the area ratio): a
// force per deformed length (the units of mu), a symmetric 3 x 3 tensor in the deformed plane, from
// energy_gradient's dE/dx (sigma = (g1 e1^T + g2 e2^T) / a, e the deformed edges, g their forces,
// a = A J the deformed area).
Mat3 cauchy_stress(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x);

// The largest principal stretch sigma_1 of F.
double max_stretch(const TriangleRest& r, const Vec9& x);

// Weight w of the triangle in L = sum_e w A_e (G_e^T G_e (x) I3): 2 mu + lambda for all three
// models. At rest all three have the same Hessian of psi (linear plane-stress elasticity), whose
// stiffest in-plane mode, a uniaxial stretch, has stiffness 2 mu + lambda (as the 3D materials'
// weight, which the tets use).
double laplacian_weight(Model m, double mu, double lambda);

// A G^T G (3x3, row-major), G the 2x3 gradients of the basis functions in the rest frame: the
// triangle's cotangent Laplacian. Rows sum to 0; positive semidefinite. L is assembled from it.
std::array<double, 9> basis_gram(const TriangleRest& r);

}  // namespace membrane
}  // namespace hyperqn

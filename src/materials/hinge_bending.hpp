// Bending of a thin shell (cloth) across an interior edge: a hinge of two triangles sharing the
// edge x0 x1. Vertex order (12 dofs, stacked x0, x1, x2, x3): x0, x1 the shared edge; x2 the vertex
// opposite it in triangle 1 = (x0, x1, x2); x3 the one in triangle 2 = (x1, x0, x3). The two
// triangles are thus consistently oriented, and their normals
//   n1 = (x1 - x0) x (x2 - x0),   n2 = (x0 - x1) x (x3 - x1)
// agree on a flat hinge. Per-element math only (no PETSc).
#pragma once
#include <Eigen/Dense>
#include <array>

#include "materials/material.hpp"

namespace hyperqn {
namespace hinge {

using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12>;

// ---- Quadratic bending (Bergou, Wardetzky, Harmon, Zorin, Grinspun 2006) ----
// E = 1/2 k x^T (Q (x) I3) x, Q = c w w^T, c = 3 / (A1 + A2), w from the cotangents of the rest
// hinge's interior angles (alpha_i at x0, beta_i at x1 in triangle i):
//   w = (cot b1 + cot b2, cot a1 + cot a2, -cot a1 - cot b1, -cot a2 - cot b2),
// Bergou's (c03 + c04, c01 + c02, -c01 - c03, -c02 - c04) in this vertex order (w . x is |e| times
// the jump of the normal derivative of x across the edge). sum w_i = 0 and, for a planar rest hinge,
// sum w_i X_i = 0: Q annihilates every affine map of a flat rest hinge (rigid motions, in-plane
// stretching), so E is 0 at a flat rest state. It assumes one: a curved rest hinge has E > 0 at
// rest. Decks with curved rest surfaces should use dihedral bending.
// Both throw std::invalid_argument if a rest triangle has no area.
std::array<double, 4> quadratic_weights(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3);
double quadratic_coefficient(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3);

double quadratic_energy(double k, const std::array<double, 4>& w, double coefficient, const Vec12& x);
double quadratic_energy_gradient(double k, const std::array<double, 4>& w, double coefficient, const Vec12& x,
                                 Vec12& g);
// k Q (x) I3: constant and positive semidefinite (rank 3).
Mat12 quadratic_hessian(double k, const std::array<double, 4>& w, double coefficient);

// ---- Dihedral bending (Grinspun, Hirani, Desbrun, Schroeder 2003, "Discrete shells") ----
// E = k (theta - theta0)^2 * 3 |e|^2 / (A1 + A2), with |e|, A1, A2 at rest and theta - theta0
// wrapped into (-pi, pi].
//
// theta = atan2((n1 x n2) . e/|e|, n1 . n2) in (-pi, pi], e = x1 - x0: 0 for a flat hinge;
// NEGATIVE when the wings x2, x3 fold towards the side the normals point to (a valley seen from
// that side), positive when they fold away from it. E.g. x0 = 0, x1 = (1,0,0), x2 = (0.5,1,0),
// x3 = (0.5,0,1): n1 = +z, x3 is lifted to +z by 90 degrees, theta = -pi/2.
struct HingeRest {
  double theta0;  // rest dihedral angle
  double weight;  // 3 |e|^2 / (A1 + A2) at rest
};
// Throws std::invalid_argument if a rest triangle has no area.
HingeRest hinge_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3);

double dihedral_angle(const Vec12& x);
// Returns theta and fills dtheta/dx.
double dihedral_angle_gradient(const Vec12& x, Vec12& dtheta);

double dihedral_energy(double k, const HingeRest& r, const Vec12& x);
double dihedral_energy_gradient(double k, const HingeRest& r, const Vec12& x, Vec12& g);
// d2E/dx2 = 2 k weight (grad theta grad theta^T + (theta - theta0) d2theta/dx2), with the exact
// analytic d2theta/dx2 (the Jacobian of the angle gradient). psd: eigenvalues clamped at 0.
Mat12 dihedral_hessian(double k, const HingeRest& r, const Vec12& x, bool psd);

}  // namespace hinge
}  // namespace hyperqn

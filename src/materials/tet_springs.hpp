// Mass-spring energy on the edges of a tetrahedron (volumetric mass-spring bodies): a spring of
// stiffness k along each of the tet's 6 edges, E_e = sum_j k/2 (|F D_j| - L_j)^2, where D_j are
// the rest edge vectors (so F D_j is the deformed edge) and L_j = |D_j|. An edge shared by m tets
// thus carries m springs. Written as a function of F so the element code (forces, Hessian
// assembly) is the one of the continuum materials; unlike them, these are energies per element,
// not per unit volume.
#pragma once
#include <Eigen/Dense>

#include "materials/material.hpp"

namespace hyperqn {

namespace tet_springs {

// The rest edges from the rest edge matrix Dm = [X1 - X0, X2 - X0, X3 - X0].
void rest_edges(const Mat3& Dm, Vec3 D[6]);
// Element energy, and P = dE_e/dF.
double energy(const Mat3& F, const Mat3& Dm, double k);
double energy_and_stress(const Mat3& F, const Mat3& Dm, double k, Mat3& P);
// dP/dF (vec(F) column-major); psd: each spring's transverse stiffness k (1 - L/l) clamped at 0
// (the Newton definiteness fix; exact otherwise).
Mat9 stress_derivative(const Mat3& F, const Mat3& Dm, double k, bool psd);
// L_e = sum_j k (e_a - e_b)(e_a - e_b)^T over the edges (a, b): the springs' PD/quasi-Newton matrix.
Eigen::Matrix4d laplacian(double k);

}  // namespace tet_springs

}  // namespace hyperqn

// What the output frames report of an element's deformation and stress (deck output.fields,
// docs/outputs.md#element-fields), from its deformation gradient F and the first Piola-Kirchhoff
// stress P = dpsi/dF that the energy's own kernel computed: no material formula is repeated here.
// Header-only; no PETSc.
#pragma once
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "materials/material.hpp"

namespace hyperqn {
namespace stress_measures {

// The symmetric part of a 3 x 3 matrix: a stress of an isotropic or fibre energy is symmetric up to
// round-off; the files hold it exactly symmetric.
inline Mat3 symmetric(const Mat3& A) { return 0.5 * (A + A.transpose()); }

// Cauchy stress sigma = P F^T / J from P of a 3 x 3 F (J = det F) or of a membrane's 3 x 2 F (J its
// area ratio, so sigma is a force per deformed length, in the deformed plane).
template <int Cols>
Mat3 cauchy(const Eigen::Matrix<double, 3, Cols>& F, const Eigen::Matrix<double, 3, Cols>& P, double J) {
  return symmetric(P * F.transpose() / J);
}

// von Mises stress sqrt(3/2 s:s), s = sigma - tr(sigma)/3 I the deviator.
inline double von_mises(const Mat3& sigma) {
  const Mat3 s = sigma - (sigma.trace() / 3.0) * Mat3::Identity();
  return std::sqrt(1.5 * s.squaredNorm());
}

// The principal stretches, the singular values of F (square roots of the eigenvalues of C = F^T F),
// descending; never negative (an inverted tet shows in det F, not here). The closed form
// (computeDirect) is fast and accurate to round-off unless two eigenvalues nearly coincide: off by
// about eps times the spread over the gap, up to 1e-9 for a uniaxial stretch. Those few go through
// Eigen's QR iteration, accurate to round-off.
inline Vec3 principal_stretches(const Mat3& F) {
  const Mat3 C = F.transpose() * F;
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  eig.computeDirect(C, Eigen::EigenvaluesOnly);  // ascending
  Vec3 c = eig.eigenvalues();
  if (std::min(c(1) - c(0), c(2) - c(1)) < 1e-3 * (c(2) - c(0))) c = eig.compute(C, Eigen::EigenvaluesOnly).eigenvalues();
  return Vec3(std::sqrt(std::max(c(2), 0.0)), std::sqrt(std::max(c(1), 0.0)), std::sqrt(std::max(c(0), 0.0)));
}

// Green-Lagrange strain E = (F^T F - I) / 2.
inline Mat3 green_strain(const Mat3& F) { return 0.5 * (F.transpose() * F - Mat3::Identity()); }

}  // namespace stress_measures
}  // namespace hyperqn

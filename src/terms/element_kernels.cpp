#include "terms/element_kernels.hpp"

namespace hyperqn {

Eigen::Matrix<double, 9, 12> deformation_jacobian(const Mat3& Dm_inv) {
  Eigen::Matrix<double, 9, 12> B = Eigen::Matrix<double, 9, 12>::Zero();
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 3; ++j) {
      const double g = k == 0 ? -Dm_inv.col(j).sum() : Dm_inv(k - 1, j);
      for (int i = 0; i < 3; ++i) B(i + 3 * j, 3 * k + i) = g;
    }
  return B;
}

// (The mass term then makes M + h^2 K SPD.) Fixed-size Eigen types: no heap allocation.
Mat9 project_psd(const Mat9& C) {
  if (Eigen::LLT<Mat9>(C).info() == Eigen::Success) return C;  // positive definite: cheap exit
  const Eigen::SelfAdjointEigenSolver<Mat9> eig(C);
  if (eig.eigenvalues()(0) >= 0) return C;  // sorted ascending; PSD already, keep it exact
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace hyperqn

// Tets of hyperelastic materials (corotated, Neo-Hookean, StVK, principal-stretch, fibres):
// E = sum_e V_e psi_m(F_e), and L_e = w_m V_e G_e^T G_e with G_e the gradients of the 4
// barycentric shape functions and w_m the material's weight (or the deck's laplacian_weight).
#pragma once
#include <memory>

#include "terms/tet_elements.hpp"

namespace hyperqn {

class ContinuumTets : public TetElements {
 public:
  // materials[m]: the material of cells with cell_material m, or null where another term holds
  // them; weight[m] its weight in L; density[m] its mass per rest volume.
  ContinuumTets(const DistributedMesh& mesh, std::vector<std::unique_ptr<Material>> materials,
                std::vector<double> weight, std::vector<double> density);
  std::string name() const override;
  bool projective_dynamics_exact() const override;
  // h0: volumetric (docs/method.md#the-initial-hessian-h0): per tet V (mu G^T G (x) I3 + c (lambda + mu) d d^T),
  // d = vec G the rest divergence, c = kVolumetricShare, mu and lambda from the material's dP/dF at F = I.
  PetscErrorCode add_volumetric_h0(Mat A, double scale) const override;
  // The share of the rest volumetric stiffness kept: measured on the stability suite
  // (docs/records/2026-12-03-volumetric-h0.md; 0.25 and 0.75 did worse).
  static constexpr double kVolumetricShare = 0.5;

 private:
  double element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const override;
  void element_energy_batch(size_t k, int m, StressBatch& b, int n) const override;
  Mat9 element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const override;
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> element_laplacian(PetscInt k, int m, double scale) const override;
  double tet_weight(size_t, int m) const override { return weight_[m]; }

  std::vector<std::unique_ptr<Material>> materials_;
  std::vector<double> weight_;
};

}  // namespace hyperqn

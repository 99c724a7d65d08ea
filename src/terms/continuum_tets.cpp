#include "terms/continuum_tets.hpp"

namespace hyperqn {

ContinuumTets::ContinuumTets(const DistributedMesh& mesh, std::vector<std::unique_ptr<Material>> materials,
                             std::vector<double> weight, std::vector<double> density)
    : TetElements(mesh, cells_where(mesh, [&](int m) { return materials[m] != nullptr; }), std::move(density), true),
      materials_(std::move(materials)),
      weight_(std::move(weight)) {}

std::string ContinuumTets::name() const {
  std::string s;
  for (const auto& m : materials_)
    if (m) s += (s.empty() ? "" : ", ") + m->name();
  return s;
}

// PD's local-global step is exact for a PD energy (ARAP) with its own weight in L.
bool ContinuumTets::projective_dynamics_exact() const {
  for (size_t m = 0; m < materials_.size(); ++m)
    if (materials_[m] && (!materials_[m]->projective_dynamics_exact() || weight_[m] != materials_[m]->laplacian_weight()))
      return false;
  return true;
}

double ContinuumTets::element_energy(PetscInt, int m, const Mat3& F, Mat3* P) const {
  return P ? materials_[m]->energy_and_stress(F, *P) : materials_[m]->energy(F);
}

void ContinuumTets::element_energy_batch(size_t, int m, StressBatch& b, int n) const {
  materials_[m]->energy_and_stress_batch(b, n);
}

Mat9 ContinuumTets::element_stress_derivative(PetscInt, int m, const Mat3& F, bool psd) const {
  return psd ? project_psd(materials_[m]->stress_derivative(F)) : materials_[m]->stress_derivative(F);
}

Eigen::Matrix<double, 4, 4, Eigen::RowMajor> ContinuumTets::element_laplacian(PetscInt k, int m, double scale) const {
  return weighted_laplacian(k, scale * weight_[m]);
}

}  // namespace hyperqn

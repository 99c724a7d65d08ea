#include "terms/continuum_tets.hpp"

#include "terms/element_kernels.hpp"

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

// mu |grad u|^2 + (lambda + mu) (div u)^2 integrates to the rest stiffness where the boundary terms
// vanish (mu grad u : grad u^T -> mu (div u)^2); the Laplacian part is rotation invariant, the
// divergence part is not, so only a share of it is kept.
PetscErrorCode ContinuumTets::add_volumetric_h0(Mat A, double scale) const {
  PetscFunctionBeginUser;
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> Ke;
  PetscInt idx[12];
  for (size_t k = 0; k < cells_.size(); ++k) {
    const int m = mesh_.cell_material[cells_[k]];
    // Isotropic dP/dF at rest: lambda vec(I) vec(I)^T + mu (I + transpose); F(i, j) is entry i + 3 j.
    const Mat9 C = materials_[m]->stress_derivative(Mat3::Identity());
    const double lambda = C(0, 4), mu = C(1, 3);
    const double V = scale * volume_[k];
    const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> Le = weighted_laplacian(k, scale * mu);
    Eigen::Matrix<double, 12, 1> d;  // d^T u = div u, u the 4 vertices' displacements
    const Mat3 Dmi = Dm_inv(k);
    for (int r = 0; r < 3; ++r) {
      d(r) = -(Dmi(0, r) + Dmi(1, r) + Dmi(2, r));
      for (int j = 1; j < 4; ++j) d(3 * j + r) = Dmi(j - 1, r);
    }
    Ke = (kVolumetricShare * (lambda + mu) * V) * (d * d.transpose());
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int r = 0; r < 3; ++r) Ke(3 * i + r, 3 * j + r) += Le(i, j);
    element_dofs<4>(mesh_, &mesh_.cells[4 * cells_[k]], idx);
    PetscCall(MatSetValues(A, 12, idx, 12, idx, Ke.data(), ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

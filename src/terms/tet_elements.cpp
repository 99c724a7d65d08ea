#include "terms/tet_elements.hpp"

namespace hyperqn {

TetElements::TetElements(const DistributedMesh& mesh, std::vector<PetscInt> cells, std::vector<double> density,
                         bool per_volume)
    : mesh_(mesh), cells_(std::move(cells)), density_(std::move(density)) {
  Dm_inv_.reserve(cells_.size());
  Dm_.reserve(cells_.size());
  volume_.reserve(cells_.size());
  for (PetscInt c : cells_) {
    const Mat3 Dm = edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]);
    Dm_inv_.push_back(Dm.inverse());
    Dm_.push_back(Dm);
    volume_.push_back(Dm.determinant() / 6.0);  // cells are positively oriented by clean_mesh
    weight_.push_back(per_volume ? volume_.back() : 1.0);
  }
}

PetscErrorCode TetElements::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e = *energy;
  Mat3 P;
  for (size_t k = 0; k < cells_.size(); ++k) {
    const PetscInt* cell = &mesh_.cells[4 * cells_[k]];
    const Mat3 F = edge_matrix(pos.data(), cell) * Dm_inv_[k];
    const int m = mesh_.cell_material[cells_[k]];
    const double w = weight_[k];
    if (!gradient) {
      e += w * element_energy(k, m, F, nullptr);
      continue;
    }
    e += w * element_energy(k, m, F, &P);
    // dE/dx_k = w P Dm^{-T} e_k for k = 1..3; vertex 0 gets minus their sum.
    const Mat3 H = w * P * Dm_inv_[k].transpose();
    add_vertex_vector(mesh_, cell[0], -H.rowwise().sum(), gradient);
    for (int j = 1; j < 4; ++j) add_vertex_vector(mesh_, cell[j], H.col(j - 1), gradient);
  }
  *energy = e;
  PetscFunctionReturn(0);
}

PetscErrorCode TetElements::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> Ke;  // row-major: the layout MatSetValues reads
  PetscInt idx[12];
  PetscFunctionBeginUser;
  for (size_t k = 0; k < cells_.size(); ++k) {
    const PetscInt* cell = &mesh_.cells[4 * cells_[k]];
    const Mat3 F = edge_matrix(pos.data(), cell) * Dm_inv_[k];
    const Mat9 C = element_stress_derivative(k, mesh_.cell_material[cells_[k]], F, psd);
    const Eigen::Matrix<double, 9, 12> B = deformation_jacobian(Dm_inv_[k]);
    Ke.noalias() = (scale * weight_[k]) * (B.transpose() * (C * B));
    // Average with the transpose so H is exactly symmetric whatever the rounding above.
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < i; ++j) Ke(i, j) = Ke(j, i) = 0.5 * (Ke(i, j) + Ke(j, i));
    element_dofs<4>(mesh_, cell, idx);
    PetscCall(MatSetValues(H, 12, idx, 12, idx, Ke.data(), ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode TetElements::add_laplacian(Mat A, double scale, int components) const {
  PetscFunctionBeginUser;
  for (size_t k = 0; k < cells_.size(); ++k)
    PetscCall(add_element_laplacian<4>(mesh_, A, &mesh_.cells[4 * cells_[k]],
                                       element_laplacian(k, mesh_.cell_material[cells_[k]], scale), components));
  PetscFunctionReturn(0);
}

// Each vertex gets a quarter of the mass of each of its tets.
void TetElements::add_lumped_mass(PetscScalar* mass) const {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const double quarter = 0.25 * density_[mesh_.cell_material[cells_[k]]] * volume_[k];
    for (int j = 0; j < 4; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.cells[4 * cells_[k] + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += quarter;
    }
  }
}

double TetElements::local_mass() const {
  double m = 0;
  for (size_t k = 0; k < cells_.size(); ++k) m += density_[mesh_.cell_material[cells_[k]]] * volume_[k];
  return m;
}

}  // namespace hyperqn

#include "terms/viscoelastic_tets.hpp"

#include <algorithm>

namespace hyperqn {

namespace {

// The global ids of the local cells, in the term's order.
std::vector<int64_t> ids_of(const DistributedMesh& mesh, const std::vector<PetscInt>& cells) {
  std::vector<int64_t> ids;
  for (PetscInt c : cells) ids.push_back(mesh.cell_ids[c]);
  return ids;
}

// Values per element: kViscousValues for each branch of the largest series.
int width(const std::vector<std::unique_ptr<MaxwellBranches>>& branches) {
  int n = 0;
  for (const auto& b : branches)
    if (b) n = std::max(n, b->size());
  return kViscousValues * n;
}

}  // namespace

ViscoelasticTets::ViscoelasticTets(const DistributedMesh& mesh, std::vector<std::unique_ptr<Material>> materials,
                                   std::vector<std::unique_ptr<MaxwellBranches>> branches, std::vector<double> weight,
                                   std::vector<double> density)
    : TetElements(mesh, cells_where(mesh, [&](int m) { return materials[m] != nullptr; }), std::move(density), true),
      materials_(std::move(materials)),
      branches_(std::move(branches)),
      weight_(std::move(weight)),
      state_("viscous", width(branches_), ids_of(mesh, cells_)) {
  std::vector<double> rest(state_.elements() * state_.per_element(), 0.0);
  for (size_t k = 0; k < cells_.size(); ++k)
    branches_[mesh.cell_material[cells_[k]]]->rest(&rest[k * state_.per_element()]);
  state_.restore(std::move(rest));
}

std::string ViscoelasticTets::name() const {
  std::string s;
  for (const auto& m : materials_)
    if (m) s += (s.empty() ? "" : ", ") + m->name();
  return "viscoelastic " + s;
}

PetscErrorCode ViscoelasticTets::begin_step(const StepStart& step) {
  dt_ = step.t - step.t_start;
  return 0;
}

double ViscoelasticTets::energy(int m, const Mat3& F, const double* h, double dt, Mat3* P) const {
  const double psi = P ? materials_[m]->energy_and_stress(F, *P) : materials_[m]->energy(F);
  return psi + branches_[m]->energy(F, h, dt, P);
}

double ViscoelasticTets::element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const {
  return energy(m, F, state_.start(k), dt_, P);
}

void ViscoelasticTets::stored_energy_batch(size_t k, int m, StressBatch& b, int n) const {
  per_element(b, n, [&](int e, const Mat3& F, Mat3& P) { return energy(m, F, state_.current(k + e), 0.0, &P); });
}

Mat9 ViscoelasticTets::element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const {
  const Mat9 C = materials_[m]->stress_derivative(F) + branches_[m]->stress_derivative(F, state_.start(k), dt_);
  return psd ? project_psd(C) : C;
}

Eigen::Matrix<double, 4, 4, Eigen::RowMajor> ViscoelasticTets::element_laplacian(PetscInt k, int m, double scale) const {
  return weighted_laplacian(k, scale * weight_[m]);
}

PetscErrorCode ViscoelasticTets::update_state(const std::vector<double>& pos) {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const Mat3 F = edge_matrix(pos.data(), &mesh_.cells[4 * cells_[k]]) * Dm_inv(k);
    branches_[mesh_.cell_material[cells_[k]]]->update(F, state_.start(k), dt_, state_.current(k));
  }
  return 0;
}

}  // namespace hyperqn

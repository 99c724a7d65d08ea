#include "terms/inelastic_tets.hpp"

#include <algorithm>

namespace hyperqn {

namespace {

// The global ids of the local cells, in the term's order.
std::vector<int64_t> ids_of(const DistributedMesh& mesh, const std::vector<PetscInt>& cells) {
  std::vector<int64_t> ids;
  for (PetscInt c : cells) ids.push_back(mesh.cell_ids[c]);
  return ids;
}

// Values per element: the widest model's history.
int width(const std::vector<std::unique_ptr<InelasticModel>>& models) {
  int n = 0;
  for (const auto& m : models)
    if (m) n = std::max(n, m->history_width());
  return n;
}

}  // namespace

InelasticTets::InelasticTets(const DistributedMesh& mesh, const std::string& state,
                             std::vector<std::unique_ptr<Material>> materials,
                             std::vector<std::unique_ptr<InelasticModel>> models, std::vector<double> weight,
                             std::vector<double> density)
    : TetElements(mesh, cells_where(mesh, [&](int m) { return models[m] != nullptr; }), std::move(density), true),
      materials_(std::move(materials)),
      models_(std::move(models)),
      weight_(std::move(weight)),
      state_(state, width(models_) + 1, ids_of(mesh, cells_)),
      dissipated_(state_.per_element() - 1) {
  for (const auto& m : models_)
    if (m) step_width_ = std::max(step_width_, m->step_width());
  std::vector<double> rest(state_.elements() * state_.per_element(), 0.0);  // nothing dissipated
  for (size_t k = 0; k < cells_.size(); ++k)
    models_[mesh.cell_material[cells_[k]]]->rest(&rest[k * state_.per_element()]);
  state_.restore(std::move(rest));
  virgin_.resize(models_.size());
  for (size_t m = 0; m < models_.size(); ++m)
    if (models_[m]) {
      virgin_[m].assign(state_.per_element(), 0.0);
      models_[m]->rest(virgin_[m].data());
    }
}

std::string InelasticTets::name() const {
  std::string s;
  for (size_t m = 0; m < models_.size(); ++m) {
    if (!models_[m]) continue;
    const std::string material = materials_[m] ? materials_[m]->name() : "";  // none: the model names it
    if (s.empty()) s = models_[m]->name() + (material.empty() ? "" : " " + material);
    else if (!material.empty()) s += ", " + material;
  }
  return s;
}

PetscErrorCode InelasticTets::begin_step(const StepStart& step) {
  dt_ = step.t - step.t_start;
  return 0;
}

double InelasticTets::equilibrium_energy(int m, const Mat3& F, Mat3* P) const {
  const double psi = !materials_[m] ? 0.0 : P ? materials_[m]->energy_and_stress(F, *P) : materials_[m]->energy(F);
  if (!materials_[m] && P) P->setZero();
  return psi;
}

double InelasticTets::energy(int m, const Mat3& F, const double* h, double dt, Mat3* P) const {
  return equilibrium_energy(m, F, P) + models_[m]->energy(F, h, dt, P);
}

double InelasticTets::element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const {
  if (dt_ == 0) {  // no step (none begun, or one of no length): the energy stored with the history as it stands
    return equilibrium_energy(m, F, P) + models_[m]->stored_energy(F, state_.start(k), P);
  }
  return energy(m, F, state_.start(k), dt_, P);
}

void InelasticTets::element_energy_batch(size_t k, int m, StressBatch& b, int n) const {
  if (materials_[m]) {
    materials_[m]->energy_and_stress_batch(b, n);
  } else {
    b.psi = Lanes{};
    for (Lanes& P : b.P) P = Lanes{};
  }
  const double* history[kBatch];
  const double* condensed = models_[m]->step_width() > 0 ? step_values(k) : nullptr;  // k's, then k + 1's, ...
  for (int e = 0; e < n; ++e) history[e] = condensed ? condensed + e * step_width_ : state_.start(k + e);
  models_[m]->energy_batch(b, n, history, dt_);
}

// Kept while the start values and dt are (one pass over the history per step, not per evaluation:
// the Prony series reads 6 values per tet instead of its 30).
const double* InelasticTets::step_values(size_t k) const {
  if (!step_valid_ || step_revision_ != state_.revision() || step_dt_ != dt_) {
    step_values_.resize(cells_.size() * step_width_);  // a model without step values leaves its tets' unread
    for (size_t e = 0; e < cells_.size(); ++e) {
      const InelasticModel& model = *models_[mesh_.cell_material[cells_[e]]];
      if (model.step_width() > 0) model.step_values(state_.start(e), dt_, &step_values_[e * step_width_]);
    }
    step_valid_ = true;
    step_revision_ = state_.revision();
    step_dt_ = dt_;
  }
  return &step_values_[k * step_width_];
}

void InelasticTets::stored_energy_batch(size_t k, int m, StressBatch& b, int n) const {
  per_element(b, n, [&](int e, const Mat3& F, Mat3& P) {
    const double psi = materials_[m] ? materials_[m]->energy_and_stress(F, P) : (P.setZero(), 0.0);
    return psi + models_[m]->stored_energy(F, state_.current(k + e), &P);
  });
}

PetscErrorCode InelasticTets::add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const {
  at_rest_ = true;
  const PetscErrorCode ierr = add_hessian(rest, H, scale, true);
  at_rest_ = false;
  return ierr;
}

Mat9 InelasticTets::element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const {
  Mat9 C = at_rest_ ? models_[m]->stress_derivative(F, virgin_[m].data(), 0.0) : models_[m]->stress_derivative(F, state_.start(k), dt_);
  if (materials_[m]) C = materials_[m]->stress_derivative(F) + C;
  return psd ? project_psd(C) : C;
}

Eigen::Matrix<double, 4, 4, Eigen::RowMajor> InelasticTets::element_laplacian(PetscInt k, int m, double scale) const {
  return weighted_laplacian(k, scale * weight_[m]);
}

// Every element's current values written (ElementState::overwrite: a step's begin copied none).
PetscErrorCode InelasticTets::update_state(const std::vector<double>& pos) {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const Mat3 F = edge_matrix(pos.data(), &mesh_.cells[4 * cells_[k]]) * Dm_inv(k);
    const InelasticModel& model = *models_[mesh_.cell_material[cells_[k]]];
    const double* start = state_.start(k);
    double* end = state_.overwrite(k);
    model.update(F, start, dt_, end);
    end[dissipated_] = start[dissipated_] + model.dissipation(F, start, dt_, end);
  }
  return 0;
}

double InelasticTets::dissipated_energy() const {
  double sum = 0;
  for (size_t k = 0; k < cells_.size(); ++k) sum += volume_[k] * state_.current(k)[dissipated_];
  return sum;
}

namespace {

// The output field of a history measure.
constexpr std::pair<ElementField, HistoryMeasure> kMeasureFields[] = {
    {ElementField::viscous_strain, HistoryMeasure::viscous_strain},
    {ElementField::equivalent_plastic_strain, HistoryMeasure::equivalent_plastic_strain}};

}  // namespace

std::vector<ElementField> InelasticTets::element_fields() const {
  std::vector<ElementField> fields = TetElements::element_fields();
  fields.push_back(ElementField::dissipated_energy);
  for (const auto& [field, measure] : kMeasureFields)
    if (std::any_of(models_.begin(), models_.end(), [&](const auto& m) { return m && m->has_measure(measure); }))
      fields.push_back(field);
  return fields;
}

void InelasticTets::fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const {
  TetElements::fill_element_fields(pos, fields);
  for (ElementFieldValues& f : fields) {
    if (f.field == ElementField::dissipated_energy) {
      for (size_t k = 0; k < cells_.size(); ++k) f.values[cells_[k]] = state_.current(k)[dissipated_];
      continue;
    }
    for (const auto& [field, measure] : kMeasureFields) {
      if (f.field != field) continue;
      for (size_t k = 0; k < cells_.size(); ++k) {
        const InelasticModel& model = *models_[mesh_.cell_material[cells_[k]]];
        if (model.has_measure(measure)) f.values[cells_[k]] = model.measure(measure, state_.current(k));
      }
    }
  }
}

}  // namespace hyperqn

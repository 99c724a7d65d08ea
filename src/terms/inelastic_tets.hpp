// Tets of inelastic materials (docs/inelastic.md#inelastic-models): per material an inelastic model
// (materials/inelastic_model.hpp: the viscoelastic Maxwell branches, J2 plasticity), over an
// equilibrium hyperelastic material or alone (a model whose energy is the material's whole one).
// Within a step of dt the element's energy is V_e (psi(F) + W(F; h_n, dt)), W the model's condensed
// incremental energy from the history at the step's start, so the step stays one minimization; at
// its accept the history moves to the step's end (update_state). Each element carries its history
// in the term's ElementState (the kind's name: "viscous", "plastic"; the width of its widest
// model, and the energy it has dissipated), checkpointed and carried over by global cell id. L's weight is the equilibrium material's
// (or the deck's laplacian_weight) plus the model's. One term per inelastic kind
// (model/elastic_terms.cpp); a scene without inelastic materials has none.
#pragma once
#include <algorithm>
#include <memory>

#include "materials/inelastic_model.hpp"
#include "terms/tet_elements.hpp"

namespace hyperqn {

class InelasticTets : public TetElements {
 public:
  // state: the history's name (the checkpoints' key); models[m]: the inelastic model of cells with
  // cell_material m, or null where another term holds them; materials[m] its equilibrium material
  // (null: the model's energy is the whole); weight[m] its weight in L; density[m] its mass per rest
  // volume.
  InelasticTets(const DistributedMesh& mesh, const std::string& state, std::vector<std::unique_ptr<Material>> materials,
                std::vector<std::unique_ptr<InelasticModel>> models, std::vector<double> weight,
                std::vector<double> density);
  std::string name() const override;
  bool projective_dynamics_exact() const override { return false; }
  // The step's length dt = t - t_start (a sub-step's own; the static integrator's load step h). With
  // none begun, or dt = 0, the energy is the one stored with the history as it stands (the reactions'
  // and the energy balance's copies of the terms).
  PetscErrorCode begin_step(const StepStart& step) override;
  ElementState* element_state() override { return &state_; }
  // With the history at its start (InelasticModel::rest) and dt 0: the stored energy's Hessian, as at setup.
  PetscErrorCode add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const override;
  PetscErrorCode update_state(const std::vector<double>& pos) override;
  double dissipated_energy() const override;
  double small_strain_reach() const override {
    double reach = -1;
    for (const auto& m : models_)  // (none for a material of no inelastic model: models_ is by material)
      if (m) reach = std::max(reach, m->small_strain_reach());
    return reach;
  }
  double step_length() const { return dt_; }
  // The tets' fields and dissipated_energy, and those of its models' histories (viscous_strain,
  // equivalent_plastic_strain), each where a model has it (NaN in the others' tets).
  std::vector<ElementField> element_fields() const override;
  void fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const override;

 private:
  double element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const override;
  // The material's batch kernel, then the model's (the Maxwell branches': across the lanes).
  void element_energy_batch(size_t k, int m, StressBatch& b, int n) const override;
  void stored_energy_batch(size_t k, int m, StressBatch& b, int n) const override;
  Mat9 element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const override;
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> element_laplacian(PetscInt k, int m, double scale) const override;
  // psi (if any; P set to its stress, or 0), and + the model's W with the history h and step length dt.
  double equilibrium_energy(int m, const Mat3& F, Mat3* P) const;
  double energy(int m, const Mat3& F, const double* h, double dt, Mat3* P) const;

  std::vector<std::unique_ptr<Material>> materials_;
  std::vector<std::unique_ptr<InelasticModel>> models_;
  std::vector<double> weight_;
  // Per element its models' history, then the energy dissipated since the run began per rest
  // volume (the last value: the step's dissipation added at each accept).
  ElementState state_;
  mutable bool at_rest_ = false;            // add_rest_stiffness is running: element_stress_derivative's history is virgin_
  std::vector<std::vector<double>> virgin_;  // per material, an element's history at its start (InelasticModel::rest)
  int dissipated_ = 0;  // that value's index in an element's values
  double dt_ = 0;
  // The models' step values (InelasticModel::step_width) per element, for the step of dt_ from the
  // start values of revision step_revision_; computed at the first batch that needs them.
  const double* step_values(size_t k) const;
  int step_width_ = 0;  // the widest model's
  mutable std::vector<double> step_values_;
  mutable uint64_t step_revision_ = 0;
  mutable double step_dt_ = 0;
  mutable bool step_valid_ = false;
};

}  // namespace hyperqn

// Tets of viscoelastic materials (docs/materials.md#viscoelasticity): an equilibrium hyperelastic
// material in parallel with generalized Maxwell branches (materials/maxwell_branches.hpp). Within
// a step of dt the element's energy is V_e (psi(F) + W(F; C_v,n, dt)), W the branches' condensed
// incremental energy from the viscous state at the step's start, so the step stays one
// minimization; at its accept the viscous state moves to the step's end (update_state). Each
// element carries C_v^{-1} per branch in its ElementState ("viscous", kViscousValues per branch
// of the term's largest series), checkpointed and carried over by global cell id. L's weight is
// the equilibrium material's (or the deck's laplacian_weight) plus the branches' 2 sum mu_i.
// A scene without viscoelastic materials has no such term (model/elastic_terms.cpp).
#pragma once
#include <memory>

#include "materials/maxwell_branches.hpp"
#include "terms/tet_elements.hpp"

namespace hyperqn {

class ViscoelasticTets : public TetElements {
 public:
  // materials[m], branches[m]: the equilibrium material and the branches of cells with
  // cell_material m, or null where another term holds them; weight[m] its weight in L; density[m]
  // its mass per rest volume.
  ViscoelasticTets(const DistributedMesh& mesh, std::vector<std::unique_ptr<Material>> materials,
                   std::vector<std::unique_ptr<MaxwellBranches>> branches, std::vector<double> weight,
                   std::vector<double> density);
  std::string name() const override;
  bool projective_dynamics_exact() const override { return false; }
  // The step's length dt = t - t_start (a sub-step's own; the static integrator's load step h).
  PetscErrorCode begin_step(const StepStart& step) override;
  ElementState* element_state() override { return &state_; }
  PetscErrorCode update_state(const std::vector<double>& pos) override;
  double step_length() const { return dt_; }

 private:
  double element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const override;
  void stored_energy_batch(size_t k, int m, StressBatch& b, int n) const override;
  Mat9 element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const override;
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> element_laplacian(PetscInt k, int m, double scale) const override;
  // psi + W with the history h and step length dt.
  double energy(int m, const Mat3& F, const double* h, double dt, Mat3* P) const;

  std::vector<std::unique_ptr<Material>> materials_;
  std::vector<std::unique_ptr<MaxwellBranches>> branches_;
  std::vector<double> weight_;
  ElementState state_;
  double dt_ = 0;
};

}  // namespace hyperqn

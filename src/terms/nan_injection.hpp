// A term for the guardrail tests only (tests/python/test_guardrails.py): it makes E, and so g,
// NaN where ||x - y||_inf > beyond (beyond >= 0), or everywhere from the from_step-th time step
// of the scene on (from_step >= 0), so that the tests can provoke non-finite energies in any
// scene. The scene holds it only when -hyperqn_test_nan_energy_beyond or
// -hyperqn_test_nan_energy_from_step is given; it adds nothing else.
#pragma once
#include "terms/energy_term.hpp"

namespace hyperqn {

class NanInjection : public EnergyTerm {
 public:
  NanInjection(double beyond, PetscInt from_step) : beyond_(beyond), from_step_(from_step) {}
  ~NanInjection() override { VecDestroy(&diff_); }
  std::string name() const override { return "nan-injection"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }
  PetscErrorCode begin_step(const StepStart& step) override;

 private:
  double beyond_;
  PetscInt from_step_, steps_ = 0;
  Vec y_ = nullptr;              // the step's inertial target (not owned)
  mutable Vec diff_ = nullptr;   // work: x - y
};

}  // namespace hyperqn

// Liu, Bouaziz & Kavan 2017: L-BFGS on g whose initial inverse Hessian is A^{-1} = (M + h^2 L)^{-1},
// run by PETSc TAO (TAOLMVM) with A's Cholesky factor given as H0. Without h0 it is TAO's
// L-BFGS with its own default H0 (in PETSc 3.18 a diagonal scaling updated from the (s, y)
// pairs; -tao_lmvm_mat_lmvm_scale_type scalar gives the classic gamma*I): the ablation
// "lbfgs-identity".
#pragma once
#include <petsctao.h>

#include "deck.hpp"
#include "factored_system.hpp"
#include "time_step_solver.hpp"

namespace hyperqn {

class LbfgsSolver : public TimeStepSolver {
 public:
  // h0: the factored M + h^2 L, or nullptr for TAO's default H0.
  LbfgsSolver(TimeStep& step, const FactoredSystem* h0) : step_(step), h0_(h0) {}
  ~LbfgsSolver() override { TaoDestroy(&tao_); }
  PetscErrorCode setup(const SolverSpec& spec);
  std::string name() const override { return h0_ ? "lbfgs" : "lbfgs-identity"; }
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  static PetscErrorCode objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx);
  static PetscErrorCode monitor(Tao tao, void* ctx);
  static PetscErrorCode convergence_test(Tao tao, void* ctx);

  TimeStep& step_;
  const FactoredSystem* h0_;
  Tao tao_ = nullptr;
  const IterationCallback* on_iteration_ = nullptr;
  double start_ = 0;
  bool stop_requested_ = false;
};

}  // namespace hyperqn

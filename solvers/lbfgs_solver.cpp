#include "lbfgs_solver.hpp"

#include <string>

namespace hyperqn {

PetscErrorCode LbfgsSolver::objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx) {
  PetscFunctionBeginUser;
  PetscCall(static_cast<LbfgsSolver*>(ctx)->step_.objective(x, f, g));
  PetscFunctionReturn(0);
}

PetscErrorCode LbfgsSolver::monitor(Tao tao, void* ctx) {
  auto* self = static_cast<LbfgsSolver*>(ctx);
  IterationRecord r;
  PetscReal f, gnorm, step;
  PetscFunctionBeginUser;
  PetscCall(TaoGetSolutionStatus(tao, &r.iteration, &f, &gnorm, nullptr, &step, nullptr));
  r.time_s = MPI_Wtime() - self->start_;
  r.energy = f;
  r.grad_norm = gnorm;
  r.step = r.iteration == 0 ? 0.0 : step;
  r.evaluations = self->step_.evaluations();
  if (self->on_iteration_ && *self->on_iteration_) self->stop_requested_ = (*self->on_iteration_)(r);
  PetscFunctionReturn(0);
}

// TAO's own test, plus a stop the iteration callback asked for.
PetscErrorCode LbfgsSolver::convergence_test(Tao tao, void* ctx) {
  PetscFunctionBeginUser;
  PetscCall(TaoDefaultConvergenceTest(tao, nullptr));
  if (static_cast<LbfgsSolver*>(ctx)->stop_requested_) PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_USER));
  PetscFunctionReturn(0);
}

// Sets an option's default unless the user gave it (command line or deck petsc: section).
static PetscErrorCode set_default_option(const char* name, const std::string& value) {
  PetscBool set;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasName(nullptr, nullptr, name, &set));
  if (!set) PetscCall(PetscOptionsSetValue(nullptr, name, value.c_str()));
  PetscFunctionReturn(0);
}

PetscErrorCode LbfgsSolver::setup(const SolverSpec& spec) {
  TaoLineSearch ls;
  PetscFunctionBeginUser;
  PetscCall(TaoCreate(PetscObjectComm((PetscObject)step_.layout()), &tao_));
  PetscCall(TaoSetType(tao_, TAOLMVM));
  PetscCall(TaoSetObjectiveAndGradient(tao_, nullptr, objective_gradient, this));
  if (h0_) PetscCall(TaoLMVMSetH0(tao_, h0_->inverse_operator()));
  PetscCall(TaoSetTolerances(tao_, spec.grad_atol, 0.0, spec.grad_rtol));
  PetscCall(TaoSetMaximumIterations(tao_, spec.iterations));
  PetscCall(TaoSetMaximumFunctionEvaluations(tao_, 100 * spec.iterations + 100));
  PetscCall(TaoGetLineSearch(tao_, &ls));
  PetscCall(TaoLineSearchSetType(ls, spec.line_search.c_str()));
  // TAOLMVM's history size is only reachable as an option (no setter for its matrix in 3.18).
  PetscCall(set_default_option("-tao_lmvm_mat_lmvm_hist_size", std::to_string(spec.history)));
  PetscCall(TaoSetMonitor(tao_, monitor, this, nullptr));
  PetscCall(TaoSetConvergenceTest(tao_, convergence_test, this));
  PetscCall(TaoSetFromOptions(tao_));
  // Allocate TAO's work space now, so the first frame's timing holds only its iterations.
  Vec x;
  PetscCall(VecDuplicate(step_.layout(), &x));
  PetscCall(TaoSetSolution(tao_, x));
  PetscCall(TaoSetUp(tao_));
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

PetscErrorCode LbfgsSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
  TaoConvergedReason reason;
  PetscFunctionBeginUser;
  step_.reset_evaluations();
  on_iteration_ = &on_iteration;
  stop_requested_ = false;
  start_ = MPI_Wtime();
  PetscCall(TaoSetSolution(tao_, x));
  PetscCall(TaoSolve(tao_));
  on_iteration_ = nullptr;
  PetscCall(TaoGetSolutionStatus(tao_, &result.iterations, &result.energy, &result.grad_norm, nullptr, nullptr, &reason));
  result.converged = reason > 0 && reason != TAO_CONVERGED_USER && reason != TAO_CONVERGED_STEPTOL;
  result.failed = reason < 0 && reason != TAO_DIVERGED_MAXITS;
  result.reason = TaoConvergedReasons[reason];
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

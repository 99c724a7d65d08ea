#include "lbfgs_solver.hpp"

#include <cmath>
#include <string>

#include "line_search.hpp"

namespace hyperqn {

PetscErrorCode LbfgsSolver::objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx) {
  auto* self = static_cast<LbfgsSolver*>(ctx);
  PetscFunctionBeginUser;
  PetscCall(self->step_.objective(x, f, g));
  if (TimeStep::rejected(*f) && !self->have_rejected_trial_) {
    PetscCall(VecCopy(x, self->rejected_trial_));
    self->have_rejected_trial_ = true;
  }
  PetscFunctionReturn(0);
}

LbfgsSolver::~LbfgsSolver() {
  TaoDestroy(&tao_);
  VecDestroy(&last_x_);
  VecDestroy(&grad_);
  VecDestroy(&rejected_trial_);
}

PetscErrorCode LbfgsSolver::monitor(Tao tao, void* ctx) {
  auto* self = static_cast<LbfgsSolver*>(ctx);
  IterationRecord r;
  PetscReal f, gnorm, step;
  PetscInt it;
  TaoConvergedReason reason;
  Vec x;
  PetscFunctionBeginUser;
  PetscCall(TaoGetSolutionStatus(tao, &it, &f, &gnorm, nullptr, &step, &reason));
  // Not iterates of the frame, so not reported: a rejected point (the initial guess, or a point a
  // line search without a test accepted), a point found by a line search that met a rejected
  // trial (More-Thuente then accepts only steps that collapsed towards 0, which may even increase
  // g by its 1e-10 relative slack) -- for these the convergence test stops TAO and solve() undoes
  // the step --, TAOLMVM's record of a failed line search (the same point again, step 0; solve()
  // retries), and the first point of a TaoSolve that resumes the frame (already reported).
  self->bad_point_ = TimeStep::rejected(f) || !std::isfinite(gnorm) || (it > 0 && self->have_rejected_trial_);
  if (self->bad_point_ || reason == TAO_DIVERGED_LS_FAILURE || (self->restarted_ && it == 0)) PetscFunctionReturn(0);
  self->have_rejected_trial_ = false;  // a new iterate: a new line search follows
  r.iteration = self->offset_ + it;
  r.time_s = MPI_Wtime() - self->start_;
  r.energy = f;
  r.grad_norm = gnorm;
  r.step = r.iteration == 0 ? 0.0 : step;
  r.evaluations = self->step_.evaluations();
  PetscCall(TaoGetSolution(tao, &x));
  PetscCall(VecCopy(x, self->last_x_));
  self->last_f_ = f;
  self->last_gnorm_ = gnorm;
  self->reported_ = r.iteration;
  if (r.iteration == 0) self->gnorm0_ = gnorm;
  if (self->on_iteration_ && *self->on_iteration_) self->stop_requested_ = (*self->on_iteration_)(r);
  PetscFunctionReturn(0);
}

// TAO's own test, plus: a stop the iteration callback asked for; a rejected point ends the solve
// (solve() takes over); after a retry the relative tolerance stays relative to the frame's
// first gradient (TAO's gttol would restart from the resumed point's).
PetscErrorCode LbfgsSolver::convergence_test(Tao tao, void* ctx) {
  auto* self = static_cast<LbfgsSolver*>(ctx);
  TaoConvergedReason reason;
  PetscReal gnorm;
  PetscFunctionBeginUser;
  PetscCall(TaoDefaultConvergenceTest(tao, nullptr));
  PetscCall(TaoGetSolutionStatus(tao, nullptr, nullptr, &gnorm, nullptr, nullptr, &reason));
  if (self->bad_point_) {
    PetscCall(TaoSetConvergedReason(tao, self->reported_ < 0 ? TAO_DIVERGED_NAN : TAO_DIVERGED_LS_FAILURE));
  } else if (self->restarted_ && reason == TAO_CONTINUE_ITERATING && self->gnorm0_ != 0 &&
             gnorm / self->gnorm0_ < self->gttol_) {
    PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_GTTOL));
  }
  if (self->stop_requested_) PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_USER));
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
  PetscCall(VecDuplicate(step_.layout(), &last_x_));
  PetscCall(VecDuplicate(step_.layout(), &grad_));
  PetscCall(VecDuplicate(step_.layout(), &rejected_trial_));
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
  PetscCall(TaoGetTolerances(tao_, &gatol_, &grtol_, &gttol_));
  PetscCall(TaoGetMaximumIterations(tao_, &max_it_));
  // Allocate TAO's work space now, so the first frame's timing holds only its iterations.
  Vec x;
  PetscCall(VecDuplicate(step_.layout(), &x));
  PetscCall(TaoSetSolution(tao_, x));
  PetscCall(TaoSetUp(tao_));
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

// Guardrails. TAO 3.18 never accepts a rejected point in More-Thuente or Armijo, but More-Thuente
// does not backtrack from one either (measured: its interpolation collapses to step 0 and it
// reports a failure; Armijo backtracks), and TAOLMVM's own recovery from a failed line search does
// not work in 3.18 (it clears the history and H0 and retries along the negated failed direction
// with a clobbered gradient, so it always fails again). So a failed line search ends the
// TaoSolve, with x at the last accepted iterate, and here, from there:
//  1. if the line search stopped at a rejected point, backtrack (Armijo, halving) along its
//     direction, from half that point;
//  2. otherwise, or if that fails (a line-search failure proper, counted), backtrack along
//     -H0 grad g, then along -grad g (solvers/line_search.hpp);
// and, once g decreased, resume TAO from the new point (TAO has cleared the L-BFGS history). A
// frame where nothing decreases g is reported failed (LINE_SEARCH_FAILURE).
PetscErrorCode LbfgsSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
  TaoConvergedReason reason;
  PetscFunctionBeginUser;
  step_.reset_evaluations();
  result = FrameResult{};
  on_iteration_ = &on_iteration;
  stop_requested_ = restarted_ = bad_point_ = false;
  offset_ = 0;
  reported_ = -1;
  start_ = MPI_Wtime();
  PetscCall(TaoSetTolerances(tao_, gatol_, grtol_, gttol_));
  PetscCall(TaoSetMaximumIterations(tao_, max_it_));
  PetscInt last_retry = -1;  // iteration index of the last retry along -H0 grad g or -grad g
  for (;;) {
    have_rejected_trial_ = false;
    PetscCall(TaoSetSolution(tao_, x));
    PetscCall(TaoSolve(tao_));
    PetscCall(TaoGetConvergedReason(tao_, &reason));
    if (reported_ < 0) break;  // the initial guess itself is rejected: nothing to retry from
    if (bad_point_) {          // undo the step (see monitor)
      PetscCall(VecCopy(last_x_, x));
      bad_point_ = false;
      reason = TAO_DIVERGED_LS_FAILURE;
    }
    if (reason != TAO_DIVERGED_LS_FAILURE || stop_requested_) break;

    PetscReal g, gnorm;
    double alpha = 0;
    bool recovered = false;
    std::string along;
    PetscCall(step_.objective(x, &g, grad_));  // x is the last accepted iterate
    if (have_rejected_trial_) {
      // The line search stopped at a rejected point: backtrack along its direction from there.
      Vec dir;
      PetscCall(VecDuplicate(x, &dir));
      PetscCall(VecWAXPY(dir, -1.0, x, rejected_trial_));
      PetscCall(backtrack_and_move(step_, x, &g, grad_, dir, 0.5, Backtracking{}, &alpha, &recovered));
      PetscCall(VecDestroy(&dir));
    }
    if (!recovered) {  // a line-search failure proper
      ++result.ls_failures;
      // Not again if TAO could not take a single step since the last retry (g stalled at
      // round-off: more retries would only burn evaluations).
      if (reported_ != last_retry)
        PetscCall(retry_descent(step_, h0_, -1.0, x, &g, grad_, &alpha, &along, &recovered));
      last_retry = reported_ + 1;
    }
    if (!recovered) break;
    PetscCall(VecNorm(grad_, NORM_2, &gnorm));
    IterationRecord r;
    r.iteration = reported_ + 1;
    r.time_s = MPI_Wtime() - start_;
    r.energy = g;
    r.grad_norm = gnorm;
    r.step = alpha;
    r.evaluations = step_.evaluations();
    PetscCall(VecCopy(x, last_x_));
    last_f_ = g;
    last_gnorm_ = gnorm;
    reported_ = r.iteration;
    if (on_iteration && on_iteration(r)) {
      reason = TAO_CONVERGED_USER;
      break;
    }
    if (reported_ >= max_it_) {
      reason = TAO_DIVERGED_MAXITS;
      break;
    }
    // Resume: a new TaoSolve clears the L-BFGS history; its first point is this one.
    offset_ = reported_;
    restarted_ = true;
    PetscCall(TaoSetTolerances(tao_, gatol_, grtol_, 0.0));  // gttol: convergence_test
    PetscCall(TaoSetMaximumIterations(tao_, max_it_ - offset_));
  }
  on_iteration_ = nullptr;
  if (reported_ < 0) {
    result.failed = true;
    result.reason = "REJECTED_INITIAL_GUESS";
    result.energy = TimeStep::kRejectedEnergy;
    PetscFunctionReturn(0);
  }
  result.iterations = reported_;
  result.energy = last_f_;
  result.grad_norm = last_gnorm_;
  result.converged = reason > 0 && reason != TAO_CONVERGED_USER && reason != TAO_CONVERGED_STEPTOL;
  result.failed = reason < 0 && reason != TAO_DIVERGED_MAXITS;
  result.reason = reason_text(reason);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "newton_solver.hpp"

#include <cmath>
#include <string>

#include "line_search.hpp"

namespace hyperqn {

NewtonSolver::~NewtonSolver() {
  TaoDestroy(&tao_);
  MatDestroy(&H_);
  VecDestroy(&coords_);
  VecDestroy(&last_x_);
  VecDestroy(&grad_);
  VecDestroy(&dir_);
  VecDestroy(&rejected_trial_);
}

PetscErrorCode NewtonSolver::objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  PetscFunctionBeginUser;
  PetscCall(self->step_.objective(x, f, g));
  // (NTR has no line search: it shrinks its radius past a rejected trial and goes on.)
  if (!self->trust_region_ && TimeStep::rejected(*f) && !self->have_rejected_trial_) {
    PetscCall(VecCopy(x, self->rejected_trial_));
    self->have_rejected_trial_ = true;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::hessian(Tao, Vec x, Mat, Mat Hpre, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  PetscFunctionBeginUser;
  PetscCall(self->step_.assemble_hessian(x, Hpre, self->exact_));
  if (self->coords_) {
    // The rigid-body motions about the current positions (x itself: the unknowns are positions)
    // span K(x)'s near-null space. GAMG uses them as given; BoomerAMG only with
    // -tao_nls_pc_hypre_boomeramg_vec_interp_variant > 0, which on the bar gave no fewer CG
    // iterations for several times the setup cost, so that stays off by default.
    MatNullSpace rigid;
    PetscCall(VecCopy(x, self->coords_));
    PetscCall(MatNullSpaceCreateRigidBody(self->coords_, &rigid));
    PetscCall(MatSetNearNullSpace(Hpre, rigid));
    PetscCall(MatNullSpaceDestroy(&rigid));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::monitor(Tao tao, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  IterationRecord r;
  PetscReal f, gnorm, step;
  PetscInt it;
  Vec x;
  PetscFunctionBeginUser;
  PetscCall(TaoGetSolutionStatus(tao, &it, &f, &gnorm, nullptr, &step, nullptr));
  // Not iterates of the frame, so not reported: a rejected point (non-finite g or grad g), a point
  // a line search found past a rejected trial (More-Thuente's step then collapsed towards 0) -- for
  // these the convergence test stops TAO and solve() undoes the step --, and the first point of a
  // TaoSolve that resumes the frame (already reported).
  self->bad_point_ = TimeStep::rejected(f) || !std::isfinite(gnorm) || (it > 0 && self->have_rejected_trial_);
  if (self->bad_point_ || (self->restarted_ && it == 0)) PetscFunctionReturn(0);
  self->have_rejected_trial_ = false;  // a new iterate: a new line search follows
  r.iteration = self->offset_ + it;
  PetscCall(TaoGetSolution(tao, &x));
  PetscCall(VecCopy(x, self->last_x_));
  self->last_f_ = f;
  self->last_gnorm_ = gnorm;
  self->reported_ = r.iteration;
  if (r.iteration == 0) self->gnorm0_ = gnorm;
  r.time_s = MPI_Wtime() - self->start_;
  r.energy = f;
  r.grad_norm = gnorm;
  r.step = r.iteration == 0 ? 0.0 : step;  // NTR reports its trust-region radius here
  r.evaluations = self->step_.evaluations();
  if (self->on_iteration_ && *self->on_iteration_) self->stop_requested_ = (*self->on_iteration_)(r);
  PetscFunctionReturn(0);
}

// TAO's own test, plus: a stop the iteration callback asked for; a rejected point ends the solve
// (solve() takes over); after a recovery the relative tolerance stays relative to the frame's
// first gradient (TAO's gttol would restart from the resumed point's).
PetscErrorCode NewtonSolver::convergence_test(Tao tao, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
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

PetscErrorCode NewtonSolver::setup(const SolverSpec& spec) {
  const bool amg = spec.linear_solver == "cg-amg";
  KSP ksp;
  PC pc;
  PetscFunctionBeginUser;
  exact_ = spec.newton_hessian == "exact";
  trust_region_ = spec.newton_method == "ntr";
  for (Vec* v : {&last_x_, &grad_, &dir_, &rejected_trial_}) PetscCall(VecDuplicate(step_.layout(), v));
  PetscCall(step_.create_hessian(&H_));
  PetscCall(TaoCreate(PetscObjectComm((PetscObject)step_.layout()), &tao_));
  PetscCall(TaoSetType(tao_, trust_region_ ? TAONTR : TAONLS));
  PetscCall(TaoSetObjectiveAndGradient(tao_, nullptr, objective_gradient, this));
  PetscCall(TaoSetHessian(tao_, H_, H_, hessian, this));
  PetscCall(TaoSetTolerances(tao_, spec.grad_atol, 0.0, spec.grad_rtol));
  PetscCall(TaoSetMaximumIterations(tao_, spec.iterations));
  PetscCall(TaoSetMaximumFunctionEvaluations(tao_, 100 * spec.iterations + 100));
  if (!trust_region_) {  // NTR has no line search; NLS defaults to More-Thuente, as does the deck
    TaoLineSearch ls;
    PetscCall(TaoGetLineSearch(tao_, &ls));
    PetscCall(TaoLineSearchSetType(ls, spec.line_search.c_str()));
  }

  // Linear solver defaults, set on the KSP itself rather than in the options database (so two
  // Newton solvers in one process, e.g. in the study, do not see each other's choices as the
  // user's). TaoSetFromOptions below applies -tao_nls_* / -tao_ntr_* options on top, so the
  // command line and the deck's petsc: section still win. NTR needs a trust-region CG.
  PetscCall(TaoGetKSP(tao_, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  if (amg) {
    PetscCall(KSPSetType(ksp, trust_region_ ? KSPSTCG : KSPCG));
    PetscCall(PCSetType(pc, PCHYPRE));
    PetscCall(PCHYPRESetType(pc, "boomeramg"));
    PetscCall(VecDuplicate(step_.layout(), &coords_));
    PetscCall(VecSetBlockSize(coords_, 3));
  } else {
    // Cholesky of an SPD matrix whose pattern never changes: MUMPS analyses it once (the first
    // PCSetUp) and only refactors numerically in later iterations and frames.
    PetscCall(KSPSetType(ksp, trust_region_ ? KSPSTCG : KSPPREONLY));
    PetscCall(PCSetType(pc, PCCHOLESKY));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  PetscCall(TaoSetMonitor(tao_, monitor, this, nullptr));
  PetscCall(TaoSetConvergenceTest(tao_, convergence_test, this));
  PetscCall(TaoSetFromOptions(tao_));
  PetscCall(TaoGetTolerances(tao_, &gatol_, &grtol_, &gttol_));
  PetscCall(TaoGetMaximumIterations(tao_, &max_it_));
  PetscFunctionReturn(0);
}

// dir = -H(x)^{-1} grad, with H assembled at x and TAO's own linear solver.
PetscErrorCode NewtonSolver::newton_direction(Vec x, Vec grad, Vec dir) {
  KSP ksp;
  PetscFunctionBeginUser;
  PetscCall(hessian(tao_, x, H_, H_, this));
  PetscCall(TaoGetKSP(tao_, &ksp));
  PetscCall(KSPSetOperators(ksp, H_, H_));
  PetscCall(KSPSolve(ksp, grad, dir));
  PetscCall(VecScale(dir, -1.0));
  PetscFunctionReturn(0);
}

// After a failed line search at x, the last accepted iterate: backtrack (Armijo, halving) along
// the direction of the rejected trial point the line search met, from half of it; otherwise, or if
// that fails (*proper_failure), and if retry: along the Newton direction, then along -grad g with
// a first step as long as the Newton step. On success x, *g and grad_ are the new point.
PetscErrorCode NewtonSolver::recover(Vec x, bool retry, PetscReal* g, double* alpha, bool* proper_failure,
                                     bool* recovered) {
  PetscReal length;
  std::string along;
  PetscFunctionBeginUser;
  *recovered = false;
  *alpha = 0;
  PetscCall(step_.objective(x, g, grad_));
  if (have_rejected_trial_) {
    PetscCall(VecWAXPY(dir_, -1.0, x, rejected_trial_));
    PetscCall(backtrack_and_move(step_, x, g, grad_, dir_, 0.5, Backtracking{}, alpha, recovered));
  }
  *proper_failure = !*recovered;
  if (*recovered || !retry) PetscFunctionReturn(0);
  PetscCall(newton_direction(x, grad_, dir_));
  PetscCall(backtrack_and_move(step_, x, g, grad_, dir_, 1.0, Backtracking{}, alpha, recovered));
  PetscCall(VecNorm(dir_, NORM_2, &length));
  if (!*recovered) PetscCall(retry_descent(step_, nullptr, length, x, g, grad_, alpha, &along, recovered));
  PetscFunctionReturn(0);
}

// Reports the point recover() found as the frame's next iteration; *reason is TAO_CONTINUE_ITERATING
// unless the frame ends there (the iteration callback asked to stop, or the budget is used).
PetscErrorCode NewtonSolver::report_recovered(Vec x, PetscReal g, double alpha, TaoConvergedReason* reason) {
  IterationRecord r;
  PetscFunctionBeginUser;
  r.iteration = reported_ + 1;
  r.time_s = MPI_Wtime() - start_;
  r.energy = g;
  PetscCall(VecNorm(grad_, NORM_2, &r.grad_norm));
  r.step = alpha;
  r.evaluations = step_.evaluations();
  PetscCall(VecCopy(x, last_x_));
  last_f_ = g;
  last_gnorm_ = r.grad_norm;
  reported_ = r.iteration;
  *reason = TAO_CONTINUE_ITERATING;
  if (reported_ >= max_it_) *reason = TAO_DIVERGED_MAXITS;
  if (*on_iteration_ && (*on_iteration_)(r)) *reason = TAO_CONVERGED_USER;
  PetscFunctionReturn(0);
}

// Guardrails. TAONLS's line search (More-Thuente) does not backtrack from a rejected point (its
// interpolation collapses to step 0), nor do its fallbacks (the gradient direction, same line
// search); a failed frame ends with DIVERGED_LS_FAILURE and x at the last accepted iterate. A
// rejected point accepted by a line search without a test (unit), or a step found past a rejected
// trial, is undone first. Then recover() (as LbfgsSolver::solve, with the Newton direction in
// place of -H0 grad g) and, once g decreased, TAO resumes from the new point; no second retry if
// TAO made no step since the last one (g stalled at round-off). A frame where nothing decreases g
// is reported failed (LINE_SEARCH_FAILURE).
PetscErrorCode NewtonSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
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
  PetscInt last_retry = -1;  // iteration index of the last retry along the Newton direction
  for (;;) {
    have_rejected_trial_ = false;
    PetscCall(TaoSetSolution(tao_, x));
    PetscCall(TaoSolve(tao_));
    PetscCall(TaoGetConvergedReason(tao_, &reason));
    if (reported_ < 0) break;  // the initial guess itself is rejected: nothing to recover from
    if (bad_point_) {          // undo the step (see monitor)
      PetscCall(VecCopy(last_x_, x));
      bad_point_ = false;
      reason = TAO_DIVERGED_LS_FAILURE;
    }
    if (reason != TAO_DIVERGED_LS_FAILURE || stop_requested_) break;

    PetscReal g;
    double alpha;
    bool proper_failure, recovered;
    PetscCall(recover(x, reported_ != last_retry, &g, &alpha, &proper_failure, &recovered));
    if (proper_failure) {
      ++result.ls_failures;
      last_retry = reported_ + 1;
    }
    if (!recovered) break;
    PetscCall(report_recovered(x, g, alpha, &reason));
    if (reason != TAO_CONTINUE_ITERATING) break;
    // Resume from this point: a new TaoSolve, whose first point is this one.
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

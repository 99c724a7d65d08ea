#include "solvers/guarded_tao_solver.hpp"

#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "solvers/line_search.hpp"
#include "solvers/stop_request.hpp"

namespace hyperqn {

GuardedTaoSolver::~GuardedTaoSolver() {
  TaoDestroy(&tao_);
  for (Vec* v : {&last_x_, &grad_, &dir_, &rejected_trial_, &step_work_}) VecDestroy(v);
}

PetscErrorCode GuardedTaoSolver::create_tao(const SolverSpec& spec, TaoType type, bool line_search) {
  PetscFunctionBeginUser;
  line_search_ = line_search;
  max_iterations_ = spec.max_iterations;
  for (Vec* v : {&last_x_, &grad_, &dir_, &rejected_trial_, &step_work_}) PetscCall(VecDuplicate(step_.layout(), v));
  PetscCall(TaoCreate(PetscObjectComm((PetscObject)step_.layout()), &tao_));
  PetscCall(TaoSetType(tao_, type));
  requested_type_ = type;
  PetscCall(TaoSetObjectiveAndGradient(tao_, nullptr, objective_gradient, this));
  PetscCall(TaoSetTolerances(tao_, spec.grad_atol, 0.0, spec.grad_rtol));
  PetscCall(TaoSetMaximumIterations(tao_, spec.iterations));
  PetscCall(TaoSetMaximumFunctionEvaluations(tao_, 100 * spec.iterations + 100));
  if (line_search) {
    TaoLineSearch ls;
    PetscCall(TaoGetLineSearch(tao_, &ls));
    PetscCall(TaoLineSearchSetType(ls, spec.line_search.c_str()));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode GuardedTaoSolver::finish_setup() {
  PetscFunctionBeginUser;
  PetscCall(TaoSetMonitor(tao_, monitor, this, nullptr));
  PetscCall(TaoSetConvergenceTest(tao_, convergence_test, this));
  PetscCall(TaoSetFromOptions(tao_));
  TaoType used;
  PetscCall(TaoGetType(tao_, &used));
  if (requested_type_ != used) {
    // Another TAO type from the options runs on what this solver gives it: the objective and
    // gradient, and (Newton) the Hessian; not constraints, residuals or bounds. Refused before the
    // first frame otherwise (TAO stopped in the time loop: "TaoSetHessian() not called").
    static const std::set<std::string> gradient_only = {"lmvm", "blmvm", "bqnls", "bqnkls", "bqnktr", "bqnktl",
                                                        "cg", "bncg", "nm"};
    static const std::set<std::string> with_hessian = {"nls", "ntr", "ntl", "tron", "bnls", "bntr", "bntl"};
    Mat hessian = nullptr;
    PetscCall(TaoGetHessian(tao_, &hessian, nullptr, nullptr, nullptr));
    const bool runs = gradient_only.count(used) || (hessian && with_hessian.count(used));
    std::string choices;
    for (const std::string& t : gradient_only) choices += (choices.empty() ? "" : ", ") + t;
    if (hessian)
      for (const std::string& t : with_hessian) choices += ", " + t;
    PetscCheck(runs, PetscObjectComm((PetscObject)tao_), PETSC_ERR_ARG_WRONG,
               "-tao_type %s: TAO %s needs what this solver does not give it (%s); it runs one of %s", used, used,
               hessian ? "constraints, residuals or bounds" : "a Hessian, or constraints, residuals or bounds", choices.c_str());
    overridden_ = std::string("TAO ") + used + " from the options, not " + requested_type_;
    PetscCall(PetscPrintf(PetscObjectComm((PetscObject)tao_), "hyperqn: warning: the solver runs %s\n", overridden_.c_str()));
  }
  PetscCall(TaoGetTolerances(tao_, &gatol_, &grtol_, &gttol_));
  PetscCall(TaoGetMaximumIterations(tao_, &max_it_));
  // (Their values from the options are checked as given: app/run_options.cpp.)
  budget_ = FrameBudget((int)max_it_, max_iterations_, gttol_);
  PetscFunctionReturn(0);
}

PetscErrorCode GuardedTaoSolver::objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx) {
  auto* self = static_cast<GuardedTaoSolver*>(ctx);
  PetscFunctionBeginUser;
  // A term that bounds steps (the contact barrier: no vertex may cross an obstacle) rejects a
  // trial point whose straight path from the last iterate it would not admit: TAO's line searches
  // cannot be told the bound, so they learn it as a rejected point and back off (see solve()).
  double admitted = 1;
  if (self->step_.bounds_steps() && self->reported_ >= 0) {
    PetscCall(VecWAXPY(self->step_work_, -1.0, self->last_x_, x));
    PetscCall(self->step_.limit_step(self->last_x_, self->step_work_, &admitted));
  }
  if (admitted < 1) {
    *f = Objective::kRejectedEnergy;
    PetscCall(VecSet(g, 0.0));
  } else {
    PetscCall(self->step_.objective(x, f, g));
  }
  if (self->line_search_ && Objective::rejected(*f) && !self->have_rejected_trial_) {
    PetscCall(VecCopy(x, self->rejected_trial_));
    self->have_rejected_trial_ = true;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode GuardedTaoSolver::report(PetscInt iteration, Vec x, PetscReal f, PetscReal gnorm, double step,
                                        bool* stop) {
  IterationRecord r;
  PetscFunctionBeginUser;
  r.iteration = iteration;
  r.time_s = MPI_Wtime() - start_;
  r.energy = f;
  r.grad_norm = gnorm;
  r.step = iteration == 0 ? 0.0 : step;  // NTR reports its trust-region radius as the step
  r.evaluations = step_.evaluations();
  last_step_ = 0;
  if (iteration > 0 && iteration >= budget_.budget) {  // only the tests past the budget need it
    PetscCall(VecWAXPY(step_work_, -1.0, last_x_, x));
    PetscCall(VecNorm(step_work_, NORM_INFINITY, &last_step_));
  }
  PetscCall(VecCopy(x, last_x_));
  previous_decrease_ = iteration <= 1 ? 0.0 : last_decrease_;
  last_decrease_ = iteration == 0 ? 0.0 : last_f_ - f;
  last_f_ = f;
  last_gnorm_ = gnorm;
  reported_ = iteration;
  if (iteration == 0) {
    gnorm0_ = gnorm;
    f0_ = f;
  }
  *stop = (on_iteration_ && *on_iteration_ && (*on_iteration_)(r)) || stop_agreed();  // a caller's stop, or a signal's
  PetscFunctionReturn(0);
}

PetscErrorCode GuardedTaoSolver::monitor(Tao tao, void* ctx) {
  auto* self = static_cast<GuardedTaoSolver*>(ctx);
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
  self->bad_point_ = Objective::rejected(f) || !std::isfinite(gnorm) || (it > 0 && self->have_rejected_trial_);
  if (self->bad_point_ || reason == TAO_DIVERGED_LS_FAILURE || (self->restarted_ && it == 0)) PetscFunctionReturn(0);
  self->have_rejected_trial_ = false;  // a new iterate: a new line search follows
  PetscCall(TaoGetSolution(tao, &x));
  PetscCall(self->report(self->offset_ + it, x, f, gnorm, step, &self->stop_requested_));
  PetscCall(self->after_iterate(self->offset_ + it));
  PetscFunctionReturn(0);
}

// TAO's own test, plus: a stop the iteration callback or a signal (stop_request.hpp) asked for; a
// rejected point ends the solve (solve() takes over); frame_budget.hpp's rule instead of TAO's
// relative test (which it contains), at every iterate, relative to the frame's first gradient also
// after a recovery (TAO's gttol would restart from the resumed point's); past the budget the frame
// goes on while it is far from converged, up to the cap.
PetscErrorCode GuardedTaoSolver::convergence_test(Tao tao, void* ctx) {
  auto* self = static_cast<GuardedTaoSolver*>(ctx);
  TaoConvergedReason reason;
  PetscReal gnorm;
  PetscInt it;
  Vec x;
  double scale = -1;  // the force scale at x, once needed
  PetscFunctionBeginUser;
  PetscCall(TaoDefaultConvergenceTest(tao, nullptr));
  PetscCall(TaoGetSolutionStatus(tao, &it, nullptr, &gnorm, nullptr, nullptr, &reason));
  PetscCall(TaoGetSolution(tao, &x));
  const FrameBudget& budget = self->budget_;
  if (self->bad_point_) {
    PetscCall(TaoSetConvergedReason(tao, self->reported_ < 0 ? TAO_DIVERGED_NAN : TAO_DIVERGED_LS_FAILURE));
  } else if (reason == TAO_CONTINUE_ITERATING || reason == TAO_CONVERGED_GTTOL || reason == TAO_DIVERGED_MAXITS) {
    PetscCall(self->step_.force_scale(x, &scale));
    const bool at_start = it == 0 && !self->restarted_;  // the initial guess: converged only by the floor
    if (budget.converged(gnorm, at_start ? gnorm : self->gnorm0_, scale))
      PetscCall(TaoSetConvergedReason(tao, at_start ? TAO_CONVERGED_GATOL : TAO_CONVERGED_GTTOL));
    else if (reason == TAO_CONVERGED_GTTOL)
      PetscCall(TaoSetConvergedReason(tao, TAO_CONTINUE_ITERATING));
  }
  PetscCall(TaoGetConvergedReason(tao, &reason));
  if (!self->bad_point_ && (reason == TAO_CONTINUE_ITERATING || reason == TAO_DIVERGED_MAXITS) &&
      self->reported_ >= budget.budget) {
    if (scale < 0) PetscCall(self->step_.force_scale(x, &scale));
    PetscCall(TaoSetConvergedReason(tao, budget.spent(self->progress(), scale, self->step_.length_scale(), self->step_.seeks_equilibrium()) ? TAO_DIVERGED_MAXITS
                                                                               : TAO_CONTINUE_ITERATING));
  }
  if (self->history_reset_requested_ && reason == TAO_CONTINUE_ITERATING)
    PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_USER));  // solve() resumes with no history
  if (self->stop_requested_ || stop_agreed()) PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_USER));
  PetscFunctionReturn(0);
}

// Guardrails. TAO 3.18's More-Thuente never accepts a rejected point, but does not backtrack from
// one either (measured: its interpolation collapses to step 0 and it reports a failure), and TAO's
// own fallbacks do not help (see the solvers' retry()). So a failed line search ends the TaoSolve,
// with x at the last accepted iterate (a step onto or just past a rejected point, which a line
// search without a test (unit) may take, is undone first), and here, from there:
//  1. if the line search stopped at a rejected point, backtrack (Armijo, halving) along its
//     direction, from half that point;
//  2. otherwise, or if that fails (a line-search failure proper, counted), retry() along the
//     solver's own directions (solvers/line_search.hpp), but not if TAO could not take a single
//     step since the last retry (g stalled at round-off: more retries would only burn evaluations);
// and, once g decreased, report the new point and resume TAO from it (a new TaoSolve, which clears
// TAO's history). A frame where nothing decreases g is reported failed (LINE_SEARCH_FAILURE).
// Resume: a new TaoSolve, whose first point is the last reported iterate.
PetscErrorCode GuardedTaoSolver::resume_from_last() {
  PetscFunctionBeginUser;
  offset_ = reported_;
  restarted_ = true;
  PetscCall(TaoSetTolerances(tao_, gatol_, grtol_, 0.0));  // gttol: convergence_test
  PetscCall(TaoSetMaximumIterations(tao_, budget_.cap - offset_));
  PetscFunctionReturn(0);
}

PetscErrorCode GuardedTaoSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
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
  PetscCall(TaoSetMaximumIterations(tao_, budget_.cap));
  PetscInt last_retry = -1;  // iteration index of the last retry()
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
    if (stop_agreed()) break;  // a stop signal: no retry, no new TaoSolve
    const bool reset_history = history_reset_requested_ && reason == TAO_CONVERGED_USER && !stop_requested_;
    history_reset_requested_ = false;
    if (reset_history) {  // a new TaoSolve from this iterate: TAOLMVM starts it with no (s, y) pairs
      PetscCall(before_resume(x));
      PetscCall(resume_from_last());
      continue;
    }
    if (reason != TAO_DIVERGED_LS_FAILURE || stop_requested_) break;

    PetscReal g, gnorm;
    double alpha = 0;
    bool recovered = false, stop;
    PetscCall(step_.objective(x, &g, grad_));  // x is the last accepted iterate
    if (have_rejected_trial_) {  // 1.
      PetscCall(VecWAXPY(dir_, -1.0, x, rejected_trial_));
      PetscCall(backtrack_and_move(step_, x, &g, grad_, dir_, 0.5, Backtracking{}, &alpha, &recovered));
    }
    if (!recovered) {  // 2.
      ++result.ls_failures;
      if (reported_ != last_retry) PetscCall(retry(x, &g, &alpha, &recovered));
      last_retry = reported_ + 1;
    }
    if (!recovered) break;
    PetscCall(VecNorm(grad_, NORM_2, &gnorm));
    PetscCall(report(reported_ + 1, x, g, gnorm, alpha, &stop));
    if (stop) {
      reason = TAO_CONVERGED_USER;
      break;
    }
    if (reported_ >= budget_.budget) {
      double scale;
      PetscCall(step_.force_scale(x, &scale));
      if (budget_.spent(progress(), scale, step_.length_scale(), step_.seeks_equilibrium())) {
        reason = TAO_DIVERGED_MAXITS;
        break;
      }
    }
    PetscCall(before_resume(x));
    PetscCall(resume_from_last());
  }
  on_iteration_ = nullptr;
  if (reported_ < 0) {
    result.failed = true;
    result.reason = "REJECTED_INITIAL_GUESS";
    result.energy = Objective::kRejectedEnergy;
    PetscFunctionReturn(0);
  }
  result.iterations = reported_;
  result.energy = last_f_;
  result.grad_norm = last_gnorm_;
  result.grad_norm0 = gnorm0_;
  result.energy0 = f0_;
  result.last_decrease = last_decrease_;
  result.previous_decrease = previous_decrease_;
  result.last_step = last_step_;
  result.extended = reported_ > budget_.budget;
  result.converged = reason > 0 && reason != TAO_CONVERGED_USER && reason != TAO_CONVERGED_STEPTOL;
  result.failed = reason < 0 && reason != TAO_DIVERGED_MAXITS;
  if (reason == TAO_DIVERGED_LS_FAILURE) {
    // g stalled at its round-off with a residual that is no reason to work on (FrameBudget::far):
    // not a failure of the frame (a tight grad_rtol ends so).
    double scale;
    PetscCall(step_.force_scale(x, &scale));
    if (last_gnorm_ <= FrameBudget::kFloor * scale) result.failed = false;
  }
  result.reason = reason_text(reason);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "solvers/pd_solver.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "solvers/frame_budget.hpp"
#include "solvers/line_search.hpp"
#include "solvers/stop_request.hpp"

namespace hyperqn {

namespace {
// Backtracking Armijo line search (used only where PD is not exact).
constexpr double kArmijoC1 = 1e-4;
constexpr double kBacktrack = 0.5;
constexpr int kMaxHalvings = 30;
}  // namespace

PdSolver::~PdSolver() {
  VecDestroy(&grad_);
  VecDestroy(&dir_);
  VecDestroy(&trial_);
  VecDestroy(&trial_grad_);
}

PetscErrorCode PdSolver::setup(const SolverSpec& spec) {
  MPI_Comm comm = PetscObjectComm((PetscObject)step_.layout());
  PetscFunctionBeginUser;
  spec_ = spec;
  // The step is PD's local-global step only if A was built with the material's own weight
  // (2 mu for ARAP, k for springs); a deck's laplacian_weight override makes it an approximation again.
  exact_ = step_.projective_dynamics_exact();
  if (spec.quiet) {
  } else if (exact_) {
    PetscCall(PetscPrintf(comm, "pd: %s is a Projective Dynamics energy (ARAP, or springs): exact local-global "
                                "steps x <- x - A^{-1} grad g (alpha = 1, no line search)\n",
                          step_.energy_names().c_str()));
  } else {
    PetscCall(PetscPrintf(comm, "pd: Projective Dynamics is not exact for this material (not: %s; exact needs ARAP or "
                                "springs without yield_strain, each with its own laplacian_weight); running its quasi-Newton step "
                                "x <- x - alpha A^{-1} grad g with a backtracking Armijo line search (L-BFGS with m = 0)\n",
                          step_.inexact_energy_names().c_str()));
  }
  PetscCall(VecDuplicate(step_.layout(), &grad_));
  PetscCall(VecDuplicate(step_.layout(), &dir_));
  PetscCall(VecDuplicate(step_.layout(), &trial_));
  PetscCall(VecDuplicate(step_.layout(), &trial_grad_));
  PetscFunctionReturn(0);
}

PetscErrorCode PdSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
  PetscReal g, gnorm, gnorm0, g_trial = 0;
  PetscInt k = 0;
  double alpha = 0;
  FrameProgress progress;  // as of the last report
  PetscFunctionBeginUser;
  step_.reset_evaluations();
  const double start = MPI_Wtime();
  const auto report = [&]() {
    progress.previous_decrease = k <= 1 ? 0.0 : progress.last_decrease;
    progress.last_decrease = k == 0 ? 0.0 : progress.g - g;
    progress.iterations = (int)k;
    progress.g = g;
    progress.gnorm = gnorm;
    if (k == 0) {
      progress.g0 = g;
      progress.gnorm0 = gnorm;
    }
    IterationRecord r;
    r.iteration = k;
    r.time_s = MPI_Wtime() - start;
    r.energy = g;
    r.grad_norm = gnorm;
    r.step = alpha;
    r.evaluations = step_.evaluations();
    return (on_iteration && on_iteration(r)) || stop_agreed();  // a caller's stop, or a signal's
  };

  result = FrameResult{};
  const FrameBudget budget(spec_.iterations, spec_.max_iterations, spec_.grad_rtol);
  PetscCall(step_.objective(x, &g, grad_));
  PetscCall(VecNorm(grad_, NORM_2, &gnorm));
  gnorm0 = gnorm;
  // A rejected initial guess (non-finite g or grad g) is not an iterate: nothing to log.
  bool stop = Objective::rejected(g) ? false : report();
  bool after_retry = false;  // the last iteration was a retry along -grad g
  for (;;) {
    if (Objective::rejected(g) || !std::isfinite(gnorm)) {
      result.failed = true;
      result.reason = "REJECTED_INITIAL_GUESS";
      break;
    }
    // Same tests, in the same order and with the same (in)equalities as GuardedTaoSolver's
    // (TAO's default test with frame_budget.hpp's reference and budget), so pd and TAO's
    // L-BFGS with m = 0 stop at the same iterate.
    if (gnorm <= spec_.grad_atol) {
      result.converged = true;
      result.reason = "CONVERGED_GATOL";
      break;
    }
    double scale;  // the force scale at x
    PetscCall(step_.force_scale(x, &scale));
    if (budget.converged(gnorm, gnorm0, scale)) {
      result.converged = true;
      result.reason = k == 0 ? "CONVERGED_GATOL" : "CONVERGED_GTTOL";
      break;
    }
    if (stop) {
      result.reason = "STOPPED_BY_CALLER";
      break;
    }
    if (k >= budget.budget && budget.spent(progress, scale, step_.length_scale(), step_.seeks_equilibrium())) {
      result.reason = "MAX_ITERATIONS";
      break;
    }

    // Global step: d = -A^{-1} grad g(x). With a PD energy, x + d is the local step (projection
    // of every element onto its constraint set, inside grad g) followed by the global solve.
    PetscCall(A_.solve(grad_, dir_));
    PetscCall(VecScale(dir_, -1.0));
    // Exact PD never increases g, so its step is taken as is (g is evaluated for the log and
    // the next gradient) unless g is rejected (non-finite); otherwise Armijo backtracking.
    bool accepted = false;
    Backtracking armijo;
    armijo.c1 = kArmijoC1;
    armijo.shrink = kBacktrack;
    armijo.max_halvings = kMaxHalvings;
    const PetscInt rejected_before = step_.rejected_evaluations();
    PetscCall(backtrack(step_, x, g, grad_, dir_, 1.0, armijo, exact_, trial_, &g_trial, trial_grad_, &alpha,
                        &accepted));
    if (stop_agreed()) {  // a stop signal during the line search: no retry
      result.reason = "STOPPED_BY_SIGNAL";
      break;
    }
    if (!accepted) {
      // Guardrail: if the backtracking met rejected (non-finite) points, retry from the last
      // accepted iterate along -grad g (-A^{-1} grad g just failed), first trial as long as the
      // failed step. Not when every trial was finite (g stalled at round-off: measured on the
      // bar, a retry there costs up to 51 evaluations and does not help), nor right after a
      // retry. x, g and grad g stay put if there is no retry or it fails too.
      PetscReal dir_norm;
      bool recovered = false;
      std::string along;
      ++result.ls_failures;
      PetscCall(VecNorm(dir_, NORM_2, &dir_norm));
      if (!after_retry && step_.rejected_evaluations() > rejected_before)
        PetscCall(retry_descent(step_, nullptr, dir_norm, x, &g, grad_, &alpha, &along, &recovered));
      after_retry = true;
      if (!recovered) {
        alpha = 0;
        result.failed = true;
        result.reason = "LINE_SEARCH_FAILURE";
        break;
      }
      PetscCall(VecNorm(grad_, NORM_2, &gnorm));
      ++k;
      stop = report();
      continue;
    }
    // Accept: the trial point's gradient is the next iteration's G (one evaluation per iteration).
    after_retry = false;
    progress.last_step = 0;
    if (k + 1 >= budget.budget) {  // only the tests past the budget need it
      PetscReal d;
      PetscCall(VecNorm(dir_, NORM_INFINITY, &d));
      progress.last_step = alpha * d;
    }
    PetscCall(VecCopy(trial_, x));
    std::swap(grad_, trial_grad_);
    g = g_trial;
    PetscCall(VecNorm(grad_, NORM_2, &gnorm));
    ++k;
    stop = report();
  }
  result.iterations = k;
  result.energy = g;
  result.grad_norm = gnorm;
  result.grad_norm0 = gnorm0;
  result.energy0 = progress.g0;
  result.last_decrease = progress.last_decrease;
  result.previous_decrease = progress.previous_decrease;
  result.last_step = progress.last_step;
  result.extended = k > budget.budget;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

// The one interface every time-step solver implements: minimize the step's g(x) from an
// initial guess, reporting each iteration as it happens.
#pragma once
#include <petsctao.h>

#include <functional>
#include <string>

#include "io/records.hpp"

namespace hyperqn {


struct FrameResult {
  PetscInt iterations = 0;
  double energy = 0, grad_norm = 0;
  // How it got there (solvers/frame_budget.hpp): g and ||grad g|| at the initial guess, the
  // last two iterations' decreases of g, and whether it iterated past the budget.
  double energy0 = 0, grad_norm0 = 0, last_decrease = 0, last_step = 0, previous_decrease = 0;
  bool extended = false;
  bool converged = false;    // met the gradient tolerance (otherwise: iteration budget, or failure)
  bool failed = false;       // the solver could not decrease g (line search failure, NaN, ...)
  std::string reason;        // solver's own words
  // Line searches that failed in this frame (each one followed by the retries of
  // solvers/line_search.hpp, or by TAONLS's own fallbacks). failed = false with ls_failures > 0:
  // the frame recovered.
  PetscInt ls_failures = 0;
};

// Called at iteration 0 and after every iteration; returning true asks the solver to stop after
// this iteration (used by the study's time limit).
// TAO's reason in the words the logs use for every solver: the iteration budget is
// MAX_ITERATIONS (not TAO's "DIVERGED_MAXITS": using the budget is the normal case).
inline std::string reason_text(TaoConvergedReason reason) {
  if (reason == TAO_DIVERGED_MAXITS) return "MAX_ITERATIONS";
  if (reason == TAO_DIVERGED_LS_FAILURE) return "LINE_SEARCH_FAILURE";
  return TaoConvergedReasons[reason];
}

using IterationCallback = std::function<bool(const IterationRecord&)>;

class TimeStepSolver {
 public:
  virtual ~TimeStepSolver() = default;
  // x: in, the initial guess; out, the accepted iterate.
  virtual PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) = 0;
  // What runs instead of the method asked for, if options (e.g. -tao_type) changed it; else "".
  virtual std::string overridden() const { return ""; }
};

}  // namespace hyperqn

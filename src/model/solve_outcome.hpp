// What one solve of a frame is worth to the fallback chain (model/fallback_chain.hpp,
// docs/guardrails.md#fallback), and which of two is kept when neither is acceptable.
#pragma once

namespace hyperqn {

// Acceptable: finite, not far from converged (solvers/frame_budget.hpp), and sound: no element
// past the run's element limit, none newly inverted.
struct SolveOutcome {
  bool finite = false, converged_enough = false, sound = false;
  double energy = 0;                // g at the solve's end
  double min_J = 0, max_abs_J = 0;  // of the tets there
  double residual = 0;              // ||grad g|| / S there (StepSolve::residual)
  bool acceptable() const { return finite && converged_enough && sound; }
};

// Of two solves of the same step's g from the same start (the chain's first stage and Newton),
// whether b is worth more than a: acceptable, then finite, then sound, then the lower g. Both
// minimize g, so g - g* is how far each still is from the answer (for a quadratic g, half the
// squared distance in the Hessian's norm); ||grad g|| is not: it is dominated by the stiffest
// modes, and a solve stalled against the contact barrier can end at a smaller ||grad g|| than one
// that went on lowering g (the bunny cut in two, docs/records/2026-12-06-chain-keeps-lower-g.md).
inline bool worth_more(const SolveOutcome& b, const SolveOutcome& a) {
  const auto rank = [](const SolveOutcome& o) { return 4 * o.acceptable() + 2 * o.finite + o.sound; };
  if (rank(b) != rank(a)) return rank(b) > rank(a);
  return b.finite && b.energy < a.energy;
}

}  // namespace hyperqn

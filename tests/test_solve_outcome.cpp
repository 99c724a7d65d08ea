// SolveOutcome (model/solve_outcome.hpp): which of the fallback chain's first stage and Newton a
// frame keeps when neither is acceptable.
#include "model/solve_outcome.hpp"

#include "check.hpp"

using hyperqn::SolveOutcome;
using hyperqn::worth_more;

static SolveOutcome outcome(bool finite, bool converged_enough, bool sound, double energy) {
  SolveOutcome o;
  o.finite = finite;
  o.converged_enough = converged_enough;
  o.sound = sound;
  o.energy = energy;
  return o;
}

int main() {
  // Frame 7 of input/topology/bunny_cut.yaml restarted from frame 6: L-BFGS stalled against the
  // barrier at g = 1.112041e-3 (||grad g|| 1.1e-2), Newton went on to g = 1.069609e-3 (||grad g|| 0.31,
  // still descending). Newton's is kept: its g is lower, whatever its gradient.
  const SolveOutcome stalled = outcome(true, false, true, 1.112040847e-03);
  const SolveOutcome descending = outcome(true, false, true, 1.069609407e-03);
  CHECK(worth_more(descending, stalled));
  CHECK(!worth_more(stalled, descending));
  // Equal g: the first stage stays.
  CHECK(!worth_more(stalled, stalled));
  // An acceptable solve beats any unacceptable one, a sound one an unsound one, a finite one a
  // non-finite one, whatever their g.
  CHECK(worth_more(outcome(true, true, true, 5.0), outcome(true, false, true, 1.0)));
  CHECK(worth_more(outcome(true, false, true, 5.0), outcome(true, false, false, 1.0)));
  CHECK(worth_more(outcome(true, false, false, 5.0), outcome(false, false, false, 1.0)));
  CHECK(!worth_more(outcome(true, false, false, 1.0), outcome(true, false, true, 5.0)));
  // Two non-finite solves: neither is worth more (the first stays).
  CHECK(!worth_more(outcome(false, false, false, 0.0), outcome(false, false, false, 1.0)));
  return check::summary("test_solve_outcome");
}

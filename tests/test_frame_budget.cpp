// FrameBudget::far (solvers/frame_budget.hpp): when a frame's solve, past its budget, is far from
// converged, measured on frames that were accepted or extended.
#include "solvers/frame_budget.hpp"

#include "check.hpp"

using hyperqn::FrameBudget;
using hyperqn::FrameProgress;

// The progress after the last three values of g (g0 the frame's first), with a gradient far above
// the floor (S = 1) and no step test (the last step 0).
static FrameProgress after(double g0, double g_before2, double g_before, double g, int iterations = 10) {
  FrameProgress p;
  p.iterations = iterations;
  p.g0 = g0;
  p.g = g;
  p.last_decrease = g_before - g;
  p.previous_decrease = g_before2 - g_before;
  p.gnorm0 = 100;
  p.gnorm = 7;  // below kFarGradient of the first
  return p;
}

static bool far(const FrameProgress& p) { return FrameBudget::far(p, 1.0, 1.0); }

int main() {
  // Frame 3 of a bunny cut at 2 ranks (tests/python/test_cut_contact.py's, frame: rest): L-BFGS
  // creeping along the barrier by 0.77 an iteration, its last decrease 0.9998 % of the frame's;
  // accepted at ||grad g|| = 667 S before the rate was read.
  const FrameProgress creeping = after(0.0402919958612004, 0.0074514241804570702, 0.0070128077247674772,
                                       0.0066767087987491891);
  CHECK(!(creeping.last_decrease > FrameBudget::kFarDecrease * (creeping.g0 - creeping.g)));  // the old test
  CHECK(FrameBudget::creeping(creeping));
  CHECK(far(creeping));
  // Converging fast (each decrease a tenth of the one before): what is left is a ninth of the last.
  CHECK(!far(after(1.0, 0.5 + 1e-2, 0.5 + 1e-3, 0.5)));
  // A last decrease larger than the one before, above the gate: no rate to trust, far.
  CHECK(far(after(1.0, 0.5 + 3e-3, 0.5 + 2e-3, 0.5)));
  // The same below the gate (1e-3 of the frame's decrease): nothing worth working on.
  CHECK(!far(after(1.0, 0.5 + 3e-4, 0.5 + 2e-4, 0.5)));
  // A last decrease of 0.8 % of the frame's (under the old test's 1 %): at rate 0.5 as much again
  // is left, not far; at rate 0.95 19 times as much, far.
  CHECK(!far(after(1.0, 0.5 + 4e-3 + 8e-3, 0.5 + 4e-3, 0.5)));
  CHECK(far(after(1.0, 0.5 + 4e-3 + 4e-3 / 0.95, 0.5 + 4e-3, 0.5)));
  // No decrease before the last (the first iteration, or a recovery): the rate is not read.
  CHECK(!FrameBudget::creeping(after(1.0, 0.5 + 5e-3, 0.5 + 5e-3, 0.5)));
  // Below the floor nothing is far, whatever the trend.
  FrameProgress small = after(1.0, 0.5 + 3e-3, 0.5 + 2e-3, 0.5);
  small.gnorm = 1e-4;
  CHECK(!far(small));
  return check::summary("test_frame_budget");
}

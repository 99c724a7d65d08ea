// Where the fallback chain (model/fallback_chain.hpp) starts a frame: a frame accepted in 2^k
// sub-steps makes the next ones start at 2^k, so that a scene that needs them for a while (a
// cloth folding onto itself) does not pay, frame after frame, for a full step and sizes between
// that the chain abandons at their iteration cap. After `hold` frames accepted at 2^k a frame
// tries 2^(k-1) again; a try that fails doubles the hold (up to solver.keep_substeps), one that
// holds sets it back to 1. So a single hard frame (an impact) costs at most one more frame in
// sub-steps, and a long stretch of them about one failed try in keep_substeps frames.
// It is part of the run's state (State), saved in checkpoints: a restart goes on as the run would.
#pragma once
#include <algorithm>

namespace hyperqn {

struct SubstepMemory {
  int halvings = 0;     // the next frame starts in 2^halvings sub-steps (0: the full step)
  int kept = 0;         // frames accepted at it in a row
  int hold = 1;         // frames to keep it before trying 2^(halvings - 1)
  bool trying = false;  // halvings is such a try

  // After a frame that started at `start` (<= halvings) and was accepted at `accepted` (0: the
  // full step; -1: at no size, then the memory stays). cap: solver.keep_substeps (0: no memory).
  void after_frame(int start, int accepted, int cap) {
    if (cap <= 0 || accepted < 0) return;
    if (accepted != start) {  // the start failed (a finer size held), or every size from it on did (a larger one)
      if (trying) hold = std::min(2 * hold, cap);
      if (accepted < start) hold = 1;
      halvings = accepted;
      kept = 0;
      trying = false;
      return;
    }
    if (trying) hold = 1;  // the try held
    trying = false;
    if (halvings > 0 && ++kept >= hold) {
      --halvings;
      kept = 0;
      trying = true;
    }
  }
};

}  // namespace hyperqn

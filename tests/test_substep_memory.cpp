// SubstepMemory (model/substep_memory.hpp): where the fallback chain starts each frame, driven by
// scripted outcomes: which sub-step sizes a frame would be accepted at.
#include "model/substep_memory.hpp"

#include <vector>

#include "check.hpp"

using hyperqn::SubstepMemory;

// The starts of frames whose finest needed size is needs[f] (the chain accepts the first size
// from the start on that is at least needs[f]; a start finer than needed is accepted too).
static std::vector<int> starts(const std::vector<int>& needs, int cap) {
  SubstepMemory m;
  std::vector<int> out;
  for (int need : needs) {
    const int start = m.halvings;
    out.push_back(start);
    m.after_frame(start, start >= need ? start : need, cap);
  }
  return out;
}

int main() {
  // No memory: every frame starts at the full step.
  CHECK((starts({0, 1, 1, 2, 0}, 0) == std::vector<int>{0, 0, 0, 0, 0}));
  // One hard frame (an impact): one frame more in sub-steps, then the full step is tried and holds.
  CHECK((starts({0, 1, 0, 0, 0}, 8) == std::vector<int>{0, 0, 1, 0, 0}));
  // A long stretch at 2 sub-steps: tries of the full step after 1, 2, 4, 8, 8 frames kept.
  // frame:       0  1  2  3  4  5  6  7  8  9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27
  const std::vector<int> stretch(28, 1);
  CHECK((starts(stretch, 8) ==
         std::vector<int>{0, 1, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1}));
  // ... up to the cap: with cap 2 the tries come every 2 frames kept.
  CHECK((starts(std::vector<int>(10, 1), 2) == std::vector<int>{0, 1, 0, 1, 1, 0, 1, 1, 0, 1}));
  // A try that holds sets the hold back to 1; the stretch ends: the full step from then on.
  CHECK((starts({1, 1, 1, 1, 1, 0, 0, 0}, 8) == std::vector<int>{0, 1, 0, 1, 1, 0, 0, 0}));
  // Finer and finer: the start follows the finest needed; easing off goes back one size per try.
  CHECK((starts({2, 3, 0, 0, 0, 0, 0}, 8) == std::vector<int>{0, 2, 3, 2, 1, 0, 0}));
  // A frame accepted at no size (Newton, or none acceptable) leaves the memory as it was.
  SubstepMemory m;
  m.after_frame(0, 2, 8);
  const SubstepMemory before = m;
  m.after_frame(2, -1, 8);
  CHECK(m.halvings == before.halvings && m.kept == before.kept && m.hold == before.hold && m.trying == before.trying);
  // Every size from the start on failed and a larger one held: start there, hold 1.
  m = SubstepMemory{3, 0, 4, false};
  m.after_frame(3, 1, 8);
  CHECK(m.halvings == 1 && m.hold == 1 && m.kept == 0 && !m.trying);
  // A frame that needs a finer size than the kept one (no try) keeps the hold earned so far.
  m = SubstepMemory{1, 2, 4, false};
  m.after_frame(1, 2, 8);
  CHECK(m.halvings == 2 && m.hold == 4 && m.kept == 0 && !m.trying);
  return check::summary("test_substep_memory");
}

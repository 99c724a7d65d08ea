// One frame of a state, as the simulation and the study both take it: a solve (the run's through
// the fallback chain, the study's by one solver at its fixed budget), then the guardrails decide
// whether the state can go on from the frame's end (docs/guardrails.md). If it can, the step is
// ended (the integrator's end map); if not, `stop` says why and the caller undoes the step.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "app/run_options.hpp"
#include "model/scene.hpp"
#include "model/step_objective.hpp"

namespace hyperqn {

// The guardrails' limits (RunOptions: -hyperqn_divergence_limit, -hyperqn_element_limit).
struct Guardrails {
  double divergence_limit = 0;  // longest element edge, in rest bounding-box diagonals (<= 0: off)
  double element_limit = 0;     // largest |det F| (<= 0: off)
  double diagonal = 0;          // the rest bounding-box diagonal
  // What a static step's stop names (SceneSpec): the deck keys of the fixed regions and
  // attachments (State::released says which are gone), and whether penalty self-contact is on.
  std::vector<std::string> fixed_keys, attachment_keys;
  bool penalty_self_contact = false;
  static Guardrails of(const RunOptions& o, const Scene& s, const SceneSpec& spec);
  // What a static step's stop adds: why a load step finds no equilibrium, what state has released,
  // and what holds a body by contact there ("; static: ...").
  std::string static_hint(const Scene& scene, const State& state) const;
};

struct FrameStep {
  StepSolve solve;         // how the solve went
  std::string stop;        // why the state cannot go on from this frame; "": it can, and the step has ended
  double min_J = 0, max_abs_J = 0;  // of the tets at the frame's end (if its positions are finite)
  bool inverted = false;   // an element with det F <= 0 at the frame's end
};

// Solves the step from state (begin_step included), reporting iterations to on_iteration.
using FrameSolve = std::function<PetscErrorCode(State&, const IterationCallback&, StepSolve&)>;

class FrameStepper {
 public:
  explicit FrameStepper(const Guardrails& limits) : limits_(limits) {}
  // solve, then the guardrails, in order: g and grad g finite, positions finite, (a static step)
  // no vertex moved by more than divergence_limit diagonals beyond the held vertices' largest move,
  // no edge longer than divergence_limit diagonals, no |det F| above element_limit, (a static step)
  // not left unresolved by the fallback chain with its Newton run away; then StepLifecycle::accept.
  // A solve that a stop signal ended (out.solve.interrupted) is neither judged nor ended.
  PetscErrorCode step(const Scene& scene, const FrameSolve& solve, State& state, const IterationCallback& on_iteration,
                      FrameStep& out);

 private:
  Guardrails limits_;
  std::vector<double> pos_, before_;  // work: local positions (at the end; a static step's at its start)
};

// Inverted or flat: an element with det F <= 0. A flat one (a body collapsed onto a plane or a
// point) is no more a solid than an inverted one, and Neo-Hookean's extended energy holds it
// there: F = 0 is a local minimum of every energy smooth at F = 0 (docs/guardrails.md).
inline bool degenerate(double min_J) { return min_J <= 0; }

}  // namespace hyperqn

// A frame's solve with the fallback chain (docs/guardrails.md#fallback). A fixed iteration budget
// can lose a run: a frame that falls behind hands the next one a bad inertial guess, and the run
// runs away. So a frame that ends far from converged (solvers/frame_budget.hpp), or whose solver
// could not decrease g, is not simply accepted:
//  1. the solver itself iterates past the budget while the frame is far from converged, up to
//     solver.max_iterations (inside the solvers: no cost while frames behave);
//  2. the frame is redone from x_n in 2, 4, ... 2^max_halvings sub-steps of the same solver (each
//     sub-step size with its own integrator and factored M + (h/k)^2 L, made the first time needed);
//     a sub-step that fails the same test abandons that size;
//  3. the frame is redone with Newton (projected Hessian).
// A frame accepted in sub-steps makes the next ones start at that sub-step size (stage 2 first;
// the full step and the sizes between only if it and every finer size fail), for as long as
// model/substep_memory.hpp says.
// A result is acceptable if it is finite, not far from converged, and sound: no element with
// |det F| past the run's element limit, none inverted that was not at x_n. The first stage whose
// result is acceptable is kept; if none is, the better of 1 and 3 (finite, then sound, then the
// lower g: model/solve_outcome.hpp), and the caller flags or stops the run.
// A stop signal (solvers/stop_request.hpp) ends the solve at hand and the chain with it: no stage
// after it, and the frame is given up as if it had not begun (StepSolve::interrupted).
#pragma once
#include <functional>
#include <memory>
#include <vector>

#include "model/step_objective.hpp"
#include "model/scene.hpp"
#include "model/solve_outcome.hpp"
#include "solvers/solver_spec.hpp"

namespace hyperqn {

// Sees every iteration of every stage of a frame's solve as it happens (the console's progress of a
// slow frame, a test hook); it cannot stop the solve.
using IterationWatch = std::function<void(const IterationRecord&)>;

class FallbackChain {
 public:
  // scene and solver (the run's, for the scene's full step) must outlive the chain; a new
  // scene (after a release) needs a new chain.
  // element_limit: a solve that leaves an element with |det F| above it is not acceptable (<= 0:
  // no limit); nor one that inverts an element when x_n had none.
  FallbackChain(Scene& scene, const SolverSpec& spec, TimeStepSolver& solver, double element_limit);
  ~FallbackChain();
  FallbackChain(const FallbackChain&) = delete;
  FallbackChain& operator=(const FallbackChain&) = delete;

  // Begins the step from s and solves it, as StepObjective::solve_step does, through the chain.
  // Then the caller ends the step (the lifecycle's accept(s, out.velocity)) or undoes it.
  // on_iteration sees the iterations of the kept solve only (for sub-steps: the last one's), once
  // the chain is done; watch, every iteration as it comes. After a stop signal, out.interrupted:
  // on_iteration has seen nothing, s holds no trace of the frame (SubstepMemory, the step's
  // counters) but the positions and velocities the caller's StepLifecycle::undo puts back.
  PetscErrorCode solve_frame(State& s, const IterationCallback& on_iteration, StepSolve& out,
                             const IterationWatch& watch = {});

 private:
  // The sub-step integrator, factored matrix and solver for h / 2^halvings.
  struct Level {
    std::unique_ptr<StepObjective> step;
    std::unique_ptr<FactoredSystem> factored;
    std::unique_ptr<TimeStepSolver> solver;
  };
  using Outcome = SolveOutcome;
  // What a solve that left x and r is worth.
  PetscErrorCode judge(const FrameResult& r, Objective& g, Vec x, Outcome* o) const;
  PetscErrorCode level(int halvings, Level** out);
  // Redoes the step from x_n in 2^halvings sub-steps, each moving the terms' element state; *ok:
  // every one acceptable (s then holds the end positions and velocity_ the end velocity), else s
  // is back at x_n and the element state at the frame's start.
  PetscErrorCode substeps(State& s, int halvings, StepSolve& out, bool* ok);
  // The chain from the full step, with sub-steps of up to 2^finest (the finer ones were tried);
  // *accepted: the sub-step size whose result is kept (0: the full step), unchanged if none.
  PetscErrorCode solve_from_full_step(State& s, int finest, StepSolve& out, int* accepted);

  Scene& scene_;
  SolverSpec spec_;
  TimeStepSolver& solver_;
  double element_limit_;
  double start_min_J_ = 0;  // the smallest det F at x_n
  bool start_known_ = false;
  Outcome outcome_;         // of the solve at hand
  std::vector<Level> levels_;               // [k - 1]: h / 2^k
  std::unique_ptr<TimeStepSolver> newton_;  // made the first time needed
  State sub_;                               // the sub-steps' state
  Vec kept_x_ = nullptr, velocity_ = nullptr;
  std::vector<IterationRecord> records_;    // the current solve's iterations
  IterationCallback record_;                // appends to records_, shows watch_
  const IterationWatch* watch_ = nullptr;   // solve_frame's, while it runs
  PetscInt iterations_seen_ = 0;            // in the frame so far, every stage's
};

}  // namespace hyperqn

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
// The first stage whose result is acceptable is kept; if none is, the better of 1 and 3 (smaller
// ||grad g||: both minimize the frame's own g), flagged by the caller as before.
#pragma once
#include <memory>
#include <vector>

#include "model/implicit_euler.hpp"
#include "model/scene.hpp"
#include "solvers/solver_spec.hpp"

namespace hyperqn {

class FallbackChain {
 public:
  // scene and solver (the run's, for the scene's full step) must outlive the chain; a new
  // scene (after a release) needs a new chain.
  FallbackChain(Scene& scene, const SolverSpec& spec, TimeStepSolver& solver);
  ~FallbackChain();
  FallbackChain(const FallbackChain&) = delete;
  FallbackChain& operator=(const FallbackChain&) = delete;

  // Begins the step from s and solves it, as ImplicitEuler::solve_step does, through the chain.
  // Then the caller ends the step (integrator.end_step(s, out.velocity)) or undoes it.
  // on_iteration sees the iterations of the kept solve only (for sub-steps: the last one's).
  PetscErrorCode solve_frame(State& s, const IterationCallback& on_iteration, StepSolve& out);

 private:
  // The sub-step integrator, factored matrix and solver for h / 2^halvings.
  struct Level {
    std::unique_ptr<ImplicitEuler> integrator;
    std::unique_ptr<FactoredSystem> factored;
    std::unique_ptr<TimeStepSolver> solver;
  };
  // Whether the solve that left x and r is acceptable: finite, and not far from converged.
  PetscErrorCode acceptable(const FrameResult& r, Objective& g, Vec x, bool* ok) const;
  PetscErrorCode level(int halvings, Level** out);
  // Redoes the step from x_n in 2^halvings sub-steps; *ok: every one acceptable (s then holds the
  // end positions and velocity_ the end velocity), else s is back at x_n.
  PetscErrorCode substeps(State& s, int halvings, StepSolve& out, bool* ok);

  Scene& scene_;
  SolverSpec spec_;
  TimeStepSolver& solver_;
  std::vector<Level> levels_;               // [k - 1]: h / 2^k
  std::unique_ptr<TimeStepSolver> newton_;  // made the first time needed
  State sub_;                               // the sub-steps' state
  Vec kept_x_ = nullptr, velocity_ = nullptr;
  std::vector<IterationRecord> records_;    // the current solve's iterations
};

}  // namespace hyperqn

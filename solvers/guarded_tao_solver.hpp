// What LbfgsSolver and NewtonSolver share: a TAO solver run with the guardrails of solve() (a
// rejected point is never an iterate; after a failed line search, backtracking and retries, then
// TAO resumes the frame). A solver adds its TAO type and settings and its own retry().
#pragma once
#include <petsctao.h>

#include "solvers/frame_budget.hpp"
#include "solvers/solver_spec.hpp"
#include "solvers/objective.hpp"
#include "solvers/time_step_solver.hpp"

namespace hyperqn {

class GuardedTaoSolver : public TimeStepSolver {
 public:
  explicit GuardedTaoSolver(Objective& step) : step_(step) {}
  ~GuardedTaoSolver() override;
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;
  std::string overridden() const override { return overridden_; }

 protected:
  // Creates tao_ with the deck's tolerances, budget and line search (if the type has one).
  PetscErrorCode create_tao(const SolverSpec& spec, TaoType type, bool line_search);
  // After the solver's own settings: installs monitor and convergence test, applies the options.
  PetscErrorCode finish_setup();
  // After a line-search failure proper at x (*g and grad_ given): the solver's own directions.
  // On success x, *g and grad_ are the new point and *alpha its step.
  virtual PetscErrorCode retry(Vec x, PetscReal* g, double* alpha, bool* recovered) = 0;
  // Called at every accepted iterate (after it is reported); may set history_reset_requested_.
  virtual PetscErrorCode after_iterate(PetscInt /*iteration*/) { return 0; }
  // Called before a new TaoSolve resumes the frame from the iterate x.
  virtual PetscErrorCode before_resume(Vec /*x*/) { return 0; }
  bool history_reset_requested_ = false;  // end this TaoSolve and resume from the iterate

  Objective& step_;
  Tao tao_ = nullptr;
  Vec grad_ = nullptr, dir_ = nullptr;  // work vectors: a gradient, a search direction

 private:
  PetscErrorCode resume_from_last();
  static PetscErrorCode objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx);
  static PetscErrorCode monitor(Tao tao, void* ctx);
  static PetscErrorCode convergence_test(Tao tao, void* ctx);
  // Records x as the frame's iteration and reports it; *stop: the callback asks to stop.
  PetscErrorCode report(PetscInt iteration, Vec x, PetscReal f, PetscReal gnorm, double step, bool* stop);
  // The frame so far, at the last iterate reported.
  FrameProgress progress() const {
    return {(int)reported_, f0_, last_f_, last_decrease_, gnorm0_, last_gnorm_, false, last_step_, previous_decrease_};
  }

  std::string requested_type_, overridden_;  // TAO type asked for; what the options made of it
  bool line_search_ = true;  // NTR has none: it shrinks its radius past a rejected trial and goes on
  // TAO's tolerances and iteration budget after TaoSetFromOptions (the deck's, or -tao_gatol,
  // -tao_grtol, -tao_gttol, -tao_max_it): solve() changes them while it resumes a frame.
  PetscReal gatol_ = 0, grtol_ = 0, gttol_ = 0;
  PetscInt max_it_ = 0;
  int max_iterations_ = 0;  // the deck's fallback cap (SolverSpec::max_iterations)
  FrameBudget budget_;      // max_it_ as the budget, gttol_ as grad_rtol
  const IterationCallback* on_iteration_ = nullptr;
  double start_ = 0;
  bool stop_requested_ = false;
  // The last iterate reported in this frame, to undo a step onto or just after a rejected point,
  // and the first rejected trial point since then: it lies on the line search's direction, along
  // which solve() backtracks when TAO's line search stops at it (More-Thuente does).
  Vec last_x_ = nullptr, rejected_trial_ = nullptr;
  bool have_rejected_trial_ = false;
  PetscReal last_f_ = 0, last_gnorm_ = 0, gnorm0_ = 0, f0_ = 0, last_decrease_ = 0, last_step_ = 0, previous_decrease_ = 0;
  Vec step_work_ = nullptr;
  PetscInt offset_ = 0;     // this frame's iterations before the current TaoSolve (after a recovery)
  PetscInt reported_ = -1;  // index of the last iteration reported in this frame
  bool restarted_ = false;  // the current TaoSolve resumes the frame after a recovery
  bool bad_point_ = false;  // TAO's current point is rejected, or was found past a rejected trial
};

}  // namespace hyperqn

// Baseline: Newton's method on g with TAO (TAONLS by default, TAONTR selectable). The Hessian
// M + h^2 K(x) uses per-element stiffness made positive semi-definite (definiteness fix), and is
// solved by MUMPS Cholesky (symbolic analysis once per scene, numeric factorization per
// iteration) or by CG + BoomerAMG with the rigid-body near-null space.
#pragma once
#include <petsctao.h>

#include "deck.hpp"
#include "time_step_solver.hpp"
#include "time_step.hpp"

namespace hyperqn {

class NewtonSolver : public TimeStepSolver {
 public:
  explicit NewtonSolver(TimeStep& step) : step_(step) {}
  ~NewtonSolver() override;
  PetscErrorCode setup(const SolverSpec& spec);
  std::string name() const override { return "newton"; }
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  static PetscErrorCode objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx);
  static PetscErrorCode hessian(Tao, Vec x, Mat H, Mat Hpre, void* ctx);
  static PetscErrorCode monitor(Tao tao, void* ctx);
  static PetscErrorCode convergence_test(Tao tao, void* ctx);
  PetscErrorCode recover(Vec x, bool retry, PetscReal* g, double* alpha, bool* proper_failure, bool* recovered);
  PetscErrorCode newton_direction(Vec x, Vec grad, Vec dir);
  PetscErrorCode report_recovered(Vec x, PetscReal g, double alpha, TaoConvergedReason* reason);

  TimeStep& step_;
  Tao tao_ = nullptr;
  Mat H_ = nullptr;
  bool exact_ = false;    // newton_hessian: exact -> no PSD fix (LDL^T; quadratic convergence)
  bool trust_region_ = false;  // TAONTR instead of TAONLS
  Vec coords_ = nullptr;  // cg-amg only: the current positions with block size 3 (rigid-body modes)
  // TAO's tolerances and iteration budget after TaoSetFromOptions: solve() changes them while it
  // resumes a frame after a recovery.
  PetscReal gatol_ = 0, grtol_ = 0, gttol_ = 0;
  PetscInt max_it_ = 0;
  const IterationCallback* on_iteration_ = nullptr;
  double start_ = 0;
  bool stop_requested_ = false;
  // Guardrails (see solve()): the last reported iterate, to undo a step onto or just after a
  // rejected point (non-finite g), and the first rejected trial point since then, along whose
  // direction solve() backtracks.
  Vec last_x_ = nullptr, grad_ = nullptr, dir_ = nullptr, rejected_trial_ = nullptr;
  bool have_rejected_trial_ = false;
  PetscReal last_f_ = 0, last_gnorm_ = 0, gnorm0_ = 0;
  PetscInt offset_ = 0;     // this frame's iterations before the current TaoSolve (after a recovery)
  PetscInt reported_ = -1;  // index of the last iteration reported in this frame
  bool restarted_ = false;  // the current TaoSolve resumes the frame after a recovery
  bool bad_point_ = false;  // TAO's current point is rejected, or was found past a rejected trial
};

}  // namespace hyperqn

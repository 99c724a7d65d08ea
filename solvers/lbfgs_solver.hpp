// Liu, Bouaziz & Kavan 2017: L-BFGS on g whose initial inverse Hessian is A^{-1} = (M + h^2 L)^{-1},
// run by PETSc TAO (TAOLMVM) with A's Cholesky factor given as H0. Without h0 it is TAO's
// L-BFGS with its own default H0 (in PETSc 3.18 a diagonal scaling updated from the (s, y)
// pairs; -tao_lmvm_mat_lmvm_scale_type scalar gives the classic gamma*I): the ablation
// "lbfgs-identity".
#pragma once
#include <petsctao.h>

#include "deck.hpp"
#include "factored_system.hpp"
#include "time_step_solver.hpp"

namespace hyperqn {

class LbfgsSolver : public TimeStepSolver {
 public:
  // h0: the factored M + h^2 L, or nullptr for TAO's default H0.
  LbfgsSolver(TimeStep& step, const FactoredSystem* h0) : step_(step), h0_(h0) {}
  ~LbfgsSolver() override;
  PetscErrorCode setup(const SolverSpec& spec);
  std::string name() const override { return h0_ ? "lbfgs" : "lbfgs-identity"; }
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  static PetscErrorCode objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx);
  static PetscErrorCode monitor(Tao tao, void* ctx);
  static PetscErrorCode convergence_test(Tao tao, void* ctx);

  TimeStep& step_;
  const FactoredSystem* h0_;
  Tao tao_ = nullptr;
  // TAO's tolerances and iteration budget after TaoSetFromOptions (the deck's, or -tao_gatol,
  // -tao_grtol, -tao_gttol, -tao_max_it): solve() changes them while it resumes a frame.
  PetscReal gatol_ = 0, grtol_ = 0, gttol_ = 0;
  PetscInt max_it_ = 0;
  const IterationCallback* on_iteration_ = nullptr;
  double start_ = 0;
  bool stop_requested_ = false;
  // Guardrails (see solve()): the last iterate reported in this frame, to undo a step that a
  // line search without a sufficient-decrease test (unit) accepted at a rejected point.
  Vec last_x_ = nullptr, grad_ = nullptr;
  // The first rejected trial point since the last iterate: it lies on the line search's direction,
  // along which solve() backtracks when TAO's line search stops at it (More-Thuente does).
  Vec rejected_trial_ = nullptr;
  bool have_rejected_trial_ = false;
  PetscReal last_f_ = 0, last_gnorm_ = 0, gnorm0_ = 0;
  PetscInt offset_ = 0;     // this frame's iterations before the current TaoSolve (after a retry)
  PetscInt reported_ = -1;  // index of the last iteration reported in this frame
  bool restarted_ = false;  // the current TaoSolve resumes the frame after a retry
  bool bad_point_ = false;  // TAO's current point is rejected (non-finite g or grad g)
};

}  // namespace hyperqn

#include "newton_solver.hpp"

#include <cmath>

namespace hyperqn {

NewtonSolver::~NewtonSolver() {
  TaoDestroy(&tao_);
  MatDestroy(&H_);
  VecDestroy(&coords_);
  VecDestroy(&last_x_);
}

PetscErrorCode NewtonSolver::objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx) {
  PetscFunctionBeginUser;
  PetscCall(static_cast<NewtonSolver*>(ctx)->step_.objective(x, f, g));
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::hessian(Tao, Vec x, Mat, Mat Hpre, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  PetscFunctionBeginUser;
  PetscCall(self->step_.assemble_hessian(x, Hpre, self->exact_));
  if (self->coords_) {
    // The rigid-body motions about the current positions (x itself: the unknowns are positions)
    // span K(x)'s near-null space. GAMG uses them as given; BoomerAMG only with
    // -tao_nls_pc_hypre_boomeramg_vec_interp_variant > 0, which on the bar gave no fewer CG
    // iterations for several times the setup cost, so that stays off by default.
    MatNullSpace rigid;
    PetscCall(VecCopy(x, self->coords_));
    PetscCall(MatNullSpaceCreateRigidBody(self->coords_, &rigid));
    PetscCall(MatSetNearNullSpace(Hpre, rigid));
    PetscCall(MatNullSpaceDestroy(&rigid));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::monitor(Tao tao, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  IterationRecord r;
  PetscReal f, gnorm, step;
  Vec x;
  PetscFunctionBeginUser;
  PetscCall(TaoGetSolutionStatus(tao, &r.iteration, &f, &gnorm, nullptr, &step, nullptr));
  // A rejected point (non-finite g or grad g) is not an iterate: the convergence test stops TAO.
  self->bad_point_ = TimeStep::rejected(f) || !std::isfinite(gnorm);
  if (self->bad_point_) PetscFunctionReturn(0);
  PetscCall(TaoGetSolution(tao, &x));
  PetscCall(VecCopy(x, self->last_x_));
  self->last_f_ = f;
  self->last_gnorm_ = gnorm;
  self->reported_ = r.iteration;
  r.time_s = MPI_Wtime() - self->start_;
  r.energy = f;
  r.grad_norm = gnorm;
  r.step = r.iteration == 0 ? 0.0 : step;  // NTR reports its trust-region radius here
  r.evaluations = self->step_.evaluations();
  if (self->on_iteration_ && *self->on_iteration_) self->stop_requested_ = (*self->on_iteration_)(r);
  PetscFunctionReturn(0);
}

// TAO's own test, plus a stop the iteration callback asked for.
PetscErrorCode NewtonSolver::convergence_test(Tao tao, void* ctx) {
  PetscFunctionBeginUser;
  auto* self = static_cast<NewtonSolver*>(ctx);
  PetscCall(TaoDefaultConvergenceTest(tao, nullptr));
  if (self->bad_point_) PetscCall(TaoSetConvergedReason(tao, self->reported_ < 0 ? TAO_DIVERGED_NAN : TAO_DIVERGED_LS_FAILURE));
  if (self->stop_requested_) PetscCall(TaoSetConvergedReason(tao, TAO_CONVERGED_USER));
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::setup(const SolverSpec& spec) {
  const bool trust_region = spec.newton_method == "ntr";
  const bool amg = spec.linear_solver == "cg-amg";
  KSP ksp;
  PC pc;
  PetscFunctionBeginUser;
  exact_ = spec.newton_hessian == "exact";
  PetscCall(VecDuplicate(step_.layout(), &last_x_));
  PetscCall(step_.create_hessian(&H_));
  PetscCall(TaoCreate(PetscObjectComm((PetscObject)step_.layout()), &tao_));
  PetscCall(TaoSetType(tao_, trust_region ? TAONTR : TAONLS));
  PetscCall(TaoSetObjectiveAndGradient(tao_, nullptr, objective_gradient, this));
  PetscCall(TaoSetHessian(tao_, H_, H_, hessian, this));
  PetscCall(TaoSetTolerances(tao_, spec.grad_atol, 0.0, spec.grad_rtol));
  PetscCall(TaoSetMaximumIterations(tao_, spec.iterations));
  PetscCall(TaoSetMaximumFunctionEvaluations(tao_, 100 * spec.iterations + 100));
  if (!trust_region) {  // NTR has no line search; NLS defaults to More-Thuente, as does the deck
    TaoLineSearch ls;
    PetscCall(TaoGetLineSearch(tao_, &ls));
    PetscCall(TaoLineSearchSetType(ls, spec.line_search.c_str()));
  }

  // Linear solver defaults, set on the KSP itself rather than in the options database (so two
  // Newton solvers in one process, e.g. in the study, do not see each other's choices as the
  // user's). TaoSetFromOptions below applies -tao_nls_* / -tao_ntr_* options on top, so the
  // command line and the deck's petsc: section still win. NTR needs a trust-region CG.
  PetscCall(TaoGetKSP(tao_, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  if (amg) {
    PetscCall(KSPSetType(ksp, trust_region ? KSPSTCG : KSPCG));
    PetscCall(PCSetType(pc, PCHYPRE));
    PetscCall(PCHYPRESetType(pc, "boomeramg"));
    PetscCall(VecDuplicate(step_.layout(), &coords_));
    PetscCall(VecSetBlockSize(coords_, 3));
  } else {
    // Cholesky of an SPD matrix whose pattern never changes: MUMPS analyses it once (the first
    // PCSetUp) and only refactors numerically in later iterations and frames.
    PetscCall(KSPSetType(ksp, trust_region ? KSPSTCG : KSPPREONLY));
    PetscCall(PCSetType(pc, PCCHOLESKY));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  PetscCall(TaoSetMonitor(tao_, monitor, this, nullptr));
  PetscCall(TaoSetConvergenceTest(tao_, convergence_test, this));
  PetscCall(TaoSetFromOptions(tao_));
  PetscFunctionReturn(0);
}

// Guardrails: TAONLS has its own fallbacks after a failed line search (Newton -> scaled
// gradient -> gradient step); a frame where they all fail ends with DIVERGED_LS_FAILURE, x at the
// last accepted iterate, and is reported failed. A rejected point accepted by a line search
// without a test (unit) is undone and the frame reported failed too.
PetscErrorCode NewtonSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
  TaoConvergedReason reason;
  PetscFunctionBeginUser;
  step_.reset_evaluations();
  result = FrameResult{};
  on_iteration_ = &on_iteration;
  stop_requested_ = bad_point_ = false;
  reported_ = -1;
  start_ = MPI_Wtime();
  PetscCall(TaoSetSolution(tao_, x));
  PetscCall(TaoSolve(tao_));
  on_iteration_ = nullptr;
  PetscCall(TaoGetConvergedReason(tao_, &reason));
  if (reported_ < 0) {  // the initial guess is rejected
    result.failed = true;
    result.reason = "REJECTED_INITIAL_GUESS";
    result.energy = TimeStep::kRejectedEnergy;
    PetscFunctionReturn(0);
  }
  if (bad_point_) PetscCall(VecCopy(last_x_, x));
  result.iterations = reported_;
  result.energy = last_f_;
  result.grad_norm = last_gnorm_;
  result.converged = reason > 0 && reason != TAO_CONVERGED_USER && reason != TAO_CONVERGED_STEPTOL;
  result.failed = reason < 0 && reason != TAO_DIVERGED_MAXITS;
  result.ls_failures = reason == TAO_DIVERGED_LS_FAILURE;
  result.reason = reason_text(reason);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

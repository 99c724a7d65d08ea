#include "solvers/newton_solver.hpp"

#include <string>

#include "solvers/line_search.hpp"

namespace hyperqn {

NewtonSolver::~NewtonSolver() {
  MatDestroy(&H_);
  VecDestroy(&coords_);
}

// PETSc 3.18's MUMPS interface keeps a failed numeric factorization's INFOG(1) < 0 (-10, a singular
// Hessian) and then skips every later numeric factorization of that factor ("MatFactorNumeric is
// called after analysis phase fails"), while PCSetUp clears the factor's error: the next solve
// failed in MUMPS's solve phase (INFOG(1) = -3) and stopped the run. After a failed factorization
// the PC is reset, so that the next one analyses the Hessian afresh (TAO took the failed step's
// fallback, as for any failed factorization). Unused with CG + AMG.
static PetscErrorCode reset_after_failed_factor(KSP ksp, Mat H) {
  PC pc, factoring;
  PetscBool redundant, cholesky;
  PCFailedReason reason;
  PetscFunctionBeginUser;
  PetscCall(KSPGetPC(ksp, &pc));
  factoring = pc;
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCREDUNDANT, &redundant));
  if (redundant) {
    KSP inner;
    PetscCall(PCRedundantGetKSP(pc, &inner));
    PetscCall(KSPGetPC(inner, &factoring));
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)factoring, PCCHOLESKY, &cholesky));
  if (!cholesky) PetscFunctionReturn(0);
  PetscCall(PCGetFailedReason(factoring, &reason));
  if (reason == PC_NOERROR) PetscFunctionReturn(0);
  PetscCall(PCReset(pc));
  PetscCall(KSPSetOperators(ksp, H, H));
  PetscFunctionReturn(0);
}

PetscErrorCode NewtonSolver::hessian(Tao, Vec x, Mat, Mat Hpre, void* ctx) {
  auto* self = static_cast<NewtonSolver*>(ctx);
  KSP ksp;
  PetscFunctionBeginUser;
  PetscCall(self->step_.assemble_hessian(x, Hpre, self->exact_));
  PetscCall(TaoGetKSP(self->tao_, &ksp));
  if (ksp) PetscCall(reset_after_failed_factor(ksp, self->H_));
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

bool newton_uses_amg(LinearSolver linear_solver, int64_t vertices) {
  return linear_solver == LinearSolver::cg_amg ||
         (linear_solver == LinearSolver::automatic && vertices >= kNewtonAmgFromVertices);
}

PetscErrorCode NewtonSolver::setup(const SolverSpec& spec) {
  KSP ksp;
  PC pc;
  PetscInt dofs;
  PetscFunctionBeginUser;
  exact_ = spec.newton_hessian == NewtonHessian::exact;
  trust_region_ = spec.newton_method == NewtonMethod::ntr;
  PetscCall(step_.create_hessian(&H_));
  PetscCall(MatGetSize(H_, &dofs, nullptr));
  const bool amg = newton_uses_amg(spec.linear_solver, dofs / 3);
  // NTR has no line search; NLS defaults to More-Thuente, as does the deck.
  PetscCall(create_tao(spec, trust_region_ ? TAONTR : TAONLS, !trust_region_));
  PetscCall(TaoSetHessian(tao_, H_, H_, hessian, this));

  // Linear solver defaults, set on the KSP itself rather than in the options database (so two
  // Newton solvers in one process, e.g. in the study, do not see each other's choices as the
  // user's). TaoSetFromOptions below applies -tao_nls_* / -tao_ntr_* options on top, so the
  // command line and the deck's petsc: section still win. NTR needs a trust-region CG.
  PetscCall(TaoGetKSP(tao_, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  if (amg) {
    PetscCall(KSPSetType(ksp, trust_region_ ? KSPSTCG : KSPCG));
    PetscCall(PCSetType(pc, PCHYPRE));
    PetscCall(PCHYPRESetType(pc, "boomeramg"));
    PetscCall(VecDuplicate(step_.layout(), &coords_));
    PetscCall(VecSetBlockSize(coords_, 3));
  } else {
    // Cholesky of an SPD matrix whose pattern never changes: MUMPS analyses it once (the first
    // PCSetUp) and only refactors numerically in later iterations and frames.
    PetscCall(KSPSetType(ksp, trust_region_ ? KSPSTCG : KSPPREONLY));
    PetscMPIInt size;
    PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)tao_), &size));
    if (size > 1) {
      // Parallel MUMPS does not give the same answer twice (docs/performance.md#reproducibility):
      // every rank factors the whole Hessian itself, sequentially and identically (PCREDUNDANT,
      // one copy per rank; its inner solver takes the options -tao_nls_redundant_*).
      KSP inner;
      PetscCall(PCSetType(pc, PCREDUNDANT));
      PetscCall(PCRedundantSetNumber(pc, size));
      PetscCall(PCRedundantGetKSP(pc, &inner));
      PetscCall(KSPSetType(inner, KSPPREONLY));
      PetscCall(KSPGetPC(inner, &pc));
    }
    PetscCall(PCSetType(pc, PCCHOLESKY));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  PetscCall(finish_setup());
  PetscFunctionReturn(0);
}

// TAONLS's own fallback after a failed More-Thuente search (the gradient direction, same line
// search) stops at a rejected point too. So, after GuardedTaoSolver::solve's backtracking: along
// the Newton direction -H(x)^{-1} grad g (H assembled at x, TAO's own linear solver), then along
// -grad g with a first step as long as the Newton step.
PetscErrorCode NewtonSolver::retry(Vec x, PetscReal* g, double* alpha, bool* recovered) {
  KSP ksp;
  PetscReal length;
  std::string along;
  PetscFunctionBeginUser;
  PetscCall(TaoGetKSP(tao_, &ksp));
  if (!ksp) {  // a TAO type from the options without a linear solver (-tao_type lmvm): no Newton step to retry
    *recovered = false;
    PetscFunctionReturn(0);
  }
  PetscCall(hessian(tao_, x, H_, H_, this));
  PetscCall(KSPSetOperators(ksp, H_, H_));
  PetscCall(KSPSolve(ksp, grad_, dir_));
  PetscCall(VecScale(dir_, -1.0));
  PetscCall(backtrack_and_move(step_, x, g, grad_, dir_, 1.0, Backtracking{}, alpha, recovered));
  PetscCall(VecNorm(dir_, NORM_2, &length));
  if (!*recovered) PetscCall(retry_descent(step_, nullptr, length, x, g, grad_, alpha, &along, recovered));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

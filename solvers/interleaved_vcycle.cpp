#include "solvers/interleaved_vcycle.hpp"

#include <cstdint>

namespace hyperqn {

InterleavedVCycle::~InterleavedVCycle() {
  KSPDestroy(&ksp_);
  for (Mat& m : owned_) MatDestroy(&m);
  for (Vec& v : inverse_diagonals_) VecDestroy(&v);
  VecDestroy(&coarse_in_);
  VecDestroy(&coarse_out_);
}

PetscErrorCode InterleavedVCycle::supported(PC pc, PetscBool* ok) {
  PetscBool mg;
  PetscInt levels;
  PCMGType type;
  PetscFunctionBeginUser;
  *ok = PETSC_FALSE;
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &mg, PCMG, PCGAMG, ""));
  if (!mg) PetscFunctionReturn(0);
  PetscCall(PCMGGetType(pc, &type));
  PetscCall(PCMGGetLevels(pc, &levels));
  if (type != PC_MG_MULTIPLICATIVE || levels < 2) PetscFunctionReturn(0);
  // Options this cycle does not copy (it is one V-cycle of first-kind Chebyshev): column by column.
  const char* prefix;
  PetscCall(PCGetOptionsPrefix(pc, &prefix));
  for (const char* option : {"-pc_mg_cycle_type", "-pc_mg_multiplicative_cycles", "-mg_levels_ksp_chebyshev_kind"}) {
    PetscBool given;
    PetscCall(PetscOptionsHasName(nullptr, prefix, option, &given));
    if (given) PetscFunctionReturn(0);
  }
  for (PetscInt l = 1; l < levels; ++l) {
    // PCMGGetSmoother: the level's smoother, before and after (PCMGGetSmootherUp would create a
    // separate one).
    KSP smoother;
    PC jacobi;
    PetscBool chebyshev, is_jacobi, abs;
    PCJacobiType jacobi_type;
    PetscCall(PCMGGetSmoother(pc, l, &smoother));
    PetscCall(PetscObjectTypeCompare((PetscObject)smoother, KSPCHEBYSHEV, &chebyshev));
    PetscCall(KSPGetPC(smoother, &jacobi));
    PetscCall(PetscObjectTypeCompare((PetscObject)jacobi, PCJACOBI, &is_jacobi));
    if (!chebyshev || !is_jacobi) PetscFunctionReturn(0);
    PetscCall(PCJacobiGetType(jacobi, &jacobi_type));
    PetscCall(PCJacobiGetUseAbs(jacobi, &abs));
    if (jacobi_type != PC_JACOBI_DIAGONAL || abs) PetscFunctionReturn(0);
  }
  *ok = PETSC_TRUE;
  PetscFunctionReturn(0);
}

// Extreme eigenvalues of D^-1 A (A's Jacobi-preconditioned spectrum) from 10 steps of CG, as
// PETSc's Chebyshev estimates them, but from a fixed right-hand side (entries from their global
// row number), so that the bounds, and B, are the same in every run at a rank count whatever the
// first right-hand side is (a restarted run must apply the same B).
static PetscErrorCode jacobi_spectrum(Mat A, PetscReal* emin, PetscReal* emax) {
  KSP cg;
  PC pc;
  Vec b, x;
  PetscInt first, last;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(MatCreateVecs(A, &x, &b));
  PetscCall(VecGetOwnershipRange(b, &first, &last));
  PetscCall(VecGetArrayWrite(b, &a));
  for (PetscInt i = first; i < last; ++i)  // 1 + a multiplicative hash of i in [0, 1)
    a[i - first] = 1.0 + static_cast<double>((static_cast<uint64_t>(i) * 2654435761u) % 1000u) / 1000.0;
  PetscCall(VecRestoreArrayWrite(b, &a));
  PetscCall(KSPCreate(PetscObjectComm((PetscObject)A), &cg));
  PetscCall(KSPSetOperators(cg, A, A));
  PetscCall(KSPSetType(cg, KSPCG));
  PetscCall(KSPGetPC(cg, &pc));
  PetscCall(PCSetType(pc, PCJACOBI));
  PetscCall(KSPSetTolerances(cg, 1e-12, PETSC_DEFAULT, PETSC_DEFAULT, 10));
  PetscCall(KSPSetComputeEigenvalues(cg, PETSC_TRUE));
  PetscCall(KSPSolve(cg, b, x));
  PetscCall(KSPComputeExtremeSingularValues(cg, emax, emin));
  PetscCall(KSPDestroy(&cg));
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

// The coarse level: GAMG's coarse solve on each component of an interleaved vector.
static PetscErrorCode coarse_apply(PC shell, Vec b, Vec x) {
  InterleavedVCycle* cycle;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(shell, &cycle));
  PetscCall(cycle->coarse_solve(b, x));
  PetscFunctionReturn(0);
}

PetscErrorCode InterleavedVCycle::coarse_solve(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  for (PetscInt d = 0; d < 3; ++d) {
    PetscCall(VecStrideGather(b, d, coarse_in_, INSERT_VALUES));
    PetscCall(KSPSolve(coarse_, coarse_in_, coarse_out_));
    PetscCall(VecStrideScatter(coarse_out_, d, x, INSERT_VALUES));
  }
  PetscFunctionReturn(0);
}

// The Jacobi step of a level: y = D^-1 x with D^-1 repeated for x, y and z.
static PetscErrorCode jacobi_apply(PC shell, Vec x, Vec y) {
  Vec inverse_diagonal;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(shell, &inverse_diagonal));
  PetscCall(VecPointwiseMult(y, inverse_diagonal, x));
  PetscFunctionReturn(0);
}

// A MAIJ wrapper M (x) I3 of M, owned by the cycle.
static PetscErrorCode interleaved(Mat M, std::vector<Mat>& owned, Mat* M3) {
  PetscFunctionBeginUser;
  PetscCall(MatCreateMAIJ(M, 3, M3));
  owned.push_back(*M3);
  PetscFunctionReturn(0);
}

PetscErrorCode InterleavedVCycle::setup(PC gamg) {
  PetscInt levels;
  PC mg;
  PetscFunctionBeginUser;
  PetscCall(PCMGGetLevels(gamg, &levels));
  MPI_Comm comm = PetscObjectComm((PetscObject)gamg);
  PetscCall(KSPCreate(comm, &ksp_));
  PetscCall(KSPSetType(ksp_, KSPPREONLY));
  PetscCall(KSPGetPC(ksp_, &mg));
  PetscCall(PCSetType(mg, PCMG));
  PetscCall(PCMGSetLevels(mg, levels, nullptr));
  PetscCall(PCMGSetType(mg, PC_MG_MULTIPLICATIVE));
  PetscCall(PCMGSetCycleType(mg, PC_MG_CYCLE_V));
  PetscCall(PCMGSetGalerkin(mg, PC_MG_GALERKIN_NONE));

  // Coarse level: GAMG's own solver on each component.
  Mat A0, A0_3;
  PC shell;
  PetscCall(PCMGGetCoarseSolve(gamg, &coarse_));
  PetscCall(KSPGetOperators(coarse_, &A0, nullptr));
  PetscCall(MatCreateVecs(A0, &coarse_out_, &coarse_in_));
  PetscCall(interleaved(A0, owned_, &A0_3));
  KSP coarse;
  PetscCall(PCMGGetCoarseSolve(mg, &coarse));
  PetscCall(KSPSetType(coarse, KSPPREONLY));
  PetscCall(KSPSetOperators(coarse, A0_3, A0_3));
  PetscCall(KSPGetPC(coarse, &shell));
  PetscCall(PCSetType(shell, PCSHELL));
  PetscCall(PCShellSetContext(shell, this));
  PetscCall(PCShellSetApply(shell, coarse_apply));

  // Smoothed levels: GAMG's Chebyshev degree, bounds estimated here and given to both cycles.
  Mat Al_3 = A0_3;
  for (PetscInt l = 1; l < levels; ++l) {
    KSP smoother;
    Mat Al, P, P3;
    Vec diagonal, inverse;
    PetscInt degree;
    PetscReal emin, emax;
    PetscCall(PCMGGetSmoother(gamg, l, &smoother));
    PetscCall(KSPGetOperators(smoother, &Al, nullptr));
    PetscCall(KSPGetTolerances(smoother, nullptr, nullptr, nullptr, &degree));
    PetscCall(jacobi_spectrum(Al, &emin, &emax));
    // PETSc's default transform of the estimates to Chebyshev's target interval.
    PetscCall(KSPChebyshevSetEigenvalues(smoother, 1.1 * emax, 0.1 * emax));
    PetscCall(interleaved(Al, owned_, &Al_3));
    PetscCall(PCMGGetInterpolation(gamg, l, &P));
    PetscCall(interleaved(P, owned_, &P3));
    PetscCall(PCMGSetInterpolation(mg, l, P3));
    PetscCall(MatCreateVecs(Al, nullptr, &diagonal));
    PetscCall(MatGetDiagonal(Al, diagonal));
    PetscCall(VecReciprocal(diagonal));
    PetscCall(MatCreateVecs(Al_3, nullptr, &inverse));
    for (PetscInt d = 0; d < 3; ++d) PetscCall(VecStrideScatter(diagonal, d, inverse, INSERT_VALUES));
    PetscCall(VecDestroy(&diagonal));
    inverse_diagonals_.push_back(inverse);
    // One smoother before and after the coarse correction, as GAMG's (PCMG skips computing b - A x
    // before it, x being zero and known to be).
    KSP own;
    PC jacobi;
    PetscCall(PCMGGetSmoother(mg, l, &own));
    PetscCall(KSPSetType(own, KSPCHEBYSHEV));
    PetscCall(KSPChebyshevSetEigenvalues(own, 1.1 * emax, 0.1 * emax));
    PetscCall(KSPSetTolerances(own, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, degree));
    PetscCall(KSPSetOperators(own, Al_3, Al_3));
    PetscCall(KSPGetPC(own, &jacobi));
    PetscCall(PCSetType(jacobi, PCSHELL));
    PetscCall(PCShellSetContext(jacobi, inverse));
    PetscCall(PCShellSetApply(jacobi, jacobi_apply));
  }
  PetscCall(KSPSetOperators(ksp_, Al_3, Al_3));
  PetscCall(KSPSetUp(ksp_));
  PetscFunctionReturn(0);
}

PetscErrorCode InterleavedVCycle::apply(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  PetscCall(KSPSolve(ksp_, b, x));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

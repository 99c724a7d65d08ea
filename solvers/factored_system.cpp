#include "factored_system.hpp"

namespace hyperqn {

FactoredSystem::~FactoredSystem() {
  MatDestroy(&shell_);
  MatDestroy(&factor_);
  MatDestroy(&A_);
}

static PetscErrorCode shell_solve(Mat S, Vec b, Vec x) {
  FactoredSystem* sys;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &sys));
  PetscCall(sys->solve(b, x));
  PetscFunctionReturn(0);
}

static PetscErrorCode shell_mult(Mat S, Vec x, Vec y) {
  FactoredSystem* sys;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &sys));
  PetscCall(MatMult(sys->matrix(), x, y));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::setup(const TimeStep& step) {
  MatFactorInfo info;
  PetscInt m, n, M, N;
  PetscFunctionBeginUser;
  double t0 = MPI_Wtime();
  PetscCall(step.assemble_constant_matrix(&A_));
  assembly_s_ = MPI_Wtime() - t0;

  t0 = MPI_Wtime();
  PetscCall(MatGetFactor(A_, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &factor_));
  PetscCall(MatSetOptionsPrefix(factor_, "h0_"));  // -h0_mat_mumps_icntl_* tune this factorization
  PetscCall(MatSetFromOptions(factor_));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatCholeskyFactorSymbolic(factor_, A_, nullptr, &info));
  PetscCall(MatCholeskyFactorNumeric(factor_, A_, &info));
  ++factorizations_;
  factor_s_ = MPI_Wtime() - t0;

  PetscCall(MatGetLocalSize(A_, &m, &n));
  PetscCall(MatGetSize(A_, &M, &N));
  PetscCall(MatCreateShell(PetscObjectComm((PetscObject)A_), m, n, M, N, this, &shell_));
  PetscCall(MatShellSetOperation(shell_, MATOP_SOLVE, (void (*)(void))shell_solve));
  PetscCall(MatShellSetOperation(shell_, MATOP_MULT, (void (*)(void))shell_mult));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::solve(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  const double t0 = MPI_Wtime();
  PetscCall(MatSolve(factor_, b, x));
  ++solves_;
  solve_s_ += MPI_Wtime() - t0;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

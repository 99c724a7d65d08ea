#include "solvers/factored_system.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>
#include <vector>

#include "io/log_events.hpp"

namespace hyperqn {

FactoredSystem::~FactoredSystem() {
  interleaved_.reset();  // before the GAMG cycle whose coarse solver it borrows
  MatDestroy(&shell_);
  KSPDestroy(&ksp_);
  MatDestroy(&rhs_);
  MatDestroy(&sol_);
  MatDestroy(&factor_);
  MatDestroy(&rhs0_);
  MatDestroy(&sol0_);
  VecDestroy(&b0_);
  VecDestroy(&x0_);
  VecScatterDestroy(&to_zero_);
  if (A0_) MatDestroySubMatrices(1, &A0_);
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
  PetscCall(sys->mult(x, y));
  PetscFunctionReturn(0);
}

const char* factor_package_name(FactorPackage p) {
  switch (p) {
    case FactorPackage::mumps: return "mumps";
    case FactorPackage::cholmod: return "cholmod";
    case FactorPackage::supernodal: return "supernodal";
    case FactorPackage::split: return "split";
    case FactorPackage::amg: return "amg";
    case FactorPackage::automatic: return "auto";
  }
  return "?";
}

bool factor_package_available(FactorPackage p) {
#if defined(PETSC_HAVE_SUITESPARSE)
  (void)p;
  return true;
#else
  return p != FactorPackage::cholmod;
#endif
}

FactorPackage default_factor_package() { return FactorPackage::automatic; }

PetscErrorCode choose_factor_package(Mat A, FactorPackage* package) {
  PetscMPIInt size;
  PetscInt interface = 0;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)A), &size));
  if (size > 1) PetscCall(SplitCholesky::interface_size(A, &interface));
  *package = size > 1 && interface <= kMaxSplitInterface ? FactorPackage::split : FactorPackage::supernodal;
  PetscFunctionReturn(0);
}

// The message of a factorization that met a pivot <= 0, the same for every package.
static PetscErrorCode not_positive_definite(ConstantMatrix kind, FactorPackage package) {
  SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MAT_CH_ZRPVT,
          "the constant matrix A (solver.h0: %s) is not positive definite: its Cholesky factorization by %s met a "
          "zero or negative pivot",
          kind == ConstantMatrix::laplacian ? "laplacian" : kind == ConstantMatrix::volumetric ? "volumetric" : "rest-stiffness", factor_package_name(package));
}

// One V-cycle of A1 as a fixed linear operator B: KSPPREONLY applies the preconditioner once from a
// zero guess, so b -> B b is linear and the same at every call (no Krylov method, no convergence
// test). GAMG by default (measured against BoomerAMG: docs/performance.md#amg-h0). L-BFGS needs B
// symmetric positive definite, which both give with their defaults: GAMG smooths with the same
// Chebyshev polynomial in D^-1 A1 before and after the coarse correction, BoomerAMG with PETSc's
// default hybrid symmetric Gauss-Seidel (symmetric-SOR/Jacobi) on both sides; both restrict with
// P^T and solve the coarsest level exactly (tests/test_assembly.cpp checks <Bx, y> = <x, By> and
// <Bx, x> > 0). Options: prefix h0_ (-h0_pc_type hypre, -h0_pc_gamg_*, -h0_mg_levels_*).
PetscErrorCode FactoredSystem::setup_amg() {
  PC pc;
  PetscBool preonly, mg;
  PetscFunctionBeginUser;
  PetscCheck(components_ == 1, PETSC_COMM_SELF, PETSC_ERR_SUP,
             "solver.h0: amg applies M + h^2 L only, without rollers");
  PetscCall(KSPCreate(PetscObjectComm((PetscObject)A_), &ksp_));
  PetscCall(KSPSetOptionsPrefix(ksp_, "h0_"));
  PetscCall(KSPSetOperators(ksp_, A_, A_));
  PetscCall(KSPSetType(ksp_, KSPPREONLY));
  PetscCall(KSPGetPC(ksp_, &pc));
  PetscCall(PCSetType(pc, PCGAMG));
  // Aggregate A1 along its strong connections only (|a_ij| >= 0.05 sqrt(a_ii a_jj)), the coarser
  // levels along all: on bar66792 lbfgs needed 23, 11, 10, 7, 7 iterations to e <= 1e-3 with
  // GAMG's default (no filtering) and thresholds 0.01, 0.02, 0.05, 0.1, and on the 2M-tet box 0.05
  // on every level coarsened slowly (setup 9.1 s instead of 2.2 s), on the finest alone it did not
  // (docs/performance.md#amg-h0). -h0_pc_gamg_threshold and -h0_pc_gamg_threshold_scale override.
  PetscReal threshold = 0.05;
  PetscCall(PCGAMGSetThresholdScale(pc, 0.0));  // before the threshold, as PETSc asks
  PetscCall(PCGAMGSetThreshold(pc, &threshold, 1));
  // The coarse operators P^T A P by PETSc's "allatonce" product: its default ("scalable") adds the
  // rows other ranks send in the order their messages arrive, so on 3 or more ranks the hierarchy,
  // and every run's last bits, changed from run to run (amg_bar at 4 ranks: 2 of 6 runs; with
  // allatonce 18 of 18 alike, docs/performance.md#reproducibility). -matptap_via overrides. (A
  // parallel matrix's choice: one rank's products have other algorithms, and one sender.)
  PetscBool chosen;
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)A_), &size));
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-matptap_via", &chosen));
  if (!chosen && size > 1) PetscCall(PetscOptionsSetValue(nullptr, "-matptap_via", "allatonce"));
  PetscCall(KSPSetFromOptions(ksp_));
  PetscCall(PetscObjectTypeCompare((PetscObject)ksp_, KSPPREONLY, &preonly));
  PetscCheck(preonly, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG,
             "solver.h0: amg is one V-cycle, a fixed linear operator: -h0_ksp_type must stay preonly");
  PetscCall(KSPSetUp(ksp_));
  // Read by the products of that setup, if GAMG ran them: ours, not the user's to be warned of
  // as unused (-h0_pc_type hypre makes none).
  if (!chosen && size > 1) PetscCall(PetscOptionsClearValue(nullptr, "-matptap_via"));
  PetscBool supported;
  PetscCall(InterleavedVCycle::supported(pc, &supported));
  if (supported) {
    interleaved_ = std::make_unique<InterleavedVCycle>();
    PetscCall(interleaved_->setup(pc));
    // -h0_ksp_view: the hierarchy the interleaved cycle runs (GAMG's KSP is not solved with then).
    PetscCall(KSPViewFromOptions(ksp_, nullptr, "-ksp_view"));
  }
  // The hierarchy's entries, where PETSc holds the levels (PCMG and its GAMG).
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &mg, PCMG, PCGAMG, ""));
  MatInfo info;
  factor_nonzeros_ = 0;
  if (mg) {
    PetscInt levels;
    PetscCall(PCMGGetLevels(pc, &levels));
    for (PetscInt l = 0; l < levels; ++l) {
      KSP smoother;
      Mat Al;
      PetscCall(PCMGGetSmoother(pc, l, &smoother));
      PetscCall(KSPGetOperators(smoother, &Al, nullptr));
      PetscCall(MatGetInfo(Al, MAT_GLOBAL_SUM, &info));
      factor_nonzeros_ += info.nz_used;
    }
  } else {
    PetscCall(MatGetInfo(A_, MAT_GLOBAL_SUM, &info));
    factor_nonzeros_ = info.nz_used;
  }
  PetscFunctionReturn(0);
}

// A's rows (sorted columns) as compressed rows: both triangles, or (upper) the entries with column >= row.
static PetscErrorCode rows_of(Mat A, bool upper, SymmetricCsr* csr) {
  PetscInt n;
  PetscFunctionBeginUser;
  PetscCall(MatGetSize(A, &n, nullptr));
  csr->n = n;
  csr->start.assign(n + 1, 0);
  csr->column.clear();
  csr->value.clear();
  for (PetscInt i = 0; i < n; ++i) {
    PetscInt nc;
    const PetscInt* c;
    const PetscScalar* v;
    PetscCall(MatGetRow(A, i, &nc, &c, &v));
    for (PetscInt k = 0; k < nc; ++k)
      if (!upper || c[k] >= i) {
        csr->column.push_back(c[k]);
        csr->value.push_back(v[k]);
      }
    csr->start[i + 1] = static_cast<int64_t>(csr->column.size());
    PetscCall(MatRestoreRow(A, i, &nc, &c, &v));
  }
  PetscFunctionReturn(0);
}

// A's rows handed to SupernodalCholesky, which reads their upper triangle.
PetscErrorCode FactoredSystem::factor_supernodal(Mat A, CholeskyAnalysis* analysis) {
  SymmetricCsr a;
  PetscFunctionBeginUser;
  PetscCall(rows_of(A, true, &a));
  supernodal_ = std::make_unique<SupernodalCholesky>();
  const SupernodalCholesky::Status status =
      supernodal_->factor(a.n, a.start.data(), a.column.data(), a.value.data(), 0, nullptr, analysis);
  if (status != SupernodalCholesky::Status::ok) supernodal_.reset();
  if (status == SupernodalCholesky::Status::not_positive_definite) PetscCall(not_positive_definite(kind_, package_));
  PetscCheck(status != SupernodalCholesky::Status::out_of_memory, PETSC_COMM_SELF, PETSC_ERR_MEM,
             "the Cholesky factorization of the constant matrix by CHOLMOD (supernodal) ran out of memory");
  PetscCheck(status == SupernodalCholesky::Status::ok, PETSC_COMM_SELF, PETSC_ERR_LIB,
             "the Cholesky factorization of the constant matrix by CHOLMOD (supernodal) failed");
  PetscFunctionReturn(0);
}

// The same factor held by a TopologyH0 (it keeps A's both triangles, for the changes to come).
PetscErrorCode FactoredSystem::factor_topology(Mat A) {
  SymmetricCsr a;
  PetscFunctionBeginUser;
  PetscCall(rows_of(A, false, &a));
  topology_ = std::make_unique<TopologyH0>();
  const TopologyH0::Status status = topology_->setup(std::move(a), max_touched_);
  if (status != TopologyH0::Status::ok) topology_.reset();
  if (status == TopologyH0::Status::not_positive_definite) PetscCall(not_positive_definite(kind_, package_));
  PetscCheck(status == TopologyH0::Status::ok, PETSC_COMM_SELF, PETSC_ERR_LIB,
             "the Cholesky factorization of the constant matrix by CHOLMOD (supernodal) failed");
  topology_ids_ = row_ids_;
  topology_row_.clear();
  PetscFunctionReturn(0);
}

// Each rank's interior and the shared Schur complement of the interface (solvers/split_cholesky.hpp).
PetscErrorCode FactoredSystem::factor_split(Mat A, CholeskyAnalysis* analysis) {
  SplitCholesky::Status status;
  PetscFunctionBeginUser;
  split_ = std::make_unique<SplitCholesky>();
  PetscCall(split_->factor(A, components_ == 1 ? 3 : 1, &status, analysis));
  if (status != SplitCholesky::Status::ok) split_.reset();
  if (status == SplitCholesky::Status::not_positive_definite) PetscCall(not_positive_definite(kind_, package_));
  PetscCheck(status != SplitCholesky::Status::out_of_memory, PETSC_COMM_SELF, PETSC_ERR_MEM,
             "the split Cholesky factorization of the constant matrix ran out of memory (its interface block is "
             "dense on every rank: fewer ranks, or solver.h0: amg)");
  PetscCheck(status == SplitCholesky::Status::ok, PETSC_COMM_SELF, PETSC_ERR_LIB,
             "the split Cholesky factorization of the constant matrix failed");
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::factor(Mat A, CholeskyAnalysis* analysis) {
  MatFactorInfo info;
  MatFactorError failed = MAT_FACTOR_NOERROR;
  const char* name = factor_package_name(package_);
  PetscFunctionBeginUser;
  PetscInt rows;
  PetscCall(MatGetSize(A, &rows, nullptr));
  empty_ = rows == 0;  // the packages fail on a matrix of no rows (split alone took it)
  if (empty_) PetscFunctionReturn(0);
  PetscMPIInt ranks;  // of A: 1 on one rank and for the copy gathered to rank 0
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)A), &ranks));
  const bool supernodal = package_ == FactorPackage::supernodal || package_ == FactorPackage::split;
  if (supernodal && ranks == 1 && components_ == 1 && !row_ids_.empty()) {  // a scene with cuts
    PetscCall(factor_topology(A));
    PetscFunctionReturn(0);
  }
  if (package_ == FactorPackage::supernodal) {
    PetscCall(factor_supernodal(A, analysis));
    PetscFunctionReturn(0);
  }
  if (package_ == FactorPackage::split) {
    PetscMPIInt size;
    PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)A), &size));
    PetscCall(size > 1 ? factor_split(A, analysis) : factor_supernodal(A, analysis));
    PetscFunctionReturn(0);
  }
  PetscCheck(factor_package_available(package_), PETSC_COMM_SELF, PETSC_ERR_SUP,
             "this PETSc was built without SuiteSparse: no CHOLMOD (use -hyperqn_h0_package mumps)");
  PetscCall(MatGetFactor(A, package_ == FactorPackage::cholmod ? MATSOLVERCHOLMOD : MATSOLVERMUMPS,
                         MAT_FACTOR_CHOLESKY, &factor_));
  PetscCall(MatSetOptionsPrefix(factor_, "h0_"));  // -h0_mat_mumps_* / -h0_mat_cholmod_* tune this factorization
  PetscCall(MatSetFromOptions(factor_));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatCholeskyFactorSymbolic(factor_, A, nullptr, &info));  // reads the package's options
  // A pivot <= 0: CHOLMOD raises PETSC_ERR_MAT_CH_ZRPVT, MUMPS records it as the factor's error.
  // Either way the message says what it means for the run (no column numbers: PetscErrors would
  // take a number in the message for an option value it quotes).
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  const PetscErrorCode ierr = MatCholeskyFactorNumeric(factor_, A, &info);
  PetscCall(PetscPopErrorHandler());
  if (!ierr) PetscCall(MatFactorGetError(factor_, &failed));
  if (ierr == PETSC_ERR_MAT_CH_ZRPVT || failed == MAT_FACTOR_NUMERIC_ZEROPIVOT)
    PetscCall(not_positive_definite(kind_, package_));
  if (ierr) {  // anything else: the package's own message
    char* message = nullptr;
    PetscErrorMessage(ierr, nullptr, &message);
    SETERRQ(PETSC_COMM_SELF, ierr, "the Cholesky factorization of the constant matrix by %s failed: %s", name,
            message ? message : "(no message)");
  }
  PetscCheck(failed == MAT_FACTOR_NOERROR, PETSC_COMM_SELF, PETSC_ERR_LIB,
             "the Cholesky factorization of the constant matrix by %s failed (%s)", name,
             failed == MAT_FACTOR_OUTMEMORY ? "out of memory" : "MatFactorError");
  PetscCall(MatViewFromOptions(factor_, nullptr, "-mat_view"));  // -h0_mat_view ::ascii_info: the factor's size
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::keep_single_precision() {
  MPI_Comm comm = PetscObjectComm((PetscObject)A_);
  bool kept = true;
  PetscFunctionBeginUser;
  PetscCheck(package_ == FactorPackage::supernodal || package_ == FactorPackage::split, comm, PETSC_ERR_SUP,
             "solver.h0_precision: single is solved by hyperqn's own loops: -hyperqn_h0_package auto, supernodal or "
             "split, not %s", factor_package_name(package_));
  if (split_) {
    PetscCall(split_->keep_single_precision(&kept));
  } else {  // on rank 0 alone when gathered
    int mine = supernodal_ ? supernodal_->keep_single_precision() : 1, all = 0;
    PetscCallMPI(MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, comm));
    kept = all == 1;
  }
  PetscCheck(kept, comm, PETSC_ERR_FP,
             "solver.h0_precision: single: the factor of the constant matrix has values beyond a float's range "
             "(give double)");
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::setup(const Objective& step, ConstantMatrix kind, FactorPackage package,
                                     H0Precision precision, Vec extra_diagonal) {
  PetscFunctionBeginUser;
  kind_ = kind;
  precision_ = package == FactorPackage::amg ? H0Precision::double_precision : precision;
  // Rollers' identity rows break A = A1 (x) I3: the full matrix (Objective::holds_components).
  components_ = kind == ConstantMatrix::laplacian && !step.holds_components() ? 1 : 3;
  PetscCall(event_begin(&LogEvents::h0_assembly));
  PetscCall(step.assemble_constant_matrix(&A_, components_, kind));
  PetscCall(add_diagonal(extra_diagonal));
  PetscCall(event_end(&LogEvents::h0_assembly));
  PetscCall(factor_assembled(package));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::setup(const FactoredSystem& base, Vec extra_diagonal, CholeskyAnalysis* analysis) {
  PetscFunctionBeginUser;
  kind_ = base.kind_;
  components_ = base.components_;
  precision_ = base.precision_;
  PetscCall(event_begin(&LogEvents::h0_assembly));
  PetscCall(MatDuplicate(base.A_, MAT_COPY_VALUES, &A_));  // the values setup(step, ...) would assemble
  PetscCall(MatSetOption(A_, MAT_SPD, PETSC_TRUE));
  PetscCall(add_diagonal(extra_diagonal));
  PetscCall(event_end(&LogEvents::h0_assembly));
  PetscCall(factor_assembled(base.package_, analysis));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::diagonal(Vec d) const {
  PetscFunctionBeginUser;
  if (components_ == 3) {
    PetscCall(MatGetDiagonal(A_, d));
    PetscFunctionReturn(0);
  }
  Vec d1;
  const PetscScalar* a;
  PetscScalar* out;
  PetscInt n1;
  PetscCall(MatCreateVecs(A_, &d1, nullptr));
  PetscCall(MatGetDiagonal(A_, d1));
  PetscCall(VecGetLocalSize(d1, &n1));
  PetscCall(VecGetArrayRead(d1, &a));
  PetscCall(VecGetArrayWrite(d, &out));
  for (PetscInt i = 0; i < n1; ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + c] = a[i];  // local vertex i holds local dofs 3i..3i+2
  PetscCall(VecRestoreArrayWrite(d, &out));
  PetscCall(VecRestoreArrayRead(d1, &a));
  PetscCall(VecDestroy(&d1));
  PetscFunctionReturn(0);
}

PetscErrorCode add_dof_diagonal(Mat A, Vec diagonal, int components) {
  PetscFunctionBeginUser;
  if (components == 3) {
    PetscCall(MatDiagonalSet(A, diagonal, ADD_VALUES));
    PetscFunctionReturn(0);
  }
  Vec d;  // the x entries: one per free vertex
  const PetscScalar* e;
  PetscScalar* a;
  PetscInt n1;
  PetscCall(MatCreateVecs(A, &d, nullptr));
  PetscCall(VecGetLocalSize(d, &n1));
  PetscCall(VecGetArrayRead(diagonal, &e));
  PetscCall(VecGetArrayWrite(d, &a));
  for (PetscInt i = 0; i < n1; ++i) a[i] = e[3 * i];  // local vertex i holds local dofs 3i..3i+2
  PetscCall(VecRestoreArrayWrite(d, &a));
  PetscCall(VecRestoreArrayRead(diagonal, &e));
  PetscCall(MatDiagonalSet(A, d, ADD_VALUES));
  PetscCall(VecDestroy(&d));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::add_diagonal(Vec extra_diagonal) {
  PetscFunctionBeginUser;
  if (extra_diagonal) PetscCall(add_dof_diagonal(A_, extra_diagonal, components_));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::gather_to_zero() {
  PetscInt N;
  PetscMPIInt rank;
  IS all;
  PetscFunctionBeginUser;
  if (A0_) PetscFunctionReturn(0);
  PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)A_), &rank));
  PetscCall(MatGetSize(A_, &N, nullptr));
  PetscCall(ISCreateStride(PETSC_COMM_SELF, rank == 0 ? N : 0, 0, 1, &all));
  PetscCall(MatCreateSubMatrices(A_, 1, &all, &all, MAT_INITIAL_MATRIX, &A0_));
  PetscCall(ISDestroy(&all));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::factor_assembled(FactorPackage package, CholeskyAnalysis* analysis, bool corrected) {
  PetscInt n, N, m, M;
  const int components = components_;
  PetscFunctionBeginUser;
  // -hyperqn_h0_matrix_view binary:A1.bin: the matrix, e.g. for bench/mumps_repro.cpp.
  PetscCall(MatViewFromOptions(A_, nullptr, "-hyperqn_h0_matrix_view"));
  if (package == FactorPackage::automatic) PetscCall(choose_factor_package(A_, &package));
  package_ = package;

  MPI_Comm comm = PetscObjectComm((PetscObject)A_);
  PetscMPIInt size, rank;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  // The V-cycle and the split factor stay distributed.
  const bool gathered = size > 1 && package != FactorPackage::amg && package != FactorPackage::split;
  const double before = event_seconds(log_events().h0_factor);
  if (!corrected) PetscCall(event_begin(&LogEvents::h0_factor));
  Mat factored = A_;
  if (corrected) {  // follow's correction is the inverse
  } else if (package == FactorPackage::amg) {
    PetscCall(setup_amg());
  } else if (gathered) {  // gathered to rank 0, for reproducible solves (see the header)
    PetscCall(gather_to_zero());
    factored = A0_[0];
    PetscCall(MatSetOption(factored, MAT_SPD, PETSC_TRUE));  // as A_: MUMPS's LL^T, not LDL^T
  }
  PetscErrorCode ierr = 0;
  if (!corrected && package != FactorPackage::amg && (!gathered || rank == 0)) ierr = factor(factored, analysis);
  if (gathered) {  // an error on rank 0 (e.g. a bad -h0_mat_*_* value) must stop every rank
    int failed = ierr != 0, any = 0;
    PetscCallMPI(MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm));
    PetscCall(ierr);
    PetscCheck(!any, PETSC_COMM_SELF, PETSC_ERR_LIB, "the factorization of the constant matrix failed on rank 0");
  }
  PetscCall(ierr);
  if (!corrected) {
    if (precision_ == H0Precision::single_precision) PetscCall(keep_single_precision());
    PetscCall(event_end(&LogEvents::h0_factor));
    ++factorizations_;
    factor_s_ = event_seconds(log_events().h0_factor) - before;
  }
  MatInfo factor_info;
  if (factor_) {
    PetscCall(MatGetInfo(factor_, MAT_LOCAL, &factor_info));
    factor_nonzeros_ = factor_info.nz_used;
  }
  if (supernodal_) factor_nonzeros_ = static_cast<double>(supernodal_->nonzeros());
  if (topology_) factor_nonzeros_ = static_cast<double>(topology_->factor_nonzeros());
  int follows = topology_ != nullptr;  // gathered: rank 0's
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &follows, 1, MPI_INT, MPI_MAX, comm));
  follows_topology_ = follows != 0;
  if (split_) factor_nonzeros_ = split_->nonzeros();  // already the sum over the ranks
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &factor_nonzeros_, 1, MPI_DOUBLE, MPI_MAX, comm));  // gathered: rank 0's

  PetscCall(MatGetLocalSize(A_, &n, nullptr));
  PetscCall(MatGetSize(A_, &N, nullptr));
  m = n;
  M = N;
  if (components == 1) {
    PetscCall(MatCreateDense(comm, n, PETSC_DECIDE, N, 3, nullptr, &rhs_));
    PetscCall(MatCreateDense(comm, n, PETSC_DECIDE, N, 3, nullptr, &sol_));
    m = 3 * n;
    M = 3 * N;
  }
  PetscCall(MatCreateShell(comm, m, m, M, M, this, &shell_));
  if (gathered) {
    Vec layout;
    PetscCall(MatCreateVecs(shell_, &layout, nullptr));
    PetscCall(VecScatterCreateToZero(layout, &to_zero_, &b0_));
    PetscCall(VecDestroy(&layout));
    PetscCall(VecDuplicate(b0_, &x0_));
    if (components == 1 && rank == 0 && !supernodal_ && !topology_) {  // MatMatSolve's columns (supernodal solves in place)
      PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, N, 3, nullptr, &rhs0_));
      PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, N, 3, nullptr, &sol0_));
    }
  }
  PetscCall(MatShellSetOperation(shell_, MATOP_SOLVE, (void (*)(void))shell_solve));
  PetscCall(MatShellSetOperation(shell_, MATOP_MULT, (void (*)(void))shell_mult));
  PetscFunctionReturn(0);
}

// Dof vector (x, y, z per vertex) <-> n x 3 dense matrix of its x, y, z columns.
PetscErrorCode FactoredSystem::copy_columns(Vec v, Mat cols, bool to_columns) const {
  PetscInt n, lda;
  PetscFunctionBeginUser;
  PetscCall(MatGetLocalSize(cols, &n, nullptr));
  PetscCall(MatDenseGetLDA(cols, &lda));
  if (to_columns) {  // read v, write cols (v's state stays unchanged)
    const PetscScalar* a;
    PetscScalar* c;
    PetscCall(VecGetArrayRead(v, &a));
    PetscCall(MatDenseGetArrayWrite(cols, &c));
    for (PetscInt i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d) c[i + d * lda] = a[3 * i + d];
    PetscCall(MatDenseRestoreArrayWrite(cols, &c));
    PetscCall(VecRestoreArrayRead(v, &a));
  } else {
    const PetscScalar* c;
    PetscScalar* a;
    PetscCall(MatDenseGetArrayRead(cols, &c));
    PetscCall(VecGetArrayWrite(v, &a));
    for (PetscInt i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d) a[3 * i + d] = c[i + d * lda];
    PetscCall(VecRestoreArrayWrite(v, &a));
    PetscCall(MatDenseRestoreArrayRead(cols, &c));
  }
  PetscFunctionReturn(0);
}

// y = op(x) column by column: the x, y and z components of the dof vector x, each as a vector of
// A1's layout, through op into the same component of y.
PetscErrorCode FactoredSystem::by_columns(Vec x, Vec y, const std::function<PetscErrorCode(Vec, Vec)>& op) const {
  PetscFunctionBeginUser;
  PetscCall(copy_columns(x, rhs_, true));
  for (PetscInt d = 0; d < 3; ++d) {
    Vec in, out;
    PetscCall(MatDenseGetColumnVecRead(rhs_, d, &in));
    PetscCall(MatDenseGetColumnVecWrite(sol_, d, &out));
    PetscCall(op(in, out));
    PetscCall(MatDenseRestoreColumnVecWrite(sol_, d, &out));
    PetscCall(MatDenseRestoreColumnVecRead(rhs_, d, &in));
  }
  PetscCall(copy_columns(y, sol_, false));
  PetscFunctionReturn(0);
}

// x = A^{-1} b with the factor on this rank (b and x: all of A's rows), or x = B b by the V-cycle.
PetscErrorCode FactoredSystem::solve_here(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  if (empty_) PetscFunctionReturn(0);
  if (split_ || supernodal_ || topology_) {  // the dof layout is the interleaved one: no copies
    const PetscScalar* in;
    PetscScalar* out;
    PetscCall(VecGetArrayRead(b, &in));
    PetscCall(VecGetArrayWrite(x, &out));
    if (split_)  // this rank's rows, every rank
      PetscCall(split_->solve(in, out));
    else if (topology_ && topology_row_.empty())
      topology_->solve(3, in, out);
    else if (topology_) {  // in topology_'s rows and back (0 in the rows of vertices that left)
      const size_t rows = topology_row_.size();
      if (topology_->size() != (int64_t)rows) std::fill(topology_work_.begin(), topology_work_.end(), 0.0);
      topology_work_.resize(3 * size_t(topology_->size()), 0.0);
      for (size_t r = 0; r < rows; ++r)
        for (int c = 0; c < 3; ++c) topology_work_[3 * topology_row_[r] + c] = in[3 * r + c];
      topology_->solve(3, topology_work_.data(), topology_work_.data());
      for (size_t r = 0; r < rows; ++r)
        for (int c = 0; c < 3; ++c) out[3 * r + c] = topology_work_[3 * topology_row_[r] + c];
    } else
      supernodal_->solve(components_ == 1 ? 3 : 1, in, out);
    PetscCall(VecRestoreArrayWrite(x, &out));
    PetscCall(VecRestoreArrayRead(b, &in));
  } else if (interleaved_) {
    PetscCall(interleaved_->apply(b, x));
  } else if (ksp_) {  // one V-cycle per column x, y, z
    PetscCall(solve_by_columns(b, x));
  } else if (components_ == 1) {
    Mat rhs = rhs0_ ? rhs0_ : rhs_, sol = sol0_ ? sol0_ : sol_;
    PetscCall(copy_columns(b, rhs, true));
    PetscCall(MatMatSolve(factor_, rhs, sol));
    PetscCall(copy_columns(x, sol, false));
  } else {
    PetscCall(MatSolve(factor_, b, x));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::solve(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  PetscCall(event_begin(&LogEvents::h0_solve));
  if (to_zero_) {  // more than one rank: solved on rank 0
    PetscCall(VecScatterBegin(to_zero_, b, b0_, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(to_zero_, b, b0_, INSERT_VALUES, SCATTER_FORWARD));
    if (factor_ || supernodal_ || topology_) PetscCall(solve_here(b0_, x0_));
    PetscCall(VecScatterBegin(to_zero_, x0_, x, INSERT_VALUES, SCATTER_REVERSE));
    PetscCall(VecScatterEnd(to_zero_, x0_, x, INSERT_VALUES, SCATTER_REVERSE));
  } else {
    PetscCall(solve_here(b, x));
  }
  PetscCall(event_end(&LogEvents::h0_solve));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::solve_by_columns(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  PetscCheck(ksp_, PETSC_COMM_SELF, PETSC_ERR_ORDER, "solve_by_columns: the constant matrix is not solver.h0: amg");
  PetscCall(by_columns(b, x, [this](Vec in, Vec out) { return KSPSolve(ksp_, in, out); }));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::mult(Vec x, Vec y) const {
  PetscFunctionBeginUser;
  if (components_ == 3) {
    PetscCall(MatMult(A_, x, y));
    PetscFunctionReturn(0);
  }
  PetscCall(by_columns(x, y, [this](Vec in, Vec out) { return MatMult(A_, in, out); }));
  PetscFunctionReturn(0);
}

PetscErrorCode FactoredSystem::follow(FactoredSystem& before, const Objective& step, FactorPackage package,
                                      std::vector<int64_t> row_ids, const TopologyCheck& check, bool* corrected) {
  PetscFunctionBeginUser;
  *corrected = false;
  kind_ = before.kind_;
  components_ = kind_ == ConstantMatrix::laplacian && !step.holds_components() ? 1 : 3;
  set_row_ids(std::move(row_ids), check.max_touched);
  PetscCall(event_begin(&LogEvents::h0_assembly));
  PetscCall(step.assemble_constant_matrix(&A_, components_, kind_));
  PetscCall(event_end(&LogEvents::h0_assembly));
  if (before.follows_topology() && components_ == 1 && !row_ids_.empty()) {
    // On more than one rank before's TopologyH0 is on rank 0, with the gathered factor: A_ is
    // gathered there too, rank 0 corrects, and every rank learns whether it did.
    MPI_Comm comm = PetscObjectComm((PetscObject)A_);
    PetscMPIInt size, rank;
    PetscCallMPI(MPI_Comm_size(comm, &size));
    PetscCallMPI(MPI_Comm_rank(comm, &rank));
    if (size > 1) PetscCall(gather_to_zero());
    const PetscErrorCode ierr = rank == 0 ? correct_from(before, size > 1 ? A0_[0] : A_, check, corrected) : 0;
    int outcome[2] = {static_cast<int>(ierr), *corrected ? 1 : 0};
    PetscCallMPI(MPI_Bcast(outcome, 2, MPI_INT, 0, comm));  // before rank 0 returns an error: no rank waits
    PetscCall(ierr);                                          // rank 0's, with its trace
    PetscCheck(outcome[0] == 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "the correction of the constant matrix failed on rank 0");
    *corrected = outcome[1] != 0;
  }
  if (*corrected) {
    package_ = before.package_;
    PetscCall(factor_assembled(package_, nullptr, true));
    if (check.check) PetscCall(check_correction());
  } else {
    PetscCall(factor_assembled(package));
  }
  PetscFunctionReturn(0);
}

// The change as edits of before's TopologyH0: its matrix C (the factored one and every change
// since) and A_ in its rows, B; every entry where B - C is not zero is an edit (rows no element
// of the cut touched are assembled from the same elements in the same order, so they are equal
// bit for bit and stay out of T). A vertex of A_ that C does not have is a new vertex (a copy),
// numbered in the order of A_'s rows; a vertex of C missing from A_ (it left the mesh: a removed
// tet's orphan) keeps its row, decoupled (its diagonal only; solves put 0 there). Not corrected:
// more rows touched than max_touched (the size trigger: the caller factors A_ anew).
PetscErrorCode FactoredSystem::correct_from(FactoredSystem& before, Mat A, const TopologyCheck& check, bool* corrected) {
  PetscFunctionBeginUser;
  std::unique_ptr<TopologyH0> h0 = std::move(before.topology_);
  std::vector<int64_t> ids = before.topology_ids_;
  const int64_t old_rows = h0->size(), rows = static_cast<int64_t>(row_ids_.size());
  std::unordered_map<int64_t, int64_t> old_row_of;
  for (int64_t k = 0; k < old_rows; ++k) old_row_of.emplace(ids[k], k);
  std::vector<int64_t> row(rows, -1);
  for (int64_t r = 0; r < rows; ++r) {
    const auto it = old_row_of.find(row_ids_[r]);
    if (it != old_row_of.end()) row[r] = it->second;
  }
  const SymmetricCsr C = h0->changed_matrix();
  for (int64_t r = 0; r < rows; ++r)
    if (row[r] < 0) {
      row[r] = h0->add_vertex();
      ids.push_back(row_ids_[r]);
    }
  // B's rows in h0's order, each merged with C's: the upper triangle's differences. A row of h0
  // whose vertex A_ no longer has (a removed tet's orphan, docs/removal.md) is decoupled: B keeps
  // C's diagonal there and nothing else, and a solve puts 0 in it.
  const int64_t all_rows = h0->size();
  std::vector<int64_t> scene_row(all_rows, -1);
  for (int64_t r = 0; r < rows; ++r) scene_row[row[r]] = r;
  struct Edit {
    int64_t i, j;
    double delta;
  };
  std::vector<Edit> edits;
  std::vector<std::pair<int64_t, double>> b;
  for (int64_t i = 0; i < all_rows; ++i) {
    b.clear();
    if (scene_row[i] < 0) {
      for (int64_t p = C.start[i]; p < C.start[i + 1]; ++p)
        if (C.column[p] == i) b.push_back({i, C.value[p]});
    } else {
      PetscInt nc;
      const PetscInt* c;
      const PetscScalar* v;
      PetscCall(MatGetRow(A, scene_row[i], &nc, &c, &v));
      for (PetscInt k = 0; k < nc; ++k)
        if (row[c[k]] >= i) b.push_back({row[c[k]], v[k]});
      PetscCall(MatRestoreRow(A, scene_row[i], &nc, &c, &v));
    }
    std::sort(b.begin(), b.end());
    size_t q = 0;
    int64_t p = i < old_rows ? C.start[i] : 0;
    const int64_t end = i < old_rows ? C.start[i + 1] : 0;
    while (p < end && C.column[p] < i) ++p;
    while (q < b.size() || p < end) {
      const int64_t j = q < b.size() && (p >= end || b[q].first <= C.column[p]) ? b[q].first : C.column[p];
      const double bij = q < b.size() && b[q].first == j ? b[q++].second : 0.0;
      const double cij = p < end && C.column[p] == j ? C.value[p++] : 0.0;
      if (bij != cij) edits.push_back({i, j, bij - cij});
    }
  }
  if (check.drop_edit) {  // the largest off-diagonal one; without any (a strand snapped at its end), an old row's diagonal one
    size_t largest = edits.size();
    for (int pass = 0; pass < 2 && largest == edits.size(); ++pass)
      for (size_t k = 0; k < edits.size(); ++k)
        if ((pass == 0 ? edits[k].i != edits[k].j : edits[k].i < old_rows) &&
            (largest == edits.size() || std::fabs(edits[k].delta) > std::fabs(edits[largest].delta)))
          largest = k;
    if (largest < edits.size()) edits.erase(edits.begin() + largest);
  }
  for (const Edit& e : edits) h0->add_entry(e.i, e.j, e.delta);
  if (h0->pending_touched() > h0->max_touched()) PetscFunctionReturn(0);
  const double before_commit = event_seconds(log_events().h0_correct);
  PetscCall(event_begin(&LogEvents::h0_correct));
  const TopologyH0::Status status = h0->commit();
  PetscCall(event_end(&LogEvents::h0_correct));
  if (status != TopologyH0::Status::ok) PetscFunctionReturn(0);  // factored anew, which says why
  factor_s_ = event_seconds(log_events().h0_correct) - before_commit;
  topology_ = std::move(h0);
  topology_ids_ = std::move(ids);
  topology_row_ = std::move(row);
  *corrected = true;
  PetscFunctionReturn(0);
}

// The corrected inverse against a fresh factorization of A_ on 2 x 3 random vectors (a fixed
// seed): the largest relative difference, printed.
PetscErrorCode FactoredSystem::check_correction() const {
  SymmetricCsr a;
  SupernodalCholesky fresh;
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)A_), &rank));
  if (A0_ && rank != 0) PetscFunctionReturn(0);  // gathered: the factor and the correction are rank 0's
  PetscCall(rows_of(A0_ ? A0_[0] : A_, true, &a));
  PetscCheck(fresh.factor(a.n, a.start.data(), a.column.data(), a.value.data()) == SupernodalCholesky::Status::ok,
             PETSC_COMM_SELF, PETSC_ERR_LIB, "the check's factorization of the changed matrix failed");
  std::mt19937_64 random(44);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Vec b, x;
  if (A0_) {
    PetscCall(VecDuplicate(b0_, &b));
    PetscCall(VecDuplicate(x0_, &x));
  } else {
    PetscCall(MatCreateVecs(shell_, &b, &x));
  }
  double worst = 0;
  for (int draw = 0; draw < 2; ++draw) {
    PetscScalar* in;
    PetscCall(VecGetArrayWrite(b, &in));
    for (int64_t k = 0; k < 3 * a.n; ++k) in[k] = uniform(random);
    PetscCall(VecRestoreArrayWrite(b, &in));
    PetscCall(solve_here(b, x));
    const PetscScalar *bin, *xin;
    std::vector<double> y(3 * a.n);
    PetscCall(VecGetArrayRead(b, &bin));
    fresh.solve(3, bin, y.data());
    PetscCall(VecRestoreArrayRead(b, &bin));
    PetscCall(VecGetArrayRead(x, &xin));
    double diff = 0, norm = 0;
    for (int64_t k = 0; k < 3 * a.n; ++k) {
      diff += (xin[k] - y[k]) * (xin[k] - y[k]);
      norm += y[k] * y[k];
    }
    PetscCall(VecRestoreArrayRead(x, &xin));
    worst = std::fmax(worst, std::sqrt(diff / norm));
  }
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscCall(PetscPrintf(PETSC_COMM_SELF,
                        "hyperqn: topology H0 check: %lld rows touched since the factorization, relative difference "
                        "%.3e from a fresh factorization\n",
                        (long long)topology_->touched(), worst));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

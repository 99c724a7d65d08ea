// Which phase of a distributed sparse factorization (MUMPS, SuperLU_DIST) is not bitwise
// reproducible: the analysis (ordering, mapping), the numerical factorization or the solve.
//
// Loads a matrix (PETSc binary, e.g. hyperqn's A1 from -hyperqn_h0_matrix_view binary:A1.bin),
// distributes it by rows over the ranks, and solves A X = B for a fixed N x 3 B:
//   - `analyses` times a new factor (analysis + factorization), each
//   - `numerics` times the numerical factorization again on the same analysis, each
//   - `solves` times a solve with that factor.
// Every solution X is gathered to rank 0 and compared bitwise with the first; the output says
// which changed, and prints a hash of the first X so that separate runs (mpiexec again) can be
// compared. With -mat_mumps_icntl_33 1 each factorization also prints MUMPS's determinant (a
// function of the pivots alone, in hex: bitwise). Options: -f FILE, -package mumps|superlu_dist, -analyses, -numerics, -solves, and
// the package's own (-mat_mumps_icntl_7 2, -mat_mumps_icntl_20 0, ...), read by MatSetFromOptions.
// Run: mpiexec -n 2 build/mumps_repro -f A1.bin [-mat_mumps_icntl_28 1 ...]
#include <petscmat.h>

#include <cstdint>
#include <cstring>
#include <vector>

// The bits of X on rank 0 (empty elsewhere), column by column.
static PetscErrorCode gather_bits(Mat X, std::vector<double>* out) {
  Mat all;
  PetscFunctionBeginUser;
  PetscCall(MatCreateRedundantMatrix(X, 0, PETSC_COMM_SELF, MAT_INITIAL_MATRIX, &all));  // every rank, simplest
  PetscInt m, n;
  PetscCall(MatGetSize(all, &m, &n));
  const PetscScalar* a;
  PetscCall(MatDenseGetArrayRead(all, &a));
  out->assign(a, a + m * n);
  PetscCall(MatDenseRestoreArrayRead(all, &a));
  PetscCall(MatDestroy(&all));
  PetscFunctionReturn(0);
}

static uint64_t fnv1a(const std::vector<double>& v) {
  uint64_t h = 1469598103934665603ull;
  const unsigned char* p = reinterpret_cast<const unsigned char*>(v.data());
  for (size_t i = 0; i < v.size() * sizeof(double); ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

// Entries of a differing from b, and the largest |a - b| / max |b|.
static void compare(const std::vector<double>& a, const std::vector<double>& b, size_t* differ, double* rel) {
  double top = 0, d = 0;
  *differ = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(&a[i], &b[i], sizeof(double))) ++*differ;
    top = PetscMax(top, PetscAbsReal(b[i]));
    d = PetscMax(d, PetscAbsReal(a[i] - b[i]));
  }
  *rel = top > 0 ? d / top : d;
}

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  char file[PETSC_MAX_PATH_LEN] = "", package[64] = "mumps";
  PetscInt analyses = 2, numerics = 2, solves = 3;
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-f", file, sizeof file, nullptr));
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-package", package, sizeof package, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-analyses", &analyses, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-numerics", &numerics, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-solves", &solves, nullptr));
  PetscBool superlu;
  PetscCall(PetscStrcmp(package, "superlu_dist", &superlu));

  Mat A, B, X;
  PetscViewer viewer;
  PetscCall(PetscViewerBinaryOpen(PETSC_COMM_WORLD, file, FILE_MODE_READ, &viewer));
  PetscCall(MatCreate(PETSC_COMM_WORLD, &A));
  PetscCall(MatSetType(A, MATAIJ));
  PetscCall(MatLoad(A, viewer));
  PetscCall(PetscViewerDestroy(&viewer));
  PetscCall(MatSetOption(A, MAT_SPD, PETSC_TRUE));
  PetscInt N, rstart, rend;
  PetscCall(MatGetSize(A, &N, nullptr));
  PetscCall(MatGetOwnershipRange(A, &rstart, &rend));
  // A fixed right-hand side of 3 columns: smooth and nonzero everywhere, independent of the ranks.
  PetscCall(MatCreateDense(PETSC_COMM_WORLD, rend - rstart, PETSC_DECIDE, N, 3, nullptr, &B));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X));
  {
    PetscScalar* b;
    PetscInt lda;
    PetscCall(MatDenseGetArrayWrite(B, &b));
    PetscCall(MatDenseGetLDA(B, &lda));
    for (PetscInt i = rstart; i < rend; ++i)
      for (int d = 0; d < 3; ++d) b[(i - rstart) + d * lda] = PetscSinReal(0.37 * i + d) + 0.1 * (d + 1);
    PetscCall(MatDenseRestoreArrayWrite(B, &b));
  }

  std::vector<double> first, x;
  size_t differ;
  double rel;
  for (PetscInt a = 0; a < analyses; ++a) {
    Mat F;
    MatFactorInfo info;
    PetscCall(MatFactorInfoInitialize(&info));
    PetscCall(MatGetFactor(A, superlu ? MATSOLVERSUPERLU_DIST : MATSOLVERMUMPS,
                           superlu ? MAT_FACTOR_LU : MAT_FACTOR_CHOLESKY, &F));
    PetscCall(MatSetFromOptions(F));
    if (superlu)
      PetscCall(MatLUFactorSymbolic(F, A, nullptr, nullptr, &info));
    else
      PetscCall(MatCholeskyFactorSymbolic(F, A, nullptr, &info));
    for (PetscInt f = 0; f < numerics; ++f) {
      if (superlu)
        PetscCall(MatLUFactorNumeric(F, A, &info));
      else
        PetscCall(MatCholeskyFactorNumeric(F, A, &info));
      PetscInt det_icntl = 0;
      if (!superlu) PetscCall(MatMumpsGetIcntl(F, 33, &det_icntl));
      if (det_icntl) {  // -mat_mumps_icntl_33 1: the factor's pivots, bit for bit, without a solve
        PetscReal mantissa;
        PetscInt exponent;
        PetscCall(MatMumpsGetRinfog(F, 12, &mantissa));
        PetscCall(MatMumpsGetInfog(F, 34, &exponent));
        PetscCall(PetscPrintf(PETSC_COMM_WORLD, "analysis %" PetscInt_FMT " numeric %" PetscInt_FMT
                              ": det %a * 2^%" PetscInt_FMT "\n", a, f, (double)mantissa, exponent));
      }
      for (PetscInt s = 0; s < solves; ++s) {
        PetscCall(MatMatSolve(F, B, X));
        PetscCall(gather_bits(X, &x));
        if (first.empty()) {
          first = x;
          PetscCall(PetscPrintf(PETSC_COMM_WORLD, "N %" PetscInt_FMT "  first X hash %016llx\n", N,
                                (unsigned long long)fnv1a(first)));
        }
        compare(x, first, &differ, &rel);
        PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                              "analysis %" PetscInt_FMT " numeric %" PetscInt_FMT " solve %" PetscInt_FMT
                              ": %s  (%zu of %zu entries differ, max rel %.2e)  hash %016llx\n",
                              a, f, s, differ ? "DIFFERS" : "identical", differ, x.size(), rel,
                              (unsigned long long)fnv1a(x)));
      }
    }
    PetscCall(MatDestroy(&F));
  }
  PetscCall(MatDestroy(&X));
  PetscCall(MatDestroy(&B));
  PetscCall(MatDestroy(&A));
  PetscCall(PetscFinalize());
  return 0;
}

// The constant SPD matrix A of a scene, factored once by a sparse Cholesky (CHOLMOD or MUMPS, see
// FactorPackage), then applied as A^{-1} as often as needed (L-BFGS initial Hessian, PD global
// step).
//
// A = M + h^2 L is A1 (x) I3 (the same scalar matrix for x, y and z), so only the vertex matrix
// A1 = M1 + h^2 L1 is factored, and A^{-1} b is one solve with A1 for the three right-hand
// sides b_x, b_y, b_z: a third of the unknowns and a ninth of the nonzeros of A.
// A = M + h^2 K(x_rest) couples x, y and z: the full 3n x 3n matrix is factored and applied to b
// as one vector. So is M + h^2 L in a scene with rollers (model/body.hpp hold): its held rows and
// columns are the identity's, which A1 (x) I3 cannot say.
//
// FactorPackage::amg factors nothing: A1^{-1} is replaced by one algebraic multigrid V-cycle of A1
// (solver.h0: amg), a fixed symmetric positive definite operator, set up once and kept distributed.
//
// On more than one rank A is gathered to rank 0 and factored there sequentially (by the same
// package); each solve gathers b to rank 0 and scatters x back. Parallel MUMPS is not
// reproducible: its factorization and solve sum the contribution blocks of a front in the order
// the other ranks' messages arrive, so two runs of a deck at 2 ranks differed in the last bits of
// every A^{-1} b and, through L-BFGS, in iteration counts (docs/performance.md#reproducibility).
#pragma once
#include <petscksp.h>
#include <petscmat.h>

#include <functional>
#include <memory>
#include <vector>

#include "solvers/interleaved_vcycle.hpp"
#include "solvers/objective.hpp"
#include "solvers/solver_spec.hpp"
#include "solvers/split_cholesky.hpp"
#include "solvers/supernodal_cholesky.hpp"
#include "solvers/topology_h0.hpp"

namespace hyperqn {

// Who factors and solves A (option -hyperqn_h0_package). mumps and cholmod: the package through
// PETSc (MatGetFactor; its options take the prefix h0_: -h0_mat_mumps_*, -h0_mat_cholmod_*).
// supernodal: CHOLMOD's factorization, solved by hyperqn's own loops on the dof array with x, y
// and z interleaved (solvers/supernodal_cholesky.hpp). All compute the same LL^T up to the
// fill-reducing ordering (results differ in the last bits); they differ in the cost of a solve
// (docs/performance.md#h0-package), which decided the default.
// amg: no factorization; x = B b with B one V-cycle of PETSc's GAMG (or BoomerAMG, -h0_pc_type
// hypre) on A1, through a KSPPREONLY with the prefix h0_. Not A^{-1}: an approximation L-BFGS can
// take as H0 (symmetric and positive definite by the choice of smoothers), not PD's exact steps.
// Chosen by solver.h0 (lbfgs only), not by -hyperqn_h0_package.
// split: supernodal's factor and solve, distributed: each rank factors its own interior and the
// ranks share the Schur complement of their interface (solvers/split_cholesky.hpp); on one rank
// it is supernodal. The others gather A to rank 0 on more than one rank (see above).
// automatic: resolved when the matrix is set up (choose_factor_package).
enum class FactorPackage { mumps, cholmod, supernodal, split, amg, automatic };
const char* factor_package_name(FactorPackage p);  // "mumps", "cholmod", "supernodal", "split", "amg", "auto"
// PETSc's CHOLMOD needs a PETSc built with SuiteSparse (PETSC_HAVE_SUITESPARSE); MUMPS and
// hyperqn's own link to CHOLMOD are always there.
bool factor_package_available(FactorPackage p);
// -hyperqn_h0_package's default: automatic.
FactorPackage default_factor_package();
// What automatic becomes for the assembled matrix A (collective): supernodal on one rank; on more,
// split while its dense interface block is affordable (at most kMaxSplitInterface rows), else
// supernodal gathered to rank 0 (docs/performance.md#distributed-h0).
PetscErrorCode choose_factor_package(Mat A, FactorPackage* package);
constexpr PetscInt kMaxSplitInterface = 8000;
// True if `package` (-hyperqn_h0_package) splits the factor on more than one rank where it can.
inline bool splits_on_many_ranks(FactorPackage package) {
  return package == FactorPackage::split || package == FactorPackage::automatic;
}

// A += diag(diagonal), diagonal in the dof layout (x, y, z per free vertex): the whole of it into a
// matrix of that layout (components = 3), its x entries into one of the vertex layout (components =
// 1, A1 of A = A1 (x) I3, whose diagonal is the same for x, y and z).
PetscErrorCode add_dof_diagonal(Mat A, Vec diagonal, int components);

// What follow() does beside the correction (tests and the check of docs/topology.md): check, the
// corrected solve against a fresh factorization of the changed matrix on random vectors (printed);
// drop_edit, the largest off-diagonal entry of the change left out (the check must see it), or
// where the change has none (a strand snapped next to its fixed end), an old row's largest diagonal one.
// max_touched: TopologyH0's size trigger (0: its default), smaller in tests to reach it.
struct TopologyCheck {
  bool check = false, drop_edit = false;
  int64_t max_touched = 0;
};

class FactoredSystem {
 public:
  FactoredSystem() = default;
  ~FactoredSystem();
  FactoredSystem(const FactoredSystem&) = delete;
  FactoredSystem& operator=(const FactoredSystem&) = delete;

  // Assembles A (A1 for the Laplacian) and computes its Cholesky factorization (once per scene),
  // or for amg sets up the V-cycle of A1 (kind must be laplacian). A factorization that fails
  // (A not positive definite) is an error saying so.
  // With single_precision the factor's values are kept as floats (SupernodalCholesky::
  // keep_single_precision): supernodal and split only (another package is an error); amg, which
  // factors nothing, ignores it (precision() says double).
  // extra_diagonal (a dof vector, x, y and z alike for the Laplacian) is added to A's diagonal
  // before it is factored.
  PetscErrorCode setup(const Objective& step, ConstantMatrix kind = ConstantMatrix::laplacian,
                       FactorPackage package = default_factor_package(),
                       H0Precision precision = H0Precision::double_precision, Vec extra_diagonal = nullptr);
  // The same as setup(step, base.kind(), base.package(), base.precision(), extra_diagonal) from a copy of base's
  // assembled matrix, with no assembly (solver.h0_contact: refactor, once per change of its
  // diagonal). With `analysis` (kept by the caller from one such setup to the next) the supernodal
  // and split packages analyse the pattern once (CholeskyAnalysis); the others ignore it.
  PetscErrorCode setup(const FactoredSystem& base, Vec extra_diagonal, CholeskyAnalysis* analysis = nullptr);
  // A scene whose topology may change (deck cuts:, docs/topology.md): before setup, the vertex id
  // of each row of A1 (every row's, on every rank; the constant matrix follows vertices by id
  // across a cut). The supernodal factor of A1 (the Laplacian without rollers; on one rank, or
  // gathered to rank 0) is then held by a TopologyH0, whose solve with no change is the plain
  // factor's, bit for bit.
  void set_row_ids(std::vector<int64_t> row_ids, int64_t max_touched = 0) {
    row_ids_ = std::move(row_ids);
    max_touched_ = max_touched > 0 ? max_touched : TopologyH0::kDefaultMaxTouched;
  }
  // The scene changed by a cut: this system is set up for `step` (A assembled, row ids as above)
  // and, where `before` holds a TopologyH0, takes it over: the change A' - A, mapped to its rows by
  // vertex id (a copy is a new vertex; a vertex that left keeps a decoupled row), becomes its
  // edits and one commit (*corrected = true).
  // Otherwise (another package (split or amg) or kind, rollers, or more than TopologyH0::max_touched
  // rows touched since the last factorization) A' is factored as setup would with `package`.
  PetscErrorCode follow(FactoredSystem& before, const Objective& step, FactorPackage package, std::vector<int64_t> row_ids,
                        const TopologyCheck& check, bool* corrected);
  // Whether this system's inverse is a TopologyH0's (a cut can be followed by a correction; the
  // same on every rank, the TopologyH0 on rank 0 when gathered).
  bool follows_topology() const { return follows_topology_; }
  // The package that ran (automatic resolved).
  ConstantMatrix kind() const { return kind_; }
  FactorPackage package() const { return package_; }
  H0Precision precision() const { return precision_; }
  // x = A^{-1} b (dof layout: x, y, z per free vertex); for amg x = B b, one V-cycle of A1 (x) I3
  // (solvers/interleaved_vcycle.hpp), or one per column x, y, z where it does not apply.
  PetscErrorCode solve(Vec b, Vec x) const;
  // amg only: whether solve runs the interleaved cycle, and B b by GAMG's own cycle on each
  // column (the same B to round-off; the reference tests compare the interleaved one against).
  bool interleaved() const { return interleaved_ != nullptr; }
  PetscErrorCode solve_by_columns(Vec b, Vec x) const;
  // y = A x.
  PetscErrorCode mult(Vec x, Vec y) const;
  // A's diagonal in the dof layout (x, y and z alike for the Laplacian's A1 (x) I3).
  PetscErrorCode diagonal(Vec d) const;
  // A shell matrix whose MatSolve applies A^{-1} and whose MatMult applies A: the form
  // TaoLMVMSetH0 takes.
  Mat inverse_operator() const { return shell_; }

  // Time of this system's factorization or AMG setup, or of the TopologyH0 correction that made
  // it (follow; the run's totals are the log events hqnH0*).
  double factor_seconds() const { return factor_s_; }
  // Entries of the Cholesky factor (the package's count; the same on every rank). For amg: the
  // entries of the multigrid hierarchy's matrices, A1 and its coarse levels (PCMG, e.g. GAMG),
  // or A1's alone where PETSc does not hold them (BoomerAMG).
  double factor_nonzeros() const { return factor_nonzeros_; }
  int factorizations() const { return factorizations_; }
  // Rows of the split factor's dense interface block (0 for the other packages).
  PetscInt interface_size() const { return split_ ? split_->separator_size() : 0; }

 private:
  PetscErrorCode add_diagonal(Vec extra_diagonal);  // to A_ (nothing if null)
  // The rest of setup once A_ is assembled: the factorization or the V-cycle, the shell.
  // corrected: the inverse is already in place (follow's correction): no factorization.
  PetscErrorCode factor_assembled(FactorPackage package, CholeskyAnalysis* analysis = nullptr, bool corrected = false);
  PetscErrorCode factor_topology(Mat A);  // A_ into topology_ (one rank)
  // follow's correction: takes before's TopologyH0 and commits A_ - its matrix (*corrected: it did).
  // A: the assembled A', A_ or (gathered) its copy on rank 0, where this runs.
  PetscErrorCode correct_from(FactoredSystem& before, Mat A, const TopologyCheck& check, bool* corrected);
  PetscErrorCode gather_to_zero();  // more than one rank: A_ to A0_ on rank 0 (once)
  PetscErrorCode check_correction() const;  // TopologyCheck::check
  // Cholesky factorization of A (A_, or its copy on rank 0) into factor_ or supernodal_.
  PetscErrorCode factor(Mat A, CholeskyAnalysis* analysis);
  // supernodal_'s or split_'s values to float (precision_ single; collective).
  PetscErrorCode keep_single_precision();
  PetscErrorCode factor_supernodal(Mat A, CholeskyAnalysis* analysis);
  PetscErrorCode factor_split(Mat A, CholeskyAnalysis* analysis);  // A_ itself, on more than one rank
  PetscErrorCode setup_amg();  // ksp_ on A_
  // x = A^{-1} b with the factor on this rank (b and x: all of A's rows, on rank 0 when gathered).
  PetscErrorCode solve_here(Vec b, Vec x) const;
  // y = op(x) applied to the x, y, z columns of a dof vector one by one (rhs_, sol_ as work).
  PetscErrorCode by_columns(Vec x, Vec y, const std::function<PetscErrorCode(Vec, Vec)>& op) const;
  // Dof vector <-> the n x 3 dense matrix of its x, y, z columns (either direction).
  PetscErrorCode copy_columns(Vec v, Mat cols, bool to_columns) const;

  ConstantMatrix kind_ = ConstantMatrix::laplacian;
  int components_ = 1;  // A_'s: 1 for A1 of A = A1 (x) I3 (the Laplacian's), 3 for the full A (rest stiffness, rollers)
  FactorPackage package_ = FactorPackage::mumps;
  H0Precision precision_ = H0Precision::double_precision;
  Mat A_ = nullptr, factor_ = nullptr, shell_ = nullptr;  // A_: A1 for the Laplacian, else A
  std::unique_ptr<SupernodalCholesky> supernodal_;         // instead of factor_ for supernodal
  std::unique_ptr<SplitCholesky> split_;                   // instead of factor_ for split on > 1 rank
  std::unique_ptr<TopologyH0> topology_;                   // instead of supernodal_ in a scene with cuts (rank 0's when gathered)
  bool follows_topology_ = false;                          // topology_ on this rank or rank 0
  bool empty_ = false;  // a scene with no free dof (every vertex left fixed by a removal): nothing to factor or solve
  std::vector<int64_t> row_ids_;       // per row of A1: its vertex id (empty: topology_ not used)
  int64_t max_touched_ = TopologyH0::kDefaultMaxTouched;  // topology_'s size trigger
  std::vector<int64_t> topology_ids_;  // per row of topology_: its vertex id (the rows it had, then its new vertices)
  std::vector<int64_t> topology_row_;  // per row of A1: its row of topology_ (empty: the same)
  mutable std::vector<double> topology_work_;  // a solve's right-hand side in topology_'s rows
  KSP ksp_ = nullptr;                                      // instead of a factor for amg
  std::unique_ptr<InterleavedVCycle> interleaved_;         // amg with GAMG's default smoothers
  Mat rhs_ = nullptr, sol_ = nullptr;  // Laplacian: n x 3 dense work matrices
  // More than one rank: A on rank 0 (a 0 x 0 matrix elsewhere), the scatter of a dof vector to
  // rank 0 and its gathered copy there (length 0 elsewhere).
  Mat* A0_ = nullptr;  // MatCreateSubMatrices' array of one
  VecScatter to_zero_ = nullptr;
  Vec b0_ = nullptr, x0_ = nullptr;
  Mat rhs0_ = nullptr, sol0_ = nullptr;  // Laplacian, on rank 0: N x 3 dense work matrices
  double factor_s_ = 0;
  int factorizations_ = 0;
  double factor_nonzeros_ = 0;
};

}  // namespace hyperqn

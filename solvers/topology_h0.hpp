// The inverse of A = M + h^2 L after changes of the mesh's topology (docs/topology.md), from the
// factor of A before them: issue 44's H0 that follows cuts without a refactorization.
//
// A change is a list of edits of the vertex matrix A (A1 of A1 (x) I3, n x n):
//   - a new vertex, the copy of an old one, taking `mass_moved` of its lumped mass (duplicate_vertex);
//   - a vertex's mass changed (add_mass);
//   - an element's contribution s K_e added on its vertices (add_element): s = -1 and the old
//     vertices, s = +1 and the new ones move an element to a copy; s = -1 alone removes it.
// After commit(), solve() applies A'^{-1}, A' the changed matrix ((n + p) x (n + p), p new vertices),
// by the factor A = P^T L L^T P of setup() and a correction of the size of the touched set T (the
// rows where A' - A is not zero):
//   A' = Lh (I + W E W^T) Lh^T,   Lh = blkdiag(P^T L, D^{1/2}),   W = Lh^{-1} P_T,   E = (A' - blkdiag(A, D))_TT
//   A'^{-1} = Lh^{-T} (I - W E (I + G E)^{-1} W^T) Lh^{-1},   G = W^T W   (t x t, t = |T|),
// D the new vertices' own diagonal entries of A' when first committed. A column of W for an old
// vertex is L^{-1} P e_i, nonzero only on the supernodes from i's up to the root (a sparse forward
// solve, SupernodalCholesky::forward_units), computed once per vertex; a new vertex's is a unit
// column. The correction sits between the forward and backward passes of the one solve with L
// (SupernodalCholesky::solve_corrected) as y -= W K W^T y, K = E (I + G E)^{-1} applied by the LU
// of I + G E from the commit: a solve costs the factor's plus O(nnz(W) + t^2).
//
// Each column of W and each entry of G depends on its vertices alone, and I + G E is factored
// anew (dense LU) from the whole T at every commit, so the operator is a function of the factor
// and the ordered list of changes and commits, bit for bit. A deterministic trigger bounds the
// correction: a commit that makes t exceed max_touched refactors A' (refactor()), and a caller
// refactors at a checkpoint write (setup() with the changed matrix), which a restart repeats.
//
// One rank, the supernodal factor: what a distributed one needs is in docs/topology.md.
// No PETSc here (as supernodal_cholesky.hpp).
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <map>
#include <unordered_map>
#include <utility>
#include <vector>

#include "solvers/supernodal_cholesky.hpp"

namespace hyperqn {

// A symmetric matrix in compressed rows, both triangles, columns sorted within a row.
struct SymmetricCsr {
  int64_t n = 0;
  std::vector<int64_t> start{0}, column;
  std::vector<double> value;
};

class TopologyH0 {
 public:
  enum class Status { ok, not_positive_definite, failed };
  // E_TT by columns (rows in T's order), what the correction's middle multiplies by.
  struct CapacitanceColumns {
    std::vector<int64_t> start{0}, row;
    std::vector<double> value;
  };
  // A commit past this many touched rows refactors (measured: docs/topology-cost.md).
  static constexpr int64_t kDefaultMaxTouched = 200;

  // Factors A and forgets every change (what a refactorization at a checkpoint write does with
  // the changed matrix).
  Status setup(SymmetricCsr A, int64_t max_touched = kDefaultMaxTouched);

  // Rows of the changed matrix (n + p); of the factored one.
  int64_t size() const { return n_ + static_cast<int64_t>(sqrt_d_.size()) + pending_vertices_; }
  int64_t factored_size() const { return n_; }

  // Edits of A' (see above), in order; none applies to solve() before commit().
  int64_t duplicate_vertex(int64_t vertex, double mass_moved);  // the new vertex's index
  void add_mass(int64_t vertex, double delta);
  // A new vertex whose row comes entirely from later edits (add_entry), e.g. a cut's copy when
  // the change is given as the difference of two assembled matrices; its index.
  int64_t add_vertex();
  // A'(i, j) and A'(j, i) += delta (once if i == j).
  void add_entry(int64_t i, int64_t j, double delta);
  // A'(v_a, v_b) += scale K[a count + b] for the element's `count` vertices (K row-major, symmetric).
  void add_element(int count, const int64_t* vertices, const double* K, double scale);

  // The correction for every edit so far, or a refactorization of A' when its touched rows exceed
  // max_touched. not_positive_definite: A' is not (then the operator is unusable until setup).
  Status commit();
  // A' factored anew (the correction dropped).
  Status refactor();

  // x = A'^{-1} b for k = 1 or 3 interleaved right-hand sides of size() rows (b and x may alias).
  void solve(int k, const double* b, double* x) const;

  // The changed matrix A' (the factored one plus every committed and pending edit).
  SymmetricCsr changed_matrix() const;

  int64_t touched() const { return static_cast<int64_t>(touched_.size()); }  // t at the last commit
  int64_t pending_touched() const;  // t if commit() were called now (> max_touched: it would refactor)
  int64_t max_touched() const { return max_touched_; }
  int refactorizations() const { return refactorizations_; }                 // by commit() or refactor()
  int64_t columns_computed() const { return columns_computed_; }             // sparse forward solves since setup
  int64_t correction_nonzeros() const;                                       // nnz(W) at the last commit
  int64_t factor_nonzeros() const { return factor_.nonzeros(); }             // of the factor L

 private:
  int64_t slot_of(int64_t row);  // its place in G_ (the order rows were first touched)
  template <int k, int lanes>
  void correct(double* w, int) const;  // the step between the factor's passes

  SymmetricCsr A_;  // the factored matrix
  SupernodalCholesky factor_;
  int64_t n_ = 0, max_touched_ = kDefaultMaxTouched;
  std::vector<int64_t> position_;               // of row i of A in the factor's ordering
  std::map<std::pair<int64_t, int64_t>, double> edits_;  // A' - A (both triangles; new rows: A' itself)
  int64_t pending_vertices_ = 0;                // new vertices not yet committed
  bool pending_ = false;                        // edits since the last commit
  std::vector<double> sqrt_d_;                  // per committed new vertex: D^{1/2}
  // Per touched old row, by slot: its column of W; G_ over the slots (only grown, never recomputed).
  std::unordered_map<int64_t, int64_t> slot_;
  std::vector<SupernodalCholesky::SparseColumn> column_;
  Eigen::MatrixXd G_;
  int64_t slots_ = 0;
  // The last commit: T ascending, per row of T its column of W (null: a new vertex's), the LU of
  // I + G_TT E_TT (row-major, t x t; P's rows: `to_`) and E_TT.
  std::vector<int64_t> touched_;
  std::vector<const SupernodalCholesky::SparseColumn*> column_of_;
  std::vector<double> lu_;
  std::vector<int64_t> to_;
  CapacitanceColumns e_;
  int refactorizations_ = 0;
  int64_t columns_computed_ = 0;
  mutable std::vector<double> extra_;  // the new rows' part of a solve (k per row)
  mutable std::vector<double> s_, u_, z_;  // a solve's W^T y, (I + G E)^{-1} W^T y, K W^T y (lanes per row of T)
};

}  // namespace hyperqn

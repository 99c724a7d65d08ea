// A sparse SPD matrix factored as A = P^T L L^T P by CHOLMOD (its fill-reducing ordering and its
// supernodal factorization), then held supernode by supernode (dense blocks of columns with one
// row pattern) and solved by our own two loops with k right-hand sides interleaved: row i of the
// n x k block is k adjacent doubles. Each loop reads L once for all k columns, so a solve reads
// the factor twice (the streaming bound of bench/bench.py), whatever k is. hyperqn's dof vectors are already interleaved (x, y, z
// of a vertex side by side), so A1^{-1} applied to x, y and z is one solve with k = 3 on the dof
// array itself: no copies into columns, no per-call setup, no BLAS calls on tiny blocks, which
// is where a package's solve spends its time on the small and medium factors hyperqn has
// (docs/performance.md#h0-package).
//
// No PETSc here: the caller hands over the matrix in compressed rows and turns the status into
// its own error.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

struct cholmod_factor_struct;

namespace hyperqn {

// CHOLMOD's analysis of one matrix pattern (its ordering and supernodes), kept by the caller so that
// later factorizations of other values in the same pattern skip it (SupernodalCholesky::factor's
// `analysis`): H0's refactorizations with contact (solvers/contact_h0.hpp) change only the diagonal.
// A kept analysis merges small supernodes as CHOLMOD does by default (`relaxed`): on the bunny's
// 6,308 rows that factors 3-5x faster and adds 27% explicit zeros that each solve reads, the
// trade for a matrix factored about once per frame (docs/performance.md#h0-package).
class CholeskyAnalysis {
 public:
  CholeskyAnalysis() = default;
  ~CholeskyAnalysis();
  CholeskyAnalysis(const CholeskyAnalysis&) = delete;
  CholeskyAnalysis& operator=(const CholeskyAnalysis&) = delete;
  int analyses() const { return analyses_; }  // how often the pattern was analysed (1 while it stays)

 private:
  friend class SupernodalCholesky;
  cholmod_factor_struct* symbolic_ = nullptr;  // the symbolic factor, copied before a numeric factorization
  int64_t n_ = 0, separator_ = 0;  // the pattern it was made for
  uint64_t pattern_ = 0;           // a hash of its row starts and columns
  int analyses_ = 0;
};

class SupernodalCholesky {
 public:
  enum class Status { ok, not_positive_definite, out_of_memory, failed };

  // Factors the symmetric n x n matrix given in compressed sparse rows, columns sorted within a
  // row: both triangles or the upper one (only entries with column >= row are read).
  // On a status other than ok the object holds no factor.
  // With `analysis`, an empty one receives this pattern's analysis (relaxed supernodes, see
  // CholeskyAnalysis) and one made for the same pattern and separator is used instead of analysing
  // again: the same factor, bit for bit, as a new analysis would give.
  //
  // With separator s > 0 the last s rows and columns (the separator S; the others are the
  // interior I) are ordered last, after CHOLMOD's ordering of the interior block alone, so that
  //   A = [A_II A_IS; A_SI A_SS] = [L_I 0; X L_S] [L_I^T X^T; 0 L_S^T],
  // and only L_I and X are held (solve_interior_*); the dense lower triangle L_S (s x s, by
  // columns) goes to *separator_factor: L_S L_S^T = A_SS - X X^T. solve() then needs s = 0.
  Status factor(int64_t n, const int64_t* row_start, const int64_t* columns, const double* values,
                int64_t separator = 0, std::vector<double>* separator_factor = nullptr,
                CholeskyAnalysis* analysis = nullptr);

  // x = A^{-1} b for k = 1 or 3 interleaved right-hand sides (b[k i + c]); b and x may be the same
  // array.
  void solve(int k, const double* b, double* x) const;

  // A solve with the separator's part done by the caller (SplitCholesky), k = 1 or 3 interleaved
  // columns as in solve(): forward takes the interior rows of b (n - s rows), solves L_I y = P b_I
  // and writes -X y (s rows) to separator_update; backward takes the separator's solution x_S
  // and writes x_I = P^T L_I^{-T} (y - X^T x_S) (n - s rows). y stays in this object's work block
  // between the two, so they come in pairs.
  void solve_interior_forward(int k, const double* b_interior, double* separator_update) const;
  void solve_interior_backward(int k, const double* separator_solution, double* x_interior) const;

  // Keeps the factor's values as floats, each the nearest float to the double it replaces (the
  // reciprocal diagonals included), and drops the doubles: half the bytes a solve streams.
  // solve() and solve_interior_*() then widen each value to double as they load it and do all
  // their arithmetic in double, in the same order, on double right-hand sides: the operator
  // P^T (L_f L_f^T)^{-1} P of the rounded factor L_f, symmetric positive definite as before,
  // within about 1e-7 of A^{-1} (tests/test_supernodal_cholesky.cpp; solver.h0_precision).
  // forward_units() and solve_corrected() need the doubles (TopologyH0 keeps its own factor).
  // False, and the doubles kept, if a value is beyond float's range (overflows, or a normal
  // double rounds to 0).
  bool keep_single_precision();
  bool single_precision() const { return !single_value_.empty(); }

  int64_t size() const { return n_; }
  int64_t separator() const { return separator_; }

  // A supernode: `width` consecutive columns of L from `column`, sharing one row pattern below
  // them. Its values from value_[value]: the width x width triangle by columns, each row below
  // (row_[rows], ...) as `width` adjacent values, the triangle by rows (factor() says how).
  struct Node {
    int64_t column, value, rows;
    int32_t width;
  };
  // Entries of L, the diagonal included (supernodes are merged only where no zero is added, so
  // these are L's nonzeros).
  int64_t nonzeros() const { return entries_; }

  // solve() with middle(w, lanes) applied between its two passes to y = L^{-1} P b, held as the
  // n x lanes block w (row i: position i of the ordering, lanes >= k adjacent doubles, those past
  // k zero): x = P^T L^{-T} middle(L^{-1} P b). TopologyH0's correction (solvers/topology_h0.hpp).
  using Middle = std::function<void(double* w, int lanes)>;
  void solve_corrected(int k, const double* b, double* x, const Middle& middle) const;

  // L^{-1} P e_i for a row i of A at `position` of the ordering (perm()[position] == i), sparse:
  // nonzero only on the columns of `nodes`, the supernodes from the one holding `position` up to
  // the root (ascending), `values` those nodes' columns in order. A column has the same bits
  // whatever it is computed with.
  struct SparseColumn {
    std::vector<int32_t> nodes;
    std::vector<double> values;
  };
  // All of them in passes over the union of their paths, each node's values read once per pass for
  // all the columns through it; a pass's block holds at most max_block doubles (0: 4 n, the
  // solve's, or 2^21 if more). With `gram` (count rows of count + other_count) also the dot
  // products of the new columns with each other (gram[a (count + other_count) + b], b < count)
  // and with `others` (b = count + o), columns from an earlier call. An entry is one multiply-add
  // per row the two columns share, ascending, from 0: a function of the two columns alone.
  void forward_units(const int64_t* positions, int count, SparseColumn* out, const SparseColumn* const* others = nullptr,
                     int other_count = 0, double* gram = nullptr, int64_t max_block = 0) const;
  // The ordering: row i of L L^T is row perm()[i] of A.
  const std::vector<int64_t>& perm() const { return perm_; }
  const std::vector<Node>& nodes() const { return nodes_; }

 private:
  template <int k, int lanes>
  void solve_k(const double* b, double* x) const;
  // L y = w, and L^T z = w, in place on the n x lanes block w, from the values kept (double or float).
  template <int lanes>
  void forward(double* w) const;
  template <int lanes>
  void backward(double* w) const;
  template <int k, int lanes>
  void solve_corrected_k(const double* b, double* x, const Middle& middle) const;
  int32_t node_of(int64_t position) const;            // the node holding a column
  std::vector<int32_t> path(int64_t position) const;  // its node and their ancestors, ascending
  template <int k, int lanes>
  void forward_k(const double* b_interior, double* separator_update) const;
  template <int k, int lanes>
  void backward_k(const double* separator_solution, double* x_interior) const;

  int64_t n_ = 0;
  int64_t separator_ = 0;             // the last separator_ rows are not in nodes_ (see factor)
  std::vector<int64_t> perm_;         // row i of L L^T is row perm_[i] of A
  std::vector<Node> nodes_;
  std::vector<int32_t> row_;          // the rows below each node, node after node
  int64_t row_end_ = 0;               // row_.size(), where the last node's rows end
  std::vector<double> value_;         // the nodes' values, a node's triangle twice (see Node)
  std::vector<float> single_value_;   // value_ rounded to float instead (keep_single_precision); then value_ is empty
  int64_t entries_ = 0;               // L's entries (each triangle counted once)
  mutable std::vector<double> work_;  // the permuted right-hand sides, n x 4 (lanes past k stay 0)
  mutable std::vector<double> unit_work_;  // forward_units' block of columns
  mutable std::vector<int32_t> node_offset_, column_offset_;  // forward_units' rows in it (-1 between calls)
};

}  // namespace hyperqn

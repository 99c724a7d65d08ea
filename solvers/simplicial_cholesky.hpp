// A sparse SPD matrix factored as A = P^T L L^T P by CHOLMOD (its fill-reducing ordering and its
// supernodal factorization), then held as a simplicial L, column by column, and solved by our own
// two loops with k right-hand sides interleaved: row i of the n x k block is k adjacent doubles.
// Each loop reads L once for all k columns, so a solve reads the factor twice (the streaming
// bound of bench/bench.py), whatever k is. hyperqn's dof vectors are already interleaved (x, y, z
// of a vertex side by side), so A1^{-1} applied to x, y and z is one solve with k = 3 on the dof
// array itself: no copies into columns, no per-call setup, no BLAS calls on tiny blocks, which
// is where a package's solve spends its time on the small and medium factors hyperqn has
// (docs/performance.md#h0-package).
//
// No PETSc here: the caller hands over the matrix in compressed rows and turns the status into
// its own error.
#pragma once
#include <cstdint>
#include <vector>

namespace hyperqn {

class SimplicialCholesky {
 public:
  enum class Status { ok, not_positive_definite, out_of_memory, failed };

  // Factors the symmetric n x n matrix given in compressed sparse rows, columns sorted within a
  // row: both triangles or the upper one (only entries with column >= row are read).
  // On a status other than ok the object holds no factor.
  Status factor(int64_t n, const int64_t* row_start, const int64_t* columns, const double* values);

  // x = A^{-1} b for k = 1 or 3 interleaved right-hand sides (b[k i + c]); b and x may be the same
  // array.
  void solve(int k, const double* b, double* x) const;

  int64_t size() const { return n_; }
  // Entries of L, the diagonal included (the factor's size, as CHOLMOD counts it).
  int64_t nonzeros() const { return static_cast<int64_t>(value_.size()); }

 private:
  template <int k, int lanes>
  void solve_k(const double* b, double* x) const;

  int64_t n_ = 0;
  std::vector<int64_t> perm_;         // row i of L L^T is row perm_[i] of A
  std::vector<int64_t> column_start_; // L's column j: entries column_start_[j] .. column_start_[j+1]-1,
  std::vector<int32_t> row_;          //   the diagonal first, then the rows below it
  std::vector<double> value_;
  mutable std::vector<double> work_;  // the permuted right-hand sides, n x 4 (lanes past k stay 0)
};

}  // namespace hyperqn

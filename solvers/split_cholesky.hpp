// A^{-1} with the factor split over the ranks along the rank interface (-hyperqn_h0_package
// split): no rank holds the whole factor and no rank gathers b.
//
// The separator S is the set of rows owned by a rank and coupled to a row of a higher rank, so no
// entry of A couples the interiors I_r (owned rows not in S) of two ranks. Ordered [I_1, .., I_p, S],
//   A = [L_1 .. 0 0; .. ; 0 .. L_p 0; X_1 .. X_p L_S] [..]^T,   S_c = A_SS - sum_r X_r X_r^T = L_S L_S^T,
// and rank r holds L_r and X_r alone: it factors [A_{I_r I_r} A_{I_r S}; A_{S I_r} A_SS] with S
// last (SupernodalCholesky with a separator), whose last block gives X_r X_r^T = A_SS - L_D L_D^T.
// The Schur complement S_c = sum_r L_D,r L_D,r^T - (p - 1) A_SS is summed over the ranks once and
// factored densely (LAPACK) on every rank. A solve: each rank's forward pass over its interior
// (-X_r y_r), one MPI_Allreduce of the separator's s x k values, the dense solve with L_S on every
// rank, each rank's backward pass. Bitwise reproducible at a fixed rank count: every part is a
// fixed sequence of operations (CHOLMOD, serial BLAS and Open MPI's Allreduce, whose order of
// summation depends on the rank count and the message size only); the result differs from one
// rank's solve in the last bits (another ordering).
//
// Its cost: the dense S_c, s x s doubles on every rank, and s^3/3 flops to factor it; s grows with
// the interface (a plane of a 3-D box between 2 ranks: about V^(2/3) vertices). Where that does
// not pay, auto takes amg (docs/performance.md#distributed-h0).
#pragma once
#include <petscmat.h>

#include <vector>

#include "solvers/supernodal_cholesky.hpp"

namespace hyperqn {

class SplitCholesky {
 public:
  enum class Status { ok, not_positive_definite, out_of_memory, failed };

  // Factors the assembled parallel SPD matrix A (collective). k: the right-hand sides per row a
  // solve takes interleaved (3 for the vertex matrix A1 applied to x, y, z; 1 for a dof matrix).
  // Every rank returns the same status. With `analysis`, this rank's interior is factored as
  // SupernodalCholesky::factor does with it (its pattern analysed once, relaxed supernodes).
  PetscErrorCode factor(Mat A, int k, Status* status, CholeskyAnalysis* analysis = nullptr);

  // x = A^{-1} b on this rank's rows (k interleaved values per row; collective).
  PetscErrorCode solve(const double* b, double* x) const;

  // Keeps this rank's interior factor L_r, X_r in single precision
  // (SupernodalCholesky::keep_single_precision); the dense L_S stays double (LAPACK's solve).
  // Collective: *kept is false on every rank if one rank's values are beyond float's range.
  PetscErrorCode keep_single_precision(bool* kept);

  // s for A without factoring it (collective, cheap: a pass over the local rows' columns).
  static PetscErrorCode interface_size(Mat A, PetscInt* s);

  PetscInt separator_size() const { return separator_; }  // s, the same on every rank
  // Entries of the split factor over all ranks: each rank's L_r and X_r, and S_c's triangle.
  double nonzeros() const { return nonzeros_; }

 private:
  // This rank's rows of S and of I_r (local numbers, increasing).
  static PetscErrorCode local_separator(Mat A, std::vector<PetscInt>* separator, std::vector<PetscInt>* interior);

  MPI_Comm comm_ = MPI_COMM_NULL;
  int k_ = 3;
  PetscInt separator_ = 0;                // s
  PetscInt own_separator_begin_ = 0;      // this rank's separator rows are S's [begin, begin + count)
  std::vector<PetscInt> interior_rows_;   // local row numbers of I_r, increasing
  std::vector<PetscInt> separator_rows_;  // local row numbers of this rank's rows in S, increasing
  SupernodalCholesky interior_;           // L_r and X_r
  std::vector<double> schur_;             // L_S, s x s by columns (lower triangle)
  mutable std::vector<double> b_interior_, x_interior_, separator_values_;
  double nonzeros_ = 0;
};

}  // namespace hyperqn

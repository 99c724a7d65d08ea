#include "solvers/split_cholesky.hpp"

#include <petscblaslapack.h>

#include <algorithm>
#include <limits>
#include <new>
#include <numeric>
#include <utility>

#include "parallel/collectives.hpp"
#include "io/log_events.hpp"

namespace hyperqn {

namespace {

SplitCholesky::Status status_of(SupernodalCholesky::Status s) {
  switch (s) {
    case SupernodalCholesky::Status::ok: return SplitCholesky::Status::ok;
    case SupernodalCholesky::Status::not_positive_definite: return SplitCholesky::Status::not_positive_definite;
    case SupernodalCholesky::Status::out_of_memory: return SplitCholesky::Status::out_of_memory;
    case SupernodalCholesky::Status::failed: break;
  }
  return SplitCholesky::Status::failed;
}

// The worst status of any rank, on every rank (ok < not_positive_definite < out_of_memory < failed).
PetscErrorCode agree(MPI_Comm comm, SplitCholesky::Status* s) {
  int mine = static_cast<int>(*s), worst = 0;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Allreduce(&mine, &worst, 1, MPI_INT, MPI_MAX, comm));
  *s = static_cast<SplitCholesky::Status>(worst);
  PetscFunctionReturn(0);
}

// Rows of one rank's block [A_II A_IS; A_SI A_SS] in compressed form, columns sorted.
struct LocalBlock {
  std::vector<int64_t> start{0}, columns;
  std::vector<double> values;
};

}  // namespace

PetscErrorCode SplitCholesky::local_separator(Mat A, std::vector<PetscInt>* separator, std::vector<PetscInt>* interior) {
  PetscInt rstart, rend;
  PetscFunctionBeginUser;
  PetscCall(MatGetOwnershipRange(A, &rstart, &rend));
  // S: owned rows coupled to a higher rank's row (a column at or past rend).
  for (PetscInt g = rstart; g < rend; ++g) {
    PetscInt nc;
    const PetscInt* c;
    PetscCall(MatGetRow(A, g, &nc, &c, nullptr));
    const bool coupled = nc > 0 && c[nc - 1] >= rend;  // MatGetRow's columns are sorted
    PetscCall(MatRestoreRow(A, g, &nc, &c, nullptr));
    if (coupled)
      separator->push_back(g - rstart);
    else if (interior)
      interior->push_back(g - rstart);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode SplitCholesky::interface_size(Mat A, PetscInt* s) {
  std::vector<PetscInt> separator;
  PetscFunctionBeginUser;
  PetscCall(local_separator(A, &separator, nullptr));
  PetscInt own = static_cast<PetscInt>(separator.size());
  PetscCallMPI(MPI_Allreduce(&own, s, 1, MPIU_INT, MPI_SUM, PetscObjectComm((PetscObject)A)));
  PetscFunctionReturn(0);
}

PetscErrorCode SplitCholesky::factor(Mat A, int k, Status* status, CholeskyAnalysis* analysis) {
  PetscMPIInt size, rank;
  PetscInt rstart, rend;
  PetscFunctionBeginUser;
  *this = SplitCholesky();
  k_ = k;
  comm_ = PetscObjectComm((PetscObject)A);
  PetscCallMPI(MPI_Comm_size(comm_, &size));
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  PetscCall(MatGetOwnershipRange(A, &rstart, &rend));
  PetscCall(local_separator(A, &separator_rows_, &interior_rows_));
  std::vector<PetscInt> mine(separator_rows_.size());
  for (size_t t = 0; t < mine.size(); ++t) mine[t] = rstart + separator_rows_[t];
  std::vector<int> counts;
  const std::vector<PetscInt> all = all_gathered(comm_, mine, MPIU_INT, &counts);
  separator_ = static_cast<PetscInt>(all.size());
  own_separator_begin_ = std::accumulate(counts.begin(), counts.begin() + rank, PetscInt(0));

  // This rank's block, rows and columns [I_r, S]: fetched in increasing global order (as
  // MatCreateSubMatrices wants them), then renumbered.
  const PetscInt interior = static_cast<PetscInt>(interior_rows_.size()), n = interior + separator_;
  std::vector<PetscInt> globals;
  std::vector<int64_t> position;  // of globals[j] in [I_r, S]
  globals.reserve(n);
  position.reserve(n);
  {
    size_t i = 0, s = 0;
    while (i < interior_rows_.size() || s < all.size()) {
      if (s == all.size() || (i < interior_rows_.size() && rstart + interior_rows_[i] < all[s])) {
        globals.push_back(rstart + interior_rows_[i]);
        position.push_back(static_cast<int64_t>(i++));
      } else {
        globals.push_back(all[s]);
        position.push_back(interior + static_cast<int64_t>(s++));
      }
    }
  }
  IS rows;
  Mat* sub = nullptr;
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, n, globals.data(), PETSC_USE_POINTER, &rows));
  PetscCall(MatCreateSubMatrices(A, 1, &rows, &rows, MAT_INITIAL_MATRIX, &sub));
  PetscCall(ISDestroy(&rows));
  LocalBlock block;
  {
    std::vector<std::vector<std::pair<int64_t, double>>> by_row(n);
    for (PetscInt j = 0; j < n; ++j) {
      PetscInt nc;
      const PetscInt* c;
      const PetscScalar* v;
      PetscCall(MatGetRow(sub[0], j, &nc, &c, &v));
      auto& row = by_row[position[j]];
      for (PetscInt e = 0; e < nc; ++e)
        if (position[c[e]] >= position[j]) row.emplace_back(position[c[e]], v[e]);  // the upper triangle is read
      PetscCall(MatRestoreRow(sub[0], j, &nc, &c, &v));
    }
    PetscCall(MatDestroySubMatrices(1, &sub));
    for (auto& row : by_row) {
      std::sort(row.begin(), row.end());
      for (const auto& [c, v] : row) {
        block.columns.push_back(c);
        block.values.push_back(v);
      }
      block.start.push_back(static_cast<int64_t>(block.columns.size()));
      std::vector<std::pair<int64_t, double>>().swap(row);
    }
  }

  // L_r, X_r and L_D (A_SS - X_r X_r^T = L_D L_D^T).
  std::vector<double> dense;
  *status = Status::ok;
  if (n > 0)
    *status = status_of(interior_.factor(n, block.start.data(), block.columns.data(), block.values.data(), separator_,
                                         separator_ > 0 ? &dense : nullptr, analysis));
  PetscCall(agree(comm_, status));
  if (*status != Status::ok) PetscFunctionReturn(0);

  // S_c = sum_r L_D,r L_D,r^T - (p - 1) A_SS, then L_S L_S^T = S_c, on every rank.
  if (separator_ > 0) {
    if (separator_ > std::numeric_limits<PetscBLASInt>::max() / separator_) {
      *status = Status::out_of_memory;  // beyond one BLAS call (and any rank's memory)
      PetscFunctionReturn(0);
    }
    const PetscBLASInt s = static_cast<PetscBLASInt>(separator_);
    const PetscScalar one = 1, zero = 0;
    try {
      schur_.assign(dense.size(), 0.0);
    } catch (const std::bad_alloc&) {
      *status = Status::out_of_memory;
    }
    PetscCall(agree(comm_, status));
    if (*status != Status::ok) PetscFunctionReturn(0);
    PetscCallBLAS("BLASsyrk", BLASsyrk_("L", "N", &s, &s, &one, dense.data(), &s, &zero, schur_.data(), &s));
    std::vector<double>().swap(dense);
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, schur_.data(), s * s, MPI_DOUBLE, MPI_SUM, comm_));
    for (int64_t i = interior; i < n; ++i)
      for (int64_t e = block.start[i]; e < block.start[i + 1]; ++e)  // row i's entries at and right of the diagonal
        schur_[(block.columns[e] - interior) + (i - interior) * separator_] -= (size - 1) * block.values[e];
    PetscBLASInt info = 0;
    PetscCallBLAS("LAPACKpotrf", LAPACKpotrf_("L", &s, schur_.data(), &s, &info));
    if (info != 0) *status = info > 0 ? Status::not_positive_definite : Status::failed;
    PetscCall(agree(comm_, status));
    if (*status != Status::ok) PetscFunctionReturn(0);
  }
  nonzeros_ = static_cast<double>(interior_.nonzeros());
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &nonzeros_, 1, MPI_DOUBLE, MPI_SUM, comm_));
  nonzeros_ += 0.5 * double(separator_) * double(separator_ + 1);
  b_interior_.assign(static_cast<size_t>(k * interior), 0.0);
  x_interior_.assign(static_cast<size_t>(k * interior), 0.0);
  separator_values_.assign(static_cast<size_t>(k * separator_), 0.0);
  PetscFunctionReturn(0);
}

PetscErrorCode SplitCholesky::keep_single_precision(bool* kept) {
  int mine = interior_.keep_single_precision() ? 1 : 0, all = 0;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, comm_));
  *kept = all == 1;
  PetscFunctionReturn(0);
}

PetscErrorCode SplitCholesky::solve(const double* b, double* x) const {
  const int k = k_;
  PetscFunctionBeginUser;
  for (size_t t = 0; t < interior_rows_.size(); ++t)
    for (int c = 0; c < k; ++c) b_interior_[k * t + c] = b[k * interior_rows_[t] + c];
  double* g = separator_values_.data();
  if (interior_.size() > 0) interior_.solve_interior_forward(k, b_interior_.data(), g);
  for (size_t t = 0; t < separator_rows_.size(); ++t)
    for (int c = 0; c < k; ++c) g[k * (own_separator_begin_ + t) + c] += b[k * separator_rows_[t] + c];
  if (separator_ > 0) {
    // g = b_S - sum_r X_r y_r, summed over the ranks; then x_S = S_c^{-1} g on every rank. g is
    // s rows of k values: as BLAS sees it, the k x s matrix g^T, so x_S^T = g^T L_S^{-T} L_S^{-1}.
    const PetscBLASInt s = static_cast<PetscBLASInt>(separator_), m = k;
    const PetscScalar one = 1;
    PetscCall(event_begin(&LogEvents::h0_interface));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, g, k * separator_, MPI_DOUBLE, MPI_SUM, comm_));
    PetscCallBLAS("BLAStrsm", BLAStrsm_("R", "L", "T", "N", &m, &s, &one, schur_.data(), &s, g, &m));
    PetscCallBLAS("BLAStrsm", BLAStrsm_("R", "L", "N", "N", &m, &s, &one, schur_.data(), &s, g, &m));
    PetscCall(event_end(&LogEvents::h0_interface));
  }
  if (interior_.size() > 0) interior_.solve_interior_backward(k, g, x_interior_.data());
  for (size_t t = 0; t < interior_rows_.size(); ++t)
    for (int c = 0; c < k; ++c) x[k * interior_rows_[t] + c] = x_interior_[k * t + c];
  for (size_t t = 0; t < separator_rows_.size(); ++t)
    for (int c = 0; c < k; ++c) x[k * separator_rows_[t] + c] = g[k * (own_separator_begin_ + t) + c];
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

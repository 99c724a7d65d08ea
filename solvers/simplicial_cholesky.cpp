#include "solvers/simplicial_cholesky.hpp"

#include <cholmod.h>

#include <stdexcept>

#include "materials/lanes.hpp"

namespace hyperqn {

namespace {

// cholmod_common for one factorization, finished whatever way the factorization ends.
struct Cholmod {
  cholmod_common c;
  Cholmod() {
    cholmod_l_start(&c);
    c.print = 0;  // the caller reports the status
    // After the (supernodal, by CHOLMOD's choice) factorization, convert L to simplicial LL^T,
    // packed and with its columns in order: the form solve() reads.
    c.final_asis = 0;
    c.final_super = 0;
    c.final_ll = 1;
    c.final_pack = 1;
    c.final_monotonic = 1;
  }
  ~Cholmod() { cholmod_l_finish(&c); }
};

SimplicialCholesky::Status status_of(const cholmod_common& c) {
  if (c.status == CHOLMOD_NOT_POSDEF) return SimplicialCholesky::Status::not_positive_definite;
  if (c.status == CHOLMOD_OUT_OF_MEMORY) return SimplicialCholesky::Status::out_of_memory;
  return c.status == CHOLMOD_OK ? SimplicialCholesky::Status::ok : SimplicialCholesky::Status::failed;
}

}  // namespace

SimplicialCholesky::Status SimplicialCholesky::factor(int64_t n, const int64_t* row_start, const int64_t* columns,
                                                      const double* values) {
  *this = SimplicialCholesky();
  Cholmod cm;
  // A symmetric matrix's rows are its columns: row i is handed over as column i, whose entries
  // with index >= i are the lower triangle, the part CHOLMOD reads with stype -1.
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<size_t>(n);
  A.nzmax = static_cast<size_t>(row_start[n]);
  A.p = const_cast<int64_t*>(row_start);
  A.i = const_cast<int64_t*>(columns);
  A.x = const_cast<double*>(values);
  A.stype = -1;
  A.itype = CHOLMOD_LONG;
  A.xtype = CHOLMOD_REAL;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = 1;
  cholmod_factor* L = cholmod_l_analyze(&A, &cm.c);
  if (!L) return status_of(cm.c) == Status::ok ? Status::failed : status_of(cm.c);
  const int done = cholmod_l_factorize(&A, L, &cm.c);
  Status status = done ? status_of(cm.c) : Status::failed;
  if (status == Status::ok && (L->minor < L->n || L->is_super || !L->is_ll)) status = Status::failed;
  if (status == Status::ok && n > INT32_MAX) status = Status::failed;  // row_ holds 32-bit rows
  if (status == Status::ok) {
    const auto* p = static_cast<const int64_t*>(L->p);
    const auto* i = static_cast<const int64_t*>(L->i);
    const auto* x = static_cast<const double*>(L->x);
    const auto* perm = static_cast<const int64_t*>(L->Perm);
    n_ = n;
    perm_.assign(perm, perm + n);
    column_start_.assign(p, p + n + 1);
    row_.assign(i, i + p[n]);
    value_.assign(x, x + p[n]);
    work_.assign(static_cast<size_t>(4 * n), 0.0);  // up to 4 lanes, the unused ones 0
  }
  cholmod_l_free_factor(&L, &cm.c);
  if (status != Status::ok) *this = SimplicialCholesky();
  return status;
}

// L y = w, then L^T z = y, in place on the n x lanes block w (row i: lanes adjacent doubles), every
// lane in the same pass. Forward: by columns of L (column j, once y_j is known, updates the rows
// below it). Backward: by rows of L^T, which are L's columns (z_j needs the z of the rows below
// j). Compiled for x86-64-v3 (AVX2 and FMA: a row of 4 lanes is one register) and plain x86-64
// (HYPERQN_VECTOR_CLONES).
namespace {

// A row of the right-hand-side block: one double, or 4 lanes as one GCC vector (a 256-bit register
// under AVX2, two SSE registers otherwise; unaligned, and allowed to alias the doubles it is read
// from).
typedef double Lanes4 __attribute__((vector_size(32), aligned(8), may_alias));
template <int lanes>
struct RowOf;
template <>
struct RowOf<1> {
  using type = double;
};
template <>
struct RowOf<4> {
  using type = Lanes4;
};

template <int lanes>
HYPERQN_VECTOR_CLONES void triangular_solves(
    int64_t n, const int64_t* __restrict start, const int32_t* __restrict row, const double* __restrict L,
    double* __restrict block) {
  using Row = typename RowOf<lanes>::type;
  Row* w = reinterpret_cast<Row*>(block);
  for (int64_t j = 0; j < n; ++j) {
    const Row y = w[j] / L[start[j]];
    w[j] = y;
    for (int64_t p = start[j] + 1; p < start[j + 1]; ++p) w[row[p]] -= L[p] * y;
  }
  for (int64_t j = n - 1; j >= 0; --j) {
    // Two partial sums (entries taken in pairs): one running sum would make every entry wait for
    // the previous one's multiply-add.
    Row s = w[j], t = Row{};
    int64_t p = start[j] + 1;
    for (; p + 1 < start[j + 1]; p += 2) {
      s -= L[p] * w[row[p]];
      t -= L[p + 1] * w[row[p + 1]];
    }
    if (p < start[j + 1]) s -= L[p] * w[row[p]];
    w[j] = (s + t) / L[start[j]];
  }
}

}  // namespace

// x = P^T (L L^T)^{-1} P b for k interleaved columns, worked on in `lanes` >= k lanes (the others
// stay 0: 0 - l * 0).
template <int k, int lanes>
void SimplicialCholesky::solve_k(const double* b, double* x) const {
  double* w = work_.data();
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b[k * perm_[i] + c];
  triangular_solves<lanes>(n_, column_start_.data(), row_.data(), value_.data(), w);
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) x[k * perm_[i] + c] = w[lanes * i + c];
}

void SimplicialCholesky::solve(int k, const double* b, double* x) const {
  if (k == 3) return solve_k<3, 4>(b, x);
  if (k == 1) return solve_k<1, 1>(b, x);
  throw std::invalid_argument("SimplicialCholesky::solve: k must be 1 or 3");
}

}  // namespace hyperqn

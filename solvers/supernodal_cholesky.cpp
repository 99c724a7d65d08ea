#include "solvers/supernodal_cholesky.hpp"

#include <cholmod.h>
#include <omp.h>

#include <algorithm>
#include <stdexcept>

#include "io/fnv_hash.hpp"
#include "materials/lanes.hpp"

namespace hyperqn {

namespace {

// cholmod_common for one factorization, finished whatever way the factorization ends.
struct Cholmod {
  cholmod_common c;
  explicit Cholmod(bool relaxed = false) {
    // CHOLMOD's supernodal factorization opens parallel regions of 4 OpenMP threads (its build's
    // CHOLMOD_OMP_NUM_THREADS, whatever OMP_NUM_THREADS says), but hyperqn's ranks already take the
    // cores (as for the serial BLAS, docs/performance.md): with another job on the 2 cores the
    // bunny's 38 refactorizations took 0.71-0.84 s with them and 0.40-0.46 s without. No OpenMP
    // region of this process runs more than one thread.
    omp_set_max_active_levels(0);
    cholmod_l_start(&c);
    c.print = 0;  // the caller reports the status
    // A supernodal factor, kept as CHOLMOD leaves it: its dense column blocks are what solve() reads.
    c.supernodal = CHOLMOD_SUPERNODAL;
    c.final_asis = 1;
    // Supernodes are merged only where that adds no zeros: every zero would be read and multiplied
    // by every solve (CHOLMOD's default merges up to 80 % zeros for its BLAS; on strands' chains
    // that tripled the solve, docs/performance.md#h0-package).
    // A relaxed analysis (CholeskyAnalysis) keeps CHOLMOD's defaults.
    for (int i = 0; i < 3 && !relaxed; ++i) {
      c.nrelax[i] = 0;
      c.zrelax[i] = 0.0;
    }
  }
  ~Cholmod() { cholmod_l_finish(&c); }
};

SupernodalCholesky::Status status_of(const cholmod_common& c) {
  if (c.status == CHOLMOD_NOT_POSDEF) return SupernodalCholesky::Status::not_positive_definite;
  if (c.status == CHOLMOD_OUT_OF_MEMORY) return SupernodalCholesky::Status::out_of_memory;
  return c.status == CHOLMOD_OK ? SupernodalCholesky::Status::ok : SupernodalCholesky::Status::failed;
}

}  // namespace

namespace {

// A's rows as CHOLMOD columns (stype -1: the entries with index >= the column's, the lower
// triangle), of A itself (nz null) or of its leading block (nz[i]: row i's entries inside it).
cholmod_sparse lower_view(int64_t n, const int64_t* row_start, const int64_t* columns, const double* values,
                          int64_t* nz = nullptr) {
  cholmod_sparse A{};
  A.nrow = A.ncol = static_cast<size_t>(n);
  A.nzmax = static_cast<size_t>(row_start[n]);
  A.p = const_cast<int64_t*>(row_start);
  A.i = const_cast<int64_t*>(columns);
  A.nz = nz;
  A.x = const_cast<double*>(values);
  A.stype = -1;
  A.itype = CHOLMOD_LONG;
  A.xtype = CHOLMOD_REAL;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = nz ? 0 : 1;
  return A;
}

// The fill-reducing ordering of A with its last `separator` rows kept last: CHOLMOD's choice for
// the interior block (already postordered), then the separator as it is. Empty on failure.
std::vector<int64_t> ordering_with_separator(int64_t n, const int64_t* row_start, const int64_t* columns,
                                             const double* values, int64_t separator, cholmod_common* c) {
  const int64_t interior = n - separator;
  std::vector<int64_t> perm(static_cast<size_t>(n));
  for (int64_t i = interior; i < n; ++i) perm[i] = i;
  if (interior == 0) return perm;
  std::vector<int64_t> nz(static_cast<size_t>(interior));  // columns are sorted: the block's entries come first
  for (int64_t i = 0; i < interior; ++i)
    nz[i] = std::lower_bound(columns + row_start[i], columns + row_start[i + 1], interior) - (columns + row_start[i]);
  cholmod_sparse block = lower_view(interior, row_start, columns, values, nz.data());
  cholmod_factor* L = cholmod_l_analyze(&block, c);
  if (!L) return {};
  const auto* p = static_cast<const int64_t*>(L->Perm);
  std::copy(p, p + interior, perm.begin());
  cholmod_l_free_factor(&L, c);
  return perm;
}

// A hash of the row starts and columns: which pattern a kept analysis belongs to.
uint64_t pattern_hash(int64_t n, const int64_t* row_start, const int64_t* columns) {
  Fnv1a h;
  h.add(row_start, sizeof(int64_t) * static_cast<size_t>(n + 1));
  h.add(columns, sizeof(int64_t) * static_cast<size_t>(row_start[n]));
  return h.value;
}

}  // namespace

CholeskyAnalysis::~CholeskyAnalysis() {
  if (!symbolic_) return;
  Cholmod cm;
  cholmod_l_free_factor(&symbolic_, &cm.c);
}

SupernodalCholesky::Status SupernodalCholesky::factor(int64_t n, const int64_t* row_start, const int64_t* columns,
                                                      const double* values, int64_t separator,
                                                      std::vector<double>* separator_factor,
                                                      CholeskyAnalysis* analysis) {
  *this = SupernodalCholesky();
  Cholmod cm(analysis != nullptr);
  cholmod_sparse A = lower_view(n, row_start, columns, values);
  cholmod_factor* L = nullptr;
  const uint64_t pattern = analysis ? pattern_hash(n, row_start, columns) : 0;
  const bool reuse = analysis && analysis->symbolic_ && analysis->n_ == n && analysis->separator_ == separator &&
                     analysis->pattern_ == pattern;
  if (reuse) {
    L = cholmod_l_copy_factor(analysis->symbolic_, &cm.c);
  } else if (separator == 0) {
    L = cholmod_l_analyze(&A, &cm.c);
  } else {
    std::vector<int64_t> perm = ordering_with_separator(n, row_start, columns, values, separator, &cm.c);
    if (perm.empty()) return status_of(cm.c) == Status::ok ? Status::failed : status_of(cm.c);
    // The given order as it is: a postorder of the whole tree could move separator columns
    // between interior subtrees; the interior's own order is postordered already.
    cm.c.nmethods = 1;
    cm.c.method[0].ordering = CHOLMOD_GIVEN;
    cm.c.postorder = 0;
    L = cholmod_l_analyze_p(&A, perm.data(), nullptr, 0, &cm.c);
  }
  if (!L) return status_of(cm.c) == Status::ok ? Status::failed : status_of(cm.c);
  if (analysis && !reuse) {  // kept before the numeric factorization fills L
    if (analysis->symbolic_) cholmod_l_free_factor(&analysis->symbolic_, &cm.c);
    analysis->symbolic_ = cholmod_l_copy_factor(L, &cm.c);
    analysis->n_ = n;
    analysis->pattern_ = pattern;
    analysis->separator_ = separator;
    ++analysis->analyses_;
    if (!analysis->symbolic_) {
      cholmod_l_free_factor(&L, &cm.c);
      return status_of(cm.c) == Status::ok ? Status::failed : status_of(cm.c);
    }
  }
  const int done = cholmod_l_factorize(&A, L, &cm.c);
  Status status = done ? status_of(cm.c) : Status::failed;
  if (status == Status::ok && (L->minor < L->n || !L->is_super)) status = Status::failed;
  if (status == Status::ok && n > INT32_MAX) status = Status::failed;  // rows are held as 32-bit
  if (status == Status::ok) {
    const auto* super = static_cast<const int64_t*>(L->super);
    const auto* pi = static_cast<const int64_t*>(L->pi);
    const auto* px = static_cast<const int64_t*>(L->px);
    const auto* s = static_cast<const int64_t*>(L->s);
    const auto* x = static_cast<const double*>(L->x);
    const auto* perm = static_cast<const int64_t*>(L->Perm);
    const int64_t interior = n - separator;
    n_ = n;
    separator_ = separator;
    perm_.assign(perm, perm + n);
    // A CHOLMOD supernode may straddle the interior's end: its interior columns become a node of
    // their own (the separator's columns among its rows below), the rest goes to L_S.
    size_t values = 0, rows = 0, count = 0;  // reserved exactly: growing would hold up to twice the factor
    for (size_t k = 0; k < L->nsuper; ++k) {
      const int64_t end = std::min<int64_t>(super[k + 1], interior);
      if (end <= super[k]) continue;
      const size_t width = end - super[k], below = pi[k + 1] - pi[k] - width;
      values += width * (width + 1) + below * width;
      rows += below;
      ++count;
    }
    value_.reserve(values);
    row_.reserve(rows);
    nodes_.reserve(count);
    if (separator_factor) separator_factor->assign(static_cast<size_t>(separator * separator), 0.0);
    for (size_t k = 0; k < L->nsuper; ++k) {
      // CHOLMOD's block: nrows x (its columns), column-major; its first rows are its own columns,
      // the rest the rows below.
      const int64_t nrows = pi[k + 1] - pi[k];
      const double* block = x + px[k];
      const int64_t* row_of = s + pi[k];
      const int64_t end = std::min<int64_t>(super[k + 1], interior);
      for (int64_t j = std::max<int64_t>(super[k], interior) - super[k]; separator_factor && j < super[k + 1] - super[k];
           ++j)
        for (int64_t r = j; r < nrows; ++r)
          (*separator_factor)[(row_of[r] - interior) + (super[k] + j - interior) * separator] = block[j * nrows + r];
      if (end <= super[k]) continue;
      const int64_t width = end - super[k];
      Node node;
      node.column = super[k];
      node.width = static_cast<int32_t>(width);
      node.value = static_cast<int64_t>(value_.size());
      node.rows = static_cast<int64_t>(row_.size());
      nodes_.push_back(node);
      // The triangle column by column (forward), each column's diagonal first and stored as its
      // reciprocal; the rows below, row by row; the triangle again row by row (backward), each
      // row's diagonal last, as its reciprocal.
      for (int64_t j = 0; j < width; ++j) {
        value_.push_back(1.0 / block[j * nrows + j]);
        for (int64_t i = j + 1; i < width; ++i) value_.push_back(block[j * nrows + i]);
      }
      for (int64_t r = width; r < nrows; ++r) {
        row_.push_back(static_cast<int32_t>(row_of[r]));
        for (int64_t j = 0; j < width; ++j) value_.push_back(block[j * nrows + r]);
      }
      for (int64_t i = 0; i < width; ++i) {
        for (int64_t j = 0; j < i; ++j) value_.push_back(block[j * nrows + i]);
        value_.push_back(1.0 / block[i * nrows + i]);
      }
      entries_ += width * (width + 1) / 2 + (nrows - width) * width;
    }
    row_end_ = static_cast<int64_t>(row_.size());
    work_.assign(static_cast<size_t>(4 * n), 0.0);  // up to 4 lanes, the unused ones 0
  }
  cholmod_l_free_factor(&L, &cm.c);
  if (status != Status::ok) {
    *this = SupernodalCholesky();
    if (separator_factor) separator_factor->clear();
  }
  return status;
}

// L y = w, then L^T z = y, in place on the n x lanes block w (row i: lanes adjacent doubles), every
// lane in the same pass, supernode by supernode. A supernode is `width` consecutive columns of L
// with one row pattern: a dense triangle on those columns and dense rows below them, each row
// `width` adjacent values under one row index. So an entry costs its value and a multiply-add,
// and a row index with the load and store of w serves a whole row. The loops are arranged so that
// no multiply-add waits for the one before (the latency, not the memory, is what bounds a solve
// of a factor that fits in cache):
// - forward: the triangle by columns (y_j known, the rows under it updated: independent), then
//   the rows below four at a time, each a dot product with y on two accumulators;
// - backward: the rows below add their part to the node's columns, four columns at a time in
//   registers, then the triangle by rows (z_i known, the columns before it updated).
// Compiled for x86-64-v3 (AVX2 and FMA: a row of 4 lanes is one register) and plain x86-64
// (HYPERQN_VECTOR_CLONES).
namespace {

// A row of the right-hand-side block: one double, or 4 lanes as one GCC vector (a 256-bit register
// under AVX2, two SSE registers otherwise; unaligned, and allowed to alias the doubles it is read
// from). Functions name it from `lanes`, never deduce it: deduction drops the typedef's
// alignment of 8.
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

// w[row[r]] -= (row r's `width` values) . y for the q <= 4 rows r from `value`.
template <int q, int lanes>
inline void dot_rows(typename RowOf<lanes>::type* w, const typename RowOf<lanes>::type* y, const int32_t* row,
                     const double* value, int width) {
  using Row = typename RowOf<lanes>::type;
  Row s[q] = {};
  for (int j = 0; j < width; ++j) {
    const Row yj = y[j];
    for (int u = 0; u < q; ++u) s[u] += value[u * width + j] * yj;
  }
  for (int u = 0; u < q; ++u) w[row[u]] -= s[u];
}

// z[0..q) -= sum over the rows below of (their values at these q <= 4 columns) * w[row], each
// column's sum in a register of its own.
template <int q, int lanes>
inline void subtract_below(typename RowOf<lanes>::type* z, const typename RowOf<lanes>::type* w, const int32_t* row,
                           int64_t rows, const double* value, int width) {
  using Row = typename RowOf<lanes>::type;
  Row t[q] = {};
  for (int64_t r = 0; r < rows; ++r) {
    const Row wr = w[row[r]];
    const double* v = value + r * width;
    for (int u = 0; u < q; ++u) t[u] += v[u] * wr;
  }
  for (int u = 0; u < q; ++u) z[u] -= t[u];
}

// Node k of the forward pass: y = its triangle's solve, then the rows below -= their values . y.
template <int lanes>
__attribute__((always_inline)) inline void forward_node(const SupernodalCholesky::Node* nodes, int64_t k,
                                                        int64_t count, int64_t row_end, const int32_t* __restrict row,
                                                        const double* __restrict L, double* __restrict block) {
  using Row = typename RowOf<lanes>::type;
  Row* w = reinterpret_cast<Row*>(block);
  const SupernodalCholesky::Node& node = nodes[k];
  const int width = node.width;
  Row* y = w + node.column;
  const double* v = L + node.value;
  const int64_t rows = (k + 1 < count ? nodes[k + 1].rows : row_end) - node.rows;
  const int32_t* below = row + node.rows;
  if (width == 1) {  // a lone column (chains of strands, leaves): no triangle, no dot products
    const Row yj = y[0] * v[0];
    y[0] = yj;
    for (int64_t r = 0; r < rows; ++r) w[below[r]] -= v[1 + r] * yj;
    return;
  }
  for (int j = 0; j < width; ++j) {
    const Row yj = y[j] * *v++;
    y[j] = yj;
    for (int i = j + 1; i < width; ++i) y[i] -= *v++ * yj;
  }
  int64_t r = 0;
  for (; r + 4 <= rows; r += 4, v += 4 * width) dot_rows<4, lanes>(w, y, below + r, v, width);
  switch (rows - r) {
    case 3: dot_rows<3, lanes>(w, y, below + r, v, width); break;
    case 2: dot_rows<2, lanes>(w, y, below + r, v, width); break;
    case 1: dot_rows<1, lanes>(w, y, below + r, v, width); break;
    default: break;
  }
}

template <int lanes>
HYPERQN_VECTOR_CLONES void forward_pass(const SupernodalCholesky::Node* nodes, int64_t count, int64_t row_end,
                                        const int32_t* __restrict row, const double* __restrict L,
                                        double* __restrict block) {
  for (int64_t k = 0; k < count; ++k) forward_node<lanes>(nodes, k, count, row_end, row, L, block);
}

// Columns per pass of forward_units: 4, a row in one AVX2 register (8 lanes in two took the box's
// commits of 12 rows from 1.4 to 3.3 ms).
constexpr int kUnitLanes = 4;

// The forward pass over the listed nodes only (ascending): a right-hand side that is 0 outside
// them, whose rows below each of them are again in them (the nodes' ancestors).
HYPERQN_VECTOR_CLONES void forward_pass_on(const SupernodalCholesky::Node* nodes, int64_t count, int64_t row_end,
                                           const int32_t* __restrict row, const double* __restrict L,
                                           double* __restrict block, const int32_t* which, int64_t listed) {
  for (int64_t a = 0; a < listed; ++a) forward_node<kUnitLanes>(nodes, which[a], count, row_end, row, L, block);
}

template <int lanes>
HYPERQN_VECTOR_CLONES void backward_pass(const SupernodalCholesky::Node* nodes, int64_t count, int64_t row_end,
                                         const int32_t* __restrict row, const double* __restrict L,
                                         double* __restrict block) {
  using Row = typename RowOf<lanes>::type;
  Row* w = reinterpret_cast<Row*>(block);
  for (int64_t k = count - 1; k >= 0; --k) {
    const SupernodalCholesky::Node& node = nodes[k];
    const int width = node.width;
    Row* z = w + node.column;
    const int64_t triangle = int64_t(width) * (width + 1) / 2;
    const int64_t rows = (k + 1 < count ? nodes[k + 1].rows : row_end) - node.rows;
    const double* v = L + node.value + triangle;  // the rows below
    const int32_t* below = row + node.rows;
    if (width == 1) {  // a lone column: one dot product, two partial sums
      Row s = z[0], t = Row{};
      int64_t r = 0;
      for (; r + 1 < rows; r += 2) {
        s -= v[r] * w[below[r]];
        t -= v[r + 1] * w[below[r + 1]];
      }
      if (r < rows) s -= v[r] * w[below[r]];
      z[0] = (s + t) * v[rows];
      continue;
    }
    int j = 0;
    for (; j + 4 <= width; j += 4) subtract_below<4, lanes>(z + j, w, below, rows, v + j, width);
    switch (width - j) {
      case 3: subtract_below<3, lanes>(z + j, w, below, rows, v + j, width); break;
      case 2: subtract_below<2, lanes>(z + j, w, below, rows, v + j, width); break;
      case 1: subtract_below<1, lanes>(z + j, w, below, rows, v + j, width); break;
      default: break;
    }
    // The triangle by rows, last row first: row i holds L_i0 .. L_i,i-1 and 1 / L_ii, so it
    // starts i (i + 1) / 2 entries in.
    const double* t = v + rows * width;
    for (int i = width - 1; i >= 0; --i) {
      const double* ri = t + int64_t(i) * (i + 1) / 2;
      const Row zi = z[i] * ri[i];
      z[i] = zi;
      for (int c = 0; c < i; ++c) z[c] -= ri[c] * zi;
    }
  }
}

}  // namespace

// x = P^T (L L^T)^{-1} P b for k interleaved columns, worked on in `lanes` >= k lanes (the others
// stay 0: 0 - l * 0).
template <int k, int lanes>
void SupernodalCholesky::solve_k(const double* b, double* x) const {
  double* w = work_.data();
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b[k * perm_[i] + c];
  const int64_t count = static_cast<int64_t>(nodes_.size());
  forward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
  backward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) x[k * perm_[i] + c] = w[lanes * i + c];
}

// The interior's forward pass: the separator's rows start at 0 and collect -X y.
template <int k, int lanes>
void SupernodalCholesky::forward_k(const double* b_interior, double* separator_update) const {
  double* w = work_.data();
  const int64_t interior = n_ - separator_;
  for (int64_t i = 0; i < interior; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b_interior[k * perm_[i] + c];
  std::fill(w + lanes * interior, w + lanes * n_, 0.0);
  forward_pass<lanes>(nodes_.data(), static_cast<int64_t>(nodes_.size()), row_end_, row_.data(), value_.data(), w);
  for (int64_t i = interior; i < n_; ++i)
    for (int c = 0; c < k; ++c) separator_update[k * (i - interior) + c] = w[lanes * i + c];
}

// The interior's backward pass from y (left by forward_k) with the separator's rows set to x_S.
template <int k, int lanes>
void SupernodalCholesky::backward_k(const double* separator_solution, double* x_interior) const {
  double* w = work_.data();
  const int64_t interior = n_ - separator_;
  for (int64_t i = interior; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = separator_solution[k * (i - interior) + c];
  backward_pass<lanes>(nodes_.data(), static_cast<int64_t>(nodes_.size()), row_end_, row_.data(), value_.data(), w);
  for (int64_t i = 0; i < interior; ++i)
    for (int c = 0; c < k; ++c) x_interior[k * perm_[i] + c] = w[lanes * i + c];
}

// solve_k with `middle` applied to P^T-ordered y = L^{-1} P b between the two passes.
template <int k, int lanes>
void SupernodalCholesky::solve_corrected_k(const double* b, double* x, const Middle& middle) const {
  double* w = work_.data();
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b[k * perm_[i] + c];
  const int64_t count = static_cast<int64_t>(nodes_.size());
  forward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
  middle(w, lanes);
  backward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) x[k * perm_[i] + c] = w[lanes * i + c];
}

void SupernodalCholesky::solve_corrected(int k, const double* b, double* x, const Middle& middle) const {
  if (separator_ != 0) throw std::logic_error("SupernodalCholesky::solve_corrected: a factor with a separator");
  if (k == 3) return solve_corrected_k<3, 4>(b, x, middle);
  if (k == 1) return solve_corrected_k<1, 1>(b, x, middle);
  throw std::invalid_argument("SupernodalCholesky::solve_corrected: k must be 1 or 3");
}

int32_t SupernodalCholesky::node_of(int64_t position) const {
  const auto after = std::upper_bound(nodes_.begin(), nodes_.end(), position,
                                      [](int64_t p, const Node& node) { return p < node.column; });
  return static_cast<int32_t>(after - nodes_.begin()) - 1;
}

std::vector<int32_t> SupernodalCholesky::path(int64_t position) const {
  std::vector<int32_t> nodes;
  const int64_t count = static_cast<int64_t>(nodes_.size());
  for (int32_t k = node_of(position); k >= 0;) {
    nodes.push_back(k);
    const int64_t end = k + 1 < count ? nodes_[k + 1].rows : row_end_;
    k = end > nodes_[k].rows ? node_of(row_[nodes_[k].rows]) : -1;  // the parent holds the first row below
  }
  return nodes;
}

// kUnitLanes columns at a time in the lanes of unit_work_, over the union of their paths: a lane is 0 on
// the nodes of the union outside its own path and stays 0 there, so each column gets the bits it
// would get alone (a column is a function of its position, whatever it is batched with).
void SupernodalCholesky::forward_units(const int64_t* positions, int count, SparseColumn* out) const {
  if (separator_ != 0) throw std::logic_error("SupernodalCholesky::forward_units: a factor with a separator");
  constexpr int L = kUnitLanes;
  if (unit_work_.size() != static_cast<size_t>(L * n_)) unit_work_.assign(static_cast<size_t>(L * n_), 0.0);
  double* w = unit_work_.data();
  const int64_t nodes = static_cast<int64_t>(nodes_.size());
  for (int first = 0; first < count; first += L) {
    const int m = std::min(L, count - first);
    std::vector<int32_t> all;
    for (int c = 0; c < m; ++c) {
      out[first + c].nodes = path(positions[first + c]);
      all.insert(all.end(), out[first + c].nodes.begin(), out[first + c].nodes.end());
    }
    std::sort(all.begin(), all.end());
    all.erase(std::unique(all.begin(), all.end()), all.end());
    for (int32_t k : all) std::fill(w + L * nodes_[k].column, w + L * (nodes_[k].column + nodes_[k].width), 0.0);
    for (int c = 0; c < m; ++c) w[L * positions[first + c] + c] = 1.0;
    forward_pass_on(nodes_.data(), nodes, row_end_, row_.data(), value_.data(), w, all.data(),
                    static_cast<int64_t>(all.size()));
    for (int c = 0; c < m; ++c) {
      SparseColumn& col = out[first + c];
      col.values.clear();
      for (int32_t k : col.nodes)
        for (int64_t i = nodes_[k].column; i < nodes_[k].column + nodes_[k].width; ++i) col.values.push_back(w[L * i + c]);
    }
    for (int32_t k : all) std::fill(w + L * nodes_[k].column, w + L * (nodes_[k].column + nodes_[k].width), 0.0);
  }
}

void SupernodalCholesky::solve(int k, const double* b, double* x) const {
  if (separator_ != 0) throw std::logic_error("SupernodalCholesky::solve: a factor with a separator solves in two halves");
  if (k == 3) return solve_k<3, 4>(b, x);
  if (k == 1) return solve_k<1, 1>(b, x);
  throw std::invalid_argument("SupernodalCholesky::solve: k must be 1 or 3");
}

void SupernodalCholesky::solve_interior_forward(int k, const double* b_interior, double* separator_update) const {
  if (k == 3) return forward_k<3, 4>(b_interior, separator_update);
  if (k == 1) return forward_k<1, 1>(b_interior, separator_update);
  throw std::invalid_argument("SupernodalCholesky::solve_interior_forward: k must be 1 or 3");
}

void SupernodalCholesky::solve_interior_backward(int k, const double* separator_solution, double* x_interior) const {
  if (k == 3) return backward_k<3, 4>(separator_solution, x_interior);
  if (k == 1) return backward_k<1, 1>(separator_solution, x_interior);
  throw std::invalid_argument("SupernodalCholesky::solve_interior_backward: k must be 1 or 3");
}

}  // namespace hyperqn

#include "solvers/supernodal_cholesky.hpp"

#include <cholmod.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
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
// Value: the factor's type, double or float (SupernodalCholesky::keep_single_precision); a float
// is widened to double as it is loaded, so every product and sum is a double's.
template <int q, int lanes, typename Value>
inline void dot_rows(typename RowOf<lanes>::type* w, const typename RowOf<lanes>::type* y, const int32_t* row,
                     const Value* value, int width) {
  using Row = typename RowOf<lanes>::type;
  Row s[q] = {};
  for (int j = 0; j < width; ++j) {
    const Row yj = y[j];
    for (int u = 0; u < q; ++u) s[u] += double(value[u * width + j]) * yj;
  }
  for (int u = 0; u < q; ++u) w[row[u]] -= s[u];
}

// z[0..q) -= sum over the rows below of (their values at these q <= 4 columns) * w[row], each
// column's sum in a register of its own.
template <int q, int lanes, typename Value>
inline void subtract_below(typename RowOf<lanes>::type* z, const typename RowOf<lanes>::type* w, const int32_t* row,
                           int64_t rows, const Value* value, int width) {
  using Row = typename RowOf<lanes>::type;
  Row t[q] = {};
  for (int64_t r = 0; r < rows; ++r) {
    const Row wr = w[row[r]];
    const Value* v = value + r * width;
    for (int u = 0; u < q; ++u) t[u] += double(v[u]) * wr;
  }
  for (int u = 0; u < q; ++u) z[u] -= t[u];
}

// Node k of the forward pass: y = its triangle's solve, then the rows below -= their values . y.
template <int lanes, typename Value>
__attribute__((always_inline)) inline void forward_node(const SupernodalCholesky::Node* nodes, int64_t k,
                                                        int64_t count, int64_t row_end, const int32_t* __restrict row,
                                                        const Value* __restrict L, double* __restrict block) {
  using Row = typename RowOf<lanes>::type;
  Row* w = reinterpret_cast<Row*>(block);
  const SupernodalCholesky::Node& node = nodes[k];
  const int width = node.width;
  Row* y = w + node.column;
  const Value* v = L + node.value;
  const int64_t rows = (k + 1 < count ? nodes[k + 1].rows : row_end) - node.rows;
  const int32_t* below = row + node.rows;
  if (width == 1) {  // a lone column (chains of strands, leaves): no triangle, no dot products
    const Row yj = y[0] * double(v[0]);
    y[0] = yj;
    for (int64_t r = 0; r < rows; ++r) w[below[r]] -= double(v[1 + r]) * yj;
    return;
  }
  for (int j = 0; j < width; ++j) {
    const Row yj = y[j] * double(*v++);
    y[j] = yj;
    for (int i = j + 1; i < width; ++i) y[i] -= double(*v++) * yj;
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

template <int lanes, typename Value>
HYPERQN_VECTOR_CLONES void forward_pass(const SupernodalCholesky::Node* nodes, int64_t count, int64_t row_end,
                                        const int32_t* __restrict row, const Value* __restrict L,
                                        double* __restrict block) {
  for (int64_t k = 0; k < count; ++k) forward_node<lanes, Value>(nodes, k, count, row_end, row, L, block);
}

// forward_units' columns: groups of kUnitLanes, a row of a group in one AVX2 register. A group of 8
// lanes in two registers per pass took the box's commits of 12 rows from 1.4 to 3.3 ms.
constexpr int kUnitLanes = 4;

// What forward_units' pass visits: the union of the columns' paths (`listed` nodes `which`,
// ascending), each node's columns at `offset` of the compact block (the union's columns one after
// the other), its rows below as rows of that block, and the groups of columns whose path has it.
// Group g is the block's rows × kUnitLanes doubles from g × stride.
struct UnitPlan {
  const int32_t* which;
  int64_t listed;
  const int32_t* offset;
  const int64_t* below_start;  // listed + 1
  const int32_t* below;
  const int64_t* group_start;  // listed + 1
  const int32_t* group;
  int64_t stride;
  int32_t* first;  // scratch: a node's first row that is not 0, per pair of its groups
};

// The kernels of forward_units_pass, on Q groups at once. Per lane each does forward_node's
// arithmetic on each entry of the block in forward_node's order (only the loops around it are
// reordered), so each lane gets the bits that forward_node<kUnitLanes> gives.
using UnitRow = RowOf<kUnitLanes>::type;

// y = L_nn^{-1} y on a node's triangle (by columns: 1 / L_jj, then L_ij below it), four columns
// (a panel) at a time: the panel's own triangle, then each row below it loaded once, its four
// updates in registers, in the order of j.
template <int Q>
inline void unit_triangle(UnitRow* const* y, const double* v, int first, int width) {
  v += int64_t(first) * width - int64_t(first) * (first - 1) / 2;  // column `first`
  int j0 = first;
  for (; j0 + 4 <= width; j0 += 4) {
    const double* c[4];
    c[0] = v;
    for (int p = 1; p < 4; ++p) c[p] = c[p - 1] + (width - j0 - p + 1);
    v = c[3] + (width - j0 - 3);
    UnitRow yj[Q][4];
    for (int q = 0; q < Q; ++q)
      for (int p = 0; p < 4; ++p) {
        const UnitRow a = y[q][j0 + p] * c[p][0];
        y[q][j0 + p] = a;
        yj[q][p] = a;
        for (int i = p + 1; i < 4; ++i) y[q][j0 + i] -= c[p][i - p] * a;
      }
    for (int i = j0 + 4; i < width; ++i) {
      const double l0 = c[0][i - j0], l1 = c[1][i - j0 - 1], l2 = c[2][i - j0 - 2], l3 = c[3][i - j0 - 3];
      for (int q = 0; q < Q; ++q) {
        UnitRow t = y[q][i];
        t -= l0 * yj[q][0];
        t -= l1 * yj[q][1];
        t -= l2 * yj[q][2];
        t -= l3 * yj[q][3];
        y[q][i] = t;
      }
    }
  }
  for (int j = j0; j < width; ++j) {  // the last columns one by one
    for (int q = 0; q < Q; ++q) {
      const UnitRow a = y[q][j] * v[0];
      y[q][j] = a;
      for (int i = j + 1; i < width; ++i) y[q][i] -= v[i - j] * a;
    }
    v += width - j;
  }
}

// dot_rows on Q groups: w[row[u]] -= (row u's values) . y for the r <= 4 rows u, each value
// loaded once for the Q groups.
template <int r, int Q>
inline void unit_dot_rows(UnitRow* const* w, UnitRow* const* y, const int32_t* row, const double* value, int first,
                          int width) {
  UnitRow s[Q][r] = {};
  for (int j = first; j < width; ++j) {
    UnitRow yj[Q];
    for (int q = 0; q < Q; ++q) yj[q] = y[q][j];
    for (int u = 0; u < r; ++u)
      for (int q = 0; q < Q; ++q) s[q][u] += value[u * width + j] * yj[q];
  }
  for (int q = 0; q < Q; ++q)
    for (int u = 0; u < r; ++u) w[q][row[u]] -= s[q][u];
}

template <int Q>
inline void unit_rows_below(UnitRow* const* w, UnitRow* const* y, const int32_t* below, int64_t rows, const double* v,
                            int first, int width) {
  switch (rows) {
    case 4: unit_dot_rows<4, Q>(w, y, below, v, first, width); break;
    case 3: unit_dot_rows<3, Q>(w, y, below, v, first, width); break;
    case 2: unit_dot_rows<2, Q>(w, y, below, v, first, width); break;
    case 1: unit_dot_rows<1, Q>(w, y, below, v, first, width); break;
    default: break;
  }
}

// The first of a node's `width` rows where a lane of the Q groups is not 0. The lanes are 0 on the
// rows before it (a column's first node starts below the others', or its path joins a node below
// its first row), so the work with them is skipped: it would subtract +0 (y is never -0: it starts
// as +0 and 1, and x - x rounds to +0), which changes no bit.
template <int Q>
inline int unit_first_nonzero(UnitRow* const* y, int width) {
  for (int j = 0; j < width; ++j)
    for (int q = 0; q < Q; ++q)
      for (int l = 0; l < kUnitLanes; ++l)
        if (y[q][j][l] != 0) return j;
  return width;
}

// The forward pass of every group over the union, node by node: a node's values of L are read once
// for all the groups through it, two groups at a time (from L1 while the pairs take their turns:
// a panel of the triangle, a block of 4 rows below), not once per group. A lane that is 0 on a
// node stays 0 there and adds 0 to the rows below, so each column gets the bits it would get alone.
HYPERQN_VECTOR_CLONES void forward_units_pass(const SupernodalCholesky::Node* nodes, const double* __restrict L,
                                              double* __restrict block, const UnitPlan& plan) {
  for (int64_t a = 0; a < plan.listed; ++a) {
    const SupernodalCholesky::Node& node = nodes[plan.which[a]];
    const int width = node.width;
    const int32_t* below = plan.below + plan.below_start[a];
    const int64_t rows = plan.below_start[a + 1] - plan.below_start[a];
    const int32_t* groups = plan.group + plan.group_start[a];
    const int64_t count = plan.group_start[a + 1] - plan.group_start[a];
    const double* v = L + node.value;
    UnitRow* w[2];
    UnitRow* y[2];
    auto take = [&](int64_t q, int slot) {
      w[slot] = reinterpret_cast<UnitRow*>(block + groups[q] * plan.stride);
      y[slot] = w[slot] + plan.offset[a];
    };
    if (width == 1) {  // as forward_node's lone column
      for (int64_t q = 0; q < count; ++q) {
        take(q, 0);
        const UnitRow yj = y[0][0] * v[0];
        y[0][0] = yj;
        for (int64_t r = 0; r < rows; ++r) w[0][below[r]] -= v[1 + r] * yj;
      }
      continue;
    }
    int32_t* first = plan.first;  // per pair of groups
    for (int64_t q = 0, p = 0; q < count; q += 2, ++p) {
      take(q, 0);
      if (q + 1 < count) {
        take(q + 1, 1);
        first[p] = unit_first_nonzero<2>(y, width);
        unit_triangle<2>(y, v, first[p], width);
      } else {
        first[p] = unit_first_nonzero<1>(y, width);
        unit_triangle<1>(y, v, first[p], width);
      }
    }
    v += int64_t(width) * (width + 1) / 2;
    // The rows below, 4 at a time, each block for every pair of groups in turn.
    for (int64_t r = 0; r < rows; r += 4, v += 4 * width) {
      const int64_t block_rows = std::min<int64_t>(4, rows - r);
      for (int64_t q = 0, p = 0; q < count; q += 2, ++p) {
        take(q, 0);
        if (q + 1 < count) {
          take(q + 1, 1);
          unit_rows_below<2>(w, y, below + r, block_rows, v, first[p], width);
        } else {
          unit_rows_below<1>(w, y, below + r, block_rows, v, first[p], width);
        }
      }
    }
  }
}

// result[kUnitLanes g + l] = column . (lane l of group g), g < groups, over the column's nodes
// that are in the block (node_offset >= 0): one multiply-add per row, ascending, from 0. Four
// groups at a time, each sum in a register of its own.
template <int m>
inline void unit_dots_of(const double* block, int64_t stride, const SupernodalCholesky::Node* nodes,
                         const int32_t* node_offset, const SupernodalCholesky::SparseColumn& column, int g0,
                         double* result) {
  using Row = RowOf<kUnitLanes>::type;
  Row s[m] = {};
  const double* v = column.values.data();
  for (int32_t k : column.nodes) {
    const int width = nodes[k].width;
    if (const int32_t offset = node_offset[k]; offset >= 0) {
      const Row* g[m];
      for (int q = 0; q < m; ++q) g[q] = reinterpret_cast<const Row*>(block + (g0 + q) * stride) + offset;
      for (int i = 0; i < width; ++i)
        for (int q = 0; q < m; ++q) s[q] += v[i] * g[q][i];
    }
    v += width;
  }
  for (int q = 0; q < m; ++q)
    for (int l = 0; l < kUnitLanes; ++l) result[kUnitLanes * (g0 + q) + l] = s[q][l];
}

HYPERQN_VECTOR_CLONES void unit_dots(const double* block, int64_t stride, const SupernodalCholesky::Node* nodes,
                                     const int32_t* node_offset, const SupernodalCholesky::SparseColumn& column,
                                     int groups, double* result) {
  int g = 0;
  for (; g + 4 <= groups; g += 4) unit_dots_of<4>(block, stride, nodes, node_offset, column, g, result);
  switch (groups - g) {
    case 3: unit_dots_of<3>(block, stride, nodes, node_offset, column, g, result); break;
    case 2: unit_dots_of<2>(block, stride, nodes, node_offset, column, g, result); break;
    case 1: unit_dots_of<1>(block, stride, nodes, node_offset, column, g, result); break;
    default: break;
  }
}

template <int lanes, typename Value>
HYPERQN_VECTOR_CLONES void backward_pass(const SupernodalCholesky::Node* nodes, int64_t count, int64_t row_end,
                                         const int32_t* __restrict row, const Value* __restrict L,
                                         double* __restrict block) {
  using Row = typename RowOf<lanes>::type;
  Row* w = reinterpret_cast<Row*>(block);
  for (int64_t k = count - 1; k >= 0; --k) {
    const SupernodalCholesky::Node& node = nodes[k];
    const int width = node.width;
    Row* z = w + node.column;
    const int64_t triangle = int64_t(width) * (width + 1) / 2;
    const int64_t rows = (k + 1 < count ? nodes[k + 1].rows : row_end) - node.rows;
    const Value* v = L + node.value + triangle;  // the rows below
    const int32_t* below = row + node.rows;
    if (width == 1) {  // a lone column: one dot product, two partial sums
      Row s = z[0], t = Row{};
      int64_t r = 0;
      for (; r + 1 < rows; r += 2) {
        s -= double(v[r]) * w[below[r]];
        t -= double(v[r + 1]) * w[below[r + 1]];
      }
      if (r < rows) s -= double(v[r]) * w[below[r]];
      z[0] = (s + t) * double(v[rows]);
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
    const Value* t = v + rows * width;
    for (int i = width - 1; i >= 0; --i) {
      const Value* ri = t + int64_t(i) * (i + 1) / 2;
      const Row zi = z[i] * double(ri[i]);
      z[i] = zi;
      for (int c = 0; c < i; ++c) z[c] -= double(ri[c]) * zi;
    }
  }
}

}  // namespace

template <int lanes>
void SupernodalCholesky::forward(double* w) const {
  const int64_t count = static_cast<int64_t>(nodes_.size());
  if (single_precision())
    forward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), single_value_.data(), w);
  else
    forward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
}

template <int lanes>
void SupernodalCholesky::backward(double* w) const {
  const int64_t count = static_cast<int64_t>(nodes_.size());
  if (single_precision())
    backward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), single_value_.data(), w);
  else
    backward_pass<lanes>(nodes_.data(), count, row_end_, row_.data(), value_.data(), w);
}

// x = P^T (L L^T)^{-1} P b for k interleaved columns, worked on in `lanes` >= k lanes (the others
// stay 0: 0 - l * 0).
template <int k, int lanes>
void SupernodalCholesky::solve_k(const double* b, double* x) const {
  double* w = work_.data();
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b[k * perm_[i] + c];
  forward<lanes>(w);
  backward<lanes>(w);
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
  forward<lanes>(w);
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
  backward<lanes>(w);
  for (int64_t i = 0; i < interior; ++i)
    for (int c = 0; c < k; ++c) x_interior[k * perm_[i] + c] = w[lanes * i + c];
}

// solve_k with `middle` applied to P^T-ordered y = L^{-1} P b between the two passes.
template <int k, int lanes>
void SupernodalCholesky::solve_corrected_k(const double* b, double* x, const Middle& middle) const {
  double* w = work_.data();
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) w[lanes * i + c] = b[k * perm_[i] + c];
  forward<lanes>(w);
  middle(w, lanes);
  backward<lanes>(w);
  for (int64_t i = 0; i < n_; ++i)
    for (int c = 0; c < k; ++c) x[k * perm_[i] + c] = w[lanes * i + c];
}

void SupernodalCholesky::solve_corrected(int k, const double* b, double* x, const Middle& middle) const {
  if (separator_ != 0) throw std::logic_error("SupernodalCholesky::solve_corrected: a factor with a separator");
  if (single_precision()) throw std::logic_error("SupernodalCholesky::solve_corrected: a factor kept in single precision");
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

// The columns in groups of kUnitLanes sorted by their first node (so a group's paths share most of
// their nodes), as many groups per pass over the union of their paths (forward_units_pass) as
// keep its compact block (the union's columns only) within max_block doubles.
void SupernodalCholesky::forward_units(const int64_t* positions, int count, SparseColumn* out,
                                       const SparseColumn* const* others, int other_count, double* gram,
                                       int64_t max_block) const {
  if (separator_ != 0) throw std::logic_error("SupernodalCholesky::forward_units: a factor with a separator");
  if (single_precision()) throw std::logic_error("SupernodalCholesky::forward_units: a factor kept in single precision");
  if (count <= 0) return;
  constexpr int L = kUnitLanes;
  std::vector<int> order(count);
  for (int c = 0; c < count; ++c) {
    out[c].nodes = path(positions[c]);
    order[c] = c;
  }
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return std::pair(out[a].nodes[0], positions[a]) < std::pair(out[b].nodes[0], positions[b]);
  });
  if (node_offset_.size() != nodes_.size()) node_offset_.assign(nodes_.size(), -1);
  if (column_offset_.size() != static_cast<size_t>(n_)) column_offset_.assign(static_cast<size_t>(n_), -1);
  const int groups = (count + L - 1) / L;
  const int64_t budget = max_block > 0 ? max_block : std::max<int64_t>(4 * n_, int64_t(1) << 21);
  const int64_t stride_gram = count + other_count;
  std::vector<double> dots;
  for (int g_begin = 0; g_begin < groups;) {
    // The pass's groups [g_begin, g_end) and the union of their paths (node_offset_ marks it).
    std::vector<int32_t> which;
    int64_t rows = 0;
    int g_end = g_begin;
    for (; g_end < groups; ++g_end) {
      std::vector<int32_t> more;
      int64_t more_rows = 0;
      for (int s = L * g_end; s < std::min(count, L * (g_end + 1)); ++s)
        for (int32_t k : out[order[s]].nodes)
          if (node_offset_[k] < 0) {
            node_offset_[k] = 0;
            more.push_back(k);
            more_rows += nodes_[k].width;
          }
      if (g_end > g_begin && int64_t(L) * (g_end + 1 - g_begin) * (rows + more_rows) > budget) {
        for (int32_t k : more) node_offset_[k] = -1;
        break;
      }
      which.insert(which.end(), more.begin(), more.end());
      rows += more_rows;
    }
    std::sort(which.begin(), which.end());
    const int64_t listed = static_cast<int64_t>(which.size());
    std::vector<int32_t> offset(listed);
    for (int64_t a = 0, at = 0; a < listed; ++a) {
      const Node& node = nodes_[which[a]];
      offset[a] = node_offset_[which[a]] = static_cast<int32_t>(at);
      for (int32_t i = 0; i < node.width; ++i) column_offset_[node.column + i] = static_cast<int32_t>(at + i);
      at += node.width;
    }
    // The rows below each node, as rows of the block (they are its ancestors' columns: in the union).
    const int64_t count_nodes = static_cast<int64_t>(nodes_.size());
    std::vector<int64_t> below_start(listed + 1, 0);
    std::vector<int32_t> below;
    for (int64_t a = 0; a < listed; ++a) {
      const int32_t k = which[a];
      const int64_t end = k + 1 < count_nodes ? nodes_[k + 1].rows : row_end_;
      for (int64_t r = nodes_[k].rows; r < end; ++r) below.push_back(column_offset_[row_[r]]);
      below_start[a + 1] = static_cast<int64_t>(below.size());
    }
    // Per node of the union, the pass's groups with a column through it (ascending, from 0).
    const int pass_groups = g_end - g_begin;
    std::vector<std::vector<int32_t>> through(listed);
    for (int g = 0; g < pass_groups; ++g) {
      std::vector<int32_t> mine;
      for (int s = L * (g_begin + g); s < std::min(count, L * (g_begin + g + 1)); ++s)
        mine.insert(mine.end(), out[order[s]].nodes.begin(), out[order[s]].nodes.end());
      std::sort(mine.begin(), mine.end());
      mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
      for (int32_t k : mine) through[std::lower_bound(which.begin(), which.end(), k) - which.begin()].push_back(g);
    }
    std::vector<int64_t> group_start(listed + 1, 0);
    std::vector<int32_t> group;
    for (int64_t a = 0; a < listed; ++a) {
      group.insert(group.end(), through[a].begin(), through[a].end());
      group_start[a + 1] = static_cast<int64_t>(group.size());
    }
    const int64_t stride = int64_t(L) * rows;
    unit_work_.assign(static_cast<size_t>(pass_groups * stride), 0.0);
    double* block = unit_work_.data();
    const int s_begin = L * g_begin, s_end = std::min(count, L * g_end);
    for (int s = s_begin; s < s_end; ++s)
      block[((s - s_begin) / L) * stride + L * column_offset_[positions[order[s]]] + s % L] = 1.0;
    std::vector<int32_t> first((pass_groups + 1) / 2);
    const UnitPlan plan{which.data(), listed, offset.data(), below_start.data(), below.data(),
                        group_start.data(), group.data(), stride, first.data()};
    forward_units_pass(nodes_.data(), value_.data(), block, plan);
    for (int s = s_begin; s < s_end; ++s) {
      SparseColumn& col = out[order[s]];
      const double* lane = block + ((s - s_begin) / L) * stride + s % L;
      col.values.clear();
      for (int32_t k : col.nodes)
        for (int32_t i = 0; i < nodes_[k].width; ++i) col.values.push_back(lane[L * (node_offset_[k] + i)]);
    }
    // The Gram entries with this pass's columns: each of them against the groups up to its own
    // (the pairs before it), the earlier passes' columns and the others against every group.
    if (gram) {
      dots.resize(static_cast<size_t>(L * pass_groups));
      // column . (this pass's columns up to sorted `last`) into gram's column `at` (and row).
      auto with = [&](const SparseColumn& column, int upto, int last, int64_t at, bool row_too) {
        unit_dots(block, stride, nodes_.data(), node_offset_.data(), column, upto, dots.data());
        for (int s = s_begin; s <= std::min(last, s_end - 1); ++s) {
          gram[order[s] * stride_gram + at] = dots[s - s_begin];
          if (row_too) gram[at * stride_gram + order[s]] = dots[s - s_begin];
        }
      };
      for (int s = s_begin; s < s_end; ++s) with(out[order[s]], (s - s_begin) / L + 1, s, order[s], true);
      for (int s = 0; s < s_begin; ++s) with(out[order[s]], pass_groups, s_end - 1, order[s], true);
      for (int o = 0; o < other_count; ++o) with(*others[o], pass_groups, s_end - 1, count + o, false);
    }
    for (int64_t a = 0; a < listed; ++a) {
      node_offset_[which[a]] = -1;
      for (int32_t i = 0; i < nodes_[which[a]].width; ++i) column_offset_[nodes_[which[a]].column + i] = -1;
    }
    g_begin = g_end;
  }
}

bool SupernodalCholesky::keep_single_precision() {
  if (single_precision() || value_.empty()) return true;
  // Each value rounded to the nearest float. One that overflows, or a normal double that rounds to
  // 0 (a reciprocal diagonal among them would make a pivot infinite), leaves the doubles in place.
  std::vector<float> single(value_.begin(), value_.end());
  for (size_t e = 0; e < single.size(); ++e)
    if (!std::isfinite(single[e]) || (single[e] == 0 && std::isnormal(value_[e]))) return false;
  single_value_ = std::move(single);
  std::vector<double>().swap(value_);
  return true;
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

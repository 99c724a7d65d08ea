#include "solvers/topology_h0.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "materials/lanes.hpp"

namespace hyperqn {

namespace {

// The correction's loops on rows of 4 lanes (k = 3 right-hand sides and a lane of padding, as the
// factor's solve holds them), compiled for x86-64-v3 and plain x86-64 (HYPERQN_VECTOR_CLONES; a
// row is one GCC vector, never passed by value across the clones).
typedef double Row4 __attribute__((vector_size(32), aligned(8), may_alias));
using Node = SupernodalCholesky::Node;
using SparseColumn = SupernodalCholesky::SparseColumn;
using CapacitanceColumns = TopologyH0::CapacitanceColumns;

// out = col^T y for one column of W (a run per node of its path) on the rows y of w: two sums
// (even and odd entries of each run), so that a multiply-add does not wait on the one before.
HYPERQN_VECTOR_CLONES void column_dot4(const Node* nodes, const SparseColumn& col, const double* w, double* out) {
  const double* v = col.values.data();
  Row4 even = {}, odd = {};
  for (int32_t node : col.nodes) {
    const Row4* y = reinterpret_cast<const Row4*>(w + 4 * nodes[node].column);
    const int32_t width = nodes[node].width;
    int32_t i = 0;
    for (; i + 1 < width; i += 2, v += 2) {
      even += v[0] * y[i];
      odd += v[1] * y[i + 1];
    }
    if (i < width) even += *v++ * y[i];
  }
  *reinterpret_cast<Row4*>(out) = even + odd;
}

// y -= col z on the rows y of w.
HYPERQN_VECTOR_CLONES void column_subtract4(const Node* nodes, const SparseColumn& col, const double* z, double* w) {
  const double* v = col.values.data();
  const Row4 zr = *reinterpret_cast<const Row4*>(z);
  for (int32_t node : col.nodes) {
    Row4* y = reinterpret_cast<Row4*>(w + 4 * nodes[node].column);
    for (int32_t i = 0; i < nodes[node].width; ++i, ++v) y[i] -= *v * zr;
  }
}

// u = (I + G E)^{-1} s by its LU (row-major, t x t: L unit lower below the diagonal, U on and
// above; row `to[i]` of P s is s's row i), s and u t rows of 4 lanes; then z = E u, E by columns.
// Each row's sum in two halves (even and odd entries), so that a multiply-add does not wait on the
// one before.
HYPERQN_VECTOR_CLONES void capacitance_solve4(const double* lu, const int64_t* to, int64_t t,
                                              const CapacitanceColumns& e, const double* s, double* u, double* z) {
  const Row4* S = reinterpret_cast<const Row4*>(s);
  Row4* U = reinterpret_cast<Row4*>(u);
  Row4* Z = reinterpret_cast<Row4*>(z);
  for (int64_t i = 0; i < t; ++i) U[to[i]] = S[i];
  for (int64_t a = 1; a < t; ++a) {
    const double* row = lu + a * t;
    Row4 even = {}, odd = {};
    int64_t b = 0;
    for (; b + 1 < a; b += 2) {
      even += row[b] * U[b];
      odd += row[b + 1] * U[b + 1];
    }
    if (b < a) even += row[b] * U[b];
    U[a] -= even + odd;
  }
  for (int64_t a = t - 1; a >= 0; --a) {
    const double* row = lu + a * t;
    Row4 even = {}, odd = {};
    int64_t b = a + 1;
    for (; b + 1 < t; b += 2) {
      even += row[b] * U[b];
      odd += row[b + 1] * U[b + 1];
    }
    if (b < t) even += row[b] * U[b];
    U[a] = (U[a] - (even + odd)) / row[a];
  }
  for (int64_t a = 0; a < t; ++a) Z[a] = Row4{};
  for (int64_t b = 0; b < t; ++b)
    for (int64_t q = e.start[b]; q < e.start[b + 1]; ++q) Z[e.row[q]] += e.value[q] * U[b];
}

// The same on rows of one lane (k = 1), plainly.
void column_dot1(const Node* nodes, const SparseColumn& col, const double* w, double* out) {
  const double* v = col.values.data();
  double sum = 0;
  for (int32_t node : col.nodes)
    for (int32_t i = 0; i < nodes[node].width; ++i, ++v) sum += *v * w[nodes[node].column + i];
  *out = sum;
}
void column_subtract1(const Node* nodes, const SparseColumn& col, const double* z, double* w) {
  const double* v = col.values.data();
  for (int32_t node : col.nodes)
    for (int32_t i = 0; i < nodes[node].width; ++i, ++v) w[nodes[node].column + i] -= *v * *z;
}
void capacitance_solve1(const double* lu, const int64_t* to, int64_t t, const CapacitanceColumns& e, const double* s,
                        double* u, double* z) {
  for (int64_t i = 0; i < t; ++i) u[to[i]] = s[i];
  for (int64_t a = 1; a < t; ++a) {
    double sum = 0;
    for (int64_t b = 0; b < a; ++b) sum += lu[a * t + b] * u[b];
    u[a] -= sum;
  }
  for (int64_t a = t - 1; a >= 0; --a) {
    double sum = 0;
    for (int64_t b = a + 1; b < t; ++b) sum += lu[a * t + b] * u[b];
    u[a] = (u[a] - sum) / lu[a * t + a];
  }
  for (int64_t a = 0; a < t; ++a) z[a] = 0;
  for (int64_t b = 0; b < t; ++b)
    for (int64_t q = e.start[b]; q < e.start[b + 1]; ++q) z[e.row[q]] += e.value[q] * u[b];
}

TopologyH0::Status status_of(SupernodalCholesky::Status s) {
  if (s == SupernodalCholesky::Status::ok) return TopologyH0::Status::ok;
  if (s == SupernodalCholesky::Status::not_positive_definite) return TopologyH0::Status::not_positive_definite;
  return TopologyH0::Status::failed;
}

}  // namespace

TopologyH0::Status TopologyH0::setup(SymmetricCsr A, int64_t max_touched) {
  *this = TopologyH0();
  max_touched_ = max_touched;
  A_ = std::move(A);
  n_ = A_.n;
  const Status s = status_of(factor_.factor(n_, A_.start.data(), A_.column.data(), A_.value.data()));
  if (s != Status::ok) return s;
  position_.assign(n_, 0);
  for (int64_t q = 0; q < n_; ++q) position_[factor_.perm()[q]] = q;
  return s;
}

int64_t TopologyH0::duplicate_vertex(int64_t vertex, double mass_moved) {
  const int64_t copy = size();
  ++pending_vertices_;
  add_mass(vertex, -mass_moved);
  add_mass(copy, mass_moved);
  return copy;
}

void TopologyH0::add_mass(int64_t vertex, double delta) {
  if (vertex < 0 || vertex >= size()) throw std::out_of_range("TopologyH0::add_mass: no such vertex");
  edits_[{vertex, vertex}] += delta;
  pending_ = true;
}

void TopologyH0::add_element(int count, const int64_t* vertices, const double* K, double scale) {
  for (int a = 0; a < count; ++a)
    if (vertices[a] < 0 || vertices[a] >= size()) throw std::out_of_range("TopologyH0::add_element: no such vertex");
  for (int a = 0; a < count; ++a)
    for (int b = 0; b < count; ++b) edits_[{vertices[a], vertices[b]}] += scale * K[a * count + b];
  pending_ = true;
}

int64_t TopologyH0::add_vertex() {
  const int64_t v = size();
  ++pending_vertices_;
  pending_ = true;
  return v;
}

void TopologyH0::add_entry(int64_t i, int64_t j, double delta) {
  if (i < 0 || i >= size() || j < 0 || j >= size()) throw std::out_of_range("TopologyH0::add_entry: no such vertex");
  edits_[{i, j}] += delta;
  if (i != j) edits_[{j, i}] += delta;
  pending_ = true;
}

int64_t TopologyH0::pending_touched() const {
  int64_t t = 0, last = -1;
  for (const auto& [key, value] : edits_)
    if (key.first != last) {
      ++t;
      last = key.first;
    }
  return t;
}

int64_t TopologyH0::slot_of(int64_t row) {
  const auto [it, added] = slot_.emplace(row, slots_);
  if (added) ++slots_;
  return it->second;
}

TopologyH0::Status TopologyH0::commit() {
  // T: every row with an edit, ascending (the map's order).
  std::vector<int64_t> touched;
  for (const auto& [key, value] : edits_)
    if (touched.empty() || touched.back() != key.first) touched.push_back(key.first);
  if (static_cast<int64_t>(touched.size()) > max_touched_) return refactor();
  // The new vertices' D: their diagonal in A' as first committed (positive: a vertex has mass).
  while (pending_vertices_ > 0) {
    const int64_t v = n_ + static_cast<int64_t>(sqrt_d_.size());
    const auto it = edits_.find({v, v});
    const double d = it == edits_.end() ? 0.0 : it->second;
    if (!(d > 0)) return Status::not_positive_definite;
    sqrt_d_.push_back(std::sqrt(d));
    --pending_vertices_;
  }
  pending_ = false;
  // W's columns of the old rows not seen before, in one sparse forward solve over their paths,
  // with their dot products with each other and with the columns kept from earlier commits.
  std::vector<int64_t> positions;
  const int64_t before = slots_;
  for (int64_t row : touched)
    if (row < n_ && !slot_.count(row)) {
      slot_of(row);
      positions.push_back(position_[row]);
    }
  const int64_t fresh = slots_ - before;
  column_.resize(slots_);
  std::vector<const SupernodalCholesky::SparseColumn*> kept(before);
  for (int64_t a = 0; a < before; ++a) kept[a] = &column_[a];
  std::vector<double> gram(fresh * slots_);  // fresh rows of (fresh, then kept) columns
  factor_.forward_units(positions.data(), static_cast<int>(fresh), column_.data() + before, kept.data(),
                        static_cast<int>(before), gram.data());
  columns_computed_ += fresh;
  // G_ grown by the new slots' rows and columns (the old entries kept as they are).
  if (fresh > 0) {
    Eigen::MatrixXd G(slots_, slots_);
    G.topLeftCorner(before, before) = G_;
    for (int64_t a = 0; a < fresh; ++a) {
      for (int64_t b = 0; b < fresh; ++b) G(before + a, before + b) = gram[a * slots_ + b];
      for (int64_t b = 0; b < before; ++b) G(before + a, b) = G(b, before + a) = gram[a * slots_ + fresh + b];
    }
    G_ = std::move(G);
  }
  // E_TT (A' - blkdiag(A, D) on T, sparse: an element's rows) and the capacitance I + G_TT E_TT,
  // by columns of E: t times E's nonzeros, not t^3.
  const int64_t t = static_cast<int64_t>(touched.size());
  touched_ = touched;
  std::vector<std::vector<std::pair<int64_t, double>>> e_column(t);  // E_TT's nonzeros by columns (row in T, value)
  for (const auto& [key, value] : edits_) {
    const int64_t a = std::lower_bound(touched_.begin(), touched_.end(), key.first) - touched_.begin();
    const int64_t b = std::lower_bound(touched_.begin(), touched_.end(), key.second) - touched_.begin();
    double e = value;
    if (a == b && key.first >= n_) e -= sqrt_d_[key.first - n_] * sqrt_d_[key.first - n_];
    e_column[b].push_back({a, e});
  }
  column_of_.assign(t, nullptr);
  std::vector<int64_t> slot(t, -1);  // per row of T: its slot in G_ (-1: a new vertex)
  for (int64_t a = 0; a < t; ++a)
    if (touched_[a] < n_) column_of_[a] = &column_[slot[a] = slot_.at(touched_[a])];
  if (t == 0) return Status::ok;
  Eigen::MatrixXd G(t, t);  // G_TT: W's columns of T's rows
  for (int64_t b = 0; b < t; ++b)
    for (int64_t a = 0; a < t; ++a) {
      if (slot[a] >= 0 && slot[b] >= 0) G(a, b) = G_(slot[a], slot[b]);
      else G(a, b) = a == b ? 1.0 / (sqrt_d_[touched_[a] - n_] * sqrt_d_[touched_[a] - n_]) : 0.0;
    }
  Eigen::MatrixXd C = Eigen::MatrixXd::Identity(t, t);
  for (int64_t b = 0; b < t; ++b)
    for (const auto& [c, e] : e_column[b]) C.col(b) += e * G.col(c);
  const Eigen::PartialPivLU<Eigen::MatrixXd> capacitance(C);
  // The correction's middle, K = E (I + G E)^{-1}, is applied in each solve from the LU and E's
  // columns (2 t^2 per right-hand side, as a product with K would be) rather than formed here
  // (2 t^3: the commit's largest part at t near max_touched, docs/topology-cost.md).
  const Eigen::MatrixXd& lu = capacitance.matrixLU();
  lu_.resize(t * t);
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(lu_.data(), t, t) = lu;
  const auto& indices = capacitance.permutationP().indices();
  to_.assign(indices.data(), indices.data() + t);
  e_ = CapacitanceColumns();
  for (int64_t b = 0; b < t; ++b) {
    for (const auto& [a, e] : e_column[b]) {
      e_.row.push_back(a);
      e_.value.push_back(e);
    }
    e_.start.push_back(static_cast<int64_t>(e_.row.size()));
  }
  // A' is positive definite only if det(I + W E W^T) = det(I + G E) > 0: its sign from the LU.
  double sign = capacitance.permutationP().determinant();
  for (int64_t a = 0; a < t; ++a) sign *= lu(a, a) > 0 ? 1.0 : (lu(a, a) < 0 ? -1.0 : 0.0);
  return sign > 0 ? Status::ok : Status::not_positive_definite;
}

SymmetricCsr TopologyH0::changed_matrix() const {
  SymmetricCsr B;
  B.n = size();
  auto edit = edits_.begin();
  for (int64_t i = 0; i < B.n; ++i) {
    int64_t p = i < n_ ? A_.start[i] : 0;
    const int64_t end = i < n_ ? A_.start[i + 1] : 0;
    while (p < end || (edit != edits_.end() && edit->first.first == i)) {
      const bool from_edit = edit != edits_.end() && edit->first.first == i;
      if (p < end && (!from_edit || A_.column[p] < edit->first.second)) {
        B.column.push_back(A_.column[p]);
        B.value.push_back(A_.value[p++]);
      } else if (p < end && A_.column[p] == edit->first.second) {
        B.column.push_back(A_.column[p]);
        B.value.push_back(A_.value[p++] + (edit++)->second);
      } else {
        B.column.push_back(edit->first.second);
        B.value.push_back((edit++)->second);
      }
    }
    B.start.push_back(static_cast<int64_t>(B.column.size()));
  }
  return B;
}

TopologyH0::Status TopologyH0::refactor() {
  const int refactorizations = refactorizations_ + 1;
  const int64_t columns = columns_computed_;
  const Status s = setup(changed_matrix(), max_touched_);
  refactorizations_ = refactorizations;
  columns_computed_ = columns;
  return s;
}

int64_t TopologyH0::correction_nonzeros() const {
  int64_t nnz = 0;
  for (const SupernodalCholesky::SparseColumn* col : column_of_) nnz += col ? static_cast<int64_t>(col->values.size()) : 1;
  return nnz;
}

// y -= W K W^T y (K = E (I + G E)^{-1}) on y = Lh^{-1} b: its old rows in w (the factor's order,
// `lanes` per row), its new ones in extra_. A column of W is contiguous runs, one per node of its
// path; a new vertex's is a unit column (its row of extra_ over D^{1/2}).
template <int k, int lanes>
void TopologyH0::correct(double* w, int) const {
  const Node* nodes = factor_.nodes().data();
  const int64_t t = static_cast<int64_t>(touched_.size());
  constexpr bool four = lanes == 4;
  s_.assign(static_cast<size_t>(lanes * t), 0.0);
  z_.resize(static_cast<size_t>(lanes * t));
  for (int64_t a = 0; a < t; ++a) {
    if (const SparseColumn* col = column_of_[a]) {
      four ? column_dot4(nodes, *col, w, &s_[lanes * a]) : column_dot1(nodes, *col, w, &s_[lanes * a]);
    } else {
      const int64_t j = touched_[a] - n_;
      for (int c = 0; c < k; ++c) s_[lanes * a + c] = extra_[k * j + c] / sqrt_d_[j];
    }
  }
  u_.resize(s_.size());
  four ? capacitance_solve4(lu_.data(), to_.data(), t, e_, s_.data(), u_.data(), z_.data())
       : capacitance_solve1(lu_.data(), to_.data(), t, e_, s_.data(), u_.data(), z_.data());
  for (int64_t a = 0; a < t; ++a) {
    if (const SparseColumn* col = column_of_[a]) {
      four ? column_subtract4(nodes, *col, &z_[lanes * a], w) : column_subtract1(nodes, *col, &z_[lanes * a], w);
    } else {
      const int64_t j = touched_[a] - n_;
      for (int c = 0; c < k; ++c) extra_[k * j + c] -= z_[lanes * a + c] / sqrt_d_[j];
    }
  }
}

void TopologyH0::solve(int k, const double* b, double* x) const {
  if (pending_ || pending_vertices_ > 0) throw std::logic_error("TopologyH0::solve: edits not committed");
  const int64_t p = static_cast<int64_t>(sqrt_d_.size());
  if (touched_.empty()) {
    factor_.solve(k, b, x);
    for (int64_t j = 0; j < p * k; ++j) x[k * n_ + j] = b[k * n_ + j] / (sqrt_d_[j / k] * sqrt_d_[j / k]);
    return;
  }
  // The new rows of Lh^{-1} b: b / D^{1/2}.
  extra_.resize(static_cast<size_t>(p * k));
  for (int64_t j = 0; j < p * k; ++j) extra_[j] = b[k * n_ + j] / sqrt_d_[j / k];
  if (k == 3) factor_.solve_corrected(3, b, x, [this](double* w, int lanes) { correct<3, 4>(w, lanes); });
  else if (k == 1) factor_.solve_corrected(1, b, x, [this](double* w, int lanes) { correct<1, 1>(w, lanes); });
  else throw std::invalid_argument("TopologyH0::solve: k must be 1 or 3");
  for (int64_t j = 0; j < p * k; ++j) x[k * n_ + j] = extra_[j] / sqrt_d_[j / k];
}

}  // namespace hyperqn

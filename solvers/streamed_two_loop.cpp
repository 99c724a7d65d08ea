#include "solvers/streamed_two_loop.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "materials/lanes.hpp"

#include "io/log_events.hpp"

namespace hyperqn {

namespace {

// Entries per chunk: a pass works through the unknowns chunk by chunk, so a chunk of g, s, y, q or
// d stays in the core's L1 cache while each pair's chunk is read once.
constexpr PetscInt kChunk = 512;

// The loops are vectorized (the sums' order is the same on every run on one processor).
HYPERQN_VECTOR_CLONES double dot(const double* a, const double* b, PetscInt n) {
  double sum = 0;
#pragma omp simd reduction(+ : sum)
  for (PetscInt i = 0; i < n; ++i) sum += a[i] * b[i];
  return sum;
}

// Pass 1's three products with one pair: s_j.g, y_j.s, s_j.y, added to out.
HYPERQN_VECTOR_CLONES void pair_dots(const double* sj, const double* yj, const double* g, const double* s,
                                     const double* y, PetscInt n, double* out) {
  double sg = 0, ys = 0, sy = 0;
#pragma omp simd reduction(+ : sg, ys, sy)
  for (PetscInt i = 0; i < n; ++i) {
    sg += sj[i] * g[i];
    ys += yj[i] * s[i];
    sy += sj[i] * y[i];
  }
  out[0] += sg;
  out[1] += ys;
  out[2] += sy;
}

HYPERQN_VECTOR_CLONES void axpy(double* y, double a, const double* x, PetscInt n) {
#pragma omp simd
  for (PetscInt i = 0; i < n; ++i) y[i] += a * x[i];
}

// PETSc's BFGS: a pair is kept if s.y > eps s.s (eps = machine epsilon^(2/3); 0 when s.s < eps).
const double kCurvatureEps = std::pow(DBL_EPSILON, 2.0 / 3.0);

}  // namespace

StreamedTwoLoop::~StreamedTwoLoop() {
  MatDestroy(&shell_);
  VecDestroy(&q_);
}

PetscErrorCode StreamedTwoLoop::setup(Vec layout) {
  PetscInt N;
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(layout, &n_));
  PetscCall(VecGetSize(layout, &N));
  comm_ = PetscObjectComm((PetscObject)layout);
  PetscCall(VecDuplicate(layout, &q_));
  pairs_.assign((size_t)2 * (history_ + 1) * n_, 0.0);
  x_prev_.assign(n_, 0.0);
  g_prev_.assign(n_, 0.0);
  sy_.assign((size_t)(history_ + 1) * (history_ + 1), 0.0);
  sg_.assign(history_ + 1, 0.0);
  order_.reserve(history_);
  PetscCall(MatCreateShell(comm_, n_, n_, N, N, this, &shell_));
  PetscCall(MatShellSetOperation(shell_, MATOP_SOLVE, (void (*)(void))solve));
  PetscFunctionReturn(0);
}

PetscErrorCode StreamedTwoLoop::solve(Mat shell, Vec g, Vec d) {
  StreamedTwoLoop* self;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(shell, &self));
  PetscCall(self->apply(g, d));
  PetscFunctionReturn(0);
}

PetscErrorCode StreamedTwoLoop::update(const PetscScalar* x, const PetscScalar* g) {
  PetscFunctionBeginUser;
  if (!have_prev_) {  // a TaoSolve's first iterate: no pair yet
    std::copy(x, x + n_, x_prev_.begin());
    std::copy(g, g + n_, g_prev_.begin());
    have_prev_ = true;
    PetscFunctionReturn(0);
  }
  const int k = (int)order_.size();
  double* s = s_slot(spare_);
  double* y = y_slot(spare_);
  // sums: s.y, s.s, s.g, then for each pair j (oldest first) s_j.g, y_j.s, s_j.y.
  std::vector<double> sums(3 + 3 * k, 0.0);
  for (PetscInt c = 0; c < n_; c += kChunk) {
    const PetscInt len = std::min(kChunk, n_ - c);
    for (PetscInt i = c; i < c + len; ++i) {
      s[i] = x[i] - x_prev_[i];
      y[i] = g[i] - g_prev_[i];
      x_prev_[i] = x[i];
      g_prev_[i] = g[i];
    }
    sums[0] += dot(s + c, y + c, len);
    sums[1] += dot(s + c, s + c, len);
    sums[2] += dot(s + c, g + c, len);
    for (int j = 0; j < k; ++j)
      pair_dots(s_slot(order_[j]) + c, y_slot(order_[j]) + c, g + c, s + c, y + c, len, &sums[3 + 3 * j]);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, sums.data(), (int)sums.size(), MPI_DOUBLE, MPI_SUM, comm_));
  for (int j = 0; j < k; ++j) sg_[order_[j]] = sums[3 + 3 * j];
  const double curvature_tol = sums[1] < kCurvatureEps ? 0.0 : kCurvatureEps * sums[1];
  if (!(sums[0] > curvature_tol)) {
    if (++rejects_in_a_row_ > history_ / 2) {
      order_.clear();
      rejects_in_a_row_ = 0;
    }
    PetscFunctionReturn(0);
  }
  rejects_in_a_row_ = 0;
  const int slot = spare_;
  for (int j = 0; j < k; ++j) {
    sy(order_[j], slot) = sums[5 + 3 * j];
    sy(slot, order_[j]) = sums[4 + 3 * j];
  }
  sy(slot, slot) = sums[0];
  sg_[slot] = sums[2];
  if (k == history_) {  // full: the oldest pair's slot becomes the spare
    spare_ = order_.front();
    order_.erase(order_.begin());
  } else {
    for (spare_ = 0; spare_ == slot || std::count(order_.begin(), order_.end(), spare_); ++spare_) {
    }
  }
  order_.push_back(slot);
  PetscFunctionReturn(0);
}

PetscErrorCode StreamedTwoLoop::apply(Vec g_vec, Vec d_vec) {
  PetscInt iteration;
  Vec x_vec;
  const PetscScalar *x, *g;
  PetscScalar *q, *d;
  PetscFunctionBeginUser;
  if (history_ == 0) {
    PetscCall(MatSolve(h0_, g_vec, d_vec));
    PetscFunctionReturn(0);
  }
  PetscCall(event_begin(&LogEvents::two_loop));
  // TAO clears its history at each TaoSolve's start and after a direction that is no descent one.
  PetscCall(TaoGetIterationNumber(tao_, &iteration));
  if (iteration == 0) {
    order_.clear();
    have_prev_ = false;
    rejects_in_a_row_ = 0;
  }
  if (forget_) {
    order_.clear();
    rejects_in_a_row_ = 0;
    forget_ = false;
  }
  PetscCall(TaoGetSolution(tao_, &x_vec));
  PetscCall(VecGetArrayRead(x_vec, &x));
  PetscCall(VecGetArrayRead(g_vec, &g));
  PetscCall(update(x, g));
  PetscCall(VecRestoreArrayRead(x_vec, &x));
  const int k = (int)order_.size();
  // First loop in scalars, newest pair first: alpha_i = (s_i.g - sum_{j newer} alpha_j s_i.y_j) / s_i.y_i.
  std::vector<double> alpha(k), coef(k + 1);
  for (int i = k - 1; i >= 0; --i) {
    const int a = order_[i];
    double t = sg_[a];
    for (int j = i + 1; j < k; ++j) t -= alpha[j] * sy(a, order_[j]);
    alpha[i] = t / sy(a, a);
  }
  // Pass 2: q = g - sum alpha_j y_j.
  PetscCall(VecGetArray(q_, &q));
  for (PetscInt c = 0; c < n_; c += kChunk) {
    const PetscInt len = std::min(kChunk, n_ - c);
    std::copy(g + c, g + c + len, q + c);
    for (int j = 0; j < k; ++j) axpy(q + c, -alpha[j], y_slot(order_[j]) + c, len);
  }
  PetscCall(VecRestoreArray(q_, &q));
  PetscCall(event_end(&LogEvents::two_loop));
  PetscCall(MatSolve(h0_, q_, d_vec));  // r = H0 q, in d
  PetscCall(event_begin(&LogEvents::two_loop));
  // Pass 3: y_j.r and g.r (coef[k]).
  PetscCall(VecGetArray(d_vec, &d));
  std::fill(coef.begin(), coef.end(), 0.0);
  for (PetscInt c = 0; c < n_; c += kChunk) {
    const PetscInt len = std::min(kChunk, n_ - c);
    for (int j = 0; j < k; ++j) coef[j] += dot(y_slot(order_[j]) + c, d + c, len);
    coef[k] += dot(g + c, d + c, len);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, coef.data(), k + 1, MPI_DOUBLE, MPI_SUM, comm_));
  // Second loop in scalars, oldest first: beta_i = (y_i.r + sum_{j older} c_j y_i.s_j) / s_i.y_i,
  // c_i = alpha_i - beta_i; and g.d = g.r + sum c_j s_j.g.
  double gd = coef[k];
  for (int i = 0; i < k; ++i) {
    const int a = order_[i];
    double t = coef[i];
    for (int j = 0; j < i; ++j) t += coef[j] * sy(order_[j], a);
    coef[i] = alpha[i] - t / sy(a, a);
    gd += coef[i] * sg_[a];
  }
  // Pass 4: d = r + sum c_j s_j.
  for (PetscInt c = 0; c < n_; c += kChunk) {
    const PetscInt len = std::min(kChunk, n_ - c);
    for (int j = 0; j < k; ++j) axpy(d + c, coef[j], s_slot(order_[j]) + c, len);
  }
  PetscCall(VecRestoreArray(d_vec, &d));
  PetscCall(VecRestoreArrayRead(g_vec, &g));
  // TAOLMVM takes -g instead and clears its history (PETSc's would be cleared too).
  if (!(gd > 0)) forget_ = true;
  PetscCall(event_end(&LogEvents::two_loop));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

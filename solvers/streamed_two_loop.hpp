// solver.two_loop: streamed. L-BFGS's two-loop recursion with the (s, y) pairs in one contiguous
// block, each pass reading every pair once and the dot products of a pass batched into one
// reduction (the Gram matrix S^T Y kept as in Byrd, Nocedal & Schnabel's compact form, so the
// loops' sequential dot products become scalar work). TAO (TAOLMVM) stays the driver: its own
// history is set to 0 and this operator is its H0, so its MatSolve receives g and returns H g.
//
// Per iteration with k pairs: 2 reductions (PETSc 3.18's MATLMVMBFGS: 2k + 2) and 5k + 14 vector
// reads and writes (PETSc's: 10k + 20), counting by vector length:
//   pass 1: s = x - x_prev, y = g - g_prev (and x_prev, g_prev updated); s.y, s.s, s.g and every
//           pair's s_j.g, y_j.s, s_j.y (one reduction)
//   pass 2: q = g - sum alpha_j y_j;  r = H0 q;
//   pass 3: y_j.r and g.r (one reduction);  pass 4: d = r + sum (alpha_j - beta_j) s_j.
// Keeping S^T Y costs 2k more products per iteration than PETSc's loops, so on one machine, where
// the vectors stay in cache, it is no faster (docs/performance.md#what-stops-scaling-first).
// The pairs are accepted, rejected and forgotten as PETSc's BFGS does (curvature s.y > eps s.s,
// forgotten after history/2 rejections in a row, at each TaoSolve, and when d is no descent
// direction, where TAO falls back to -g): a frame's iterates agree with PETSc's to round-off.
#pragma once
#include <petsctao.h>

#include <vector>

namespace hyperqn {

class StreamedTwoLoop {
 public:
  // h0: the initial inverse Hessian (its MatSolve applies it); history: the most pairs kept.
  StreamedTwoLoop(Tao tao, Mat h0, int history) : tao_(tao), h0_(h0), history_(history) {}
  ~StreamedTwoLoop();
  StreamedTwoLoop(const StreamedTwoLoop&) = delete;
  StreamedTwoLoop& operator=(const StreamedTwoLoop&) = delete;
  // layout: a vector of the unknowns' layout.
  PetscErrorCode setup(Vec layout);
  // The operator to give TaoLMVMSetH0 (MatSolve only).
  Mat operator_mat() const { return shell_; }

 private:
  static PetscErrorCode solve(Mat shell, Vec g, Vec d);
  PetscErrorCode apply(Vec g, Vec d);
  // Pass 1 at the current iterate x with gradient g: the new pair kept or not, sg_ updated.
  PetscErrorCode update(const PetscScalar* x, const PetscScalar* g);
  double* s_slot(int slot) { return pairs_.data() + (size_t)(2 * slot) * n_; }
  double* y_slot(int slot) { return pairs_.data() + (size_t)(2 * slot + 1) * n_; }
  double& sy(int a, int b) { return sy_[(size_t)a * (history_ + 1) + b]; }  // s_a . y_b

  Tao tao_;
  Mat h0_;
  int history_;
  Mat shell_ = nullptr;
  Vec q_ = nullptr;              // H0's right-hand side
  MPI_Comm comm_ = MPI_COMM_NULL;
  PetscInt n_ = 0;               // local length
  std::vector<double> pairs_;    // history + 1 slots of (s, y), each n_ long; one slot is spare
  std::vector<double> x_prev_, g_prev_;
  std::vector<double> sy_;       // (history + 1)^2 by slot
  std::vector<double> sg_;       // s_slot . g at the current iterate, by slot
  std::vector<int> order_;       // the pairs' slots, oldest first
  int spare_ = 0;                // the slot a new pair is formed in
  bool have_prev_ = false;
  int rejects_in_a_row_ = 0;
  bool forget_ = false;          // the last direction was no descent direction: TAO reset its history
};

}  // namespace hyperqn

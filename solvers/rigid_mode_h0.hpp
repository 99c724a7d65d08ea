// L-BFGS's initial Hessian with the stiff clusters' rigid rotations left to the soft coupling
// (solver.h0_rigid, docs/method.md#the-initial-hessian-h0):
//   A' = A - s sum_q h^2 L_q R_q (R_q^T L_q R_q)^{-1} R_q^T L_q,  s = kRemovedShare,
// A = M + h^2 L the scene's constant matrix (its inverse given as a shell: MatSolve A^{-1}, MatMult
// A), q a stiff cluster: a connected component (through shared vertices) of the tets whose weight in
// L is at least kStiffRatio times the softest tet's; L_q the Laplacian of its tets alone (their
// matrices in A, (x) I3), R_q its 3 infinitesimal rotations about its centroid at the step's start
// x_n (e_a x (x_i - c) at its vertices, 0 elsewhere). L_q annihilates translations, so only the
// rotations are corrected. The subtracted term is L_q^{1/2} P L_q^{1/2} (P an orthogonal
// projection) <= h^2 L_q, so A' >= M + h^2 (L - sum L_q) stays SPD.
// Applied by Woodbury beside A's factor (one factorization per scene): with V = h^2 L R (n x 3k,
// every cluster's columns), C = R^T V (block diagonal),
//   A'^{-1} b = A^{-1} b + W S^{-1} W^T b,  W = A^{-1} V,  S = C / s - V^T W (3k x 3k, SPD),
// W and S rebuilt at each step's start (3k solves of A), so H0 is a function of x_n: restarts
// stay bitwise with no state of its own. A solve is A's, one reduction of 3k dot products and 3k
// axpys.
// A cluster with a fixed vertex is left out (its rotations are not free). The clusters, their tets'
// matrices and their vertices' positions are gathered to every rank and summed in the order of the
// vertices' input ids, so they do not depend on the rank count.
#pragma once
#include <petscmat.h>

#include <Eigen/Dense>
#include <vector>

#include "solvers/objective.hpp"

namespace hyperqn {

class RigidModeH0 {
 public:
  // A tet is stiff if its weight in L is at least this times the softest tet's (measured in
  // docs/records/2026-12-04-rigid-h0.md).
  static constexpr double kStiffRatio = 100;
  // The share of the stiff charge on the rotations removed: 1 - 1e-3 keeps the secant curvature of
  // the straight-line stretch of a turn by about 0.06 rad a step (theta^2 / 4 of the charge), which
  // the energy has and the linear mode does not (measured: docs/records/2026-12-04-rigid-h0.md).
  static constexpr double kRemovedShare = 0.999;
  // Whether solver.h0_rigid: auto turns it on where there is a cluster.
  static constexpr bool kByDefault = true;

  // base: A^{-1} (MatSolve) and A (MatMult), e.g. FactoredSystem::inverse_operator.
  RigidModeH0(const Objective& step, Mat base) : step_(step), base_(base) {}
  ~RigidModeH0();
  RigidModeH0(const RigidModeH0&) = delete;
  RigidModeH0& operator=(const RigidModeH0&) = delete;
  // Finds the clusters (collective); none (no tet ratio of weights reaching ratio, or every cluster
  // fixed): *found false, and nothing else is set up.
  PetscErrorCode setup(bool* found, double ratio = kStiffRatio);
  // R, V, W, S from x_n (collective; at each step's start).
  PetscErrorCode update();
  // x = A'^{-1} b; y = A' x.
  PetscErrorCode solve(Vec b, Vec x) const;
  PetscErrorCode mult(Vec x, Vec y) const;
  Mat inverse_operator() const { return shell_; }
  int clusters() const { return static_cast<int>(clusters_.size()); }
  long long column_solves() const { return column_solves_; }

 private:
  struct Cluster {
    std::vector<PetscInt> dof;  // per vertex, in input id order: its global x dof
    std::vector<std::array<int, 4>> tets;  // per tet: its vertices (indices into dof)
    std::vector<std::array<double, 16>> K; // per tet: its matrix in h^2 L
  };
  // -hyperqn_test_rigid_h0_check: A'^{-1} b against a dense A' solved on random b (small scenes).
  PetscErrorCode check() const;

  const Objective& step_;
  Mat base_;
  Mat shell_ = nullptr;
  std::vector<Cluster> clusters_;
  PetscInt lo_ = 0, hi_ = 0;
  Vec* V_ = nullptr;  // 3k columns
  Vec* W_ = nullptr;  // A^{-1} V
  Vec work_ = nullptr;
  std::vector<Eigen::Matrix3d> C_;      // per cluster: R^T h^2 L R
  Eigen::LLT<Eigen::MatrixXd> S_;
  double share_ = kRemovedShare;  // -hyperqn_rigid_h0_share
  bool active_ = false;   // updated at least once
  bool checked_ = false;
  long long column_solves_ = 0;
};

}  // namespace hyperqn

#include "solvers/rigid_mode_h0.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include "parallel/collectives.hpp"

namespace hyperqn {

static PetscErrorCode shell_solve(Mat S, Vec b, Vec x) {
  RigidModeH0* h;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &h));
  PetscCall(h->solve(b, x));
  PetscFunctionReturn(0);
}

static PetscErrorCode shell_mult(Mat S, Vec x, Vec y) {
  RigidModeH0* h;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &h));
  PetscCall(h->mult(x, y));
  PetscFunctionReturn(0);
}

RigidModeH0::~RigidModeH0() {
  const PetscInt columns = 3 * clusters();
  if (V_) VecDestroyVecs(columns, &V_);
  if (W_) VecDestroyVecs(columns, &W_);
  VecDestroy(&work_);
  MatDestroy(&shell_);
}

namespace {
// Union-find over vertex indices.
int root_of(std::vector<int>& parent, int v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}
}  // namespace

PetscErrorCode RigidModeH0::setup(bool* found, double ratio) {
  const MPI_Comm comm = PetscObjectComm((PetscObject)step_.layout());
  PetscFunctionBeginUser;
  *found = false;
  double softest_here = PETSC_MAX_REAL, stiffest_here = 0;
  step_.tet_weight_range(softest_here, stiffest_here);
  double range[2] = {softest_here, -stiffest_here};  // the softest weight, minus the stiffest
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, range, 2, MPI_DOUBLE, MPI_MIN, comm));
  const double softest = range[0], stiffest = -range[1];
  // A relative slack of 1e-9: weights from E and nu are exact ratios only up to round-off.
  const double threshold = ratio * softest * (1 - 1e-9);
  if (!(softest > 0) || !(stiffest >= threshold)) PetscFunctionReturn(0);
  std::vector<TetLaplacian> local;  // the stiff tets
  step_.tet_laplacians(local, threshold);

  // The stiff tets of every rank: 4 ids, 4 dofs, 16 entries each.
  constexpr int kWidth = 24;
  std::vector<double> mine;
  for (const TetLaplacian& t : local) {
    for (int j = 0; j < 4; ++j) mine.push_back(static_cast<double>(t.vertex[j]));
    for (int j = 0; j < 4; ++j) mine.push_back(static_cast<double>(t.dof[j]));
    mine.insert(mine.end(), t.K.begin(), t.K.end());
  }
  const std::vector<double> all = all_gathered(comm, mine, MPI_DOUBLE);
  const size_t tets = all.size() / kWidth;
  // In the order of their vertices' ids: the same at every rank count.
  std::vector<size_t> order(tets);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::lexicographical_compare(&all[kWidth * a], &all[kWidth * a + 4], &all[kWidth * b], &all[kWidth * b + 4]);
  });
  std::map<int64_t, int> index;  // vertex id -> its index, in id order
  for (size_t e = 0; e < tets; ++e)
    for (int j = 0; j < 4; ++j) index.emplace(static_cast<int64_t>(all[kWidth * e + j]), 0);
  std::vector<PetscInt> dof(index.size());
  {
    int i = 0;
    for (auto& [id, at] : index) at = i++;
  }
  std::vector<int> parent(index.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (size_t e = 0; e < tets; ++e) {
    int v[4];
    for (int j = 0; j < 4; ++j) {
      v[j] = index.at(static_cast<int64_t>(all[kWidth * e + j]));
      dof[v[j]] = static_cast<PetscInt>(all[kWidth * e + 4 + j]);
    }
    for (int j = 1; j < 4; ++j) parent[root_of(parent, v[j])] = root_of(parent, v[0]);
  }
  // Clusters in the order of their smallest vertex id; vertices and tets in id order.
  std::vector<int> cluster_of_root(index.size(), -1), at(index.size());
  std::vector<Cluster> found_clusters;
  for (size_t v = 0; v < index.size(); ++v) {
    int& c = cluster_of_root[root_of(parent, (int)v)];
    if (c < 0) {
      c = (int)found_clusters.size();
      found_clusters.emplace_back();
    }
    at[v] = (int)found_clusters[c].dof.size();
    found_clusters[c].dof.push_back(dof[v]);
  }
  for (size_t e : order) {
    std::array<int, 4> t;
    for (int j = 0; j < 4; ++j) t[j] = index.at(static_cast<int64_t>(all[kWidth * e + j]));
    Cluster& c = found_clusters[cluster_of_root[root_of(parent, t[0])]];
    for (int& v : t) v = at[v];
    c.tets.push_back(t);
    std::array<double, 16> K;
    std::copy(&all[kWidth * e + 8], &all[kWidth * e + kWidth], K.begin());
    c.K.push_back(K);
  }
  for (Cluster& c : found_clusters)  // a fixed vertex: its rotations are not free
    if (std::none_of(c.dof.begin(), c.dof.end(), [](PetscInt d) { return d < 0; })) clusters_.push_back(std::move(c));
  if (clusters_.empty()) PetscFunctionReturn(0);
  *found = true;
  PetscCall(PetscOptionsGetReal(nullptr, nullptr, "-hyperqn_rigid_h0_share", &share_, nullptr));
  PetscCheck(share_ > 0 && share_ <= 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-hyperqn_rigid_h0_share must be in (0, 1]");

  PetscInt n, N;
  PetscCall(VecGetOwnershipRange(step_.layout(), &lo_, &hi_));
  PetscCall(VecGetLocalSize(step_.layout(), &n));
  PetscCall(VecGetSize(step_.layout(), &N));
  PetscCall(VecDuplicateVecs(step_.layout(), 3 * clusters(), &V_));
  PetscCall(VecDuplicateVecs(step_.layout(), 3 * clusters(), &W_));
  PetscCall(VecDuplicate(step_.layout(), &work_));
  PetscCall(MatCreateShell(comm, n, n, N, N, this, &shell_));
  PetscCall(MatShellSetOperation(shell_, MATOP_SOLVE, (void (*)(void))shell_solve));
  PetscCall(MatShellSetOperation(shell_, MATOP_MULT, (void (*)(void))shell_mult));
  PetscFunctionReturn(0);
}

PetscErrorCode RigidModeH0::update() {
  const MPI_Comm comm = PetscObjectComm((PetscObject)step_.layout());
  const int columns = 3 * clusters();
  PetscFunctionBeginUser;
  if (!shell_) PetscFunctionReturn(0);
  Vec x_n = step_.step_start();
  PetscCheck(x_n, comm, PETSC_ERR_PLIB, "solver.h0_rigid needs the step's start");
  // Every cluster vertex's position at x_n on every rank: (its index over all clusters, x, y, z).
  std::vector<double> mine;
  const PetscScalar* x;
  PetscCall(VecGetArrayRead(x_n, &x));
  int offset = 0;
  for (const Cluster& c : clusters_) {
    for (size_t i = 0; i < c.dof.size(); ++i)
      if (c.dof[i] >= lo_ && c.dof[i] < hi_)
        mine.insert(mine.end(), {double(offset + (int)i), x[c.dof[i] - lo_], x[c.dof[i] - lo_ + 1], x[c.dof[i] - lo_ + 2]});
    offset += (int)c.dof.size();
  }
  PetscCall(VecRestoreArrayRead(x_n, &x));
  const std::vector<double> all = all_gathered(comm, mine, MPI_DOUBLE);
  std::vector<Eigen::Vector3d> position(offset);
  for (size_t a = 0; a + 3 < all.size(); a += 4) position[(size_t)all[a]] = Eigen::Vector3d(all[a + 1], all[a + 2], all[a + 3]);

  C_.assign(clusters(), Eigen::Matrix3d::Zero());
  offset = 0;
  for (int q = 0; q < clusters(); ++q) {
    const Cluster& c = clusters_[q];
    const size_t nv = c.dof.size();
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < nv; ++i) centroid += position[offset + i];
    centroid /= double(nv);
    std::vector<Eigen::Matrix3d> R(nv), V(nv, Eigen::Matrix3d::Zero());  // per vertex: column a of R and of h^2 L R
    for (size_t i = 0; i < nv; ++i)
      for (int a = 0; a < 3; ++a) R[i].col(a) = Eigen::Vector3d::Unit(a).cross(position[offset + i] - centroid);
    for (size_t e = 0; e < c.tets.size(); ++e)
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) V[c.tets[e][i]] += c.K[e][4 * i + j] * R[c.tets[e][j]];
    for (size_t i = 0; i < nv; ++i) C_[q] += R[i].transpose() * V[i];
    C_[q] = 0.5 * (C_[q] + C_[q].transpose()).eval();
    for (int a = 0; a < 3; ++a) {
      PetscScalar* v;
      PetscCall(VecSet(V_[3 * q + a], 0.0));
      PetscCall(VecGetArray(V_[3 * q + a], &v));
      for (size_t i = 0; i < nv; ++i)
        if (c.dof[i] >= lo_ && c.dof[i] < hi_)
          for (int d = 0; d < 3; ++d) v[c.dof[i] - lo_ + d] = V[i](d, a);
      PetscCall(VecRestoreArray(V_[3 * q + a], &v));
    }
    offset += (int)nv;
  }
  for (int j = 0; j < columns; ++j) PetscCall(MatSolve(base_, V_[j], W_[j]));
  column_solves_ += columns;
  // S = C - V^T W, one reduction per row.
  Eigen::MatrixXd S(columns, columns);
  std::vector<PetscScalar> row(columns);
  for (int j = 0; j < columns; ++j) {
    PetscCall(VecMDot(V_[j], columns, W_, row.data()));
    for (int k = 0; k < columns; ++k) S(j, k) = -row[k];
  }
  for (int q = 0; q < clusters(); ++q) S.block<3, 3>(3 * q, 3 * q) += C_[q] / share_;
  S = 0.5 * (S + S.transpose()).eval();
  S_.compute(S);
  PetscCheck(S_.info() == Eigen::Success, comm, PETSC_ERR_NOT_CONVERGED,
             "solver.h0_rigid: the rigid-mode correction's %d x %d system is not positive definite", columns, columns);
  active_ = true;
  if (!checked_) {
    PetscBool flag = PETSC_FALSE;
    PetscCall(PetscOptionsGetBool(nullptr, nullptr, "-hyperqn_test_rigid_h0_check", &flag, nullptr));
    checked_ = true;
    if (flag) PetscCall(check());
  }
  PetscFunctionReturn(0);
}

PetscErrorCode RigidModeH0::solve(Vec b, Vec x) const {
  const int columns = 3 * clusters();
  PetscFunctionBeginUser;
  PetscCall(MatSolve(base_, b, x));
  if (!active_) PetscFunctionReturn(0);
  Eigen::VectorXd t(columns);
  PetscCall(VecMDot(b, columns, W_, t.data()));  // W^T b: one reduction
  const Eigen::VectorXd s = S_.solve(t);
  PetscCall(VecMAXPY(x, columns, s.data(), W_));
  PetscFunctionReturn(0);
}

PetscErrorCode RigidModeH0::mult(Vec x, Vec y) const {
  const int columns = 3 * clusters();
  PetscFunctionBeginUser;
  PetscCall(MatMult(base_, x, y));
  if (!active_) PetscFunctionReturn(0);
  Eigen::VectorXd t(columns), s(columns);
  PetscCall(VecMDot(x, columns, V_, t.data()));
  for (int q = 0; q < clusters(); ++q) s.segment<3>(3 * q) = -share_ * C_[q].ldlt().solve(t.segment<3>(3 * q));
  PetscCall(VecMAXPY(y, columns, s.data(), V_));
  PetscFunctionReturn(0);
}

// A column by column (MatMult of unit vectors), gathered to every rank with V; A' = A - V C^{-1} V^T
// dense, solved by Cholesky on random b; printed: the largest relative difference of solve's and of
// A^{-1} b alone from it over 3 vectors.
PetscErrorCode RigidModeH0::check() const {
  const MPI_Comm comm = PetscObjectComm((PetscObject)step_.layout());
  const int columns = 3 * clusters();
  PetscInt N;
  VecScatter to_all;
  Vec all, e = work_;
  PetscFunctionBeginUser;
  PetscCall(VecGetSize(e, &N));
  PetscCall(VecScatterCreateToAll(e, &to_all, &all));
  auto gathered = [&](Vec v, double* out) -> PetscErrorCode {
    const PetscScalar* a;
    PetscFunctionBeginUser;
    PetscCall(VecScatterBegin(to_all, v, all, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(to_all, v, all, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecGetArrayRead(all, &a));
    std::copy(a, a + N, out);
    PetscCall(VecRestoreArrayRead(all, &a));
    PetscFunctionReturn(0);
  };
  Vec Ae, b, x;
  PetscCall(VecDuplicate(e, &Ae));
  PetscCall(VecDuplicate(e, &b));
  PetscCall(VecDuplicate(e, &x));
  Eigen::MatrixXd A(N, N), V(N, columns);
  for (PetscInt j = 0; j < N; ++j) {
    PetscCall(VecSet(e, 0.0));
    if (j >= lo_ && j < hi_) PetscCall(VecSetValue(e, j, 1.0, INSERT_VALUES));
    PetscCall(VecAssemblyBegin(e));
    PetscCall(VecAssemblyEnd(e));
    PetscCall(MatMult(base_, e, Ae));
    PetscCall(gathered(Ae, A.col(j).data()));
  }
  for (int j = 0; j < columns; ++j) PetscCall(gathered(V_[j], V.col(j).data()));
  Eigen::MatrixXd Cinv = Eigen::MatrixXd::Zero(columns, columns);
  for (int q = 0; q < clusters(); ++q) Cinv.block<3, 3>(3 * q, 3 * q) = share_ * C_[q].inverse();
  const Eigen::MatrixXd Ap = A - V * Cinv * V.transpose();
  const Eigen::LLT<Eigen::MatrixXd> dense(0.5 * (Ap + Ap.transpose()));
  PetscCheck(dense.info() == Eigen::Success, comm, PETSC_ERR_PLIB, "rigid-mode H0 check: the dense A' is not positive definite");
  std::mt19937_64 random(44);
  std::uniform_real_distribution<double> uniform(-1, 1);
  double corrected = 0, uncorrected = 0;
  Eigen::VectorXd bb(N), xx(N);
  for (int trial = 0; trial < 3; ++trial) {
    for (PetscInt i = 0; i < N; ++i) bb(i) = uniform(random);
    PetscScalar* a;
    PetscCall(VecGetArray(b, &a));
    for (PetscInt i = lo_; i < hi_; ++i) a[i - lo_] = bb(i);
    PetscCall(VecRestoreArray(b, &a));
    const Eigen::VectorXd reference = dense.solve(bb);
    PetscCall(solve(b, x));
    PetscCall(gathered(x, xx.data()));
    corrected = std::max(corrected, (xx - reference).norm() / reference.norm());
    PetscCall(MatSolve(base_, b, x));
    PetscCall(gathered(x, xx.data()));
    uncorrected = std::max(uncorrected, (xx - reference).norm() / reference.norm());
  }
  PetscCall(PetscPrintf(comm, "rigid-mode H0 check: %d clusters, %" PetscInt_FMT " dofs, corrected %.3e, uncorrected %.3e\n",
                        clusters(), N, corrected, uncorrected));
  PetscCall(VecDestroy(&Ae));
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&all));
  PetscCall(VecScatterDestroy(&to_all));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "solvers/contact_h0.hpp"

#include <cmath>
#include <cstring>

#include "parallel/collectives.hpp"

namespace hyperqn {

static PetscErrorCode shell_solve(Mat S, Vec b, Vec x) {
  ContactH0* h;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &h));
  PetscCall(h->solve(b, x));
  PetscFunctionReturn(0);
}

static PetscErrorCode shell_mult(Mat S, Vec x, Vec y) {
  ContactH0* h;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(S, &h));
  PetscCall(h->mult(x, y));
  PetscFunctionReturn(0);
}

ContactH0::ContactH0(const Objective& step, const FactoredSystem& h0, H0Contact mode)
    : step_(step), h0_(h0), mode_(mode) {}

ContactH0::~ContactH0() {
  MatDestroy(&shell_);
  VecDestroy(&b_);
  VecDestroy(&x_);
}

PetscErrorCode ContactH0::setup() {
  PetscInt N;
  PetscFunctionBeginUser;
  PetscCall(MatCreateVecs(h0_.inverse_operator(), &b_, nullptr));
  PetscCall(VecDuplicate(b_, &x_));
  PetscCall(VecGetOwnershipRange(b_, &lo_, nullptr));
  PetscCall(VecGetLocalSize(b_, &local_));
  PetscCall(VecGetSize(b_, &N));
  PetscCall(MatCreateShell(PetscObjectComm((PetscObject)b_), local_, local_, N, N, this, &shell_));
  PetscCall(MatShellSetOperation(shell_, MATOP_SOLVE, (void (*)(void))shell_solve));
  PetscCall(MatShellSetOperation(shell_, MATOP_MULT, (void (*)(void))shell_mult));
  if (mode_ == H0Contact::refactor) {
    const PetscScalar* a;
    PetscCall(h0_.diagonal(x_));
    PetscCall(VecGetArrayRead(x_, &a));
    a_diagonal_.assign(a, a + local_);
    PetscCall(VecRestoreArrayRead(x_, &a));
  }
  PetscFunctionReturn(0);
}

// Every rank's blocks, in rank order: by global dof, as each rank's are.
PetscErrorCode ContactH0::gather(const std::vector<VertexStiffness>& local) {
  constexpr int kWidth = 10;  // dof, then K
  PetscFunctionBeginUser;
  std::vector<double> mine;
  for (const VertexStiffness& s : local) {
    mine.push_back(static_cast<double>(s.dof));
    mine.insert(mine.end(), s.K.begin(), s.K.end());
  }
  const std::vector<double> all = all_gathered(PetscObjectComm((PetscObject)b_), mine, MPI_DOUBLE);
  blocks_.resize(all.size() / kWidth);
  for (size_t a = 0; a < blocks_.size(); ++a) {
    blocks_[a].dof = static_cast<PetscInt>(all[kWidth * a]);
    std::memcpy(blocks_[a].K.data(), &all[kWidth * a + 1], 9 * sizeof(double));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ContactH0::update(Vec at) {
  std::vector<VertexStiffness> local;
  PetscFunctionBeginUser;
  PetscCall(step_.vertex_stiffness(local, at));
  if (mode_ == H0Contact::refactor) {  // each rank its own vertices' diagonal: nothing gathered
    PetscCall(update_refactor(local));
    PetscFunctionReturn(0);
  }
  std::vector<PetscInt> before;
  for (const VertexStiffness& s : blocks_) before.push_back(s.dof);
  PetscCall(gather(local));
  bool same = before.size() == blocks_.size();
  for (size_t a = 0; same && a < blocks_.size(); ++a) same = before[a] == blocks_[a].dof;
  active_ = !blocks_.empty();
  vertices_ = static_cast<PetscInt>(blocks_.size());
  PetscCall(update_woodbury(same));
  PetscFunctionReturn(0);
}

// Z_ = A1^{-1} e_v for every vertex v in contact, three per solve of A (x, y, z), and G_ its rows
// of those vertices.
PetscErrorCode ContactH0::compute_columns() {
  const PetscInt k = vertices(), rows = local_ / 3;
  PetscFunctionBeginUser;
  Z_.resize(rows, k);
  for (PetscInt first = 0; first < k; first += 3) {
    PetscScalar* b;
    const PetscScalar* x;
    PetscCall(VecSet(b_, 0.0));
    PetscCall(VecGetArray(b_, &b));
    for (PetscInt c = 0; c < 3 && first + c < k; ++c) {
      const PetscInt dof = blocks_[first + c].dof;
      if (dof >= lo_ && dof < lo_ + local_) b[dof - lo_ + c] = 1;
    }
    PetscCall(VecRestoreArray(b_, &b));
    PetscCall(h0_.solve(b_, x_));
    ++column_solves_;
    PetscCall(VecGetArrayRead(x_, &x));
    for (PetscInt c = 0; c < 3 && first + c < k; ++c)
      for (PetscInt i = 0; i < rows; ++i) Z_(i, first + c) = x[3 * i + c];
    PetscCall(VecRestoreArrayRead(x_, &x));
  }
  G_ = Eigen::MatrixXd::Zero(k, k);
  for (PetscInt a = 0; a < k; ++a) {
    const PetscInt dof = blocks_[a].dof;
    if (dof >= lo_ && dof < lo_ + local_) G_.row(a) = Z_.row((dof - lo_) / 3);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, G_.data(), (int)(k * k), MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)b_)));
  G_ = 0.5 * (G_ + G_.transpose());  // A1^{-1}'s symmetry, which round-off loses
  PetscFunctionReturn(0);
}

PetscErrorCode ContactH0::update_woodbury(bool same_vertices) {
  PetscFunctionBeginUser;
  if (!same_vertices && active_) PetscCall(compute_columns());
  // U C U^T: the eigenpairs of each block with c > 0 (a zero block, at the edge of the activation
  // layer, gives none).
  column_vertex_.clear();
  column_direction_.clear();
  std::vector<double> scale;
  for (size_t a = 0; a < blocks_.size(); ++a) {
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> K(blocks_[a].K.data());
    const Eigen::Matrix3d block = K;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(block);
    const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
    for (int j = 0; j < 3; ++j) {
      const double c = eig.eigenvalues()(j);
      if (!(c > 1e-12 * largest)) continue;
      column_vertex_.push_back(static_cast<int>(a));
      column_direction_.push_back(eig.eigenvectors().col(j));
      scale.push_back(std::sqrt(c));
    }
  }
  const int r = static_cast<int>(scale.size());
  active_ = r > 0;
  column_scale_ = Eigen::Map<Eigen::VectorXd>(scale.data(), r);
  Eigen::MatrixXd S(r, r);
  for (int c = 0; c < r; ++c)
    for (int d = 0; d <= c; ++d)
      S(c, d) = S(d, c) = column_scale_(c) * column_scale_(d) * G_(column_vertex_[c], column_vertex_[d]) *
                          column_direction_[c].dot(column_direction_[d]);
  S += Eigen::MatrixXd::Identity(r, r);
  S_.compute(S);
  PetscFunctionReturn(0);
}

double rounded_mean_stiffness(const VertexStiffness& s) {
  const double mean = (s.K[0] + s.K[4] + s.K[8]) / 3;
  if (!(mean > 0)) return 0;
  int e;
  const double m = std::frexp(mean, &e);  // mean = m 2^e, m in [0.5, 1)
  return std::ldexp(1.0, m >= M_SQRT1_2 ? e : e - 1);
}

// The diagonal is rounded so that H0 is a function of x_n alone: the factor is kept while no
// vertex's rounded value changes (keeping it gives the matrix a new factorization would), so a
// restart and the uninterrupted run factor the same matrices, and round-off in x_n (another rank
// count) changes H0 only where a value sits at a rounding boundary. The rounding's error, up to
// a factor of sqrt 2 in a vertex's stiffness, is what an approximate H0 tolerates.
// A vertex whose rounded value is below kNegligibleStiffness of A's diagonal entry is left out: it
// would change H0 there by a few percent, and such vertices, entering and leaving the activation
// layer, caused many refactorizations (the bunny's deck: 52 -> 38, 16.08 -> 15.77 it/frame). At 1/16
// the bunny took 20 but the 41 x 41 cloth pile 38 % more iterations (docs/contact.md#what-l-bfgs-does-with-contact).
PetscErrorCode ContactH0::update_refactor(const std::vector<VertexStiffness>& local) {
  std::vector<std::pair<PetscInt, double>> diagonal;  // (dof, rounded stiffness) of this rank's vertices
  PetscFunctionBeginUser;
  for (const VertexStiffness& s : local)
    if (const double k = rounded_mean_stiffness(s); k > 0 && k >= kNegligibleStiffness * a_diagonal_[s.dof - lo_])
      diagonal.emplace_back(s.dof, k);
  // Over the ranks: whether any rank's diagonal changed, the vertices with a block, those with a
  // positive diagonal.
  long counts[3] = {diagonal != factored_diagonal_, (long)local.size(), (long)diagonal.size()};
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPI_LONG, MPI_SUM, PetscObjectComm((PetscObject)b_)));
  vertices_ = static_cast<PetscInt>(counts[1]);
  if (counts[0] == 0) PetscFunctionReturn(0);
  factored_diagonal_ = diagonal;
  if (counts[2] == 0) {
    refactored_.reset();
    PetscFunctionReturn(0);
  }
  PetscScalar* d;
  PetscCall(VecSet(b_, 0.0));
  PetscCall(VecGetArray(b_, &d));
  for (const auto& [dof, k] : diagonal) {
    PetscCheck(dof >= lo_ && dof < lo_ + local_, PETSC_COMM_SELF, PETSC_ERR_PLIB, "a stiffness block of another rank's dof %" PetscInt_FMT, dof);
    for (int c = 0; c < 3; ++c) d[dof - lo_ + c] = k;
  }
  PetscCall(VecRestoreArray(b_, &d));
  refactored_ = std::make_unique<FactoredSystem>();
  PetscCall(refactored_->setup(h0_, b_, &analysis_));
  ++refactorizations_;
  PetscFunctionReturn(0);
}

PetscErrorCode ContactH0::solve(Vec b, Vec x) const {
  PetscFunctionBeginUser;
  if (refactored_) {
    PetscCall(refactored_->solve(b, x));
    PetscFunctionReturn(0);
  }
  PetscCall(h0_.solve(b, x));
  if (mode_ != H0Contact::woodbury || !active_) PetscFunctionReturn(0);
  // x -= W S^{-1} W^T b, W^T b = C^{1/2} U^T x
  const int r = static_cast<int>(column_scale_.size());
  Eigen::VectorXd t = Eigen::VectorXd::Zero(r);
  PetscScalar* a;
  PetscCall(VecGetArray(x, &a));
  for (int c = 0; c < r; ++c) {
    const PetscInt dof = blocks_[column_vertex_[c]].dof;
    if (dof >= lo_ && dof < lo_ + local_) t(c) = column_scale_(c) * column_direction_[c].dot(Eigen::Vector3d(&a[dof - lo_]));
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, t.data(), r, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)b_)));
  const Eigen::VectorXd s = column_scale_.cwiseProduct(S_.solve(t));
  Eigen::MatrixX3d u = Eigen::MatrixX3d::Zero(vertices(), 3);  // per vertex in contact: U's rows times s
  for (int c = 0; c < r; ++c) u.row(column_vertex_[c]) += s(c) * column_direction_[c].transpose();
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> X(a, local_ / 3, 3);
  X.noalias() -= Z_ * u;
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode ContactH0::mult(Vec x, Vec y) const {
  PetscFunctionBeginUser;
  if (refactored_) {
    PetscCall(refactored_->mult(x, y));
    PetscFunctionReturn(0);
  }
  PetscCall(h0_.mult(x, y));
  if (!active_) PetscFunctionReturn(0);
  const PetscScalar* in;
  PetscScalar* out;
  PetscCall(VecGetArrayRead(x, &in));
  PetscCall(VecGetArray(y, &out));
  for (const VertexStiffness& s : blocks_) {
    if (s.dof < lo_ || s.dof >= lo_ + local_) continue;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> K(s.K.data());
    Eigen::Map<Eigen::Vector3d>(&out[s.dof - lo_]) += K * Eigen::Vector3d(&in[s.dof - lo_]);
  }
  PetscCall(VecRestoreArray(y, &out));
  PetscCall(VecRestoreArrayRead(x, &in));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "terms/spring_set.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "materials/lanes.hpp"  // kBatch, HYPERQN_VECTOR_CLONES
#include "materials/spring.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

void SpringSet::add(PetscInt a, PetscInt b, double rest_length, double stiffness, int64_t id) {
  for (auto* v : {&a_, &b_, &dof_a_, &dof_b_}) v->resize(count_);  // drop the padding
  rest_.resize(count_);
  k_.resize(count_);
  ids_.resize(count_);
  ids_.push_back(id);
  a_.push_back(a);
  b_.push_back(b);
  dof_a_.push_back(mesh_.local_dof[a]);
  dof_b_.push_back(mesh_.local_dof[b]);
  rest_.push_back(rest_length);
  k_.push_back(stiffness);
  ++count_;
  const size_t padded = (count_ + kBatch - 1) / kBatch * kBatch;
  a_.resize(padded, 0);
  b_.resize(padded, 0);
  dof_a_.resize(padded, -1);
  dof_b_.resize(padded, -1);
  rest_.resize(padded, 1.0);
  k_.resize(padded, 0.0);
}

void SpringSet::arrange() {
  std::vector<uint64_t> colours_at(static_cast<size_t>(mesh_.num_vertices), 0);  // bit c: colour c used there
  std::vector<int> colour(count_);
  std::vector<size_t> order(count_);
  for (size_t first = 0; first < count_; first += kArrangeRun) {
    const size_t end = std::min(count_, first + kArrangeRun);
    for (size_t s = first; s < end; ++s) {
      const uint64_t used = colours_at[a_[s]] | colours_at[b_[s]];
      int c = 0;
      while (c < 63 && (used >> c & 1)) ++c;  // past 63 colours (never on a mesh) they share the last
      colour[s] = c;
      colours_at[a_[s]] |= uint64_t(1) << c;
      colours_at[b_[s]] |= uint64_t(1) << c;
    }
    for (size_t s = first; s < end; ++s) {
      colours_at[a_[s]] = colours_at[b_[s]] = 0;
      order[s] = s;
    }
    std::stable_sort(order.begin() + first, order.begin() + end,
                     [&](size_t p, size_t q) { return colour[p] < colour[q]; });
  }
  auto permute = [&](auto& v) {
    const auto old = v;
    for (size_t s = 0; s < count_; ++s) v[s] = old[order[s]];
  };
  permute(a_);
  permute(b_);
  permute(dof_a_);
  permute(dof_b_);
  permute(rest_);
  permute(k_);
  permute(ids_);
}

namespace {

// Energy of the springs [0, count) (count a multiple of kBatch); dE/dx added into gradient at
// the ends' dofs (dof_a, dof_b; -1: none) unless gradient is null. Each batch: read the edge
// vectors u, then one loop over the batch for lengths, energies and force factors (vectorized),
// then add the forces.
HYPERQN_VECTOR_CLONES double spring_batches(size_t count, const PetscInt* a, const PetscInt* b, const PetscInt* dof_a,
                                            const PetscInt* dof_b, const double* rest, const double* stiffness,
                                            const double* pos, PetscScalar* gradient) {
  double energy[kBatch] = {};
  for (size_t s = 0; s < count; s += kBatch) {
    double u[3][kBatch], c[kBatch];
    for (int l = 0; l < kBatch; ++l)
      for (int d = 0; d < 3; ++d) u[d][l] = pos[3 * b[s + l] + d] - pos[3 * a[s + l] + d];
    const double* L = rest + s;
    const double* k = stiffness + s;
#pragma omp simd
    for (int l = 0; l < kBatch; ++l) {
      // As spring::length, energy and gradient: dE/du = c u.
      const double length = std::max(std::sqrt(u[0][l] * u[0][l] + u[1][l] * u[1][l] + u[2][l] * u[2][l]),
                                     spring::kTinyLength * L[l]);
      const double stretch = length - L[l];
      energy[l] += 0.5 * k[l] * stretch * stretch;
      c[l] = k[l] * stretch / length;
    }
    if (!gradient) continue;
    for (int l = 0; l < kBatch; ++l) {
      const PetscInt da = dof_a[s + l], db = dof_b[s + l];
      if (da >= 0)
        for (int d = 0; d < 3; ++d) gradient[da + d] -= c[l] * u[d][l];
      if (db >= 0)
        for (int d = 0; d < 3; ++d) gradient[db + d] += c[l] * u[d][l];
    }
  }
  double e = 0;
  for (int l = 0; l < kBatch; ++l) e += energy[l];
  return e;
}

}  // namespace

void SpringSet::set_yield(const SpringYield& yield, const std::string& state) {
  yield_ = yield;
  state_.emplace(state, yielding_spring::kValues, std::vector<int64_t>(ids_.begin(), ids_.begin() + count_));
}

// W = k L^2 w(eps), eps = l/L - 1: dW/dl = k L w', d2W/dl2 = k w''.
yielding_spring::Flow SpringSet::flow(size_t s, double length) const {
  return yielding_spring::flow(length / rest_[s] - 1, state_->start(s), yield_);
}

double SpringSet::tension(size_t s, const double* pos) const {
  const PetscInt ab[2] = {a_[s], b_[s]};
  const Vec3 u = segment_edge(pos, ab);
  if (!state_) return spring::tension(u, rest_[s], k_[s]);
  return k_[s] * rest_[s] * flow(s, spring::length(u, rest_[s])).slope;
}

void SpringSet::update_state(const double* pos) {
  for (size_t s = 0; s < count_; ++s) {
    const PetscInt ab[2] = {a_[s], b_[s]};
    const double L = rest_[s];
    yielding_spring::update(spring::length(segment_edge(pos, ab), L) / L - 1, state_->start(s), yield_,
                            k_[s] * L * L, state_->current(s));
  }
}

double SpringSet::dissipated_energy() const {
  double e = 0;
  for (size_t s = 0; state_ && s < count_; ++s) e += state_->current(s)[2];
  return e;
}

PetscErrorCode SpringSet::add_hessian(const double* pos, Mat H, double scale, bool psd, bool elastic) const {
  Eigen::Matrix<double, 6, 6> Ks;  // d2E/dx2 for x = (x_a, x_b): [K -K; -K K]
  PetscFunctionBeginUser;
  for (size_t s = 0; s < count_; ++s) {
    const PetscInt ab[2] = {a_[s], b_[s]};
    Mat3 K;
    if (state_ && !elastic) {  // as spring::stiffness, with dW/dl and d2W/dl2 of the return map
      const Vec3 u = segment_edge(pos, ab);
      const double l = spring::length(u, rest_[s]);
      const yielding_spring::Flow f = flow(s, l);
      const Vec3 n = u / l;
      double transverse = k_[s] * rest_[s] * f.slope / l;
      if (psd) transverse = std::max(transverse, 0.0);
      K = k_[s] * f.curvature * n * n.transpose() + transverse * (Mat3::Identity() - n * n.transpose());
    } else {
      K = spring::stiffness(segment_edge(pos, ab), rest_[s], k_[s], psd);
    }
    Ks << K, -K, -K, K;
    PetscCall(add_element_hessian<2>(mesh_, H, ab, Ks, scale));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode SpringSet::add_laplacian(Mat A, double scale, int components) const {
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> Le;
  PetscFunctionBeginUser;
  for (size_t s = 0; s < count_; ++s) {
    const PetscInt ab[2] = {a_[s], b_[s]};
    const double w = scale * k_[s];
    Le << w, -w, -w, w;
    PetscCall(add_element_laplacian<2>(mesh_, A, ab, Le, components));
  }
  PetscFunctionReturn(0);
}

void SpringSet::add_energy(const double* pos, double* energy, PetscScalar* gradient) const {
  if (state_) {  // spring by spring through the return map
    double e = 0;
    for (size_t s = 0; s < count_; ++s) {
      const PetscInt ab[2] = {a_[s], b_[s]};
      const Vec3 u = segment_edge(pos, ab);
      const double L = rest_[s], l = spring::length(u, L);
      const yielding_spring::Flow f = flow(s, l);
      e += k_[s] * L * L * f.w;
      if (!gradient) continue;
      const Vec3 g = (k_[s] * L * f.slope / l) * u;  // dE/du
      if (dof_a_[s] >= 0)
        for (int d = 0; d < 3; ++d) gradient[dof_a_[s] + d] -= g[d];
      if (dof_b_[s] >= 0)
        for (int d = 0; d < 3; ++d) gradient[dof_b_[s] + d] += g[d];
    }
    *energy += e;
    return;
  }
  *energy += spring_batches(a_.size(), a_.data(), b_.data(), dof_a_.data(), dof_b_.data(), rest_.data(), k_.data(),
                            pos, gradient);
}

// Per spring, with d the edge at start, z and end and W = dE/dx(z) . (end - start) = k (l_z - L)
// d_z . (d_e - d_n) / l_z the work of its forces at z over the step: E(end) - E(start) - W, which is
// 0 for a spring that only stretches (E is then quadratic along the step) and k L (l_e - l_n)
// ((l_e + l_n) / (2 l_z) - 1) where z is the mean: > 0 where it lengthens while it turns or buckles
// (its chord at z is short of both ends), the midpoint's energy out of nothing.
void SpringSet::add_midpoint_defect(const double* start, const double* z, const double* end, double* defect,
                                    double* scale) const {
  double sum = 0, size = 0;
  for (size_t s = 0; s < count_; ++s) {
    const PetscInt ab[2] = {a_[s], b_[s]};
    const Vec3 dn = segment_edge(start, ab), dz = segment_edge(z, ab), de = segment_edge(end, ab);
    const double L = rest_[s], k = k_[s];
    const double ln = spring::length(dn, L), lz = spring::length(dz, L), le = spring::length(de, L);
    const double En = 0.5 * k * (ln - L) * (ln - L), Ee = 0.5 * k * (le - L) * (le - L);
    const double W = k * (lz - L) * dz.dot(de - dn) / lz;
    sum += Ee - En - W;
    size += En + Ee + std::fabs(W);
  }
  *defect += sum;
  *scale += size;
}

}  // namespace hyperqn

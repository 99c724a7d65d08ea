#include "terms/self_contact.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

#include "geometry/box_tree.hpp"
#include "geometry/pair_ccd.hpp"
#include "terms/contact.hpp"

namespace hyperqn {

namespace {

using Vec3 = Eigen::Vector3d;
using Key3 = std::array<int64_t, 3>;

Key3 sorted(Key3 k) {
  std::sort(k.begin(), k.end());
  return k;
}

// Every rank's items to every rank, in rank order; counts: each rank's number of items. Collective.
template <class T>
std::vector<T> all_gathered(MPI_Comm comm, const std::vector<T>& mine, MPI_Datatype type, std::vector<int>* counts_out = nullptr) {
  PetscMPIInt size;
  MPI_Comm_size(comm, &size);
  int count = (int)mine.size();
  std::vector<int> counts(size), offsets(size + 1, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  for (int r = 0; r < size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<T> all(offsets[size]);
  MPI_Allgatherv(mine.data(), count, type, all.data(), counts.data(), offsets.data(), type, comm);
  if (counts_out) *counts_out = counts;
  return all;
}

// The tets' faces of this rank that no other local tet shares, as input vertex ids, 3 each (a
// face between two ranks' tets is one of these on both ranks; the surface's faces on one only).
std::vector<int64_t> local_boundary_faces(const DistributedMesh& m) {
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // outward, as intersections.py
  std::map<Key3, std::pair<int, Key3>> faces;
  for (PetscInt c = 0; c < m.num_cells; ++c)
    for (const auto& f : kFaces) {
      const Key3 face{m.vertex_ids[m.cells[4 * c + f[0]]], m.vertex_ids[m.cells[4 * c + f[1]]],
                      m.vertex_ids[m.cells[4 * c + f[2]]]};
      auto& entry = faces[sorted(face)];
      entry.first += 1;
      entry.second = face;
    }
  std::vector<int64_t> out;
  for (const auto& [key, entry] : faces)
    if (entry.first == 1) out.insert(out.end(), entry.second.begin(), entry.second.end());
  return out;
}

Box bounds(std::initializer_list<Vec3> points, double inflate) {
  Box b{*points.begin(), *points.begin()};
  for (const Vec3& p : points) {
    b.lo = b.lo.cwiseMin(p);
    b.hi = b.hi.cwiseMax(p);
  }
  b.lo.array() -= inflate;
  b.hi.array() += inflate;
  return b;
}

// A 64-bit mix of a pair's identity (splitmix64), summed into the active set's signature.
unsigned long long mixed(unsigned long long z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

Matrix12d clamp_psd(const Matrix12d& H) {
  Eigen::SelfAdjointEigenSolver<Matrix12d> eig(H);
  const Vector12d lambda = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

double self_contact_pair_energy(const ContactSpec& spec, PairKind kind, const Vector12d& x, double mollifier_eps,
                                Vector12d* gradient, Matrix12d* hessian) {
  const bool derivatives = gradient || hessian;
  Vector12d gD;
  Matrix12d HD;
  const Vec3 p0 = x.segment<3>(0), p1 = x.segment<3>(3), p2 = x.segment<3>(6), p3 = x.segment<3>(9);
  const double D = kind == PairKind::vertex_triangle
                       ? point_triangle_squared_distance(p0, p1, p2, p3, derivatives ? &gD : nullptr, hessian ? &HD : nullptr)
                       : edge_edge_squared_distance(p0, p1, p2, p3, derivatives ? &gD : nullptr, hessian ? &HD : nullptr);
  if (gradient) gradient->setZero();
  if (hessian) hessian->setZero();
  const double d = spec.distance;
  if (!(D < d * d)) return 0;
  const double phi = std::sqrt(D);
  double b, db, d2b;
  contact_profile(spec, phi, &b, &db, &d2b);
  if (!std::isfinite(b)) return HUGE_VAL;  // the barrier at contact: a rejected point
  // phi = sqrt(D): grad phi = grad D / (2 phi), hess phi = hess D / (2 phi) - grad D grad D^T / (4 phi^3);
  // at phi = 0 (the penalty only) the direction is undefined: no force.
  Vector12d g = Vector12d::Zero();
  Matrix12d H = Matrix12d::Zero();
  if (derivatives && phi > 0) {
    const Vector12d gphi = gD / (2 * phi);
    g = db * gphi;
    if (hessian) H = d2b * gphi * gphi.transpose() + db * (HD / (2 * phi) - gphi * gphi.transpose() / phi);
  }
  double e = b;
  if (kind == PairKind::edge_edge) {  // m e: the product rule
    Vector12d gm;
    Matrix12d Hm;
    const double m = edge_edge_mollifier(p0, p1, p2, p3, mollifier_eps, derivatives ? &gm : nullptr, hessian ? &Hm : nullptr);
    if (hessian) H = m * H + g * gm.transpose() + gm * g.transpose() + e * Hm;
    if (derivatives) g = m * g + e * gm;
    e *= m;
  }
  if (gradient) *gradient = g;
  if (hessian) *hessian = H;
  return e;
}

SelfContactTerm::SelfContactTerm(const DistributedMesh& mesh, const ContactSpec& spec, PetscLogEvent event,
                                 PetscLogEvent gather_event, PetscLogEvent pairs_event, std::vector<int> fixed_lines)
    : mesh_(mesh),
      spec_(spec),
      barrier_(spec.model == ContactModel::barrier),
      event_(event),
      gather_event_(gather_event),
      pairs_event_(pairs_event),
      fixed_lines_(std::move(fixed_lines)),
      step_margin_(spec.distance) {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  PetscMPIInt rank;
  MPI_Comm_rank(comm, &rank);
  // The surface's triangles, in the order of their sorted ids (the same at any rank count): the
  // tets' faces on one rank only, then the cloth triangles (each on one rank).
  std::map<Key3, std::pair<int, Key3>> faces;
  const std::vector<int64_t> boundary = all_gathered(comm, local_boundary_faces(mesh), MPI_INT64_T);
  for (size_t f = 0; f < boundary.size(); f += 3) {
    const Key3 face{boundary[f], boundary[f + 1], boundary[f + 2]};
    auto& entry = faces[sorted(face)];
    entry.first += 1;
    entry.second = face;
  }
  std::vector<int64_t> mine;
  for (PetscInt t = 0; t < 3 * mesh.num_triangles; ++t) mine.push_back(mesh.vertex_ids[mesh.triangles[t]]);
  const std::vector<int64_t> cloth = all_gathered(comm, mine, MPI_INT64_T);
  for (size_t f = 0; f < cloth.size(); f += 3) {
    const Key3 tri{cloth[f], cloth[f + 1], cloth[f + 2]};
    faces[sorted(tri)] = {1, tri};
  }
  std::vector<Key3> surface;
  for (const auto& [key, entry] : faces)
    if (entry.first == 1) {
      surface.push_back(entry.second);
      ids_.insert(ids_.end(), key.begin(), key.end());
    }
  std::sort(ids_.begin(), ids_.end());
  ids_.erase(std::unique(ids_.begin(), ids_.end()), ids_.end());
  const auto index = [&](int64_t id) { return (int)(std::lower_bound(ids_.begin(), ids_.end(), id) - ids_.begin()); };
  for (const Key3& f : surface) {
    triangles_.push_back({index(f[0]), index(f[1]), index(f[2])});
    for (int k = 0; k < 3; ++k) {
      const int a = triangles_.back()[k], b = triangles_.back()[(k + 1) % 3];
      edges_.push_back({std::min(a, b), std::max(a, b)});
    }
  }
  std::sort(edges_.begin(), edges_.end());
  edges_.erase(std::unique(edges_.begin(), edges_.end()), edges_.end());

  // Who owns which surface vertex, its dof, rest position and body: each owner sends its own.
  std::vector<int> sent;
  std::vector<int32_t> sent_bodies, sent_regions;
  std::vector<int64_t> sent_dofs;
  std::vector<double> sent_rest;
  for (PetscInt v = 0; v < mesh.num_vertices; ++v) {
    if (!mesh.owned[v]) continue;
    const auto at = std::lower_bound(ids_.begin(), ids_.end(), mesh.vertex_ids[v]);
    if (at == ids_.end() || *at != mesh.vertex_ids[v]) continue;
    owned_local_.push_back(v);
    owned_surface_.push_back((int)(at - ids_.begin()));
    sent.push_back(owned_surface_.back());
    sent_dofs.push_back(mesh.global_dof[v]);
    sent_bodies.push_back(mesh.vertex_body.empty() ? 0 : mesh.vertex_body[v]);
    sent_regions.push_back(mesh.fixed[v]);
    for (int d = 0; d < 3; ++d) sent_rest.push_back(mesh.rest[3 * v + d]);
  }
  received_ = all_gathered(comm, sent, MPI_INT, &counts_);
  const std::vector<int64_t> dofs = all_gathered(comm, sent_dofs, MPI_INT64_T);
  const std::vector<double> rest = all_gathered(comm, sent_rest, MPI_DOUBLE);
  const std::vector<int32_t> bodies = all_gathered(comm, sent_bodies, MPI_INT32_T);
  const std::vector<int32_t> regions = all_gathered(comm, sent_regions, MPI_INT32_T);
  offsets_.assign(counts_.size() + 1, 0);
  for (size_t r = 0; r < counts_.size(); ++r) offsets_[r + 1] = offsets_[r] + counts_[r];
  const size_t n = ids_.size();
  dof_.assign(n, -1);
  owner_.assign(n, -1);
  rest_.assign(3 * n, 0.0);
  mass_.assign(n, 1.0);  // until set_masses: 1 kg each
  body_.assign(n, 0);
  region_.assign(n, 0);
  local_of_.assign(n, -1);
  accumulated_.assign(3 * n, 0.0);
  touched_.assign(n, 0);
  x_.assign(3 * n, 0.0);
  for (size_t r = 0; r + 1 < offsets_.size(); ++r)
    for (int k = offsets_[r]; k < offsets_[r + 1]; ++k) {
      const int s = received_[k];
      owner_[s] = (int)r;
      dof_[s] = (PetscInt)dofs[k];
      body_[s] = bodies[k];
      region_[s] = regions[k];
      for (int d = 0; d < 3; ++d) rest_[3 * s + d] = x_[3 * s + d] = rest[3 * k + d];
    }
  step_at_ = rest_;  // until a step says where its fixed vertices are
  for (size_t k = 0; k < owned_surface_.size(); ++k) local_of_[owned_surface_[k]] = owned_local_[k];
  for (int s : owned_surface_) my_vertices_.push_back(s);
  for (size_t e = 0; e < edges_.size(); ++e)
    if (owner_[edges_[e][0]] == rank) my_edges_.push_back((int)e);
}

SelfContactTerm::~SelfContactTerm() = default;

PetscErrorCode SelfContactTerm::set_masses(Vec mass) {
  const PetscScalar* m;
  PetscInt lo, hi;
  std::vector<double> mine;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(mass, &lo, &hi));
  PetscCall(VecGetArrayRead(mass, &m));
  for (PetscInt v : owned_local_) mine.push_back(mesh_.global_dof[v] >= 0 ? m[mesh_.global_dof[v] - lo] : 0.0);
  PetscCall(VecRestoreArrayRead(mass, &m));
  const std::vector<double> all = all_gathered(PetscObjectComm((PetscObject)mesh_.dm), mine, MPI_DOUBLE);
  for (size_t k = 0; k < all.size(); ++k) mass_[received_[k]] = all[k];
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::gather_positions(const std::vector<double>& pos) const {
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(gather_event_, 0, 0, 0, 0));
  std::vector<double> mine;
  mine.reserve(3 * owned_local_.size());
  for (PetscInt v : owned_local_) mine.insert(mine.end(), &pos[3 * v], &pos[3 * v] + 3);
  std::vector<int> counts(counts_.size()), offsets(counts_.size());
  for (size_t r = 0; r < counts_.size(); ++r) counts[r] = 3 * counts_[r], offsets[r] = 3 * offsets_[r];
  buffer_.resize(3 * received_.size());
  PetscCallMPI(MPI_Allgatherv(mine.data(), (int)mine.size(), MPI_DOUBLE, buffer_.data(), counts.data(), offsets.data(),
                              MPI_DOUBLE, PetscObjectComm((PetscObject)mesh_.dm)));
  for (size_t k = 0; k < received_.size(); ++k)
    for (int d = 0; d < 3; ++d) x_[3 * received_[k] + d] = buffer_[3 * k + d];
  PetscCall(PetscLogEventEnd(gather_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::gather_path(const std::vector<double>& mine, std::vector<double>& start,
                                            std::vector<double>& end) const {
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(gather_event_, 0, 0, 0, 0));
  std::vector<int> counts(counts_.size()), offsets(counts_.size());
  for (size_t r = 0; r < counts_.size(); ++r) counts[r] = 6 * counts_[r], offsets[r] = 6 * offsets_[r];
  buffer_.resize(6 * received_.size());
  PetscCallMPI(MPI_Allgatherv(mine.data(), (int)mine.size(), MPI_DOUBLE, buffer_.data(), counts.data(), offsets.data(),
                              MPI_DOUBLE, PetscObjectComm((PetscObject)mesh_.dm)));
  start.resize(3 * ids_.size());
  end.resize(3 * ids_.size());
  for (size_t k = 0; k < received_.size(); ++k)
    for (int d = 0; d < 3; ++d) {
      start[3 * received_[k] + d] = buffer_[6 * k + d];
      end[3 * received_[k] + d] = buffer_[6 * k + 3 + d];
    }
  PetscCall(PetscLogEventEnd(gather_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

std::array<int, 4> SelfContactTerm::points(const Pair& p) const {
  if (p.kind == PairKind::vertex_triangle) return {p.a, triangles_[p.b][0], triangles_[p.b][1], triangles_[p.b][2]};
  return {edges_[p.a][0], edges_[p.a][1], edges_[p.b][0], edges_[p.b][1]};
}

Vector12d SelfContactTerm::coordinates(const std::vector<double>& x, const std::array<int, 4>& q) const {
  Vector12d out;
  for (int k = 0; k < 4; ++k) out.segment<3>(3 * k) = Vec3(&x[3 * q[k]]);
  return out;
}

template <class Visit>
void SelfContactTerm::broad_phase(const std::vector<double>& x, const std::vector<double>* end, double reach,
                                  Visit&& visit) const {
  const auto p = [&](int s) { return Vec3(&x[3 * s]); };
  const auto q = [&](int s) { return end ? Vec3(&(*end)[3 * s]) : Vec3(&x[3 * s]); };
  std::vector<Box> boxes;
  boxes.reserve(triangles_.size());
  for (const auto& t : triangles_) boxes.push_back(bounds({p(t[0]), p(t[1]), p(t[2]), q(t[0]), q(t[1]), q(t[2])}, 0));
  const BoxTree triangles(std::move(boxes));
  for (int v : my_vertices_)
    triangles.overlapping(bounds({p(v), q(v)}, reach), [&](int t) {
      const auto& tri = triangles_[t];
      if (tri[0] != v && tri[1] != v && tri[2] != v) visit(Pair{PairKind::vertex_triangle, v, t});
    });
  boxes.clear();
  for (const auto& e : edges_) boxes.push_back(bounds({p(e[0]), p(e[1]), q(e[0]), q(e[1])}, reach));
  const BoxTree edges(std::move(boxes));
  for (int e : my_edges_) {
    const auto& a = edges_[e];
    edges.overlapping(bounds({p(a[0]), p(a[1]), q(a[0]), q(a[1])}, 0), [&](int f) {
      const auto& b = edges_[f];
      if (f > e && a[0] != b[0] && a[0] != b[1] && a[1] != b[0] && a[1] != b[1]) visit(Pair{PairKind::edge_edge, e, f});
    });
  }
}

bool SelfContactTerm::candidates_cover(const std::vector<double>& x, const std::vector<double>* end) const {
  if (stale_) return false;
  double largest = 0;
  for (size_t s = 0; s < moved_.size(); ++s) {
    const Vec3 built(&built_at_[3 * s]);
    moved_[s] = (Vec3(&x[3 * s]) - built).norm();
    if (end) moved_[s] = std::max(moved_[s], (Vec3(&(*end)[3 * s]) - built).norm());
    largest = std::max(largest, moved_[s]);
  }
  return largest <= kMoveFraction * built_margin_;
}

// Why the list misses no pair within d. A pair's distance is the least distance between a point of
// one primitive and a point of the other; each such point is a convex combination of its
// primitive's vertices, so if no vertex of a primitive has moved more than delta since the build,
// no point of it has, and the pair's distance has changed by at most the two primitives' deltas.
// The list holds every pair of this rank within d + margin at the build (the broad phase's boxes
// grown by d + margin hold the ball of that radius, then the distance decides), with that distance;
// any other pair is still farther than d + margin - 2 delta (delta: the largest move of a vertex),
// which is more than d while delta < margin / 2. The list is built again once a vertex has moved
// more than kMoveFraction (0.4) of the margin; the rest covers rounding. Within the list, a pair
// whose distance at the build less its primitives' moves is d or more cannot be within d and is
// passed over. The same holds all along a straight step whose both ends are within 0.4 of the
// margin (the path stays in the ball around the build's position), which is what limit_step needs.
PetscErrorCode SelfContactTerm::refresh_candidates() const {
  PetscFunctionBeginUser;
  if (candidates_cover(x_, nullptr)) PetscFunctionReturn(0);
  PetscCall(PetscLogEventBegin(pairs_event_, 0, 0, 0, 0));
  const double reach = spec_.distance + step_margin_;
  candidates_.clear();
  broad_phase(x_, nullptr, reach, [&](const Pair& p) {
    const double D = squared_distance(p, x_);
    if (D <= reach * reach) candidates_.push_back({p, std::sqrt(D)});
  });
  // A canonical order: the energy and gradient sums do not depend on where the list was built.
  std::sort(candidates_.begin(), candidates_.end(), [](const Candidate& c, const Candidate& e) {
    return std::tie(c.pair.kind, c.pair.a, c.pair.b) < std::tie(e.pair.kind, e.pair.a, e.pair.b);
  });
  built_at_ = x_;
  built_margin_ = step_margin_;
  moved_.assign(ids_.size(), 0.0);
  stale_ = false;
  ++builds_;
  PetscCall(PetscLogEventEnd(pairs_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

bool SelfContactTerm::may_be_within_d(const Candidate& c) const {
  const std::array<int, 4> q = points(c.pair);
  const int split = c.pair.kind == PairKind::vertex_triangle ? 1 : 2;  // the first primitive's points
  double first = 0, second = 0;
  for (int k = 0; k < 4; ++k) {
    double& moved = k < split ? first : second;
    moved = std::max(moved, moved_[q[k]]);
  }
  return c.distance - first - second < spec_.distance * (1 + 1e-9);  // the slack: rounding of the moves
}

template <class Visit>
void SelfContactTerm::near_pairs(Visit&& visit) const {
  for (const Candidate& c : candidates_)
    if (may_be_within_d(c)) visit(c.pair);
}

PetscErrorCode SelfContactTerm::begin_step(const StepStart& step) {
  const PetscScalar *x, *y;
  PetscInt lo, hi;
  double motion = 0;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(step.y, &lo, &hi));
  PetscCall(VecGetArrayRead(step.x_start, &x));
  PetscCall(VecGetArrayRead(step.y, &y));
  for (PetscInt v : owned_local_) {
    const PetscInt g = mesh_.global_dof[v] - lo;
    if (mesh_.global_dof[v] >= 0) motion = std::max(motion, (Vec3(&y[g]) - Vec3(&x[g])).norm());
  }
  PetscCall(VecRestoreArrayRead(step.x_start, &x));
  PetscCall(VecRestoreArrayRead(step.y, &y));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &motion, 1, MPI_DOUBLE, MPI_MAX, PetscObjectComm((PetscObject)mesh_.dm)));
  // A list that covers the step's predicted motion from where it is built; at least d.
  step_margin_ = std::max(spec_.distance, motion / kMoveFraction);
  // Built again at the step's first evaluation whatever it covers: what a step computes depends
  // only on its start (a restart or the study's other trajectories in the same scene alike).
  stale_ = true;
  if (barrier_ && step.positions) PetscCall(check_fixed_jump(*step.start_positions, *step.positions));
  PetscFunctionReturn(0);
}

// At a step's start the fixed vertices jump to where the step has them while the free ones are at
// x_n: the straight path of that jump must not carry a surface into another, or the solve would
// start past a crossing (two primitives that passed through each other are apart again, and their
// energy is finite). The pairs tested are those with a moving point, except a pair within one
// fixed region (it moves rigidly). A pair that comes within a tenth of its distance rejects the
// step; the fallback chain's sub-steps then try shorter jumps, between which the barrier pushes
// the free surface out of the way. (The solve's iterates then start from an admissible point and
// limit_step bounds them with the fixed vertices where the step has them.)
PetscErrorCode SelfContactTerm::check_fixed_jump(const std::vector<double>& start_positions,
                                                 const std::vector<double>& positions) {
  PetscFunctionBeginUser;
  std::vector<double> mine, start;
  mine.reserve(6 * owned_local_.size());
  for (PetscInt v : owned_local_) {
    mine.insert(mine.end(), &start_positions[3 * v], &start_positions[3 * v] + 3);
    mine.insert(mine.end(), &positions[3 * v], &positions[3 * v] + 3);
  }
  PetscCall(gather_path(mine, start, step_at_));
  rejecting_region_ = 0;
  std::vector<char> moves(ids_.size());
  bool any = false;
  for (size_t s = 0; s < ids_.size(); ++s) {
    moves[s] = Vec3(&start[3 * s]) != Vec3(&step_at_[3 * s]);
    any = any || moves[s];
  }
  if (!any) PetscFunctionReturn(0);  // every rank has the whole surface: all return here alike
  struct {
    double t;
    int region;
  } first{HUGE_VAL, 0};
  broad_phase(start, &step_at_, 0, [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    int mover = -1;
    bool one_region = region_[q[0]] > 0;
    for (int s : q) {
      if (moves[s] && mover < 0) mover = s;
      one_region = one_region && region_[s] == region_[q[0]];
    }
    if (mover < 0 || one_region) return;
    const Vector12d a = coordinates(start, q), b = coordinates(step_at_, q);
    const double t = p.kind == PairKind::vertex_triangle ? vertex_triangle_impact(a, b, 0) : edge_edge_impact(a, b, 0);
    if (t < first.t || (t == first.t && region_[mover] < first.region)) first = {t, region_[mover]};
  });
  // The earliest over the ranks (the lowest region among equal times).
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_DOUBLE_INT, MPI_MINLOC, PetscObjectComm((PetscObject)mesh_.dm)));
  if (first.t < 1) rejecting_region_ = first.region;
  PetscFunctionReturn(0);
}

double SelfContactTerm::squared_distance(const Pair& p, const std::vector<double>& x) const {
  const Vector12d c = coordinates(x, points(p));
  return p.kind == PairKind::vertex_triangle
             ? point_triangle_squared_distance(c.segment<3>(0), c.segment<3>(3), c.segment<3>(6), c.segment<3>(9))
             : edge_edge_squared_distance(c.segment<3>(0), c.segment<3>(3), c.segment<3>(6), c.segment<3>(9));
}

double SelfContactTerm::pair_energy(const Pair& p, const Vector12d& x, Vector12d* g, Matrix12d* H) const {
  const std::array<int, 4> q = points(p);
  double mass = 0;
  int free_points = 0;
  for (int s : q)
    if (dof_[s] >= 0) mass += mass_[s], ++free_points;
  if (free_points == 0) return 0;  // fixed against fixed: nothing to move
  double eps = 0;
  if (p.kind == PairKind::edge_edge)
    eps = edge_edge_mollifier_threshold(Vec3(&rest_[3 * q[0]]), Vec3(&rest_[3 * q[1]]), Vec3(&rest_[3 * q[2]]),
                                        Vec3(&rest_[3 * q[3]]));
  const double k = contact_stiffness_per_mass(spec_) * mass / free_points;
  const double e = self_contact_pair_energy(spec_, p.kind, x, eps, g, H);
  if (g) *g *= k;
  if (H) *H *= k;
  return k * e;
}

PetscErrorCode SelfContactTerm::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  if (rejecting_region_) {  // the step's start is past a crossing (every rank alike: no gather)
    *energy += HUGE_VAL;
    PetscFunctionReturn(0);
  }
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  PetscCall(gather_positions(pos));
  PetscCall(refresh_candidates());
  double e = 0;
  Vector12d g;
  active_set_ = 0;
  active_pairs_ = 0;
  near_pairs([&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    const double ep = pair_energy(p, coordinates(x_, q), gradient ? &g : nullptr, nullptr);
    if (ep == 0) return;
    ++active_pairs_;
    active_set_ += mixed(((unsigned long long)p.a << 32 | (unsigned)p.b) * 2 + (p.kind == PairKind::edge_edge));
    e += ep;
    if (!gradient) return;
    for (int k = 0; k < 4; ++k) {
      const int s = q[k];
      if (dof_[s] < 0) continue;
      if (!touched_[s]) touched_[s] = 1, touched_list_.push_back(s);
      for (int d = 0; d < 3; ++d) accumulated_[3 * s + d] += g[3 * k + d];
    }
  });
  *energy += e;
  if (gradient) PetscCall(exchange_gradient(gradient));
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::exchange_gradient(PetscScalar* gradient) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscMPIInt size, rank;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(gather_event_, 0, 0, 0, 0));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  // Per owner, in the surface's order: each touched vertex once, with its sum over this rank's
  // pairs (in the pairs' order). The owner adds its own sums, then the received ones in the order
  // of the sending ranks (MPI_Alltoallv places them so): the same bits whatever order the
  // messages arrive in.
  std::sort(touched_list_.begin(), touched_list_.end(),
            [&](int a, int b) { return std::make_pair(owner_[a], a) < std::make_pair(owner_[b], b); });
  std::vector<int> send_counts(size, 0), recv_counts(size), send_offsets(size + 1, 0), recv_offsets(size + 1, 0);
  std::vector<int> send_vertices;
  std::vector<double> send_values;
  for (int s : touched_list_) {
    if (owner_[s] == rank) {
      for (int d = 0; d < 3; ++d) gradient[mesh_.local_dof[local_of_[s]] + d] += accumulated_[3 * s + d];
    } else {
      ++send_counts[owner_[s]];
      send_vertices.push_back(s);
      send_values.insert(send_values.end(), &accumulated_[3 * s], &accumulated_[3 * s] + 3);
    }
    touched_[s] = 0;
    for (int d = 0; d < 3; ++d) accumulated_[3 * s + d] = 0;
  }
  touched_list_.clear();
  if (size > 1) {
    PetscCallMPI(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, comm));
    for (int r = 0; r < size; ++r) {
      send_offsets[r + 1] = send_offsets[r] + send_counts[r];
      recv_offsets[r + 1] = recv_offsets[r] + recv_counts[r];
    }
    std::vector<int> recv_vertices(recv_offsets[size]);
    PetscCallMPI(MPI_Alltoallv(send_vertices.data(), send_counts.data(), send_offsets.data(), MPI_INT,
                               recv_vertices.data(), recv_counts.data(), recv_offsets.data(), MPI_INT, comm));
    for (int r = 0; r <= size; ++r) send_offsets[r] *= 3, recv_offsets[r] *= 3;
    for (int r = 0; r < size; ++r) send_counts[r] *= 3, recv_counts[r] *= 3;
    std::vector<double> recv_values(recv_offsets[size]);
    PetscCallMPI(MPI_Alltoallv(send_values.data(), send_counts.data(), send_offsets.data(), MPI_DOUBLE,
                               recv_values.data(), recv_counts.data(), recv_offsets.data(), MPI_DOUBLE, comm));
    for (size_t k = 0; k < recv_vertices.size(); ++k)
      for (int d = 0; d < 3; ++d) gradient[mesh_.local_dof[local_of_[recv_vertices[k]]] + d] += recv_values[3 * k + d];
  }
  PetscCall(PetscLogEventEnd(gather_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  PetscFunctionBeginUser;
  if (rejecting_region_) PetscFunctionReturn(0);  // a rejected step (add_energy)
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  PetscCall(gather_positions(pos));
  PetscCall(refresh_candidates());
  Matrix12d h;
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> block;
  PetscErrorCode error = 0;
  near_pairs([&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    if (error || pair_energy(p, coordinates(x_, q), nullptr, &h) == 0) return;
    block = scale * (psd ? clamp_psd(h) : h);
    PetscInt idx[12];
    for (int k = 0; k < 4; ++k)
      for (int d = 0; d < 3; ++d) idx[3 * k + d] = dof_[q[k]] < 0 ? -1 : dof_[q[k]] + d;
    error = MatSetValues(H, 12, idx, 12, idx, block.data(), ADD_VALUES);
  });
  PetscCall(error);
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::limit_step(Vec x, Vec dir, double* alpha) const {
  const PetscScalar *a, *u;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  // Each owner sends its surface vertices' position and end (fixed ones: where the step has them,
  // not moving).
  std::vector<double> mine, end;
  PetscCall(VecGetOwnershipRange(x, &lo, &hi));
  PetscCall(VecGetArrayRead(x, &a));
  PetscCall(VecGetArrayRead(dir, &u));
  for (size_t k = 0; k < owned_local_.size(); ++k) {
    const PetscInt g = mesh_.global_dof[owned_local_[k]];
    const double* at = &step_at_[3 * owned_surface_[k]];
    for (int d = 0; d < 3; ++d) mine.push_back(g < 0 ? at[d] : a[g - lo + d]);
    for (int d = 0; d < 3; ++d) mine.push_back(g < 0 ? at[d] : a[g - lo + d] + *alpha * u[g - lo + d]);
  }
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCall(VecRestoreArrayRead(dir, &u));
  PetscCall(gather_path(mine, x_, end));
  double t = 1;
  const auto bound = [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    const Vector12d start = coordinates(x_, q), stop = coordinates(end, q);
    const double impact = p.kind == PairKind::vertex_triangle ? vertex_triangle_impact(start, stop, 0)
                                                              : edge_edge_impact(start, stop, 0);
    t = std::min(t, impact);
  };
  if (candidates_cover(x_, &end)) {  // no other pair comes within d along the step (refresh_candidates)
    for (const Candidate& c : candidates_)
      if (may_be_within_d(c)) bound(c.pair);
  } else {
    broad_phase(x_, &end, 0, bound);
  }
  *alpha *= t;  // the pair keeps a tenth of its clearance there (pair_ccd.hpp): never touches
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::touching_pairs(const std::vector<double>& pos, long* count) const {
  PetscFunctionBeginUser;
  PetscCall(gather_positions(pos));
  long local = 0;
  broad_phase(x_, nullptr, 0, [&](const Pair& p) { local += squared_distance(p, x_) <= 0; });
  PetscCallMPI(MPI_Allreduce(&local, count, 1, MPI_LONG, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm)));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::closest_rest_pair(double* distance, int64_t* vertex_id) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  double closest = spec_.distance * spec_.distance;  // squared, then the distance
  int64_t id = std::numeric_limits<int64_t>::max();
  PetscFunctionBeginUser;
  broad_phase(rest_, nullptr, spec_.distance, [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    if (body_[q[0]] != body_[q[2]]) return;  // two bodies placed close: not the mesh's spacing
    bool free = false;
    for (int s : q) free = free || dof_[s] >= 0;
    if (!free) return;  // fixed against fixed: no force either
    const double D = squared_distance(p, rest_);
    int64_t lowest = ids_[q[0]];
    for (int s : q) lowest = std::min(lowest, ids_[s]);
    if (D < closest || (D == closest && D < spec_.distance * spec_.distance && lowest < id)) closest = D, id = lowest;
  });
  closest = id == std::numeric_limits<int64_t>::max() ? HUGE_VAL : std::sqrt(closest);
  const double mine = closest;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &closest, 1, MPI_DOUBLE, MPI_MIN, comm));
  if (mine != closest) id = std::numeric_limits<int64_t>::max();  // the lowest id among the closest pairs
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &id, 1, MPI_INT64_T, MPI_MIN, comm));
  *distance = closest;
  *vertex_id = id;
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::check_start(const std::vector<double>& pos, InputProblem& out) const {
  double gap;
  int64_t vertex;
  long touching;
  PetscFunctionBeginUser;
  PetscCall(closest_rest_pair(&gap, &vertex));
  if (gap < spec_.distance) {
    // Half the gap, rounded down to two digits: the mesh at rest stays clear of the layer.
    const double scale = gap > 0 ? std::pow(10.0, std::floor(std::log10(gap / 2)) - 1) : 0;
    const double suggested = gap > 0 ? std::floor(gap / 2 / scale) * scale : 0;
    char what[600];
    std::snprintf(what, sizeof what,
                  "%s%g is too large for the surface: two of its primitives in one body that share no vertex (one of "
                  "them at vertex %lld) are %.4g apart at rest, closer than the activation distance, so self-contact "
                  "would push the mesh apart from itself at rest; ",
                  spec_.distance_line > 0 ? "" : "the default ", spec_.distance, (long long)vertex, gap);
    out.line = spec_.distance_line > 0 ? spec_.distance_line : spec_.self_line;
    out.key = "contact.distance";
    out.what = what;
    if (gap > 0) {
      std::snprintf(what, sizeof what, "use a distance below that gap, e.g. contact.distance: %g (half of it)", suggested);
      out.what += what;
    } else {
      out.what += "they touch (coincident primitives), which no distance fits";
    }
    PetscFunctionReturn(0);
  }
  if (!barrier_) PetscFunctionReturn(0);
  PetscCall(touching_pairs(pos, &touching));
  if (touching == 0) PetscFunctionReturn(0);
  out.line = spec_.self_line;
  out.key = "contact.self";
  out.what = std::to_string(touching) + " pairs of surface primitives touch at frame 0, where the barrier's energy is " +
             "infinite: move the bodies apart (or use the penalty)";
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::explain_rejection(const std::vector<double>& pos, std::string& why) const {
  long touching;
  PetscFunctionBeginUser;
  if (rejecting_region_) {
    const int k = rejecting_region_ - 1;
    const std::string region = k < (int)fixed_lines_.size() && fixed_lines_[k] > 0
                                   ? "the fixed region of deck line " + std::to_string(fixed_lines_[k])
                                   : "fixed region " + std::to_string(rejecting_region_);
    why += std::string(why.empty() ? "" : "; ") + "self-contact: " + region +
           " moves its surface into another surface within one step (in the smallest sub-step too): its "
           "prescribed motion forces the surfaces through each other, or is too fast for the other surface to make way";
    PetscFunctionReturn(0);
  }
  if (!barrier_) PetscFunctionReturn(0);
  PetscCall(touching_pairs(pos, &touching));
  if (touching > 0)
    why += std::string(why.empty() ? "" : "; ") + "self-contact: " + std::to_string(touching) + " pairs of surface primitives touch, where the barrier is infinite";
  PetscFunctionReturn(0);
}

std::string SelfContactTerm::describe() const {
  char text[300];
  std::snprintf(text, sizeof text,
                "self-contact: %zu surface triangles, %zu edges, %zu vertices (%zu bytes gathered to every rank per "
                "evaluation), %s, distance %.4g, stiffness %.4g",
                triangles_.size(), edges_.size(), ids_.size(), 3 * sizeof(double) * ids_.size(),
                kContactModelNames[size_t(spec_.model)].c_str(), spec_.distance, spec_.stiffness);
  return text;
}

}  // namespace hyperqn

#include "terms/self_contact.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

#include "geometry/pair_ccd.hpp"
#include "parallel/collectives.hpp"
#include "terms/boundary_faces.hpp"
#include "terms/contact.hpp"

namespace hyperqn {

namespace {
// The moves of a set of vertices, for how far they move apart: per component the largest and
// the least (negated) move, and the largest move's length. A translation of them all changes no
// distance between them; taking out the middle of the moves' range leaves moves at most
// spread() long. Reduced over the ranks (MPI_MAX) as 7 doubles from data().
struct MoveRange {
  std::array<double, 7> r{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  void add(const Vec3& u) {
    for (int d = 0; d < 3; ++d) r[d] = std::max(r[d], u[d]), r[3 + d] = std::max(r[3 + d], -u[d]);
    r[6] = std::max(r[6], u.norm());
  }
  bool empty() const { return r[6] < 0; }
  double largest() const { return empty() ? 0.0 : r[6]; }
  Vec3 middle() const {
    return empty() ? Vec3::Zero() : Vec3(0.5 * (r[0] - r[3]), 0.5 * (r[1] - r[4]), 0.5 * (r[2] - r[5]));
  }
  double spread() const {
    return empty() ? 0.0 : Vec3(0.5 * (r[0] + r[3]), 0.5 * (r[1] + r[4]), 0.5 * (r[2] + r[5])).norm();
  }
};
}  // namespace

namespace {

using Vec3 = Eigen::Vector3d;
using Key3 = std::array<int64_t, 3>;

Key3 sorted(Key3 k) {
  std::sort(k.begin(), k.end());
  return k;
}

// The tets' faces of this rank that no other local tet shares, as input vertex ids, 3 each
// (terms/boundary_faces.hpp).
std::vector<int64_t> local_boundary_face_ids(const DistributedMesh& m) {
  std::vector<int64_t> out;
  for (const auto& face : local_boundary_faces(m))
    for (PetscInt v : face) out.push_back(m.vertex_ids[v]);
  return out;
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

SelfContactTerm::SelfContactTerm(const DistributedMesh& mesh, const ContactSpec& spec, PetscLogEvent event,
                                 PetscLogEvent gather_event, PetscLogEvent pairs_event, std::vector<SelfContactBody> bodies,
                                 std::vector<int> fixed_lines)
    : mesh_(mesh),
      spec_(spec),
      barrier_(spec.model == ContactModel::barrier),
      event_(event),
      gather_event_(gather_event),
      pairs_event_(pairs_event),
      bodies_(std::move(bodies)),
      fixed_lines_(std::move(fixed_lines)),
      step_margin_(spec.distance) {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  PetscMPIInt rank;
  MPI_Comm_rank(comm, &rank);
  // The surface's triangles, in the order of their sorted ids (the same at any rank count): the
  // tets' faces on one rank only, then the cloth triangles (each on one rank).
  std::map<Key3, std::pair<int, Key3>> faces;
  const std::vector<int64_t> boundary = all_gathered(comm, local_boundary_face_ids(mesh), MPI_INT64_T);
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
  std::vector<int> counts, offsets;
  received_ = all_gathered(comm, sent, MPI_INT, &counts);
  const std::vector<int64_t> dofs = all_gathered(comm, sent_dofs, MPI_INT64_T);
  const std::vector<double> rest = all_gathered(comm, sent_rest, MPI_DOUBLE);
  const std::vector<int32_t> vertex_bodies = all_gathered(comm, sent_bodies, MPI_INT32_T);
  const std::vector<int32_t> regions = all_gathered(comm, sent_regions, MPI_INT32_T);
  offsets.assign(counts.size() + 1, 0);
  for (size_t r = 0; r < counts.size(); ++r) offsets[r + 1] = offsets[r] + counts[r];
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
  for (size_t r = 0; r + 1 < offsets.size(); ++r)
    for (int k = offsets[r]; k < offsets[r + 1]; ++k) {
      const int s = received_[k];
      owner_[s] = (int)r;
      dof_[s] = (PetscInt)dofs[k];
      body_[s] = vertex_bodies[k];
      region_[s] = regions[k];
      for (int d = 0; d < 3; ++d) rest_[3 * s + d] = x_[3 * s + d] = rest[3 * k + d];
    }
  step_at_ = rest_;  // until a step says where its fixed vertices are
  joined_.resize(n);
  std::map<std::tuple<int32_t, double, double, double>, int> first_at;
  for (size_t s = 0; s < n; ++s)
    joined_[s] = spec_.joined_twins ? first_at.emplace(std::make_tuple(body_[s], rest_[3 * s], rest_[3 * s + 1], rest_[3 * s + 2]), (int)s)
                                          .first->second
                                    : (int)s;
  for (const auto& e : edges_) mean_edge_ += (Vec3(&rest_[3 * e[0]]) - Vec3(&rest_[3 * e[1]])).norm();
  if (!edges_.empty()) mean_edge_ /= edges_.size();
  for (size_t k = 0; k < owned_surface_.size(); ++k) local_of_[owned_surface_[k]] = owned_local_[k];
  half_thickness_.assign(n, 0.0);
  for (size_t s = 0; s < n; ++s) {
    if (body_[s] < (int32_t)bodies_.size()) half_thickness_[s] = bodies_[body_[s]].thickness / 2;
    largest_offset_ = std::max(largest_offset_, 2 * half_thickness_[s]);
  }
  for (int s : owned_surface_) my_vertices_.push_back(s);
  for (size_t e = 0; e < edges_.size(); ++e)
    if (owner_[edges_[e][0]] == rank) my_edges_.push_back((int)e);
  for (size_t t = 0; t < triangles_.size(); ++t)
    if (owner_[triangles_[t][0]] == rank) my_triangles_.push_back((int)t);
  // The halo: the owner of each end of an edge sends it to the owner of the other end (a
  // triangle's vertices are joined by its edges), which needs no message to plan.
  std::vector<std::pair<int, int>> halo_receives;
  for (const auto& e : edges_)
    for (int k = 0; k < 2; ++k)
      if (owner_[e[k]] == rank && owner_[e[1 - k]] != rank) {
        halo_.push_back({owner_[e[1 - k]], e[k]});
        halo_receives.push_back({owner_[e[1 - k]], e[1 - k]});
      }
  ghosts_ = make_exchange(halo_, halo_receives);
  PetscCallAbort(comm, PetscObjectGetNewTag((PetscObject)mesh.dm, &tag_));
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
  for (size_t k = 0; k < owned_local_.size(); ++k)
    std::copy_n(&pos[3 * owned_local_[k]], 3, &x_[3 * owned_surface_[k]]);
  PetscCall(exchange(ghosts_, 3, x_));
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

Box SelfContactTerm::primitive_box(std::initializer_list<int> vertices, const std::vector<double>& x,
                                   const std::vector<double>* end, double inflate) const {
  const Vec3 first(&x[3 * *vertices.begin()]);
  Box b{first, first};
  for (int s : vertices)
    for (const std::vector<double>* at : {&x, end})
      if (at) b.include(Vec3(&(*at)[3 * s]));
  b.inflate(inflate);
  return b;
}

bool SelfContactTerm::boxes_meet(const Pair& p, const std::vector<double>& x, const std::vector<double>* end,
                                 double reach) const {
  if (p.kind == PairKind::vertex_triangle) {
    const auto& t = triangles_[p.b];
    return primitive_box({t[0], t[1], t[2]}, x, end, 0).overlaps(primitive_box({p.a}, x, end, reach));
  }
  const auto &a = edges_[p.a], &b = edges_[p.b];
  return primitive_box({b[0], b[1]}, x, end, reach).overlaps(primitive_box({a[0], a[1]}, x, end, 0));
}

template <class Visit>
void SelfContactTerm::broad_phase(const std::vector<double>& x, const std::vector<double>* end, double reach,
                                  const std::vector<char>* known, Visit&& visit) const {
  const auto is_known = [&](std::initializer_list<int> vertices) {
    for (int s : vertices)
      if (known && !(*known)[s]) return false;
    return true;
  };
  std::vector<Box> boxes;
  std::vector<int> index;  // the tree's boxes: which triangle, then which edge
  for (size_t t = 0; t < triangles_.size(); ++t) {
    const auto& v = triangles_[t];
    if (!is_known({v[0], v[1], v[2]})) continue;
    boxes.push_back(primitive_box({v[0], v[1], v[2]}, x, end, 0));
    index.push_back((int)t);
  }
  const BoxTree triangles(std::move(boxes));
  for (int v : my_vertices_)
    triangles.overlapping(primitive_box({v}, x, end, reach), [&](int i) {
      const int t = index[i];
      const auto& tri = triangles_[t];
      const int j = joined_[v];
      if (joined_[tri[0]] != j && joined_[tri[1]] != j && joined_[tri[2]] != j) visit(Pair{PairKind::vertex_triangle, v, t});
    });
  boxes.clear();
  index.clear();
  for (size_t e = 0; e < edges_.size(); ++e) {
    const auto& v = edges_[e];
    if (!is_known({v[0], v[1]})) continue;
    boxes.push_back(primitive_box({v[0], v[1]}, x, end, reach));
    index.push_back((int)e);
  }
  const BoxTree edges(std::move(boxes));
  for (int e : my_edges_) {
    const auto& a = edges_[e];
    edges.overlapping(primitive_box({a[0], a[1]}, x, end, 0), [&](int i) {
      const int f = index[i];
      const auto& b = edges_[f];
      const int a0 = joined_[a[0]], a1 = joined_[a[1]], b0 = joined_[b[0]], b1 = joined_[b[1]];
      if (f > e && a0 != b0 && a0 != b1 && a1 != b0 && a1 != b1) visit(Pair{PairKind::edge_edge, e, f});
    });
  }
}

PetscErrorCode SelfContactTerm::candidates_cover(const std::vector<double>& x, const std::vector<double>* end,
                                                 bool* covered) const {
  PetscFunctionBeginUser;
  *covered = false;
  if (stale_) PetscFunctionReturn(0);
  // The moves since the build less a translation common to the whole surface (refresh_candidates),
  // so that a body that falls or flies keeps its list: at x and at end, the middle of the owners'
  // moves; unless that leaves moves no shorter than the largest (a body that spins about its
  // centre, say), and then none.
  std::array<MoveRange, 2> moves;
  for (int s : owned_surface_) {
    const Vec3 built(&built_at_[3 * s]);
    moves[0].add(Vec3(&x[3 * s]) - built);
    if (end) moves[1].add(Vec3(&(*end)[3 * s]) - built);
  }
  static_assert(sizeof(moves) == 14 * sizeof(double), "two MoveRanges reduce as 14 doubles");
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, moves[0].r.data(), 14, MPI_DOUBLE, MPI_MAX, PetscObjectComm((PetscObject)mesh_.dm)));
  const double spread = std::max(moves[0].spread(), moves[1].spread());
  const double largest = std::max(moves[0].largest(), moves[1].largest());
  const bool translated = spread < largest;
  const Vec3 shift_x = translated ? moves[0].middle() : Vec3::Zero(), shift_end = translated ? moves[1].middle() : Vec3::Zero();
  for (int s : ghosts_.known_list) {
    const Vec3 built(&built_at_[3 * s]);
    moved_[s] = (Vec3(&x[3 * s]) - built - shift_x).norm();
    if (end) moved_[s] = std::max(moved_[s], (Vec3(&(*end)[3 * s]) - built - shift_end).norm());
  }
  *covered = std::min(spread, largest) <= kMoveFraction * built_margin_;
  PetscFunctionReturn(0);
}

// Why the list misses no pair within d. A pair's distance is the least distance between a point of
// one primitive and a point of the other; each such point is a convex combination of its
// primitive's vertices, so if no vertex of a primitive has moved more than delta since the build,
// no point of it has, and the pair's distance has changed by at most the two primitives' deltas.
// The list holds every pair of this rank within d + margin at the build (the broad phase's boxes
// grown by d + margin hold the ball of that radius, then the distance decides), with that distance;
// any other pair is still farther than d + margin - 2 delta (delta: the largest move of a vertex),
// which is more than d while delta < margin / 2. A translation of the whole surface changes no
// pair's distance, so the moves delta may be measured less any one translation common to all
// vertices (candidates_cover takes out the middle of their range). The list is built again once a
// vertex has moved more than kMoveFraction (0.4) of the margin; the rest covers rounding. Within the list, a pair
// whose distance at the build less its primitives' moves is d or more cannot be within d and is
// passed over. The same holds all along a straight step whose both ends are within 0.4 of the
// margin (the path stays in the ball around the build's position), which is what limit_step needs.
PetscErrorCode SelfContactTerm::refresh_candidates() const {
  bool covered;
  PetscFunctionBeginUser;
  PetscCall(candidates_cover(x_, nullptr, &covered));
  if (covered) PetscFunctionReturn(0);
  PetscCall(PetscLogEventBegin(pairs_event_, 0, 0, 0, 0));
  // Built again within the step: its iterates move farther than the margin foresaw (a body that
  // stops on an obstacle, whose predicted motion was a free flight), so twice the margin, up to the cap.
  if (!stale_) step_margin_ = std::max(step_margin_, std::min(2 * step_margin_, margin_cap()));
  const double reach = spec_.distance + step_margin_;  // in distance less xi
  // The ghost layer for the list: every primitive within reach of this rank's (see plan_exchange).
  PetscCall(plan_exchange(x_, nullptr, reach + largest_offset_, &ghosts_));
  PetscCall(exchange(ghosts_, 3, x_));
  PetscCall(PetscInfo(nullptr, "self-contact ghost layer: this rank knows %zu of the %zu surface vertices, sends %zu and receives %zu per evaluation\n",
                      ghosts_.known_list.size(), ids_.size(), ghosts_.send.size(), ghosts_.recv.size()));
  candidates_.clear();
  broad_phase(x_, nullptr, reach + largest_offset_, &ghosts_.known, [&](const Pair& p) {
    const double gap = std::sqrt(squared_distance(p, x_)) - offset(p);
    if (gap <= reach) candidates_.push_back({p, gap});
  });
  // A canonical order: the energy and gradient sums do not depend on where the list was built.
  std::sort(candidates_.begin(), candidates_.end(), [](const Candidate& c, const Candidate& e) {
    return std::tie(c.pair.kind, c.pair.a, c.pair.b) < std::tie(e.pair.kind, e.pair.a, e.pair.b);
  });
  PetscCall(PetscInfo(nullptr, "self-contact candidates: %zu pairs within %g (d %g, margin %g)\n", candidates_.size(), reach,
                      spec_.distance, step_margin_));
  built_at_ = x_;
  built_margin_ = step_margin_;
  moved_.assign(ids_.size(), 0.0);
  stale_ = false;
  ++builds_;
  PetscCall(PetscLogEventEnd(pairs_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

double SelfContactTerm::pair_moves(const Pair& p) const {
  const std::array<int, 4> q = points(p);
  const int split = p.kind == PairKind::vertex_triangle ? 1 : 2;  // the first primitive's points
  double first = 0, second = 0;
  for (int k = 0; k < 4; ++k) {
    double& moved = k < split ? first : second;
    moved = std::max(moved, moved_[q[k]]);
  }
  return first + second;
}

bool SelfContactTerm::may_be_within_d(const Candidate& c) const {
  return c.distance - pair_moves(c.pair) < spec_.distance * (1 + 1e-9);  // the slack: rounding of the moves
}

template <class Visit>
void SelfContactTerm::near_pairs(Visit&& visit) const {
  for (const Candidate& c : candidates_)
    if (may_be_within_d(c)) visit(c.pair);
}

template <class Visit>
void SelfContactTerm::pair_hessians(bool psd, Visit&& visit) const {
  Matrix12d h;
  near_pairs([&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    if (pair_energy(p, coordinates(x_, q), nullptr, &h) != 0) visit(q, psd ? clamp_psd(h) : h);
  });
  for (const auto& [p, friction] : friction_) {
    const std::array<int, 4> q = points(p);
    pair_friction_energy(friction, eps_h_, coordinates(x_, q), nullptr, &h);
    visit(q, h);
  }
}

PetscErrorCode SelfContactTerm::begin_step(const StepStart& step) {
  const PetscScalar *x, *y;
  PetscInt lo, hi;
  MoveRange motion;  // of the free vertices from x_n to y
  PetscFunctionBeginUser;
  quasi_static_ = step.quasi_static;
  PetscCall(VecGetOwnershipRange(step.y, &lo, &hi));
  PetscCall(VecGetArrayRead(step.x_start, &x));
  PetscCall(VecGetArrayRead(step.y, &y));
  for (PetscInt v : owned_local_) {
    const PetscInt g = mesh_.global_dof[v] - lo;
    if (mesh_.global_dof[v] >= 0) motion.add(Vec3(&y[g]) - Vec3(&x[g]));
  }
  PetscCall(VecRestoreArrayRead(step.x_start, &x));
  PetscCall(VecRestoreArrayRead(step.y, &y));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, motion.r.data(), 7, MPI_DOUBLE, MPI_MAX, PetscObjectComm((PetscObject)mesh_.dm)));
  // A list that covers the step's predicted motion from where it is built (less the translation
  // common to all vertices, which moves no pair: candidates_cover), at least d, but at most
  // margin_cap(): beyond the mesh's spacing every primitive has neighbours of its own surface in
  // reach, and the list grows with the square of the reach while no more of them touch (a 41 x 41
  // cloth: 0.13 million candidates at 3.7 cm, 0.8 at 12 cm, and evaluations 7x slower than a list
  // rebuilt more often). What the terms compute does not depend on the margin (refresh_candidates,
  // limit_step); docs/records/2026-11-26-margin-cap.md has the timings.
  step_margin_ = std::max(spec_.distance, std::min(std::min(motion.spread(), motion.largest()) / kMoveFraction, margin_cap()));
  // Built again at the step's first evaluation whatever it covers: what a step computes depends
  // only on its start (a restart or the study's other trajectories in the same scene alike).
  stale_ = true;
  if (spec_.self_friction > 0) {
    // The surface at x_n: the free vertices' from x_n, the fixed ones' where the last evaluation
    // had them (a fixed point does not slide: its weight is 0).
    std::vector<double> start(x_.size());
    PetscCall(VecGetArrayRead(step.x_start, &x));
    for (size_t k = 0; k < owned_local_.size(); ++k) {
      const PetscInt g = mesh_.global_dof[owned_local_[k]];
      for (int d = 0; d < 3; ++d) start[3 * owned_surface_[k] + d] = g < 0 ? x_[3 * owned_surface_[k] + d] : x[g - lo + d];
    }
    PetscCall(VecRestoreArrayRead(step.x_start, &x));
    // The positions within d of this rank's primitives at x_n: the halo, then a ghost layer.
    friction_.clear();
    PetscCall(exchange(ghosts_, 3, start));
    Exchange near;
    PetscCall(plan_exchange(start, nullptr, spec_.distance + largest_offset_, &near));
    PetscCall(exchange(near, 3, start));
    eps_h_ = spec_.friction_velocity * step.dt;
    freeze_friction(start, near.known);
  }
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
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscFunctionBeginUser;
  // Each owner's start and end of its vertices, to the ranks that know them, then (below) to the
  // ranks the jump's swept boxes reach.
  path_.resize(6 * ids_.size());
  int any = 0;
  for (size_t k = 0; k < owned_local_.size(); ++k) {
    const PetscInt v = owned_local_[k];
    const int s = owned_surface_[k];
    for (int d = 0; d < 3; ++d) {
      path_[6 * s + d] = start_positions[3 * v + d];
      path_[6 * s + 3 + d] = step_at_[3 * s + d] = positions[3 * v + d];
    }
    any = any || Vec3(&start_positions[3 * v]) != Vec3(&positions[3 * v]);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_INT, MPI_MAX, comm));
  rejecting_region_ = 0;
  if (!any) PetscFunctionReturn(0);
  std::vector<double> start(3 * ids_.size()), end(3 * ids_.size());
  const auto unpack = [&](const std::vector<int>& known) {
    for (int s : known)
      for (int d = 0; d < 3; ++d) start[3 * s + d] = path_[6 * s + d], end[3 * s + d] = path_[6 * s + 3 + d];
  };
  PetscCall(exchange(ghosts_, 6, path_));
  unpack(ghosts_.known_list);
  Exchange swept;
  PetscCall(plan_exchange(start, &end, largest_offset_, &swept));
  PetscCall(exchange(swept, 6, path_));
  unpack(swept.known_list);
  struct {
    double t;
    int region;
  } first{HUGE_VAL, 0};
  broad_phase(start, &end, largest_offset_, &swept.known, [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    int mover = -1;
    bool one_region = region_[q[0]] > 0;
    for (int s : q) {
      if (mover < 0 && Vec3(&start[3 * s]) != Vec3(&end[3 * s])) mover = s;
      one_region = one_region && region_[s] == region_[q[0]];
    }
    if (mover < 0 || one_region) return;
    const Vector12d a = coordinates(start, q), b = coordinates(end, q);
    const double xi = offset(p);
    const double t = p.kind == PairKind::vertex_triangle ? vertex_triangle_impact(a, b, xi) : edge_edge_impact(a, b, xi);
    if (t < first.t || (t == first.t && region_[mover] < first.region)) first = {t, region_[mover]};
  });
  // The earliest over the ranks (the lowest region among equal times).
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm));
  if (first.t < 1) rejecting_region_ = first.region;
  PetscFunctionReturn(0);
}

double SelfContactTerm::squared_distance(const Pair& p, const std::vector<double>& x) const {
  const Vector12d c = coordinates(x, points(p));
  return p.kind == PairKind::vertex_triangle
             ? point_triangle_squared_distance(c.segment<3>(0), c.segment<3>(3), c.segment<3>(6), c.segment<3>(9))
             : edge_edge_squared_distance(c.segment<3>(0), c.segment<3>(3), c.segment<3>(6), c.segment<3>(9));
}

double SelfContactTerm::offset(const Pair& p) const {
  const std::array<int, 4> q = points(p);
  return half_thickness_[q[0]] + half_thickness_[q[p.kind == PairKind::vertex_triangle ? 1 : 2]];
}

double SelfContactTerm::pair_stiffness(const std::array<int, 4>& q) const {
  double mass = 0;
  int free_points = 0;
  for (int s : q)
    if (dof_[s] >= 0) mass += mass_[s], ++free_points;
  return free_points == 0 ? 0 : contact_stiffness_per_mass(spec_) * mass / free_points;
}

double SelfContactTerm::mollifier_eps(const Pair& p) const {
  if (p.kind != PairKind::edge_edge) return 0;
  const std::array<int, 4> q = points(p);
  return edge_edge_mollifier_threshold(Vec3(&rest_[3 * q[0]]), Vec3(&rest_[3 * q[1]]), Vec3(&rest_[3 * q[2]]),
                                       Vec3(&rest_[3 * q[3]]));
}

double SelfContactTerm::pair_energy(const Pair& p, const Vector12d& x, Vector12d* g, Matrix12d* H) const {
  const double k = pair_stiffness(points(p));
  if (k == 0) return 0;  // fixed against fixed: nothing to move
  const double e = self_contact_pair_energy(spec_, p.kind, x, mollifier_eps(p), offset(p), g, H);
  if (g) *g *= k;
  if (H) *H *= k;
  return k * e;
}

void SelfContactTerm::freeze_friction(const std::vector<double>& x, const std::vector<char>& known) {
  friction_.clear();
  broad_phase(x, nullptr, spec_.distance + largest_offset_, &known, [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    const double k = pair_stiffness(q);
    PairFriction f;
    if (k == 0 || !lagged_pair_friction(spec_, p.kind, coordinates(x, q), mollifier_eps(p), offset(p), k,
                                        spec_.self_friction, &f))
      return;
    for (int i = 0; i < 4; ++i)
      if (dof_[q[i]] < 0) f.weights[i] = 0;  // a fixed point's motion is not the pair's sliding
    friction_.emplace_back(p, f);
  });
  // The canonical order of the candidates: the sums do not depend on the broad phase's.
  std::sort(friction_.begin(), friction_.end(), [](const auto& f, const auto& g) {
    return std::tie(f.first.kind, f.first.a, f.first.b) < std::tie(g.first.kind, g.first.a, g.first.b);
  });
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
    if (gradient) accumulate(q, g);
  });
  for (const auto& [p, friction] : friction_) {  // after the normal pairs, in the pairs' order
    const std::array<int, 4> q = points(p);
    e += pair_friction_energy(friction, eps_h_, coordinates(x_, q), gradient ? &g : nullptr);
    if (gradient) accumulate(q, g);
  }
  *energy += e;
  if (gradient) PetscCall(exchange_gradient(gradient));
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

void SelfContactTerm::accumulate(const std::array<int, 4>& q, const Vector12d& g) const {
  for (int k = 0; k < 4; ++k) {
    const int s = q[k];
    if (dof_[s] < 0) continue;
    if (!touched_[s]) touched_[s] = 1, touched_list_.push_back(s);
    for (int d = 0; d < 3; ++d) accumulated_[3 * s + d] += g[3 * k + d];
  }
}

template <class Add>
PetscErrorCode SelfContactTerm::sum_at_owners(int width, const std::vector<double>& sums, std::vector<int>& vertices,
                                              Add&& add) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscMPIInt size, rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  // Per owner, in the surface's order; MPI_Alltoallv places the received ones in rank order.
  std::sort(vertices.begin(), vertices.end(),
            [&](int a, int b) { return std::make_pair(owner_[a], a) < std::make_pair(owner_[b], b); });
  std::vector<int> send_counts(size, 0), recv_counts(size), send_offsets(size + 1, 0), recv_offsets(size + 1, 0);
  std::vector<int> send_vertices;
  std::vector<double> send_values;
  for (int s : vertices) {
    if (owner_[s] == rank) {
      add(s, &sums[width * s]);
    } else {
      ++send_counts[owner_[s]];
      send_vertices.push_back(s);
      send_values.insert(send_values.end(), &sums[width * s], &sums[width * s] + width);
    }
  }
  if (size == 1) PetscFunctionReturn(0);
  PetscCallMPI(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, comm));
  for (int r = 0; r < size; ++r) {
    send_offsets[r + 1] = send_offsets[r] + send_counts[r];
    recv_offsets[r + 1] = recv_offsets[r] + recv_counts[r];
  }
  std::vector<int> recv_vertices(recv_offsets[size]);
  PetscCallMPI(MPI_Alltoallv(send_vertices.data(), send_counts.data(), send_offsets.data(), MPI_INT, recv_vertices.data(),
                             recv_counts.data(), recv_offsets.data(), MPI_INT, comm));
  for (int r = 0; r <= size; ++r) send_offsets[r] *= width, recv_offsets[r] *= width;
  for (int r = 0; r < size; ++r) send_counts[r] *= width, recv_counts[r] *= width;
  std::vector<double> recv_values(recv_offsets[size]);
  PetscCallMPI(MPI_Alltoallv(send_values.data(), send_counts.data(), send_offsets.data(), MPI_DOUBLE, recv_values.data(),
                             recv_counts.data(), recv_offsets.data(), MPI_DOUBLE, comm));
  for (size_t k = 0; k < recv_vertices.size(); ++k) add(recv_vertices[k], &recv_values[width * k]);
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::exchange_gradient(PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(gather_event_, 0, 0, 0, 0));
  // Each touched vertex once, with its sum over this rank's pairs (in the pairs' order).
  PetscCall(sum_at_owners(3, accumulated_, touched_list_, [&](int s, const double* g) {
    for (int d = 0; d < 3; ++d) gradient[mesh_.local_dof[local_of_[s]] + d] += g[d];
  }));
  for (int s : touched_list_) {
    touched_[s] = 0;
    for (int d = 0; d < 3; ++d) accumulated_[3 * s + d] = 0;
  }
  touched_list_.clear();
  PetscCall(PetscLogEventEnd(gather_event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  PetscFunctionBeginUser;
  if (rejecting_region_) PetscFunctionReturn(0);  // a rejected step (add_energy)
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  PetscCall(gather_positions(pos));
  PetscCall(refresh_candidates());
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> block;
  PetscErrorCode error = 0;
  const auto add = [&](const std::array<int, 4>& q) {
    PetscInt idx[12];
    for (int k = 0; k < 4; ++k)
      for (int d = 0; d < 3; ++d) idx[3 * k + d] = dof_[q[k]] < 0 ? -1 : dof_[q[k]] + d;
    error = MatSetValues(H, 12, idx, 12, idx, block.data(), ADD_VALUES);
  };
  pair_hessians(psd, [&](const std::array<int, 4>& q, const Matrix12d& h) {
    if (error) return;
    block = scale * h;
    add(q);
  });
  PetscCall(error);
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

// The candidates hold every pair add_hessian visits until the list is built again (near_pairs,
// may_be_within_d).
PetscErrorCode SelfContactTerm::add_couplings(const std::vector<double>& pos, std::vector<std::array<PetscInt, 2>>* out,
                                              unsigned long long* generation) const {
  PetscFunctionBeginUser;
  if (rejecting_region_) PetscFunctionReturn(0);  // a rejected step (add_energy)
  PetscCall(gather_positions(pos));
  PetscCall(refresh_candidates());
  *generation += builds_;
  if (!out) PetscFunctionReturn(0);
  const auto add = [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (dof_[q[i]] >= 0 && dof_[q[j]] >= 0 && q[i] != q[j]) out->push_back({dof_[q[i]], dof_[q[j]]});
  };
  // While the list serves, no vertex moves more than kMoveFraction of its margin from the build, so
  // a pair's distance falls by at most twice that: the farther candidates are never visited.
  const double farthest = spec_.distance + 2 * kMoveFraction * built_margin_;
  for (const Candidate& c : candidates_)
    if (c.distance < farthest * (1 + 1e-9)) add(c.pair);
  for (const auto& f : friction_) add(f.first);
  PetscFunctionReturn(0);
}

// Each pair's diagonal blocks summed per surface vertex on this rank (in the pairs' order, then
// the friction pairs'), then sent to the owners as the gradient is: an owner appends its own sum and
// one per other rank with pairs at the vertex (Body::vertex_stiffness adds them up), so
// ContactH0::gather receives every block from its vertex's owner only.
PetscErrorCode SelfContactTerm::add_vertex_stiffness(const std::vector<double>& pos, std::vector<VertexStiffness>& out) const {
  PetscFunctionBeginUser;
  if (rejecting_region_) PetscFunctionReturn(0);  // a rejected step (add_energy)
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  PetscCall(gather_positions(pos));
  PetscCall(refresh_candidates());
  std::vector<double> sums(9 * ids_.size(), 0.0);
  std::vector<int> vertices;
  std::vector<char> seen(ids_.size(), 0);
  const auto add = [&](const std::array<int, 4>& q, const Matrix12d& h) {
    for (int k = 0; k < 4; ++k) {
      const int s = q[k];
      if (dof_[s] < 0) continue;
      if (!seen[s]) seen[s] = 1, vertices.push_back(s);
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(&sums[9 * s]) += h.block<3, 3>(3 * k, 3 * k);
    }
  };
  pair_hessians(true, [&](const std::array<int, 4>& q, const Matrix12d& h) {
    if (std::isfinite(h.sum())) add(q, h);
  });
  PetscCall(sum_at_owners(9, sums, vertices, [&](int s, const double* K) {
    VertexStiffness block;
    block.dof = dof_[s];
    std::copy_n(K, 9, block.K.begin());
    out.push_back(block);
  }));
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::bound_step(Vec x, Vec dir, double* alpha, bool may_use_list) const {
  const PetscScalar *a, *u;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  // Each owner sends its surface vertices' position and step (fixed ones: where the step has them,
  // not moving) to the ranks that know them.
  PetscCall(PetscLogEventBegin(gather_event_, 0, 0, 0, 0));
  PetscCall(VecGetOwnershipRange(x, &lo, &hi));
  PetscCall(VecGetArrayRead(x, &a));
  PetscCall(VecGetArrayRead(dir, &u));
  if (quasi_static_) {
    // In a static step no surface vertex moves more than the mean edge in one bound step (a smaller
    // alpha is as admissible): a step of a body that no support holds is s^2 g long (1.6e5 m for a
    // cube above a block), its swept boxes met every pair and each pair's additive CCD took dozens
    // of steps: 0.75 s per iteration on 59 vertices (docs/self-contact.md). Inertia bounds a dynamic
    // step's, which this leaves as they were.
    double longest = 0;
    for (size_t k = 0; k < owned_local_.size(); ++k) {
      const PetscInt g = mesh_.global_dof[owned_local_[k]];
      if (g >= 0) longest = std::max(longest, *alpha * Vec3(&u[g - lo]).norm());
    }
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &longest, 1, MPI_DOUBLE, MPI_MAX, PetscObjectComm((PetscObject)mesh_.dm)));
    if (longest > mean_edge_ && mean_edge_ > 0) *alpha *= mean_edge_ / longest;
  }
  path_.resize(6 * ids_.size());
  for (size_t k = 0; k < owned_local_.size(); ++k) {
    const PetscInt g = mesh_.global_dof[owned_local_[k]];
    double* out = &path_[6 * owned_surface_[k]];
    for (int d = 0; d < 3; ++d) out[d] = g < 0 ? step_at_[3 * owned_surface_[k] + d] : a[g - lo + d];
    for (int d = 0; d < 3; ++d) out[3 + d] = g < 0 ? 0.0 : *alpha * u[g - lo + d];
  }
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCall(VecRestoreArrayRead(dir, &u));
  PetscCall(exchange(ghosts_, 6, path_));
  PetscCall(PetscLogEventEnd(gather_event_, 0, 0, 0, 0));
  end_.resize(x_.size());
  const auto unpack = [&](const std::vector<int>& known) {
    for (int s : known)
      for (int d = 0; d < 3; ++d) {
        x_[3 * s + d] = path_[6 * s + d];
        end_[3 * s + d] = path_[6 * s + d] + path_[6 * s + 3 + d];
      }
  };
  unpack(ghosts_.known_list);
  double t = 1;
  const auto bound = [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    const Vector12d start = coordinates(x_, q), stop = coordinates(end_, q);
    const double xi = offset(p);
    const double impact = p.kind == PairKind::vertex_triangle ? vertex_triangle_impact(start, stop, xi)
                                                              : edge_edge_impact(start, stop, xi);
    t = std::min(t, impact);
  };
  bool covered = false;
  if (may_use_list) PetscCall(candidates_cover(x_, &end_, &covered));
  if (covered) {
    ++list_bounds_;
    // The candidates the other branch's broad phase would visit, so that t does not depend on the
    // branch. A pair off the list stays farther than d + margin/5 along the step, more than a ninth
    // of where it starts, so its impact time is infinite (pair_ccd.hpp: a tenth) in both branches;
    // so is that of a listed pair whose clearance along the step is at least a quarter of its
    // largest possible start (bounds from the build's distance and the moves).
    for (const Candidate& c : candidates_) {
      const double moves = pair_moves(c.pair);
      if (c.distance - moves >= 0.25 * (c.distance + moves)) continue;
      if (boxes_meet(c.pair, x_, &end_, largest_offset_)) bound(c.pair);
    }
  } else {  // a ghost layer for this step alone: the primitives whose swept boxes reach this rank's
    Exchange swept;
    PetscCall(plan_exchange(x_, &end_, largest_offset_, &swept));
    PetscCall(exchange(swept, 6, path_));
    unpack(swept.known_list);
    broad_phase(x_, &end_, largest_offset_, &swept.known, bound);  // boxes more than xi apart never come within xi
  }
  *alpha *= t;  // the pair keeps a tenth of its clearance above xi there (pair_ccd.hpp): never within xi
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::touching_pairs(const std::vector<double>& pos, long* count) const {
  PetscFunctionBeginUser;
  PetscCall(gather_positions(pos));
  Exchange touching;  // the primitives whose boxes touch this rank's
  PetscCall(plan_exchange(x_, nullptr, largest_offset_, &touching));
  PetscCall(exchange(touching, 3, x_));
  long local = 0;
  broad_phase(x_, nullptr, largest_offset_, &touching.known, [&](const Pair& p) {
    const double xi = offset(p);
    local += squared_distance(p, x_) <= xi * xi;
  });
  PetscCallMPI(MPI_Allreduce(&local, count, 1, MPI_LONG, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm)));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::closest_rest_pair(double* gap_out, double* xi_out, int64_t* vertex_id) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  constexpr int64_t kNone = std::numeric_limits<int64_t>::max();
  double gap = spec_.distance, xi = 0;  // the closest pair's distance less its xi, once below d
  int64_t id = kNone;
  PetscFunctionBeginUser;
  broad_phase(rest_, nullptr, spec_.distance + largest_offset_, nullptr, [&](const Pair& p) {
    const std::array<int, 4> q = points(p);
    if (body_[q[0]] != body_[q[2]]) return;  // two bodies placed close: not the mesh's spacing
    bool free = false;
    for (int s : q) free = free || dof_[s] >= 0;
    if (!free) return;  // fixed against fixed: no force either
    const double g = std::sqrt(squared_distance(p, rest_)) - offset(p);
    int64_t lowest = ids_[q[0]];
    for (int s : q) lowest = std::min(lowest, ids_[s]);
    if (g < gap || (g == gap && g < spec_.distance && lowest < id)) gap = g, xi = offset(p), id = lowest;
  });
  if (id == kNone) gap = HUGE_VAL;
  const double mine = gap;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &gap, 1, MPI_DOUBLE, MPI_MIN, comm));
  int64_t lowest = mine == gap ? id : kNone;  // the lowest id among the closest pairs
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &lowest, 1, MPI_INT64_T, MPI_MIN, comm));
  if (lowest != id) xi = 0;  // that pair's xi, from the rank that found it
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &xi, 1, MPI_DOUBLE, MPI_MAX, comm));
  *gap_out = gap;
  *xi_out = xi;
  *vertex_id = lowest;
  PetscFunctionReturn(0);
}

std::string SelfContactTerm::describe() const {
  char text[300];
  std::snprintf(text, sizeof text,
                "self-contact: %zu surface triangles, %zu edges, %zu vertices (each rank's own and a ghost layer "
                "within reach), %s, distance %.4g, stiffness %.4g",
                triangles_.size(), edges_.size(), ids_.size(),
                kContactModelNames[size_t(spec_.model)].c_str(), spec_.distance, spec_.stiffness);
  std::string out = text;
  for (const SelfContactBody& b : bodies_)
    if (b.thickness > 0) {
      std::snprintf(text, sizeof text, ", %s cloth thickness %.4g", b.key.empty() ? "the" : (b.key + "'s").c_str(), b.thickness);
      out += text;
    }
  if (spec_.self_friction > 0) {
    std::snprintf(text, sizeof text, ", friction %.4g (friction_velocity %.4g)", spec_.self_friction, spec_.friction_velocity);
    out += text;
  }
  return out;
}

}  // namespace hyperqn

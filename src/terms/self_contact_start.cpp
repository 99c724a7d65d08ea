// Self-contact's checks of a scene's start and its explanations of a rejected step
// (terms/self_contact.hpp): surfaces closer at rest than the contact distance, triangles that cross
// at frame 0, pairs that touch where the barrier is infinite, and a fixed region that drives its
// surface into another.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "geometry/box_tree.hpp"
#include "geometry/triangle_intersection.hpp"
#include "terms/self_contact.hpp"

namespace hyperqn {

namespace {

using Vec3 = Eigen::Vector3d;

// x > 0 rounded down to two significant digits (a value to suggest that still fits).
double two_digits_below(double x) {
  const double scale = std::pow(10.0, std::floor(std::log10(x)) - 1);
  return std::floor(x / scale) * scale;
}

}  // namespace

void SelfContactTerm::rest_gap_problem(double gap, double xi, int64_t vertex, InputProblem& out) const {
  char what[700];
  const double apart = gap + xi;
  if (gap <= 0 && xi > 0) {  // within the thickness: no activation distance fits
    const int s = (int)(std::lower_bound(ids_.begin(), ids_.end(), vertex) - ids_.begin());
    const SelfContactBody& b = bodies_[body_[s]];
    std::snprintf(what, sizeof what,
                  "%g is too large for the cloth's mesh: two of its primitives that share no vertex (one of them at "
                  "vertex %lld) are %.4g apart at rest, within the thickness, so self-contact would push the mesh "
                  "apart from itself at rest; ",
                  b.thickness, (long long)vertex, apart);
    out.line = b.thickness_line;
    out.key = (b.key.empty() ? "" : b.key + ".") + "cloth.thickness";
    out.what = what;
    if (apart > spec_.distance)
      std::snprintf(what, sizeof what, "use a thickness below that gap less %s %g, e.g. %g", spec_.distance_key,
                    spec_.distance, two_digits_below(apart - spec_.distance));
    else
      std::snprintf(what, sizeof what, "that gap is below %s %g too: a thinner cloth and a smaller distance",
                    spec_.distance_key, spec_.distance);
    out.what += what;
    return;
  }
  // Half the gap: the mesh at rest stays clear of the layer.
  const double suggested = gap > 0 ? two_digits_below(gap / 2) : 0;
  char beyond[120] = "";
  if (xi > 0) std::snprintf(beyond, sizeof beyond, ", %.4g beyond their thickness offset %.4g (cloth.thickness),", gap, xi);
  std::snprintf(what, sizeof what,
                "%s%g is too large for the surface: two of its primitives in one body that share no vertex (one of "
                "them at vertex %lld) are %.4g apart at rest%s closer than the activation distance, so self-contact "
                "would push the mesh apart from itself at rest; ",
                spec_.distance_line > 0 ? "" : "the default ", spec_.distance, (long long)vertex, apart,
                xi > 0 ? beyond : ",");
  out.line = spec_.distance_line > 0 ? spec_.distance_line : spec_.self_line;
  out.key = spec_.distance_key;
  out.what = what;
  if (gap > 0) {
    // The colliders' distance may stay larger: self_distance takes the self-contact's alone.
    std::snprintf(what, sizeof what, "use a distance below that gap, e.g. %s: %g (half of it)%s", spec_.distance_key,
                  suggested, spec_.self_distance > 0 ? "" : ", or contact.self_distance for self-contact alone");
    out.what += what;
  } else {
    out.what += "they touch (coincident primitives), which no distance fits";
  }
}

PetscErrorCode SelfContactTerm::count_crossings(const std::vector<double>& pos, Crossings& out) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(gather_positions(pos));
  Exchange touching;  // the triangles whose boxes touch this rank's
  PetscCall(plan_exchange(x_, nullptr, 0, &touching));
  PetscCall(exchange(touching, 3, x_));
  // The checker's tolerance: 1e-8 of the diagonal of the bounding box of all the scene's vertices.
  Vec3 lo = Vec3::Constant(HUGE_VAL), hi = Vec3::Constant(-HUGE_VAL);
  for (size_t v = 0; 3 * v < pos.size(); ++v) {
    lo = lo.cwiseMin(Vec3(&pos[3 * v]));
    hi = hi.cwiseMax(Vec3(&pos[3 * v]));
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, lo.data(), 3, MPI_DOUBLE, MPI_MIN, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, hi.data(), 3, MPI_DOUBLE, MPI_MAX, comm));
  const double tol = kIntersectionRtol * (hi - lo).norm();
  const long n = (long)triangles_.size();
  const auto corners = [&](long t) {
    Triangle3 c;
    for (int k = 0; k < 3; ++k) c[k] = Vec3(&x_[3 * triangles_[t][k]]);
    return c;
  };
  std::vector<Box> boxes;
  std::vector<int> index;  // the tree's boxes: the known triangles
  std::vector<char> usable(n, 0);
  for (long t = 0; t < n; ++t) {
    const auto& v = triangles_[t];
    if (!touching.known[v[0]] || !touching.known[v[1]] || !touching.known[v[2]]) continue;
    const Triangle3 c = corners(t);
    usable[t] = !degenerate_triangle(c, tol);
    boxes.push_back(Box::around({c[0], c[1], c[2]}, 0));
    index.push_back((int)t);
  }
  const BoxTree tree(std::move(boxes));
  // Each rank tests the pairs (t, u > t) of its triangles t (a crossing u overlaps t's box, so its
  // vertices are in the ghost layer); the first pair is the lowest (t, u) in the surface's order,
  // the same at any rank count.
  long count = 0;
  long long first = std::numeric_limits<long long>::max();
  for (int t : my_triangles_) {
    if (!usable[t]) continue;
    const Triangle3 a = corners(t);
    const auto& ta = triangles_[t];
    tree.overlapping(Box::around({a[0], a[1], a[2]}, 0), [&](int i) {
      const int u = index[i];
      const auto& tb = triangles_[u];
      if (u <= t || !usable[u]) return;
      for (int i : ta)
        if (i == tb[0] || i == tb[1] || i == tb[2]) return;  // neighbours in a mesh
      if (!triangles_cross(a, corners(u), tol)) return;
      ++count;
      first = std::min(first, (long long)t * n + u);
    });
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &count, 1, MPI_LONG, MPI_SUM, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_LONG_LONG, MPI_MIN, comm));
  out = Crossings();
  out.count = count;
  if (count == 0) PetscFunctionReturn(0);
  const long t = (long)(first / n), u = (long)(first % n);
  Vec3 at = Vec3::Zero();  // from the rank of t, which found the pair
  if (owner_[triangles_[t][0]] == rank) triangles_cross(corners(t), corners(u), tol, &at);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, at.data(), 3, MPI_DOUBLE, MPI_SUM, comm));
  out.first = {t, u};
  out.at = at;
  PetscFunctionReturn(0);
}

std::string SelfContactTerm::crossings_sentence(const Crossings& c) const {
  const auto ids = [&](long k) {
    const auto& tri = triangles_[k];
    return std::to_string(ids_[tri[0]]) + ", " + std::to_string(ids_[tri[1]]) + ", " + std::to_string(ids_[tri[2]]);
  };
  char where[200];
  std::snprintf(where, sizeof where, ", near (%.6g, %.6g, %.6g)", c.at[0], c.at[1], c.at[2]);
  return std::to_string(c.count) + " pair" + (c.count == 1 ? "" : "s") + " of surface triangles in the scene cross (by " +
         "more than 1e-8 of its diagonal, as hyperqn_tools.intersections counts them); the first: the triangle of " +
         "vertices " + ids(c.first[0]) + " and that of vertices " + ids(c.first[1]) + where;
}

PetscErrorCode SelfContactTerm::check_intersections(const std::vector<double>& pos, InputProblem& out) const {
  Crossings c;
  PetscFunctionBeginUser;
  PetscCall(count_crossings(pos, c));
  if (c.count == 0) PetscFunctionReturn(0);
  const int32_t bt = body_[triangles_[c.first[0]][0]], bu = body_[triangles_[c.first[1]][0]];
  const int32_t b1 = std::min(bt, bu), b2 = std::max(bt, bu);
  const bool named = b2 < (int32_t)bodies_.size() && !bodies_[b1].key.empty();
  std::string what;
  if (!named) {
    out.key = "contact.self";
    out.line = spec_.self_line;
    what = "the body's surface crosses itself at frame 0: ";
  } else {
    out.key = bodies_[b1].key;
    out.line = bodies_[b1].line;
    what = b1 == b2 ? "its surface crosses itself at frame 0: "
                    : "its surface and that of " + bodies_[b2].key + " (deck line " + std::to_string(bodies_[b2].line) +
                          ") cross at frame 0: ";
  }
  what += crossings_sentence(c) + ". Self-contact cannot separate " +
          "surfaces that start crossed (the barrier's energy is infinite on the way out; the penalty pushes each pair " +
          "to its nearer side, which keeps them crossed): " +
          (named && b1 != b2 ? "move the bodies apart" : "start from a mesh that does not cross itself");
  out.what = what;
  PetscFunctionReturn(0);
}

// The penalty's frames: crossings are counted at every frame's end (the barrier cannot cross).
PetscErrorCode SelfContactTerm::report(const std::vector<double>& pos, TermReport& out) const {
  Crossings c;
  PetscFunctionBeginUser;
  if (barrier_) PetscFunctionReturn(0);
  PetscCall(count_crossings(pos, c));
  out.rows.push_back(std::to_string(c.count));
  out.maxima.emplace_back("max_self_crossings", (double)c.count);
  if (c.count > 0)
    out.flags.emplace_back("self_crossing_frames", "self-contact (penalty): " + crossings_sentence(c) +
                                                       ". The penalty does not keep surfaces apart; the barrier does "
                                                       "(contact.model: barrier, docs/self-contact.md)");
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::check_start(const std::vector<double>& pos, InputProblem& out) const {
  double gap, xi;
  int64_t vertex;
  long touching;
  PetscFunctionBeginUser;
  // Crossing triangles first: their rest gap is 0 too, and no contact.distance would fix them.
  PetscCall(check_intersections(pos, out));
  if (!out.what.empty()) PetscFunctionReturn(0);
  PetscCall(closest_rest_pair(&gap, &xi, &vertex));
  if (gap < spec_.distance) {
    rest_gap_problem(gap, xi, vertex, out);
    PetscFunctionReturn(0);
  }
  if (!barrier_) PetscFunctionReturn(0);
  PetscCall(touching_pairs(pos, &touching));
  if (touching == 0) PetscFunctionReturn(0);
  out.line = spec_.self_line;
  out.key = "contact.self";
  out.what = std::to_string(touching) + " pairs of surface primitives " +
             (largest_offset_ > 0 ? "touch or are within their thickness offset" : "touch") +
             " at frame 0, where the barrier's energy is infinite: move the bodies apart (or use the penalty)";
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
    why += std::string(why.empty() ? "" : "; ") + "self-contact: " + std::to_string(touching) +
           " pairs of surface primitives touch" + (largest_offset_ > 0 ? " or are within their thickness offset" : "") +
           ", where the barrier is infinite";
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

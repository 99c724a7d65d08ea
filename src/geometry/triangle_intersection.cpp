#include "geometry/triangle_intersection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hyperqn {

namespace {

using Vec3 = Eigen::Vector3d;

Vec3 unit_normal(const Triangle3& t) { return (t[1] - t[0]).cross(t[2] - t[0]).normalized(); }

// Signed distances of t's corners from the plane (origin, unit normal), 0 within tol.
std::array<double, 3> snapped_distances(const Triangle3& t, const Vec3& origin, const Vec3& normal, double tol) {
  std::array<double, 3> d;
  for (int k = 0; k < 3; ++k) {
    d[k] = (t[k] - origin).dot(normal);
    if (std::abs(d[k]) <= tol) d[k] = 0;
  }
  return d;
}

bool straddles(const std::array<double, 3>& d) {
  return *std::max_element(d.begin(), d.end()) > 0 && *std::min_element(d.begin(), d.end()) < 0;
}

// Where t (distances d of both signs from a plane) cuts that plane: the interval [lo, hi] of the
// cut segment's projection onto the unit direction of the cut line, and the segment's ends.
struct Cut {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  Vec3 at_lo, at_hi;
  void add(double s, const Vec3& p) {
    if (s < lo) lo = s, at_lo = p;
    if (s > hi) hi = s, at_hi = p;
  }
};

Cut cut_interval(const Triangle3& t, const std::array<double, 3>& d, const Vec3& direction) {
  Cut cut;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0) cut.add(t[i].dot(direction), t[i]);
    const int j = (i + 1) % 3;
    if (d[i] * d[j] < 0) {
      const Vec3 p = t[i] + d[i] / (d[i] - d[j]) * (t[j] - t[i]);
      const double s = t[i].dot(direction) + d[i] / (d[i] - d[j]) * (t[j].dot(direction) - t[i].dot(direction));
      cut.add(s, p);
    }
  }
  return cut;
}

// Whether a and b, both within tol of the plane of base (unit normal given), overlap by more than
// tol in that plane: no edge normal of either separates them.
bool coplanar_overlap(const Triangle3& a, const Triangle3& b, const Triangle3& base, const Vec3& normal, double tol) {
  const Vec3 e1 = (base[1] - base[0]).normalized(), e2 = normal.cross(e1);
  const auto flat = [&](const Triangle3& t) {
    std::array<Eigen::Vector2d, 3> out;
    for (int k = 0; k < 3; ++k) out[k] = {t[k].dot(e1), t[k].dot(e2)};
    return out;
  };
  const auto fa = flat(a), fb = flat(b);
  for (const auto* tri : {&fa, &fb})
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector2d edge = (*tri)[(i + 1) % 3] - (*tri)[i];
      const Eigen::Vector2d axis = Eigen::Vector2d(-edge[1], edge[0]).normalized();
      double a_lo = HUGE_VAL, a_hi = -HUGE_VAL, b_lo = HUGE_VAL, b_hi = -HUGE_VAL;
      for (int k = 0; k < 3; ++k) {
        a_lo = std::min(a_lo, fa[k].dot(axis)), a_hi = std::max(a_hi, fa[k].dot(axis));
        b_lo = std::min(b_lo, fb[k].dot(axis)), b_hi = std::max(b_hi, fb[k].dot(axis));
      }
      if (!(std::min(a_hi, b_hi) - std::max(a_lo, b_lo) > tol)) return false;
    }
  return true;
}

}  // namespace

bool degenerate_triangle(const Triangle3& t, double tol) {
  const double twice_area = (t[1] - t[0]).cross(t[2] - t[0]).norm();
  const double longest = std::max({(t[1] - t[0]).norm(), (t[2] - t[1]).norm(), (t[0] - t[2]).norm()});
  return twice_area <= tol * longest;
}

bool triangles_cross(const Triangle3& a, const Triangle3& b, double tol, Vec3* point) {
  const Vec3 na = unit_normal(a), nb = unit_normal(b);
  const std::array<double, 3> db = snapped_distances(b, a[0], na, tol);  // b's corners from a's plane
  const std::array<double, 3> da = snapped_distances(a, b[0], nb, tol);
  const auto all_zero = [](const std::array<double, 3>& d) { return d[0] == 0 && d[1] == 0 && d[2] == 0; };
  const bool in_a_plane = all_zero(db), in_b_plane = all_zero(da);
  if (in_a_plane || in_b_plane) {
    const bool overlap = in_a_plane ? coplanar_overlap(a, b, a, na, tol) : coplanar_overlap(a, b, b, nb, tol);
    if (overlap && point) *point = (a[0] + a[1] + a[2]) / 3;
    return overlap;
  }
  if (!straddles(da) || !straddles(db)) return false;
  const Vec3 direction = na.cross(nb).normalized();
  const Cut ca = cut_interval(a, da, direction), cb = cut_interval(b, db, direction);
  const double lo = std::max(ca.lo, cb.lo), hi = std::min(ca.hi, cb.hi);
  if (!(hi - lo > tol)) return false;
  if (point) {  // the middle of the common segment, on a's cut
    const double s = 0.5 * (lo + hi);
    *point = ca.hi > ca.lo ? Vec3(ca.at_lo + (s - ca.lo) / (ca.hi - ca.lo) * (ca.at_hi - ca.at_lo)) : ca.at_lo;
  }
  return true;
}

}  // namespace hyperqn

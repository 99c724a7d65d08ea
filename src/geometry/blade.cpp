#include "geometry/blade.hpp"

#include <algorithm>
#include <cmath>

namespace hyperqn {

static Eigen::Vector3d vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

BladeFrame::BladeFrame(const CutSpec& c) {
  origin = vec(c.center);
  n = vec(c.normal).normalized();
  const Eigen::Vector3d a = vec(c.axis);
  u = (a - a.dot(n) * n).normalized();
  w = n.cross(u);
  half[0] = 0.5 * c.size[0];
  half[1] = 0.5 * c.size[1];
}

std::string blade_motion_problem(const CutSpec& c) {
  const Motion& m = c.motion;
  if (!m.active) return "";
  if (m.rate_deg != 0) {
    if (!c.surface.empty()) return "a triangle-mesh blade does not turn (rotate): it moves along itself only (translate)";
    if (vec(m.axis).normalized().cross(vec(c.normal).normalized()).norm() > 1e-12)
      return "rotate.axis is not along the blade's normal: a blade turns in its plane only (turning out of it, it "
             "would sweep a volume, not a crack)";
  }
  const Eigen::Vector3d v = vec(m.velocity);
  if (!c.surface.empty()) {
    // A triangle's plane holds the velocity to 1e-9 of its length (a file's coordinates are rounded).
    for (size_t k = 0; k < c.mesh_triangles.size(); ++k) {
      const auto& t = c.mesh_triangles[k];
      const Eigen::Vector3d& p = c.mesh_vertices[t[0]];
      const Eigen::Vector3d n = (c.mesh_vertices[t[1]] - p).cross(c.mesh_vertices[t[2]] - p).normalized();
      if (std::fabs(v.dot(n)) > 1e-9 * v.norm())
        return "translate.velocity leaves the plane of the surface's triangle " + std::to_string(k + 1) +
               " (of its triangles with an area): a blade moves along itself (a curved blade is a cylinder along the "
               "velocity)";
    }
    return "";
  }
  const Eigen::Vector3d n = vec(c.normal).normalized();
  if (std::fabs(v.dot(n)) > 1e-12 * v.norm())
    return "translate.velocity leaves the blade's plane (its part along normal is not 0): a blade moves in its plane";
  return "";
}

BladeSweep::BladeSweep(const CutSpec& c, double t0, double t1) : f_(c) {
  c0_ = moved(c.motion, f_.origin, t0);
  const Eigen::Vector3d d = moved(c.motion, f_.origin, t1) - c0_;
  d_[0] = d.dot(f_.u);
  d_[1] = d.dot(f_.w);
  if (c.surface.empty() && c.motion.active && c.motion.rate_deg != 0) {
    // theta, the turn about the normal (the axis may point against it); poses at progress between
    // the step's ends, every kBladeTurnSample of the turn.
    const double rate = (vec(c.motion.axis).dot(f_.n) > 0 ? 1 : -1) * c.motion.rate_deg * M_PI / 180.0;
    const double tau0 = motion_progress(c.motion, t0), tau1 = motion_progress(c.motion, t1);
    turns_ = true;
    turn_ = rate * (tau1 - tau0);
    const int samples = std::max(1, static_cast<int>(std::ceil(std::fabs(turn_) / kBladeTurnSample)));
    for (int k = 0; k <= samples; ++k) {
      const double tau = tau0 + (tau1 - tau0) * k / samples;
      const Eigen::Vector3d o = moved_by(c.motion, f_.origin, tau) - f_.origin;
      unturn_.push_back({std::cos(rate * tau), std::sin(rate * tau)});
      offset_.push_back({o.dot(f_.u), o.dot(f_.w)});
    }
  }
  if (c.surface.empty()) return;
  mesh_ = true;
  spec_ = &c;
  t0_ = t0;
  t1_ = t1;
  tree_ = c.mesh_tree;
  const Eigen::Vector3d& v0 = c.mesh_vertices[c.mesh_triangles[0][0]];
  shift_ = moved(c.motion, v0, t0) - v0;
  step_ = moved(c.motion, v0, t1) - moved(c.motion, v0, t0);
  hair_ = 1e-12 * (1 + std::max(tree_->bounds().lo.cwiseAbs().maxCoeff(), tree_->bounds().hi.cwiseAbs().maxCoeff()) +
                   shift_.cwiseAbs().maxCoeff() + step_.cwiseAbs().maxCoeff());
  // The whole sweep's box, from the box at t = 0 moved (grown by the hair: a prefilter).
  lo_ = tree_->bounds().lo + shift_ + step_.cwiseMin(0.0) - Eigen::Vector3d::Constant(hair_);
  hi_ = tree_->bounds().hi + shift_ + step_.cwiseMax(0.0) + Eigen::Vector3d::Constant(hair_);
  tris_.resize(c.mesh_triangles.size());
  made_.assign(c.mesh_triangles.size(), 0);
}

// Triangle k over the step, made when a query first meets it (a blade of many triangles meets
// few of them in a step).
const BladeSweep::Tri& BladeSweep::triangle(int k) const {
  Tri& t = tris_[k];
  if (made_[k]) return t;
  made_[k] = 1;
  const auto& tri = spec_->mesh_triangles[k];
  const Eigen::Vector3d& v0 = spec_->mesh_vertices[tri[0]];
  t.p = moved(spec_->motion, v0, t0_);
  const Eigen::Vector3d dt = moved(spec_->motion, v0, t1_) - t.p;
  const Eigen::Vector3d e1 = spec_->mesh_vertices[tri[1]] - v0, e2 = spec_->mesh_vertices[tri[2]] - v0;
  t.n = e1.cross(e2).normalized();
  t.u = e1.normalized();
  t.w = t.n.cross(t.u);
  t.q[0][0] = e1.dot(t.u), t.q[0][1] = e1.dot(t.w);
  t.q[1][0] = e2.dot(t.u), t.q[1][1] = e2.dot(t.w);
  t.d[0] = dt.dot(t.u), t.d[1] = dt.dot(t.w);
  t.lo = t.hi = t.p;
  for (const Eigen::Vector3d& x : {t.p, Eigen::Vector3d(t.p + e1), Eigen::Vector3d(t.p + e2)})
    for (const Eigen::Vector3d& y : {x, Eigen::Vector3d(x + dt)}) {
      t.lo = t.lo.cwiseMin(y);
      t.hi = t.hi.cwiseMax(y);
    }
  return t;
}

void index_blade_surface(CutSpec& c) {
  std::vector<Box> boxes;
  boxes.reserve(c.mesh_triangles.size());
  for (const auto& t : c.mesh_triangles)
    boxes.push_back(Box::around({c.mesh_vertices[t[0]], c.mesh_vertices[t[1]], c.mesh_vertices[t[2]]}, 0));
  c.mesh_tree = std::make_shared<const BoxTree>(std::move(boxes));
}

// A triangle's sweep box is its box at t = 0 moved by shift_ and stretched along step_, so it
// overlaps [lo, hi] when its box at t = 0 overlaps [lo, hi] moved back so. The query grows by a
// hair (1e-12 of the coordinates' size) so that the translations' round-off cannot drop a
// triangle; the triangle's own sweep box, then the exact test, decide as for every triangle before.
template <class Test>
bool BladeSweep::any_triangle(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Test&& test) const {
  Box query{lo - shift_ - step_.cwiseMax(0.0), hi - shift_ - step_.cwiseMin(0.0)};
  query.inflate(hair_);
  return tree_->any_overlapping(query, [&](int k) {
    const Tri& t = triangle(k);
    return (lo.array() <= t.hi.array()).all() && (hi.array() >= t.lo.array()).all() && test(t);
  });
}

static double cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// (x, y) in the closed triangle (0, a, b) of 2D points.
static bool in_triangle(double x, double y, const double a[2], const double b[2]) {
  const double s0 = cross2(a[0], a[1], x, y), s1 = cross2(b[0] - a[0], b[1] - a[1], x - a[0], y - a[1]),
               s2 = cross2(-b[0], -b[1], x - b[0], y - b[1]);
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

// (x, y) in the closed parallelogram e0 + alpha e + beta d, alpha and beta in [0, 1] (none when e
// and d are parallel: the other pieces of the sweep cover it).
static bool in_parallelogram(double x, double y, const double e0[2], const double e[2], const double d[2]) {
  const double det = cross2(e[0], e[1], d[0], d[1]);
  if (det == 0) return false;
  const double px = x - e0[0], py = y - e0[1];
  const double alpha = cross2(px, py, d[0], d[1]) / det, beta = cross2(e[0], e[1], px, py) / det;
  return alpha >= 0 && alpha <= 1 && beta >= 0 && beta <= 1;
}

// As the rectangle's test, for one triangle: a and b on opposite sides of its plane (a point on it
// counts as on the normal's side), and the crossing point in the triangle's sweep, the triangle at
// t0, at t1, or a parallelogram one of its edges sweeps (their union is the triangle's Minkowski sum
// with the step's displacement).
bool BladeSweep::mesh_crosses(const Tri& t, const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const double da = t.n.dot(a - t.p), db = t.n.dot(b - t.p);
  if ((da >= 0) == (db >= 0)) return false;
  const Eigen::Vector3d p = a + (da / (da - db)) * (b - a) - t.p;
  const double x = p.dot(t.u), y = p.dot(t.w);
  if (in_triangle(x, y, t.q[0], t.q[1]) || in_triangle(x - t.d[0], y - t.d[1], t.q[0], t.q[1])) return true;
  const double zero[2] = {0, 0}, e2m1[2] = {t.q[1][0] - t.q[0][0], t.q[1][1] - t.q[0][1]}, me2[2] = {-t.q[1][0], -t.q[1][1]};
  return in_parallelogram(x, y, zero, t.q[0], t.d) || in_parallelogram(x, y, t.q[0], e2m1, t.d) ||
         in_parallelogram(x, y, t.q[1], me2, t.d);
}

// p - lambda d in the rectangle [-half - grow, half + grow]^2 for some lambda in [0, 1]: the
// lambdas each side allows form an interval; they meet if the intervals and [0, 1] do.
static bool segment_meets_rectangle(const double p[2], const double d[2], const double half[2], double grow) {
  double lo = 0, hi = 1;
  for (int i = 0; i < 2; ++i) {
    const double h = half[i] + grow;
    if (d[i] == 0) {
      if (std::fabs(p[i]) > h) return false;
      continue;
    }
    double a = (p[i] - h) / d[i], b = (p[i] + h) / d[i];
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  return lo <= hi;
}

// (s, r) in the rectangle moved by lambda d for some lambda in [0, 1].
bool BladeSweep::inside(double s, double r, double grow) const {
  const double p[2] = {s, r};
  return segment_meets_rectangle(p, d_, f_.half, grow);
}

// In the blade's frame at t = 0 the point at sample k is R(-theta_k) (P - offset_k), P its in-plane
// coordinates; the chords between samples stray from the path by at most 3.8e-5 of the point's
// distance from the blade's centre (1 degree), far inside near's margin of half the longest edge.
bool BladeSweep::turning_inside(const Eigen::Vector3d& p, double grow) const {
  const Eigen::Vector3d q = p - f_.origin;
  const double P[2] = {q.dot(f_.u), q.dot(f_.w)};
  double prev[2] = {0, 0};
  for (size_t k = 0; k < unturn_.size(); ++k) {
    const double a = P[0] - offset_[k][0], b = P[1] - offset_[k][1], c = unturn_[k][0], s = unturn_[k][1];
    const double x[2] = {c * a + s * b, -s * a + c * b};
    if (k > 0) {  // the chord from sample k - 1 (at least two samples: the step's ends)
      const double d[2] = {prev[0] - x[0], prev[1] - x[1]};
      if (segment_meets_rectangle(prev, d, f_.half, grow)) return true;
    }
    prev[0] = x[0];
    prev[1] = x[1];
  }
  return false;
}

bool BladeSweep::crosses(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  if (mesh_) {
    const Box segment{a.cwiseMin(b), a.cwiseMax(b)};
    if ((segment.lo.array() > hi_.array()).any() || (segment.hi.array() < lo_.array()).any()) return false;
    return any_triangle(segment.lo, segment.hi, [&](const Tri& t) { return mesh_crosses(t, a, b); });
  }
  const double da = f_.n.dot(a - c0_), db = f_.n.dot(b - c0_);
  if ((da >= 0) == (db >= 0)) return false;
  if (turns_) return turning_inside(a + (da / (da - db)) * (b - a), 0);
  const Eigen::Vector3d p = a + (da / (da - db)) * (b - a) - c0_;
  return inside(p.dot(f_.u), p.dot(f_.w), 0);
}

bool BladeSweep::near(const Eigen::Vector3d& p, double reach) const {
  if (mesh_) {  // within reach of one triangle's sweep box (first of the whole sweep's)
    const Eigen::Vector3d r = Eigen::Vector3d::Constant(reach);
    if (((p + r).array() < lo_.array()).any() || ((p - r).array() > hi_.array()).any()) return false;
    return any_triangle(p - r, p + r, [](const Tri&) { return true; });
  }
  const Eigen::Vector3d q = p - c0_;
  if (turns_) return std::fabs(f_.n.dot(q)) <= reach && turning_inside(p, reach);
  return std::fabs(f_.n.dot(q)) <= reach && inside(q.dot(f_.u), q.dot(f_.w), reach);
}

bool BladeSweep::may_meet_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
  if (mesh_) return (lo_.array() <= hi.array()).all() && (hi_.array() >= lo.array()).all();
  Eigen::Vector3d plo = Eigen::Vector3d::Constant(HUGE_VAL), phi = -plo;
  for (size_t k = 0; k < unturn_.size(); ++k)  // a turning rectangle's corners at every sample
    for (int i = -1; i <= 1; i += 2)
      for (int j = -1; j <= 1; j += 2) {
        const double x = i * f_.half[0], y = j * f_.half[1], c = unturn_[k][0], s = unturn_[k][1];
        const Eigen::Vector3d q = f_.origin + (offset_[k][0] + c * x - s * y) * f_.u + (offset_[k][1] + s * x + c * y) * f_.w;
        plo = plo.cwiseMin(q);
        phi = phi.cwiseMax(q);
      }
  for (int k = 0; k < 2 && !turns_; ++k)  // the rectangle's corners at both ends of the step
    for (int i = -1; i <= 1; i += 2)
      for (int j = -1; j <= 1; j += 2) {
        const Eigen::Vector3d q = c0_ + k * (d_[0] * f_.u + d_[1] * f_.w) + i * f_.half[0] * f_.u + j * f_.half[1] * f_.w;
        plo = plo.cwiseMin(q);
        phi = phi.cwiseMax(q);
      }
  return (plo.array() <= hi.array()).all() && (phi.array() >= lo.array()).all();
}

}  // namespace hyperqn

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
  if (m.rate_deg != 0) return "a blade does not turn yet (rotate): it moves in its plane only (translate)";
  const Eigen::Vector3d v = vec(m.velocity), n = vec(c.normal).normalized();
  if (std::fabs(v.dot(n)) > 1e-12 * v.norm())
    return "translate.velocity leaves the blade's plane (its part along normal is not 0): a blade moves in its plane";
  return "";
}

BladeSweep::BladeSweep(const CutSpec& c, double t0, double t1) : f_(c) {
  c0_ = moved(c.motion, f_.origin, t0);
  const Eigen::Vector3d d = moved(c.motion, f_.origin, t1) - c0_;
  d_[0] = d.dot(f_.u);
  d_[1] = d.dot(f_.w);
}

// (s, r) in the rectangle moved by lambda d for some lambda in [0, 1]: the lambdas each side allows
// form an interval; the point is in the patch if the intervals and [0, 1] meet.
bool BladeSweep::inside(double s, double r, double grow) const {
  double lo = 0, hi = 1;
  const double p[2] = {s, r};
  for (int i = 0; i < 2; ++i) {
    const double h = f_.half[i] + grow;
    if (d_[i] == 0) {
      if (std::fabs(p[i]) > h) return false;
      continue;
    }
    double a = (p[i] - h) / d_[i], b = (p[i] + h) / d_[i];
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  return lo <= hi;
}

bool BladeSweep::crosses(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  const double da = f_.n.dot(a - c0_), db = f_.n.dot(b - c0_);
  if ((da >= 0) == (db >= 0)) return false;
  const Eigen::Vector3d p = a + (da / (da - db)) * (b - a) - c0_;
  return inside(p.dot(f_.u), p.dot(f_.w), 0);
}

bool BladeSweep::near(const Eigen::Vector3d& p, double reach) const {
  const Eigen::Vector3d q = p - c0_;
  return std::fabs(f_.n.dot(q)) <= reach && inside(q.dot(f_.u), q.dot(f_.w), reach);
}

bool BladeSweep::may_meet_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
  Eigen::Vector3d plo = Eigen::Vector3d::Constant(HUGE_VAL), phi = -plo;
  for (int k = 0; k < 2; ++k)  // the rectangle's corners at both ends of the step
    for (int i = -1; i <= 1; i += 2)
      for (int j = -1; j <= 1; j += 2) {
        const Eigen::Vector3d q = c0_ + k * (d_[0] * f_.u + d_[1] * f_.w) + i * f_.half[0] * f_.u + j * f_.half[1] * f_.w;
        plo = plo.cwiseMin(q);
        phi = phi.cwiseMax(q);
      }
  return (plo.array() <= hi.array()).all() && (phi.array() >= lo.array()).all();
}

}  // namespace hyperqn

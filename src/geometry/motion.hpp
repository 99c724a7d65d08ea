// Prescribed rigid motion, shared by fixed regions, attachments and colliders: rotation about an
// axis through a centre at a constant rate, plus a translation at a constant velocity, both active
// for t in [start, end] and held afterwards. Position at time t of a point X given at t = 0:
// c + R(rate * tau) (X - c) + velocity * tau, tau = clamp(t, start, end) - start. With a curve
// (params/curve.hpp) tau = c(t) instead, and start and end are not given: the rotation turns by
// rate * c(t) and the translation moves by velocity * c(t); c(0) = 0 (the deck reader checks).
#pragma once
#include <Eigen/Dense>
#include <array>

#include "params/curve.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

struct Motion {
  bool active = false;
  std::array<double, 3> axis{1, 0, 0}, center{0, 0, 0};
  double rate_deg = 0;               // degrees per unit time
  std::array<double, 3> velocity{0, 0, 0};
  double start = 0, end = 1e300;
  Curve curve;                       // tau = curve(t) if given
};

// The deck's motion: keys, of a fixed region, an attachment or a collider (params/deck_keys.hpp). Its
// reader sets `active`, checks end >= start, reads the curve and refuses start and end beside it.
inline const std::vector<DeckKey<Motion>>& motion_keys() {
  using M = Motion;
  static const std::vector<DeckKey<M>> keys = {
      map_key<M>("rotate", "a rotation about an axis at a constant rate", "none"),
      needed(DeckKey<M>{"rotate.axis", &M::axis, "rotation axis (normalized)", nonzero_vector()}),
      {"rotate.center", &M::center, "a point on the axis"},
      needed(DeckKey<M>{"rotate.rate", &M::rate_deg, "degrees per unit time (right-hand rule)"}),
      map_key<M>("translate", "a translation at a constant velocity", "none"),
      needed(DeckKey<M>{"translate.velocity", &M::velocity, "velocity (length per unit time)"}),
      {"start", &M::start, "start time (without `curve`)", at_least(0)},
      {"end", &M::end, "end time, at least `start`; the motion holds its last position afterwards (without `curve`)",
       {}, {}, "", "never"},
      curve_key<M>("the motion's progress in time instead of `start` and `end`: the rotation turns by `rate`·c(t) "
                   "degrees and the translation moves by `velocity`·c(t); c(0) must be 0",
                   "none (τ above)"),
  };
  return keys;
}

// The motion's rigid map at time t: p = rotation * X + translation (identity if not active).
struct RigidPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& X) const { return rotation * X + translation; }
  // The point X whose image is p.
  Eigen::Vector3d inverse(const Eigen::Vector3d& p) const { return rotation.transpose() * (p - translation); }
};
RigidPose pose_at(const Motion& m, double t);

// How far the motion has gone at time t: tau above, or the curve's c(t) (0 if not active).
double motion_progress(const Motion& m, double t);
// Position of the point X once the motion has gone tau (moved(m, X, t) is this at tau =
// motion_progress(m, t)): between two times, a constant rate's poses are those of tau in between.
Eigen::Vector3d moved_by(const Motion& m, const Eigen::Vector3d& X, double tau);

// Position at time t of the point X (X itself if the motion is not active): pose_at(m, t).apply(X)
// up to round-off, computed as c + R (X - c) + velocity tau.
Eigen::Vector3d moved(const Motion& m, const Eigen::Vector3d& X, double t);
// Velocity at time t of the point X as the motion reaches t: w x (moved(X, t) - c - velocity tau)
// + velocity (w = rate about the axis) for start < t <= end, else 0 (not yet moving, or held).
// With a curve, that times dc/dt as c reaches t (Curve::derivative: from the left).
// What a fixed region's vertices keep when released at t.
Eigen::Vector3d velocity_at(const Motion& m, const Eigen::Vector3d& X, double t);

}  // namespace hyperqn

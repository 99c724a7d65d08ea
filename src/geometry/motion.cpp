#include "geometry/motion.hpp"

#include <algorithm>
#include <cmath>

namespace hyperqn {

static double active_time(const Motion& m, double t) { return std::min(std::max(t, m.start), m.end) - m.start; }
// How far the motion has gone at t: tau, or the curve's c(t).
static double progress(const Motion& m, double t) { return m.curve.given ? m.curve.value(t) : active_time(m, t); }

double motion_progress(const Motion& m, double t) { return m.active ? progress(m, t) : 0.0; }

Eigen::Vector3d moved(const Motion& m, const Eigen::Vector3d& X, double t) {
  if (!m.active) return X;
  return moved_by(m, X, progress(m, t));
}

Eigen::Vector3d moved_by(const Motion& m, const Eigen::Vector3d& X, double tau) {
  if (!m.active) return X;
  const Eigen::Vector3d axis = Eigen::Vector3d(m.axis[0], m.axis[1], m.axis[2]).normalized();
  const Eigen::Vector3d c(m.center[0], m.center[1], m.center[2]);
  const Eigen::AngleAxisd R(m.rate_deg * M_PI / 180.0 * tau, axis);
  return c + R * (X - c) + tau * Eigen::Vector3d(m.velocity[0], m.velocity[1], m.velocity[2]);
}

Eigen::Vector3d velocity_at(const Motion& m, const Eigen::Vector3d& X, double t) {
  if (!m.active || (!m.curve.given && !(t > m.start && t <= m.end))) return Eigen::Vector3d::Zero();
  const double tau = progress(m, t);
  const Eigen::Vector3d axis = Eigen::Vector3d(m.axis[0], m.axis[1], m.axis[2]).normalized();
  const Eigen::Vector3d c(m.center[0], m.center[1], m.center[2]);
  const double rate = m.rate_deg * M_PI / 180.0;
  const Eigen::AngleAxisd R(rate * tau, axis);
  const Eigen::Vector3d u = rate * axis.cross(R * (X - c)) + Eigen::Vector3d(m.velocity[0], m.velocity[1], m.velocity[2]);
  return m.curve.given ? Eigen::Vector3d(m.curve.derivative(t) * u) : u;
}

RigidPose pose_at(const Motion& m, double t) {
  RigidPose pose;
  if (!m.active) return pose;
  const double tau = progress(m, t);
  const Eigen::Vector3d axis = Eigen::Vector3d(m.axis[0], m.axis[1], m.axis[2]).normalized();
  const Eigen::Vector3d c(m.center[0], m.center[1], m.center[2]);
  pose.rotation = Eigen::AngleAxisd(m.rate_deg * M_PI / 180.0 * tau, axis).toRotationMatrix();
  pose.translation = c - pose.rotation * c + tau * Eigen::Vector3d(m.velocity[0], m.velocity[1], m.velocity[2]);
  return pose;
}

}  // namespace hyperqn

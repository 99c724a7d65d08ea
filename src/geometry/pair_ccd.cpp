#include "geometry/pair_ccd.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hyperqn {

namespace {

constexpr double kStepFraction = 0.9;  // of the step that would just reach min_separation (IPC's)
// A bound on the work of one pair (a pair that creeps along at a clearance tiny against its
// motion); reaching it returns the time reached, which is still conservative.
constexpr long kMaxSteps = 1000000;

using SquaredDistance = double (*)(const Vector12d&);

double point_triangle_at(const Vector12d& x) {
  return point_triangle_squared_distance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9));
}
double edge_edge_at(const Vector12d& x) {
  return edge_edge_squared_distance(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9));
}

// The clearance d - xi from d^2, as (d^2 - xi^2) / (d + xi): no cancellation when d is close to xi.
double clearance(double squared_distance, double xi) {
  return (squared_distance - xi * xi) / (std::sqrt(squared_distance) + xi);
}

// motion: end - start with the mean motion of the four points removed (a common translation
// changes no distance); max_speed: l_p, the bound on |d distance / dt| along it.
double additive_ccd(const Vector12d& start, const Vector12d& motion, double max_speed, SquaredDistance squared_distance,
                    double xi, double clearance_fraction) {
  const double start_clearance = clearance(squared_distance(start), xi);
  if (!(start_clearance > 0)) return 0;
  if (!(max_speed > 0)) return std::numeric_limits<double>::infinity();
  const double gap = clearance_fraction * start_clearance;
  double t = 0, c = start_clearance;
  for (long step = 0; step < kMaxSteps; ++step) {
    const double next = t + kStepFraction * c / max_speed;
    const double next_clearance = clearance(squared_distance(start + next * motion), xi);
    // The first step always stands (it leaves at least 0.1 of the clearance); later ones stop
    // short of a point within the gap.
    if (step > 0 && !(next_clearance >= gap)) return t;
    t = next;
    c = next_clearance;
    if (t > 1) return std::numeric_limits<double>::infinity();
  }
  return t;
}

Vector12d relative_motion(const Vector12d& start, const Vector12d& end) {
  Vector12d motion = end - start;
  const Eigen::Vector3d mean =
      0.25 * (motion.segment<3>(0) + motion.segment<3>(3) + motion.segment<3>(6) + motion.segment<3>(9));
  for (int k = 0; k < 4; ++k) motion.segment<3>(3 * k) -= mean;
  return motion;
}

double speed(const Vector12d& motion, int point) { return motion.segment<3>(3 * point).norm(); }

}  // namespace

double vertex_triangle_impact(const Vector12d& start, const Vector12d& end, double min_separation,
                              double clearance_fraction) {
  const Vector12d motion = relative_motion(start, end);
  // A point of the triangle moves as a convex combination of its corners: at most the fastest.
  const double max_speed = speed(motion, 0) + std::max({speed(motion, 1), speed(motion, 2), speed(motion, 3)});
  return additive_ccd(start, motion, max_speed, point_triangle_at, min_separation, clearance_fraction);
}

double edge_edge_impact(const Vector12d& start, const Vector12d& end, double min_separation,
                        double clearance_fraction) {
  const Vector12d motion = relative_motion(start, end);
  const double max_speed = std::max(speed(motion, 0), speed(motion, 1)) + std::max(speed(motion, 2), speed(motion, 3));
  return additive_ccd(start, motion, max_speed, edge_edge_at, min_separation, clearance_fraction);
}

}  // namespace hyperqn

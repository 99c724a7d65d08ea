// IPC's smoothed Coulomb friction, shared by obstacle contact (terms/contact.hpp) and self-contact
// (terms/self_contact.hpp): the scalar profile of the lagged friction energy mu lambda f0(|u|) of
// a tangential displacement u over a step, and the tangent plane of a contact normal.
#pragma once
#include <Eigen/Dense>
#include <cmath>

namespace hyperqn {

// f0(s), f1(s)/s and (d(f1/s)/ds)/s at s = |u| >= 0, with f0' = f1 IPC's C1 mollifier of |u|:
// f1(s) = 2 s/e - s^2/e^2 below e = eps h (friction_velocity times the step), 1 above. The
// friction energy's gradient in u is mu lambda (f1/s) u, its Hessian
// mu lambda ((f1/s) I + slope u u^T) (slope counted only for s > 0), positive semidefinite.
struct SmoothedFriction {
  double f0, f1_over_s, slope;
};

inline SmoothedFriction smoothed_friction(double s, double e) {
  const bool sticking = s < e;
  SmoothedFriction f;
  f.f0 = sticking ? -s * s * s / (3 * e * e) + s * s / e + e / 3 : s;
  f.f1_over_s = sticking ? 2 / e - s / (e * e) : 1 / s;
  f.slope = s > 0 ? (sticking ? -1 / (e * e * s) : -1 / (s * s * s)) : 0;
  return f;
}

// An orthonormal basis (3 x 2) of the plane orthogonal to the unit vector n.
inline Eigen::Matrix<double, 3, 2> tangent_basis(const Eigen::Vector3d& n) {
  const Eigen::Vector3d helper = std::abs(n[0]) < 0.9 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 1, 0);
  const Eigen::Vector3d t1 = n.cross(helper).normalized();
  Eigen::Matrix<double, 3, 2> T;
  T.col(0) = t1;
  T.col(1) = n.cross(t1);
  return T;
}

}  // namespace hyperqn

// One linear spring E = k/2 (l - L)^2 between two points, l = |u| the length of the deformed
// edge u = x_b - x_a and L its rest length. The building block of the mass-spring tets
// (tet_springs) and of the strand segments (elastic_body).
#pragma once
#include <algorithm>

#include "materials/material.hpp"

namespace hyperqn {
namespace spring {

// Below this fraction of its rest length a spring's direction is undefined; the length is
// floored there so the force stays finite (it vanishes with the edge).
constexpr double kTinyLength = 1e-12;

inline double length(const Vec3& u, double L) { return std::max(u.norm(), kTinyLength * L); }

inline double energy(const Vec3& u, double L, double k) {
  const double l = length(u, L);
  return 0.5 * k * (l - L) * (l - L);
}

// The spring's tension dE/dl = k (l - L): > 0 stretched, < 0 compressed (the output field axial_force).
inline double tension(const Vec3& u, double L, double k) { return k * (length(u, L) - L); }

// dE/du = k (l - L) u / l (the force on x_b is minus this, on x_a plus this).
inline Vec3 gradient(const Vec3& u, double L, double k) {
  const double l = length(u, L);
  return (k * (l - L) / l) * u;
}

// d2E/du2 = k n n^T + k (1 - L/l) (I - n n^T), n = u / l. The transverse term is negative for a
// compressed spring; psd clamps it at 0 (the Newton definiteness fix).
inline Mat3 stiffness(const Vec3& u, double L, double k, bool psd) {
  const double l = length(u, L);
  const Vec3 n = u / l;
  double transverse = k * (1.0 - L / l);
  if (psd) transverse = std::max(transverse, 0.0);
  return k * n * n.transpose() + transverse * (Mat3::Identity() - n * n.transpose());
}

}  // namespace spring
}  // namespace hyperqn

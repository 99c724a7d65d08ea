// Small geometry shared by the cloth formulas (materials/membrane, materials/hinge_bending).
#pragma once
#include <algorithm>
#include <cmath>

#include "materials/material.hpp"

namespace hyperqn {

// [v]x: the matrix of u -> v x u.
inline Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Area of the rest triangle (a, b, c), and whether it is a proper one: an area at most 1e-14 of its
// longest edge squared is collinear up to round-off (its Dm^-1 and cotangents would be noise).
inline bool proper_rest_triangle(const Vec3& a, const Vec3& b, const Vec3& c, double* area) {
  *area = 0.5 * (b - a).cross(c - a).norm();
  const double longest2 = std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
  return *area > 1e-14 * longest2 && std::isfinite(*area);
}

}  // namespace hyperqn

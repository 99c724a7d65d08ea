#include "geometry/triangle_queries.hpp"

#include <cmath>

namespace hyperqn {

TriangleClosest closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c) {
  using F = TriangleFeature;
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {a, {F::Vertex, 0}};

  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {b, {F::Vertex, 1}};

  // Edge ab: the barycentric weight of c is <= 0 and p projects between a and b.
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double t = d1 / (d1 - d3);
    return {a + t * ab, {F::Edge, 0}};
  }

  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {c, {F::Vertex, 2}};

  // Edge ca.
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double t = d2 / (d2 - d6);
    return {a + t * ac, {F::Edge, 2}};
  }

  // Edge bc.
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {b + t * (c - b), {F::Edge, 1}};
  }

  // Inside the face. A degenerate triangle that got here (all weights 0) falls back to a corner.
  const double sum = va + vb + vc;
  if (!(sum > 0)) return {a, {F::Vertex, 0}};
  const double v = vb / sum, w = vc / sum;
  return {a + v * ab + w * ac, {F::Face, 0}};
}

double segment_triangle(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  constexpr double kEdgeTol = 1e-12;  // relative, on barycentric coordinates
  const Eigen::Vector3d d = q1 - q0, e1 = b - a, e2 = c - a;
  const Eigen::Vector3d h = d.cross(e2);
  const double det = e1.dot(h);
  // Parallel (or degenerate triangle): no transversal crossing.
  if (!(std::fabs(det) > 1e-300) || !std::isfinite(det)) return -1;
  const double inv = 1.0 / det;
  const Eigen::Vector3d s0 = q0 - a;
  const double u = s0.dot(h) * inv;
  if (u < -kEdgeTol || u > 1 + kEdgeTol) return -1;
  const Eigen::Vector3d qv = s0.cross(e1);
  const double v = d.dot(qv) * inv;
  if (v < -kEdgeTol || u + v > 1 + kEdgeTol) return -1;
  const double s = e2.dot(qv) * inv;
  if (s < 0 || s > 1) return -1;
  return s;
}

}  // namespace hyperqn

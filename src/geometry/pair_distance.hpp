// Squared distances between the surface primitives of deformable bodies, with first and second
// derivatives: a vertex against a triangle and an edge against an edge, each pair four points
// x = (x0, x1, x2, x3) stacked into 12 numbers. What a self-contact or body-against-body term
// needs (docs/self-contact.md#pair-kernels-for-self-contact); no PETSc.
//
// The squared distance D is the minimum of |r|^2 over the closest-point parameters, which is
// smooth within each sub-case of where the closest points lie (as in the IPC toolkit): on the
// face, an edge or a vertex of the triangle; in the interior of both edges, at an end point of one
// edge, or at an end point of each. Each sub-case is the distance to an affine object (a plane,
// a line, a point), so D, its gradient and Hessian are those of that sub-case; the gradient is
// continuous across sub-cases, the Hessian jumps.
#pragma once
#include <Eigen/Dense>
#include <array>

namespace hyperqn {

using Vector12d = Eigen::Matrix<double, 12, 1>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

// Where the closest points of a pair lie: which of the pair's four points (0..3, in the order of
// the 12-vector) the sub-case involves and how.
//   PointPoint: points[0] against points[1];
//   PointEdge:  points[0] against the line through points[1], points[2];
//   PointPlane: points[0] against the plane through points[1], points[2], points[3];
//   EdgeEdge:   the line through points[0], points[1] against the line through points[2], points[3].
struct PairCase {
  enum Kind { PointPoint, PointEdge, PointPlane, EdgeEdge } kind = PointPoint;
  std::array<int, 4> points{0, 1, 2, 3};
};

// Point p against triangle (t0, t1, t2); x = (p, t0, t1, t2). The sub-case is the triangle's
// feature that holds the closest point (closest_on_triangle, geometry/triangle_queries.hpp).
PairCase point_triangle_case(const Eigen::Vector3d& p, const Eigen::Vector3d& t0, const Eigen::Vector3d& t1,
                             const Eigen::Vector3d& t2);
double point_triangle_squared_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& t0, const Eigen::Vector3d& t1,
                                       const Eigen::Vector3d& t2, Vector12d* gradient = nullptr,
                                       Matrix12d* hessian = nullptr);

// Segment (a0, a1) against segment (b0, b1); x = (a0, a1, b0, b1). The interior of both edges
// when the lines' closest points lie strictly inside both segments and the edges are not parallel
// (sin^2 of their angle below 2.5e-16, the IPC toolkit's threshold); otherwise the nearest of an
// end point against the other segment (point-edge, or point-point where it projects outside).
PairCase edge_edge_case(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                        const Eigen::Vector3d& b1);
double edge_edge_squared_distance(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                                  const Eigen::Vector3d& b1, Vector12d* gradient = nullptr,
                                  Matrix12d* hessian = nullptr);

// The squared distance of a given sub-case (used by the two functions above; the sub-case's object
// is the whole plane or line, so this is the pair's distance only where the case holds).
double case_squared_distance(const PairCase& pair_case, const Vector12d& x, Vector12d* gradient = nullptr,
                             Matrix12d* hessian = nullptr);

// IPC's edge-edge mollifier (Li et al. 2020, "Incremental Potential Contact", sec. 4.3). Between
// nearly parallel edges the sub-case changes, and the distance's derivatives jump (or, exactly
// parallel, do not exist); the contact energy of an edge pair is therefore multiplied by
//   m(c) = (2 - c / eps_x) c / eps_x for c < eps_x, 1 otherwise,   c = |(a1 - a0) x (b1 - b0)|^2,
// which vanishes with zero gradient when the edges are parallel. eps_x is fixed per pair at rest.
double edge_edge_mollifier_threshold(const Eigen::Vector3d& a0_rest, const Eigen::Vector3d& a1_rest,
                                     const Eigen::Vector3d& b0_rest, const Eigen::Vector3d& b1_rest);  // 1e-3 |ea|^2 |eb|^2
double edge_edge_mollifier(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                           const Eigen::Vector3d& b1, double eps_x, Vector12d* gradient = nullptr,
                           Matrix12d* hessian = nullptr);

}  // namespace hyperqn

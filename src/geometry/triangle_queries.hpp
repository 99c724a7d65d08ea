// Exact point-triangle and segment-triangle queries: what the triangle BVH runs at its leaves
// and what the mesh collider needs to know (which feature of a triangle is closest).
#pragma once
#include <Eigen/Dense>

namespace hyperqn {

// The part of a triangle (a, b, c) that holds the closest point. Edge k joins corners k and
// (k + 1) % 3; vertex k is corner k.
struct TriangleFeature {
  enum Kind { Face, Edge, Vertex } kind = Face;
  int index = 0;
};

struct TriangleClosest {
  Eigen::Vector3d point;
  TriangleFeature feature;
};

// Closest point to p on the triangle (Voronoi regions of the corners, then of the edges, then the
// face; Ericson, Real-Time Collision Detection, 5.1.5). A degenerate triangle gives a point on it.
TriangleClosest closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c);

// Parameter s in [0, 1] where the segment q0 + s (q1 - q0) crosses the triangle (either side;
// Moller-Trumbore with a small tolerance on the barycentrics so a crossing through a shared edge
// is not lost between two triangles), or a negative value if it does not. A segment lying in the
// plane of the triangle does not cross it.
double segment_triangle(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace hyperqn

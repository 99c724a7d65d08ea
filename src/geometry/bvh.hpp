// Bounding-volume hierarchy of axis-aligned boxes over the triangles of a static surface: closest
// point and first segment crossing in about O(log n) triangle tests instead of n.
#pragma once
#include <Eigen/Dense>
#include <array>
#include <vector>

#include "geometry/triangle_queries.hpp"

namespace hyperqn {

struct SurfaceHit {
  int triangle = -1;          // -1: the surface has no triangle
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  TriangleFeature feature;
  double distance2 = 0;       // squared distance from the query point
  int triangles_tested = 0;   // work done, for tests of the pruning
};

class TriangleBVH {
 public:
  TriangleBVH() = default;
  // Builds once: median split over triangle centroids along the widest axis of their box.
  TriangleBVH(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles);

  // Closest point on the surface: branch and bound, nearer child first, skipping boxes farther
  // than the best found so far.
  SurfaceHit closest(const Eigen::Vector3d& p) const;
  // Smallest s in [0, 1] at which q0 + s (q1 - q0) crosses a triangle, or a negative value.
  double first_crossing(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) const;

  const std::vector<Eigen::Vector3d>& vertices() const { return vertices_; }
  const std::vector<std::array<int, 3>>& triangles() const { return triangles_; }

 private:
  struct Node {
    Eigen::Vector3d lo, hi;
    int first = 0, count = 0;  // leaf: order_[first, first + count); inner: count = 0
    int left = -1, right = -1;
  };
  int build(int first, int count, const std::vector<Eigen::Vector3d>& centroids);
  void corners(int tri, Eigen::Vector3d& a, Eigen::Vector3d& b, Eigen::Vector3d& c) const {
    a = vertices_[triangles_[tri][0]], b = vertices_[triangles_[tri][1]], c = vertices_[triangles_[tri][2]];
  }

  std::vector<Eigen::Vector3d> vertices_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<int> order_;   // triangle indices, grouped by leaf
  std::vector<Node> nodes_;  // nodes_[0] is the root
};

}  // namespace hyperqn

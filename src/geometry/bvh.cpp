#include "geometry/bvh.hpp"

#include <algorithm>
#include <limits>

namespace hyperqn {

namespace {

constexpr int kLeafSize = 4;
constexpr int kMaxStack = 64;  // > depth + 1 for any int triangle count (see closest)

// Squared distance from p to the box (0 inside).
double box_distance2(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm();
}

// Does q0 + s d meet the box for some s in [0, s_max]? (slab test; d_k = 0 tests the slab once)
bool segment_meets_box(const Eigen::Vector3d& q0, const Eigen::Vector3d& d, double s_max, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi) {
  double s0 = 0, s1 = s_max;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (q0[k] < lo[k] || q0[k] > hi[k]) return false;
      continue;
    }
    double a = (lo[k] - q0[k]) / d[k], b = (hi[k] - q0[k]) / d[k];
    if (a > b) std::swap(a, b);
    s0 = std::max(s0, a);
    s1 = std::min(s1, b);
    if (s0 > s1) return false;
  }
  return true;
}

}  // namespace

TriangleBVH::TriangleBVH(std::vector<Eigen::Vector3d> vertices, std::vector<std::array<int, 3>> triangles)
    : vertices_(std::move(vertices)), triangles_(std::move(triangles)) {
  const int n = int(triangles_.size());
  if (n == 0) return;
  std::vector<Eigen::Vector3d> centroids(n);
  for (int t = 0; t < n; ++t) {
    Eigen::Vector3d a, b, c;
    corners(t, a, b, c);
    centroids[t] = (a + b + c) / 3.0;
  }
  order_.resize(n);
  for (int t = 0; t < n; ++t) order_[t] = t;
  nodes_.reserve(2 * (n / kLeafSize + 1));
  build(0, n, centroids);
}

int TriangleBVH::build(int first, int count, const std::vector<Eigen::Vector3d>& centroids) {
  const int id = int(nodes_.size());
  nodes_.emplace_back();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d clo = lo, chi = hi;
  for (int i = first; i < first + count; ++i) {
    const auto& t = triangles_[order_[i]];
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(vertices_[t[k]]);
      hi = hi.cwiseMax(vertices_[t[k]]);
    }
    clo = clo.cwiseMin(centroids[order_[i]]);
    chi = chi.cwiseMax(centroids[order_[i]]);
  }
  nodes_[id].lo = lo;
  nodes_[id].hi = hi;
  if (count <= kLeafSize) {
    nodes_[id].first = first;
    nodes_[id].count = count;
    return id;
  }
  int axis;
  (chi - clo).maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](int a, int b) { return centroids[a][axis] < centroids[b][axis]; });
  const int left = build(first, half, centroids);
  const int right = build(first + half, count - half, centroids);
  nodes_[id].left = left;  // nodes_ may have reallocated: index, don't hold references
  nodes_[id].right = right;
  return id;
}

SurfaceHit TriangleBVH::closest(const Eigen::Vector3d& p) const {
  SurfaceHit best;
  if (nodes_.empty()) return best;
  best.distance2 = std::numeric_limits<double>::infinity();
  // Explicit stack of (node, lower bound), no allocation per query: the median split halves the
  // count at each level, so the depth is at most 31 and the stack holds at most depth + 1 nodes.
  std::pair<int, double> stack[kMaxStack];
  int top = 0;
  stack[top++] = {0, box_distance2(p, nodes_[0].lo, nodes_[0].hi)};
  while (top > 0) {
    const auto [id, bound] = stack[--top];
    if (bound >= best.distance2) continue;
    const Node& node = nodes_[id];
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        Eigen::Vector3d a, b, c;
        corners(order_[i], a, b, c);
        const TriangleClosest tc = closest_on_triangle(p, a, b, c);
        ++best.triangles_tested;
        const double d2 = (p - tc.point).squaredNorm();
        if (d2 < best.distance2) {
          best.distance2 = d2;
          best.triangle = order_[i];
          best.point = tc.point;
          best.feature = tc.feature;
        }
      }
      continue;
    }
    const double dl = box_distance2(p, nodes_[node.left].lo, nodes_[node.left].hi);
    const double dr = box_distance2(p, nodes_[node.right].lo, nodes_[node.right].hi);
    // Push the farther child first so the nearer one is searched first and tightens the bound.
    if (dl <= dr) {
      stack[top++] = {node.right, dr};
      stack[top++] = {node.left, dl};
    } else {
      stack[top++] = {node.left, dl};
      stack[top++] = {node.right, dr};
    }
  }
  return best;
}

double TriangleBVH::first_crossing(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) const {
  if (nodes_.empty()) return -1;
  const Eigen::Vector3d d = q1 - q0;
  double best = std::numeric_limits<double>::infinity();
  int stack[kMaxStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int id = stack[--top];
    const Node& node = nodes_[id];
    // Only the part of the segment before the best crossing so far can improve it.
    if (!segment_meets_box(q0, d, std::min(best, 1.0), node.lo, node.hi)) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        Eigen::Vector3d a, b, c;
        corners(order_[i], a, b, c);
        const double s = segment_triangle(q0, q1, a, b, c);
        if (s >= 0 && s < best) best = s;
      }
      continue;
    }
    stack[top++] = node.right;
    stack[top++] = node.left;
  }
  return best <= 1 ? best : -1;
}

}  // namespace hyperqn

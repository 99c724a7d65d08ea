// A bounding-volume hierarchy over axis-aligned boxes: which of n boxes overlap a query box, in
// about O(log n) box tests each. The broad phase of self-contact (terms/self_contact.hpp) builds
// one per evaluation over the surface primitives' boxes; unlike TriangleBVH (a static surface's
// triangles) it holds any boxes, of any sizes (the boxes swept by a step too). No PETSc.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <initializer_list>
#include <vector>

namespace hyperqn {

struct Box {
  Eigen::Vector3d lo, hi;
  bool overlaps(const Box& o) const { return (lo.array() <= o.hi.array()).all() && (o.lo.array() <= hi.array()).all(); }
  void include(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void inflate(double by) {
    lo.array() -= by;
    hi.array() += by;
  }
  // The box of the points (at least one), grown by inflate on every side.
  static Box around(std::initializer_list<Eigen::Vector3d> points, double inflate) {
    Box b{*points.begin(), *points.begin()};
    for (const Eigen::Vector3d& p : points) b.include(p);
    b.inflate(inflate);
    return b;
  }
};

class BoxTree {
 public:
  BoxTree() = default;
  // Median split of the box centers along the widest axis of their bounds, leaves of at most 4.
  explicit BoxTree(std::vector<Box> boxes) : boxes_(std::move(boxes)) {
    order_.resize(boxes_.size());
    for (size_t i = 0; i < order_.size(); ++i) order_[i] = (int)i;
    if (!boxes_.empty()) build(0, (int)boxes_.size());
  }
  // The box around all boxes (the tree holds at least one).
  const Box& bounds() const { return nodes_.front().box; }
  // Calls visit(i) for every box i that overlaps query (closed boxes), in no particular order.
  template <class Visit>
  void overlapping(const Box& query, Visit&& visit) const {
    any_overlapping(query, [&](int i) {
      visit(i);
      return false;
    });
  }
  // Whether test(i) holds for some box i that overlaps query: stops at the first that does.
  template <class Test>
  bool any_overlapping(const Box& query, Test&& test) const {
    if (nodes_.empty()) return false;
    int stack[128], top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      if (!node.box.overlaps(query)) continue;
      if (node.left < 0) {
        for (int k = node.first; k < node.first + node.count; ++k)
          if (boxes_[order_[k]].overlaps(query) && test(order_[k])) return true;
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
    return false;
  }

 private:
  struct Node {
    Box box{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    int first = 0, count = 0;  // leaf: order_[first, first + count)
    int left = -1, right = -1;
  };
  int build(int first, int count) {
    const int index = (int)nodes_.size();
    nodes_.push_back(Node());
    Box bounds = boxes_[order_[first]], centers{bounds.lo + bounds.hi, bounds.lo + bounds.hi};
    for (int k = first; k < first + count; ++k) {
      const Box& b = boxes_[order_[k]];
      bounds.lo = bounds.lo.cwiseMin(b.lo);
      bounds.hi = bounds.hi.cwiseMax(b.hi);
      centers.lo = centers.lo.cwiseMin(b.lo + b.hi);
      centers.hi = centers.hi.cwiseMax(b.lo + b.hi);
    }
    nodes_[index].box = bounds;
    if (count <= 4) {
      nodes_[index].first = first;
      nodes_[index].count = count;
      return index;
    }
    int axis;
    (centers.hi - centers.lo).maxCoeff(&axis);
    const int half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](int a, int b) {
                       return boxes_[a].lo[axis] + boxes_[a].hi[axis] < boxes_[b].lo[axis] + boxes_[b].hi[axis];
                     });
    const int left = build(first, half);
    const int right = build(first + half, count - half);
    nodes_[index].left = left;
    nodes_[index].right = right;
    return index;
  }

  std::vector<Box> boxes_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace hyperqn

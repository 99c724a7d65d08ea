// A static triangle surface as an obstacle: signed distance through the BVH's closest point, its
// sign from the angle-weighted pseudo-normal of the closest feature (Baerentzen and Aanaes 2005),
// first contact as the first triangle the path crosses.
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "geometry/bvh.hpp"
#include "geometry/collider_shapes.hpp"
#include "geometry/surface_file.hpp"
#include "mesh/input_error.hpp"

namespace hyperqn {

namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

class TriangleMeshCollider : public Collider {
 public:
  TriangleMeshCollider(const ColliderSpec& spec, TriangleSurface surface)
      : Collider(spec), bvh_(std::move(surface.vertices), std::move(surface.triangles)) {
    pseudo_normals();
    Vec3 lo = Vec3::Constant(INFINITY), hi = -lo;
    for (const Vec3& x : bvh_.vertices()) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
    // Below this the direction p - closest is round-off: use the face normal instead.
    tiny_ = 1e-12 * (hi - lo).norm();
  }

 protected:
  double local_distance(const Vec3& q, Vec3* gradient, Mat3* hessian) const override {
    const SurfaceHit hit = bvh_.closest(q);
    const auto& tri = bvh_.triangles()[hit.triangle];
    const Vec3 v = q - hit.point;
    const double dist = std::sqrt(hit.distance2);
    const Vec3& n_face = face_normal_[hit.triangle];
    const Vec3* pseudo = &n_face;
    if (hit.feature.kind == TriangleFeature::Edge) pseudo = &edge_normal_[edge_of_[hit.triangle][hit.feature.index]];
    if (hit.feature.kind == TriangleFeature::Vertex) pseudo = &vertex_normal_[tri[hit.feature.index]];
    const double sign = v.dot(*pseudo) < 0 ? -1.0 : 1.0;
    if (hessian) hessian->setZero();
    if (!(dist > tiny_)) {
      if (gradient) *gradient = n_face;
      return sign * dist;
    }
    const Vec3 u = v / dist;
    // Over a face, sign * u is the face normal: take it exactly rather than from round-off in v.
    if (gradient) *gradient = hit.feature.kind == TriangleFeature::Face ? n_face : Vec3(sign * u);
    // Along a face normal (also where a flat neighbour's edge ties with the face by round-off)
    // the distance is to a plane: no curvature. Else to the edge's line or the vertex.
    if (hessian && hit.feature.kind != TriangleFeature::Face && std::fabs(u.dot(n_face)) < 1 - 1e-12) {
      Mat3 P = Mat3::Identity() - u * u.transpose();
      if (hit.feature.kind == TriangleFeature::Edge) {
        const int k = hit.feature.index;
        const Vec3 t = (bvh_.vertices()[tri[(k + 1) % 3]] - bvh_.vertices()[tri[k]]).normalized();
        P -= t * t.transpose();
      }
      *hessian = sign * P / dist;
    }
    return sign * dist;
  }

  // The first crossing of a triangle (either direction): for a start outside, the first contact.
  double local_first_contact(const Vec3& q0, const Vec3& q1) const override {
    const double s = bvh_.first_crossing(q0, q1);
    return s >= 0 ? s : INFINITY;
  }

 private:
  // Face normals; vertex normals weighted by the corner angles; edge normals the sum of the
  // (one or two) faces along the edge. Only the direction matters for the sign test.
  void pseudo_normals() {
    const auto& x = bvh_.vertices();
    const auto& tris = bvh_.triangles();
    face_normal_.resize(tris.size());
    vertex_normal_.assign(x.size(), Vec3::Zero());
    edge_of_.resize(tris.size());
    std::unordered_map<uint64_t, int> edge_ids;
    for (size_t f = 0; f < tris.size(); ++f) {
      const auto& t = tris[f];
      const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
      const double len = n.norm();
      face_normal_[f] = len > 0 ? Vec3(n / len) : Vec3::Zero();  // a degenerate face adds nothing
      for (int k = 0; k < 3; ++k) {
        const Vec3 e1 = x[t[(k + 1) % 3]] - x[t[k]], e2 = x[t[(k + 2) % 3]] - x[t[k]];
        const double l1 = e1.norm(), l2 = e2.norm();
        if (l1 > 0 && l2 > 0) {
          const double angle = std::acos(std::min(1.0, std::max(-1.0, e1.dot(e2) / (l1 * l2))));
          vertex_normal_[t[k]] += angle * face_normal_[f];
        }
        const uint32_t i = uint32_t(std::min(t[k], t[(k + 1) % 3])), j = uint32_t(std::max(t[k], t[(k + 1) % 3]));
        const auto [it, added] = edge_ids.emplace((uint64_t(i) << 32) | j, int(edge_normal_.size()));
        if (added) edge_normal_.push_back(Vec3::Zero());
        edge_normal_[it->second] += face_normal_[f];
        edge_of_[f][k] = it->second;
      }
    }
  }

  TriangleBVH bvh_;
  std::vector<Vec3> face_normal_, vertex_normal_, edge_normal_;
  std::vector<std::array<int, 3>> edge_of_;  // edge k of triangle f (corners k, k + 1)
  double tiny_ = 0;
};

}  // namespace

std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const std::string& deck_path, int index) {
  TriangleSurface surface = read_triangle_surface(spec.file);
  if (surface.triangles.empty())
    throw InputError(deck_path, spec.line, "colliders[" + std::to_string(index) + "].file",
                     "the surface file '" + spec.file + "' holds no triangle");
  return std::make_unique<TriangleMeshCollider>(spec, std::move(surface));
}

}  // namespace hyperqn

#include "geometry/collider.hpp"

#include "geometry/collider_shapes.hpp"

namespace hyperqn {

// The shapes work in their own frame; the pose is a rotation plus a translation, so distances
// are unchanged, and the derivatives rotate back: grad = R g, hess = R H R^T.
double Collider::distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient, Eigen::Matrix3d* hessian) const {
  const Eigen::Vector3d q = pose_.inverse(p);
  Eigen::Vector3d g;
  Eigen::Matrix3d H;
  const double phi = local_distance(q, gradient ? &g : nullptr, hessian ? &H : nullptr);
  const Eigen::Matrix3d& R = pose_.rotation;
  if (gradient) *gradient = R * g;
  if (hessian) *hessian = R * H * R.transpose();
  return phi;
}

// An affine map keeps the straight path and its parameter s.
double Collider::first_contact(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1) const {
  return local_first_contact(pose_.inverse(p0), pose_.inverse(p1));
}

std::unique_ptr<Collider> make_collider(const ColliderSpec& spec, const std::string& deck_path, int index) {
  switch (spec.type) {
    case ColliderType::plane: return make_plane_collider(spec);
    case ColliderType::sphere: return make_sphere_collider(spec);
    case ColliderType::box: return make_box_collider(spec);
    case ColliderType::capsule: return make_capsule_collider(spec);
    case ColliderType::mesh: break;
  }
  return make_mesh_collider(spec, deck_path, index);
}

}  // namespace hyperqn

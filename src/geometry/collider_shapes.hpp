// The concrete colliders, one builder per shape family (analytic_colliders.cpp,
// triangle_mesh_collider.cpp); make_collider (collider.cpp) picks one by the spec's type.
#pragma once
#include <memory>

#include "geometry/collider.hpp"

namespace hyperqn {

std::unique_ptr<Collider> make_plane_collider(const ColliderSpec& spec);
std::unique_ptr<Collider> make_sphere_collider(const ColliderSpec& spec);
std::unique_ptr<Collider> make_box_collider(const ColliderSpec& spec);
std::unique_ptr<Collider> make_capsule_collider(const ColliderSpec& spec);
// Reads spec.file; file content errors name the file, an empty surface names the deck entry.
std::unique_ptr<Collider> make_mesh_collider(const ColliderSpec& spec, const std::string& deck_path, int index);

}  // namespace hyperqn

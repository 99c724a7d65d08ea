// From a deck's material description to a Material.
#pragma once
#include <memory>

#include "model/material_spec.hpp"
#include "materials/material_factory.hpp"

namespace hyperqn {

MaterialParams material_params(const MaterialSpec& spec);

// Throws std::invalid_argument for parameters the material rejects. (mass-spring is not a
// Material of F alone: see materials/tet_springs.hpp.)
inline std::unique_ptr<Material> make_material(const MaterialSpec& spec) { return make_material(material_params(spec)); }

}  // namespace hyperqn

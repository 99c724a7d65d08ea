// Material construction by model name (as written in input decks).
#pragma once
#include <memory>
#include <string>

#include "materials/material.hpp"

namespace hyperqn {

// model: "corotated" or "neohookean" (J0 is used by "neohookean" only and must be > 0).
// Throws std::invalid_argument for any other name or an invalid J0.
std::unique_ptr<Material> make_material(const std::string& model, double mu, double lambda, double J0);

}  // namespace hyperqn

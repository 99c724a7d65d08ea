#include "materials/material_factory.hpp"

#include <stdexcept>

namespace hyperqn {

std::unique_ptr<Material> make_material(const std::string& model, double mu, double lambda, double J0) {
  if (model == "corotated") return make_corotated(mu, lambda);
  if (model == "neohookean") {
    // The quadratic extension divides by J0.
    if (!(J0 > 0.0)) throw std::invalid_argument("neohookean: J0 must be > 0, got " + std::to_string(J0));
    return make_neohookean(mu, lambda, J0);
  }
  throw std::invalid_argument("unknown material model '" + model + "' (expected corotated or neohookean)");
}

}  // namespace hyperqn

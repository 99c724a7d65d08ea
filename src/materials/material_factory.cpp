#include "materials/material_factory.hpp"

#include <stdexcept>

namespace hyperqn {

namespace {
std::unique_ptr<Material> make_model(const MaterialParams& p) {
  if (p.model == "corotated") return make_corotated(p.mu, p.lambda);
  if (p.model == "neohookean") {
    // The quadratic extension divides by J0.
    if (!(p.J0 > 0.0)) throw std::invalid_argument("neohookean: J0 must be > 0, got " + std::to_string(p.J0));
    return make_neohookean(p.mu, p.lambda, p.J0);
  }
  if (p.model == "stvk") return make_stvk(p.mu, p.lambda, p.kappa);
  if (p.model == "principal-stretch") return make_principal_stretch(p.f, p.g, p.h);
  throw std::invalid_argument("unknown material model '" + p.model +
                              "' (expected corotated, neohookean, stvk or principal-stretch)");
}
}  // namespace

std::unique_ptr<Material> make_material(const MaterialParams& params) {
  std::unique_ptr<Material> m = make_model(params);
  if (params.has_fiber) m = make_fiber(std::move(m), params.fiber_direction, params.fiber_stiffness);
  return m;
}

std::unique_ptr<Material> make_material(const std::string& model, double mu, double lambda, double J0) {
  MaterialParams p;
  p.model = model;
  p.mu = mu;
  p.lambda = lambda;
  p.J0 = J0;
  return make_material(p);
}

}  // namespace hyperqn

#include "materials/material_factory.hpp"

#include <stdexcept>

namespace hyperqn {

namespace {

std::unique_ptr<Material> create_neohookean(const MaterialParams& p) {
  // The quadratic extension divides by J0.
  if (!(p.J0 > 0.0)) throw std::invalid_argument("neohookean: J0 must be > 0, got " + std::to_string(p.J0));
  return make_neohookean(p.mu, p.lambda, p.J0);
}

}  // namespace

const std::vector<MaterialModel>& material_models() {
  static const std::vector<MaterialModel> models = {
      {"corotated", "mu ||F - R||^2 + lambda/2 (tr(R^T F) - 3)^2 (ARAP when lambda = 0)", true, {"fiber"},
       "youngs_modulus and poisson_ratio, or mu and lambda; fiber: {direction, stiffness} (optional)",
       [](const MaterialParams& p) { return make_corotated(p.mu, p.lambda); }},
      {"neohookean", "mu/2 (I1 - 3) - mu log J + lambda/2 log^2 J, log J extended quadratically below J0", true,
       {"J0", "fiber"}, "youngs_modulus and poisson_ratio, or mu and lambda; J0 (default 0.1, in (0, 1)); fiber",
       create_neohookean},
      {"stvk", "St. Venant-Kirchhoff mu ||E||^2 + lambda/2 (tr E)^2, plus kappa (1 - J)^3 / 2592 for J < 1", true,
       {"kappa", "fiber"}, "youngs_modulus and poisson_ratio, or mu and lambda; kappa (default 0, >= 0); fiber",
       [](const MaterialParams& p) { return make_stvk(p.mu, p.lambda, p.kappa); }},
      {"principal-stretch", "sum f(s_i) + sum g(s_i s_j) + h(s_1 s_2 s_3) in the signed singular values s", false,
       {"f", "g", "h", "fiber"},
       "f, g, h: {polynomial: [c0, c1, ...]} or {spline: {x: [...], y: [...]}} (at least one); fiber",
       [](const MaterialParams& p) { return make_principal_stretch(p.f, p.g, p.h); }},
      {"mass-spring", "a spring k/2 (l - L)^2 on each edge of each tet", false, {"spring_stiffness"},
       "spring_stiffness (> 0)", nullptr},
  };
  return models;
}

const MaterialModel* find_material_model(const std::string& name) {
  for (const MaterialModel& m : material_models())
    if (m.name == name) return &m;
  return nullptr;
}

static std::unique_ptr<Material> make_model(const MaterialParams& p) {
  const MaterialModel* model = find_material_model(p.model);
  if (!model || !model->create) {
    std::string expected;
    for (const MaterialModel& m : material_models())
      if (m.create) expected += (expected.empty() ? "" : ", ") + m.name;
    throw std::invalid_argument("unknown material model '" + p.model + "' (expected " + expected + ")");
  }
  return model->create(p);
}

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

#include "materials/material_factory.hpp"

#include <stdexcept>

#include "materials/maxwell_branches.hpp"
#include "materials/scalar_function.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

namespace {

std::unique_ptr<Material> create_neohookean(const MaterialParams& p) {
  // The quadratic extension divides by J0.
  if (!(p.J0 > 0.0)) throw std::invalid_argument("neohookean: J0 must be > 0, got " + std::to_string(p.J0));
  return make_neohookean(p.mu, p.lambda, p.J0);
}

}  // namespace

std::unique_ptr<Material> make_hencky(const MaterialParams& p);  // log_strain_plasticity.cpp

const std::vector<MaterialKey>& elastic_constant_keys() {
  static const std::vector<MaterialKey> keys = {
      {"youngs_modulus", &MaterialSpec::youngs_modulus, "Young's modulus E (a pressure), with `poisson_ratio`", above(0), "", false, "—"},
      {"poisson_ratio", &MaterialSpec::poisson_ratio, "Poisson's ratio ν, with `youngs_modulus`", {-1, 0.5, true, true}, "", false, "—"},
      {"mu", &MaterialSpec::mu, "Lamé μ (a pressure), with `lambda`", above(0), "", false, "—"},
      {"lambda", &MaterialSpec::lambda, "Lamé λ (a pressure), with `mu`", at_least(0), "", false, "—"},
  };
  return keys;
}

const std::vector<MaterialKey>& fiber_keys() {
  static const std::vector<MaterialKey> keys = {
      {"fiber", {}, "adds the fibre term k/2 (‖F d‖ − 1)² (d normalized, in the rest configuration) to the model", {},
       "map", false, "none"},
      {"fiber.direction", &MaterialSpec::fiber_direction, "d", nonzero_vector(), "", true},
      {"fiber.stiffness", &MaterialSpec::fiber_stiffness, "k (a pressure)", at_least(0), "", true},
  };
  return keys;
}

// The viscoelastic blocks (also viscoelastic_prony's): the Prony series' fractions g must leave the
// equilibrium part a share.
std::string check_viscoelastic(const InelasticSpec& s, std::string* key) {
  double sum = 0;
  for (const auto& b : s.items) sum += b.at("g");
  *key = "branches";
  if (sum < 1) return "";
  return "the fractions g sum to " + default_text(sum) +
         "; they must sum to less than 1 (the rest is the equilibrium part's)";
}

// Branch i's shear modulus is mu_i = g_i mu / (1 - sum g): the deck's mu is the long-term one.
static std::unique_ptr<InelasticModel> create_viscoelastic(const MaterialSpec& spec) {
  double sum = 0;
  for (const auto& b : spec.inelastic.items) sum += b.at("g");
  std::vector<MaxwellBranch> out;
  for (const auto& b : spec.inelastic.items) out.push_back({b.at("g") * spec.mu / (1.0 - sum), b.at("tau")});
  return std::make_unique<MaxwellBranches>(std::move(out));
}

const InelasticKind& plasticity_kind();          // log_strain_plasticity.cpp
const InelasticKind& viscoelastic_prony_kind();  // prony_viscoelastic.cpp

const std::vector<InelasticKind>& inelastic_kinds() {
  static const std::vector<InelasticKind> kinds = [] {
    InelasticKind visco{"viscoelastic", "viscous", {}, {}, 1, kMaxMaxwellBranches, {}, false,
                        "viscoelastic: {branches: [{g, tau}, ...]}", check_viscoelastic, create_viscoelastic};
    visco.keys = {
        {"viscoelastic", {},
         "generalized Maxwell branches in parallel with the model, which is the equilibrium (long-term) part: "
         "its shear modulus μ is the relaxed one, μ/(1 − Σg) the instantaneous; the bulk modulus does not relax "
         "([inelastic.md](inelastic.md#viscoelasticity))",
         {}, "map", false, "none"},
        {"viscoelastic.branches", {},
         "1 to 4 branches `{g: …, tau: …}`: g > 0 the branch's fraction of the instantaneous shear modulus (Σg < 1), "
         "tau > 0 its relaxation time (s)",
         {}, "list of maps", true},
    };
    visco.item_keys = {
        {"g", {}, "", above(0, "the branch's fraction of the instantaneous shear modulus"), "", true},
        {"tau", {}, "", above(0, "a relaxation time, s"), "", true},
    };
    return std::vector<InelasticKind>{visco, viscoelastic_prony_kind(), plasticity_kind()};
  }();
  return kinds;
}

const InelasticKind* find_inelastic_kind(const std::string& key) {
  for (const InelasticKind& k : inelastic_kinds())
    if (k.key == key) return &k;
  return nullptr;
}

std::unique_ptr<InelasticModel> make_inelastic(const MaterialSpec& spec) {
  const InelasticKind* kind = find_inelastic_kind(spec.inelastic.kind);
  return kind ? kind->create(spec) : nullptr;
}

bool takes_inelastic(const MaterialModel& model, const InelasticKind& kind) {
  if (kind.models.empty()) return model.elastic_constants;
  for (const std::string& m : kind.models)
    if (m == model.name) return true;
  return false;
}

const std::vector<MaterialModel>& material_models() {
  static const std::vector<MaterialModel> models = {
      {"corotated", "mu ||F - R||^2 + lambda/2 (tr(R^T F) - 3)^2 (ARAP when lambda = 0)", true, {}, true,
       [](const MaterialParams& p) { return make_corotated(p.mu, p.lambda); }},
      {"neohookean", "mu/2 (I1 - 3) - mu log J + lambda/2 log^2 J, log J extended quadratically below J0", true,
       {{"J0", &MaterialSpec::J0, "log J is replaced by a quadratic below J0", {0, 1, true, true}}}, true, create_neohookean},
      {"stvk", "St. Venant-Kirchhoff mu ||E||^2 + lambda/2 (tr E)^2, plus kappa (1 - J)^3 / 2592 for J < 1", true,
       {{"kappa", &MaterialSpec::kappa, "compression term κ(1 − J)³/2592 for J < 1", at_least(0)}}, true,
       [](const MaterialParams& p) { return make_stvk(p.mu, p.lambda, p.kappa); }},
      {"principal-stretch", "sum f(s_i) + sum g(s_i s_j) + h(s_1 s_2 s_3) in the signed singular values s", false,
       {{"f", {},
         "ψ = Σ f(σᵢ) + Σ g(σᵢσⱼ) + h(σ₁σ₂σ₃) in the signed singular values σ. A function is "
         "`{polynomial: [c0, c1, ...]}` (Σ c_k (x − 1)^k) or `{spline: {x: [...], y: [...]}}` (a monotone cubic "
         "spline through the points (x, y) of its **derivative**, the stress curve; the energy is its exact "
         "integral, zero at x = 1). At least one of f, g, h.",
         {}, "function", false, "none"},
        {"g", {}, "as `f`", {}, "function", false, "none"},
        {"h", {}, "as `f`", {}, "function", false, "none"}},
       true, [](const MaterialParams& p) { return make_principal_stretch(p.f, p.g, p.h); }},
      {"hencky", "mu |dev E|^2 + kappa/2 (tr E)^2, E = 1/2 log(F^T F), kappa = lambda + 2 mu/3 (the plastic law's)",
       true, {}, false, make_hencky},
      {"mass-spring", "a spring k/2 (l - L)^2 on each edge of each tet", false,
       {{"spring_stiffness", &MaterialSpec::spring_stiffness,
         "a spring k/2 (ℓ − L)² on each of the 6 edges of every tet (an edge shared by m tets carries m springs); a "
         "Projective Dynamics energy, so `pd` runs exact steps",
         above(0), "", true}},
       false, nullptr},
  };
  return models;
}

std::vector<MaterialKey> model_keys(const MaterialModel& model) {
  std::vector<MaterialKey> keys;
  if (model.elastic_constants) keys = elastic_constant_keys();
  keys.insert(keys.end(), model.keys.begin(), model.keys.end());
  if (model.fiber) keys.insert(keys.end(), fiber_keys().begin(), fiber_keys().end());
  for (const InelasticKind& kind : inelastic_kinds())
    if (takes_inelastic(model, kind)) keys.insert(keys.end(), kind.keys.begin(), kind.keys.end());
  return keys;
}

std::string parameters_text(const MaterialModel& model) {
  std::string s = model.elastic_constants ? "youngs_modulus and poisson_ratio, or mu and lambda" : "";
  for (const MaterialKey& k : model.keys) {
    const std::string rule = k.range.rule();
    s += (s.empty() ? "" : "; ") + std::string(k.name) + (rule.empty() ? "" : " (" + rule + ")");
  }
  s += model.fiber ? "; fiber: {direction, stiffness} (optional)" : "";
  for (const InelasticKind& kind : inelastic_kinds())
    if (takes_inelastic(model, kind)) s += std::string("; ") + kind.parameters + " (optional)";
  return s;
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

static std::shared_ptr<ScalarFunction> make_function(const FunctionSpec& f) {
  if (f.kind == "polynomial") return std::make_shared<PolynomialFunction>(f.coefficients);
  if (f.kind == "spline") return std::make_shared<MonotoneSplineFunction>(f.x, f.y);
  return nullptr;
}

MaterialParams material_params(const MaterialSpec& spec) {
  MaterialParams p;
  p.model = spec.model;
  p.mu = spec.mu;
  p.lambda = spec.lambda;
  p.J0 = spec.J0;
  p.kappa = spec.kappa;
  p.f = make_function(spec.f);
  p.g = make_function(spec.g);
  p.h = make_function(spec.h);
  p.has_fiber = spec.has_fiber;
  p.fiber_direction = Vec3(spec.fiber_direction[0], spec.fiber_direction[1], spec.fiber_direction[2]);
  p.fiber_stiffness = spec.fiber_stiffness;
  return p;
}

std::unique_ptr<Material> make_material(const MaterialSpec& spec) { return make_material(material_params(spec)); }

}  // namespace hyperqn

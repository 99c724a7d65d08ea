// The material models by name (as written in decks): one registry entry per model, read by the
// deck reader, the factory below and --help. docs/architecture.md, "Add a material".
#pragma once
#include <array>
#include <memory>
#include <variant>
#include <string>
#include <vector>

#include "params/key_range.hpp"
#include "materials/material.hpp"
#include "materials/maxwell_branches.hpp"
#include "materials/scalar_function.hpp"

namespace hyperqn {

// Everything a material may need; each model reads only its own fields.
struct MaterialParams {
  std::string model = "corotated";  // "corotated", "neohookean", "stvk" or "principal-stretch"
  double mu = 0.0, lambda = 0.0;    // Lame parameters (not used by "principal-stretch")
  double J0 = 0.1;                  // "neohookean": start of the quadratic log extension, > 0
  double kappa = 0.0;               // "stvk": compression term kappa (1 - J)^3 / 2592 for J < 1, >= 0
  // "principal-stretch": psi = sum f(sigma_i) + sum g(sigma_i sigma_j) + h(J); null = zero function,
  // at least one must be set.
  std::shared_ptr<ScalarFunction> f, g, h;
  // Optional fibre term k/2 (||F d|| - 1)^2 on top of any model (d is normalized, k >= 0).
  bool has_fiber = false;
  Vec3 fiber_direction = Vec3::UnitX();
  double fiber_stiffness = 0.0;
};

// A scalar function of the principal-stretch materials: polynomial coefficients c_k of (x - 1)^k,
// or a monotone cubic spline through control points (x_i, y_i) of its derivative.
struct FunctionSpec {
  std::string kind;                  // "" (absent) | polynomial | spline
  std::vector<double> coefficients, x, y;
};

// The deck's material (a body's, model/scene_spec.hpp): its keys (app/deck_keys.cpp, material_keys) come from
// the registry below, each MaterialKey naming the member it sets.
// A branch of the viscoelastic Prony series (materials/maxwell_branches.hpp), as the deck gives it.
struct ViscoelasticBranch {
  double g = 0;    // shear-modulus fraction of the instantaneous modulus, > 0 (sum over branches < 1)
  double tau = 0;  // relaxation time, > 0
  int line = 0;    // its deck line
};

struct MaterialSpec {
  std::string model = "corotated";   // a model of the registry below
  double youngs_modulus = 0, poisson_ratio = 0;  // as the deck gives them (if it does)
  double mu = 0, lambda = 0;         // Lame parameters (from E, nu if those were given)
  double kappa = 0;                  // stvk: compression term kappa (1 - J)^3 / 2592 for J < 1
  double spring_stiffness = 0;       // mass-spring: k of the spring on each edge of each tet
  FunctionSpec f, g, h;              // principal-stretch: psi = sum f(s_i) + sum g(s_i s_j) + h(J)
  bool has_fiber = false;            // fibre term k/2 (|F d| - 1)^2 on top of the model
  std::array<double, 3> fiber_direction{1, 0, 0};
  double fiber_stiffness = 0;
  bool has_density = false;
  double density = 1000;             // mass per unit volume, or
  double total_mass = 0;             // total mass (used when has_density is false)
  double J0 = 0.1;                   // Neo-Hookean: start of the quadratic extension of log J
  double laplacian_weight = 0;       // 0: the material's own weight (mass-spring: k); > 0: override
  // Viscoelastic branches over the model as the equilibrium part (none: elastic). Branch i's shear
  // modulus is mu_i = g_i mu / (1 - sum g): the deck's mu is the long-term one, mu / (1 - sum g)
  // the instantaneous (docs/materials.md#viscoelasticity).
  std::vector<ViscoelasticBranch> viscoelastic;
};

// A deck key of material models (material.<name>), declared once here: its range, and which
// models take it (their lists below). The deck's material keys (app/deck_keys.cpp) are made
// from these, so the deck reader, --help-deck and docs/deck-scene.md take them from here.
struct MaterialKey {
  const char* name;           // a key of a map follows the map's own entry: "fiber.stiffness"
  // The member of MaterialSpec it sets (none: a map or a function, which the deck reader reads).
  std::variant<std::monostate, double MaterialSpec::*, std::array<double, 3> MaterialSpec::*> member;
  const char* doc;
  KeyRange range = {};
  const char* type = "";      // "": a number or vec3 (its member); else as docs show it ("map", ...)
  bool required = false;      // required with the models that take it
  const char* default_text = "";  // instead of MaterialSpec's default
};

// Youngs_modulus, poisson_ratio, mu and lambda: the models with elastic_constants take them.
const std::vector<MaterialKey>& elastic_constant_keys();
// The optional fibre term k/2 (||F d|| - 1)^2 on top of a model with `fiber`: fiber, fiber.direction, fiber.stiffness.
const std::vector<MaterialKey>& fiber_keys();
// The viscoelastic branches over a model with elastic constants: viscoelastic, viscoelastic.branches.
const std::vector<MaterialKey>& viscoelastic_keys();
// The branches' shear moduli and relaxation times of a material with viscoelastic branches.
std::vector<MaxwellBranch> maxwell_branches(const MaterialSpec& spec);

struct MaterialModel {
  std::string name;        // material.model in a deck
  std::string summary;     // one line: what the energy is
  // Its deck keys beside model, the mass and laplacian_weight (every model's): the elastic
  // constants or not, its own keys, and the fibre term or not; a key of another model is a deck
  // error naming the models that take it.
  bool elastic_constants;
  std::vector<MaterialKey> keys;
  bool fiber;
  // Builds the material (throws std::invalid_argument for invalid parameters); null for a model
  // that is not an energy density of F (mass-spring: springs on the tet edges, an energy term of
  // its own, terms/mass_spring_tets.hpp).
  std::unique_ptr<Material> (*create)(const MaterialParams&);
};
// Every key of the model, in that order.
std::vector<MaterialKey> model_keys(const MaterialModel& model);
// The model's keys in one line, for --help and `hyperqn registry`.
std::string parameters_text(const MaterialModel& model);
// Every model, in the order decks and --help list them.
const std::vector<MaterialModel>& material_models();
// The model of that name, or null.
const MaterialModel* find_material_model(const std::string& name);

// Throws std::invalid_argument for an unknown model or invalid parameters.
std::unique_ptr<Material> make_material(const MaterialParams& params);

// Shorthand for make_material({model, mu, lambda, J0}) with the other fields at their defaults
// (so "stvk" has kappa = 0 and "principal-stretch", having no f, g, h, throws).
std::unique_ptr<Material> make_material(const std::string& model, double mu, double lambda, double J0);

}  // namespace hyperqn

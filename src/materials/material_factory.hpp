// The material models by name (as written in decks): one registry entry per model, read by the
// deck reader, the factory below and --help. docs/architecture.md, "Add a material".
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "materials/material.hpp"
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

struct MaterialModel {
  std::string name;        // material.model in a deck
  std::string summary;     // one line: what the energy is
  // Its deck keys: the elastic constants (youngs_modulus and poisson_ratio, or mu and lambda) or
  // not, and its own keys (beside model, the mass and laplacian_weight, which every model takes);
  // a key of another model is a deck error. parameters documents them, with defaults and ranges.
  bool elastic_constants;
  std::vector<std::string> keys;
  std::string parameters;
  // Builds the material (throws std::invalid_argument for invalid parameters); null for a model
  // that is not an energy density of F (mass-spring: springs on the tet edges, an energy term of
  // its own, terms/mass_spring_tets.hpp).
  std::unique_ptr<Material> (*create)(const MaterialParams&);
};
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

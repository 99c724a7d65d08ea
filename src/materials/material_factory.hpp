// The material models by name (as written in decks): one registry entry per model, read by the
// deck reader, the factory below and --help. docs/architecture.md, "Add a material".
#pragma once
#include <array>
#include <memory>
#include <variant>
#include <string>
#include <vector>

#include "params/key_range.hpp"
#include "materials/fracture_spec.hpp"
#include "materials/material.hpp"
#include "materials/inelastic_model.hpp"
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
  // The inelastic block (material.viscoelastic, material.plastic, ...: inelastic_kinds below), if any.
  InelasticSpec inelastic;
  // Its fracture criterion (material.fracture, materials/fracture_spec.hpp), if any.
  FractureSpec fracture;
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
// An inelastic model's deck block and its builder: one entry of inelastic_kinds() per model
// (docs/extending.md, "Add an inelastic model"). The deck reader reads the block generically
// (app/deck_sections.cpp, read_inelastic): its numbers with their ranges, then check; the scene
// gives each material that has it one InelasticModel from create, in a term per kind
// (terms/inelastic_tets.hpp, model/elastic_terms.cpp).
struct InelasticKind {
  const char* key;    // material.<key>, also the word of messages ("viscoelastic")
  const char* state;  // its ElementState's name: the checkpoints' key (elements_<state>)
  // The map and its keys ("plastic", "plastic.yield_stress"), for the deck reader, --help-deck and
  // the docs; a number key's range is checked by the reader, its value lands in InelasticSpec.values.
  std::vector<MaterialKey> keys;
  // A key of type "list of maps" among keys: its items' number keys, and how many items.
  std::vector<MaterialKey> item_keys;
  int min_items = 0, max_items = 0;
  // The elastic models it sits on; empty: every model with elastic constants.
  std::vector<std::string> models;
  // True: the model's energy is the material's whole energy (the elastic model only names its
  // elastic law); false: it adds to the elastic model's energy (its equilibrium part).
  bool whole_energy = false;
  const char* parameters;  // one line for --help: "viscoelastic: {branches: [{g, tau}, ...]}"
  // The rules between the block's keys: "" or the problem, with the key it names in *key.
  std::string (*check)(const InelasticSpec&, std::string* key);
  // The model of a material whose block check passed (its elastic constants in spec).
  std::unique_ptr<InelasticModel> (*create)(const MaterialSpec&);
};
// Every inelastic model, in the order decks and --help list them.
const std::vector<InelasticKind>& inelastic_kinds();
// The kind of that key, or null.
const InelasticKind* find_inelastic_kind(const std::string& key);
// The inelastic model of a material with an inelastic block (null without one).
std::unique_ptr<InelasticModel> make_inelastic(const MaterialSpec& spec);

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
// Whether the inelastic kind sits on the model.
bool takes_inelastic(const MaterialModel& model, const InelasticKind& kind);
// Every key of the model, in that order (its inelastic kinds' last).
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

// The deck's material description in the form the factory takes (every field, the functions too),
// and its Material. (mass-spring is not a Material of F alone: see materials/tet_springs.hpp.)
MaterialParams material_params(const MaterialSpec& spec);
std::unique_ptr<Material> make_material(const MaterialSpec& spec);

}  // namespace hyperqn

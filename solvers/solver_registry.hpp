// The time-step solvers by name (solver.type in a deck): one registry entry per solver, read by
// the deck reader, the study, --help and `hyperqn registry` (which the Python tools read).
// docs/architecture.md, "Add a solver".
#pragma once
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "solvers/factored_system.hpp"
#include "solvers/objective.hpp"
#include "solvers/solver_spec.hpp"
#include "solvers/time_step_solver.hpp"

namespace hyperqn {

struct SolverInfo {
  std::string name;          // solver.type
  std::string summary;       // one line
  bool uses_constant_matrix; // needs a factored constant matrix (so the scene factors it once)
  bool takes_h0;             // solver.h0 chooses that matrix; otherwise it is M + h^2 L
  // Creates and sets it up; h0 is its factored constant matrix (null unless uses_constant_matrix).
  PetscErrorCode (*create)(const SolverSpec& spec, Objective& objective, const FactoredSystem* h0,
                           std::unique_ptr<TimeStepSolver>& solver);
};

// Every solver, in the order decks, the study and --help list them.
const std::vector<SolverInfo>& solver_registry();
std::vector<std::string> solver_names();
// The solver of that name, or null.
const SolverInfo* find_solver(const std::string& name);

// True if the solver needs a factored constant matrix (so the scene factors it once).
bool solver_uses_constant_matrix(const std::string& type);
// True if solver.h0 chooses that matrix for this solver (lbfgs); pd is defined by M + h^2 L.
bool solver_takes_h0(const std::string& type);
// What solver.h0 says of this solver's constant matrix (if solver_uses_constant_matrix): spec.h0
// for lbfgs, M + h^2 L for pd.
H0 solver_h0(const SolverSpec& spec);
// solver.h0: auto takes the V-cycle on meshes of at least this many tetrahedra (resolved_h0).
constexpr int64_t kAmgFromTets = 200000;
// Below that, solver.h0: auto takes the volumetric H0 when a tetrahedral material's Poisson ratio at
// rest is at least this (the crossover measured on the stability suite's cantilever:
// docs/records/2026-12-04-stiff-h0.md). Ratios within kPoissonSlack below it count as it (the
// ratio comes back from the Lame parameters a deck's E and nu give, to round-off).
constexpr double kVolumetricFromPoisson = 0.499;
constexpr double kPoissonSlack = 1e-9;
// Below that, solver.h0: auto takes the rest stiffness for a scene held still whose self-weight
// deflection scale (self_weight_deflection: rho |g| D^3 / (E w^2), D the rest bounding box's
// diagonal and w its smallest side, rho the densest and E the softest tet material) is below this:
// a stiff scene that bends little, where M + h^2 L leaves its bending mode behind (the crossover
// measured on cantilevers of two shapes: docs/records/2026-12-07-stiff-auto-h0.md). 0: not such a
// scene (held_still_weight, SceneOptions::weight_per_length).
constexpr double kRestStiffnessBelowDeflection = 0.1;
// That scale of a scene held still, held_weight = |g| rho / E (held_still_weight; 0: not such a
// scene, which gives 0), whose rest bounding box is lo..hi.
inline double self_weight_deflection(double held_weight, const double lo[3], const double hi[3]) {
  const double a = hi[0] - lo[0], b = hi[1] - lo[1], c = hi[2] - lo[2];
  const double D = std::sqrt(a * a + b * b + c * c), w = std::min(a, std::min(b, c));
  return held_weight > 0 && w > 0 ? held_weight * D * D * D / (w * w) : 0;
}
// That matrix on a mesh of `tets` tetrahedra whose largest tetrahedral Poisson ratio is
// poisson_ratio (largest_poisson_ratio; 0 without tets) and whose self-weight deflection scale is
// weight_deflection (0: not a scene held still): automatic resolved here, and nowhere else (the
// V-cycle from kAmgFromTets tets on, else the factor of M + h^2 K(x_rest) below
// kRestStiffnessBelowDeflection, else the factor of M + h^2 K_vol from kVolumetricFromPoisson on,
// else the factor of M + h^2 L).
H0 resolved_h0(H0 h0, int64_t tets, double poisson_ratio, double weight_deflection = 0);
inline H0 resolved_h0(const SolverSpec& spec, int64_t tets, double poisson_ratio, double weight_deflection = 0) {
  return resolved_h0(solver_h0(spec), tets, poisson_ratio, weight_deflection);
}
// The keys of `solver:` that spec.type does not read, each as "key: value", where the deck set them
// to other than their default (a run warns of each): the H0 keys but with lbfgs (solver_takes_h0),
// history and history_reset but with lbfgs and lbfgs-identity. Not a key that a rule of the scene
// set (rule_sources: Deck::rule_sources, "solver.h0" -> the rule): the deck did not. A study reads
// them all (its lbfgs contender).
std::vector<std::string> solver_keys_ignored(const SolverSpec& spec, const std::map<std::string, std::string>& rule_sources);
// The matrix itself (the V-cycle applies M + h^2 L).
ConstantMatrix constant_matrix_of(H0 h0);

// Creates the solver spec.type; h0 may be nullptr when it does not use the constant matrix.
PetscErrorCode create_solver(const SolverSpec& spec, Objective& objective, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver);

}  // namespace hyperqn

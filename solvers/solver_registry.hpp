// The time-step solvers by name (solver.type in a deck): one registry entry per solver, read by
// the deck reader, the study, --help and `hyperqn registry` (which the Python tools read).
// docs/architecture.md, "Add a solver".
#pragma once
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
// The constant matrix a solver with these settings factors (if solver_uses_constant_matrix).
ConstantMatrix constant_matrix_of(const SolverSpec& spec);
// True if that matrix (M + h^2 L) is applied by one AMG V-cycle instead of a factorization
// (lbfgs with solver.h0: amg).
bool constant_matrix_by_amg(const SolverSpec& spec);
// True if the scene chooses between the factor and the V-cycle of M + h^2 L by the mesh (lbfgs
// with solver.h0: auto, the default; auto_h0_is_amg).
bool constant_matrix_auto(const SolverSpec& spec);

// Creates the solver spec.type; h0 may be nullptr when it does not use the constant matrix.
PetscErrorCode create_solver(const SolverSpec& spec, Objective& objective, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver);

}  // namespace hyperqn

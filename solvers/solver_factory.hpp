// Creates the deck's time-step solver.
#pragma once
#include <memory>

#include "solvers/solver_spec.hpp"
#include "solvers/factored_system.hpp"
#include "solvers/time_step_solver.hpp"

namespace hyperqn {

// True if the solver needs the factored M + h^2 L (so the scene factors it once).
bool solver_uses_constant_matrix(const std::string& type);

// h0 may be nullptr when solver_uses_constant_matrix(spec.type) is false.
PetscErrorCode create_solver(const SolverSpec& spec, Objective& step, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver);

}  // namespace hyperqn

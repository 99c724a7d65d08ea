#include "solvers/solver_factory.hpp"

#include "solvers/lbfgs_solver.hpp"
#include "solvers/newton_solver.hpp"
#include "solvers/pd_solver.hpp"

namespace hyperqn {

bool solver_uses_constant_matrix(const std::string& type) { return type == "lbfgs" || type == "pd"; }

PetscErrorCode create_solver(const SolverSpec& spec, Objective& step, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver) {
  PetscFunctionBeginUser;
  PetscCheck(!solver_uses_constant_matrix(spec.type) || h0, PETSC_COMM_SELF, PETSC_ERR_ARG_NULL,
             "solver %s needs the factored M + h^2 L", spec.type.c_str());
  if (spec.type == "lbfgs" || spec.type == "lbfgs-identity") {
    auto s = std::make_unique<LbfgsSolver>(step, spec.type == "lbfgs" ? h0 : nullptr);
    PetscCall(s->setup(spec));
    solver = std::move(s);
  } else if (spec.type == "newton") {
    auto s = std::make_unique<NewtonSolver>(step);
    PetscCall(s->setup(spec));
    solver = std::move(s);
  } else if (spec.type == "pd") {
    auto s = std::make_unique<PdSolver>(step, *h0);
    PetscCall(s->setup(spec));
    solver = std::move(s);
  } else {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "unknown solver type %s", spec.type.c_str());
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

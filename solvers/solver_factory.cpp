#include "solver_factory.hpp"

#include "lbfgs_solver.hpp"

namespace hyperqn {

bool solver_uses_constant_matrix(const std::string& type) { return type == "lbfgs"; }

PetscErrorCode create_solver(const SolverSpec& spec, TimeStep& step, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver) {
  PetscFunctionBeginUser;
  if (spec.type == "lbfgs") {
    auto s = std::make_unique<LbfgsSolver>(step, h0);
    PetscCall(s->setup(spec));
    solver = std::move(s);
  } else {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "unknown solver type %s", spec.type.c_str());
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

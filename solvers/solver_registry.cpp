#include "solvers/solver_registry.hpp"

#include "solvers/lbfgs_solver.hpp"
#include "solvers/newton_solver.hpp"
#include "solvers/pd_solver.hpp"

namespace hyperqn {

namespace {

// Constructs a solver of type S with args and runs its setup(spec).
template <class S, class... Args>
PetscErrorCode set_up(const SolverSpec& spec, std::unique_ptr<TimeStepSolver>& solver, Args&&... args) {
  PetscFunctionBeginUser;
  auto s = std::make_unique<S>(std::forward<Args>(args)...);
  PetscCall(s->setup(spec));
  solver = std::move(s);
  PetscFunctionReturn(0);
}

}  // namespace

const std::vector<SolverInfo>& solver_registry() {
  static const std::vector<SolverInfo> solvers = {
      {"lbfgs", "L-BFGS (TAO) with the factored M + h^2 L (or solver.h0) as initial inverse Hessian (Liu, Bouaziz & Kavan 2017)", true, true,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem* h0, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<LbfgsSolver>(spec, s, g, h0);
       }},
      {"lbfgs-identity", "L-BFGS (TAO) with TAO's own initial Hessian: the ablation of lbfgs", false, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem*, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<LbfgsSolver>(spec, s, g, nullptr);
       }},
      {"newton", "Newton (TAO NLS or NTR) with a per-element PSD fix (or the exact Hessian), MUMPS or CG + BoomerAMG",
       false, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem*, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<NewtonSolver>(spec, s, g);
       }},
      {"pd", "Projective Dynamics / fast mass-springs: x <- x - A^{-1} grad g, exact steps for PD energies", true, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem* h0, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<PdSolver>(spec, s, g, *h0);
       }},
  };
  return solvers;
}

std::vector<std::string> solver_names() {
  std::vector<std::string> names;
  for (const SolverInfo& s : solver_registry()) names.push_back(s.name);
  return names;
}

const SolverInfo* find_solver(const std::string& name) {
  for (const SolverInfo& s : solver_registry())
    if (s.name == name) return &s;
  return nullptr;
}

bool solver_uses_constant_matrix(const std::string& type) {
  const SolverInfo* s = find_solver(type);
  return s && s->uses_constant_matrix;
}

bool solver_takes_h0(const std::string& type) {
  const SolverInfo* s = find_solver(type);
  return s && s->takes_h0;
}

ConstantMatrix constant_matrix_of(const SolverSpec& spec) {
  return solver_takes_h0(spec.type) && spec.h0 == "rest-stiffness" ? ConstantMatrix::rest_stiffness
                                                                    : ConstantMatrix::laplacian;
}

bool constant_matrix_by_amg(const SolverSpec& spec) { return solver_takes_h0(spec.type) && spec.h0 == "amg"; }

bool constant_matrix_auto(const SolverSpec& spec) { return solver_takes_h0(spec.type) && spec.h0 == "auto"; }

PetscErrorCode create_solver(const SolverSpec& spec, Objective& objective, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver) {
  const SolverInfo* s = find_solver(spec.type);
  PetscFunctionBeginUser;
  PetscCheck(s, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "unknown solver type %s", spec.type.c_str());
  PetscCheck(!s->uses_constant_matrix || h0, PETSC_COMM_SELF, PETSC_ERR_ARG_NULL, "solver %s needs its factored constant matrix",
             spec.type.c_str());
  PetscCheck(!h0 || !s->uses_constant_matrix || h0->kind() == constant_matrix_of(spec), PETSC_COMM_SELF, PETSC_ERR_PLIB,
             "solver %s was given the wrong constant matrix", spec.type.c_str());
  PetscCheck(!h0 || !s->uses_constant_matrix || constant_matrix_auto(spec) ||
                 (h0->package() == FactorPackage::amg) == constant_matrix_by_amg(spec),
             PETSC_COMM_SELF, PETSC_ERR_PLIB, "solver %s was given the wrong kind of constant matrix solve (AMG or factor)",
             spec.type.c_str());
  PetscCall(s->create(spec, objective, h0, solver));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

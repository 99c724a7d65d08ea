// Projective Dynamics / fast mass-springs local-global iteration (Bouaziz et al. 2014), written
// in its equivalent quasi-Newton form x <- x - A^{-1} grad g(x) with the prefactored
// A = M + h^2 L. For energies where PD is exact (corotated with lambda = 0, i.e. ARAP) the
// step alpha = 1 is the local-global step and decreases g monotonically; for other materials
// the same direction is used with a backtracking line search (said in the log).
#pragma once
#include "solvers/solver_spec.hpp"
#include "solvers/factored_system.hpp"
#include "solvers/time_step_solver.hpp"
#include "solvers/objective.hpp"

namespace hyperqn {

class PdSolver : public TimeStepSolver {
 public:
  PdSolver(Objective& step, const FactoredSystem& A) : step_(step), A_(A) {}
  ~PdSolver() override;
  PetscErrorCode setup(const SolverSpec& spec);
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  Objective& step_;
  const FactoredSystem& A_;
  SolverSpec spec_;
  bool exact_ = false;  // PD energy with its own L: alpha = 1, no line search
  // Work vectors, created once in setup: grad g(x), direction, trial point and its gradient.
  Vec grad_ = nullptr, dir_ = nullptr, trial_ = nullptr, trial_grad_ = nullptr;
};

}  // namespace hyperqn

// Baseline: Newton's method on g with TAO (TAONLS by default, TAONTR selectable). The Hessian
// M + h^2 K(x) uses per-element stiffness made positive semi-definite (definiteness fix), and is
// solved by MUMPS Cholesky (symbolic analysis once per scene, numeric factorization per
// iteration) or by CG + BoomerAMG with the rigid-body near-null space.
#pragma once
#include <petsctao.h>

#include "deck.hpp"
#include "time_step_solver.hpp"
#include "time_step.hpp"

namespace hyperqn {

class NewtonSolver : public TimeStepSolver {
 public:
  explicit NewtonSolver(TimeStep& step) : step_(step) {}
  ~NewtonSolver() override;
  PetscErrorCode setup(const SolverSpec& spec);
  std::string name() const override { return "newton"; }
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  static PetscErrorCode objective_gradient(Tao, Vec x, PetscReal* f, Vec g, void* ctx);
  static PetscErrorCode hessian(Tao, Vec x, Mat H, Mat Hpre, void* ctx);
  static PetscErrorCode monitor(Tao tao, void* ctx);
  static PetscErrorCode convergence_test(Tao tao, void* ctx);

  TimeStep& step_;
  Tao tao_ = nullptr;
  Mat H_ = nullptr;
  bool exact_ = false;    // newton_hessian: exact -> no PSD fix (LDL^T; quadratic convergence)
  Vec coords_ = nullptr;  // cg-amg only: the current positions with block size 3 (rigid-body modes)
  const IterationCallback* on_iteration_ = nullptr;
  double start_ = 0;
  bool stop_requested_ = false;
  // Guardrail: a line search without a sufficient-decrease test (unit) may accept a rejected
  // point (non-finite g); the last reported iterate is kept to undo that step.
  Vec last_x_ = nullptr;
  PetscReal last_f_ = 0, last_gnorm_ = 0;
  PetscInt reported_ = -1;
  bool bad_point_ = false;
};

}  // namespace hyperqn

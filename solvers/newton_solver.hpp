// Baseline: Newton's method on g with TAO (TAONLS by default, TAONTR selectable). The Hessian
// M + h^2 K(x) uses per-element stiffness made positive semi-definite (definiteness fix), and is
// solved by MUMPS Cholesky (symbolic analysis once per scene, numeric factorization per
// iteration) or by CG + BoomerAMG with the rigid-body near-null space.
#pragma once
#include <petsctao.h>

#include "solvers/solver_spec.hpp"
#include "solvers/guarded_tao_solver.hpp"

namespace hyperqn {

class NewtonSolver : public GuardedTaoSolver {
 public:
  explicit NewtonSolver(Objective& step) : GuardedTaoSolver(step) {}
  ~NewtonSolver() override;
  PetscErrorCode setup(const SolverSpec& spec);

 private:
  static PetscErrorCode hessian(Tao, Vec x, Mat H, Mat Hpre, void* ctx);
  PetscErrorCode retry(Vec x, PetscReal* g, double* alpha, bool* recovered) override;

  Mat H_ = nullptr;
  bool exact_ = false;    // newton_hessian: exact -> no PSD fix (LDL^T; quadratic convergence)
  bool trust_region_ = false;  // TAONTR instead of TAONLS
  Vec coords_ = nullptr;  // cg-amg only: the current positions with block size 3 (rigid-body modes)
};

}  // namespace hyperqn

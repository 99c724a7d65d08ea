// Baseline: Newton's method on g with TAO (TAONLS by default, TAONTR selectable). The Hessian
// M + h^2 K(x) uses per-element stiffness made positive semi-definite (definiteness fix), and is
// solved by MUMPS Cholesky (symbolic analysis once per scene, numeric factorization per
// iteration) or by CG + BoomerAMG with the rigid-body near-null space.
#pragma once
#include <petsctao.h>

#include "solvers/solver_spec.hpp"
#include "solvers/guarded_tao_solver.hpp"

namespace hyperqn {

// Whether Newton (the solver, or the fallback chain's stage 3) solves with CG + BoomerAMG:
// linear_solver cg-amg, or auto on a Hessian of kNewtonAmgFromVertices free vertices or more, where
// MUMPS's factor of the 3n x 3n Hessian, whole on every rank, would take gigabytes per rank (860 B
// per vertex^(4/3), docs/guardrails.md#memory: 1.6 GB at 50,000 vertices, 22 GB at box2m's 350,000).
bool newton_uses_amg(LinearSolver linear_solver, int64_t vertices);
constexpr int64_t kNewtonAmgFromVertices = 50000;

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

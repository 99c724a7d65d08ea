// Liu, Bouaziz & Kavan 2017: L-BFGS on g whose initial inverse Hessian is A^{-1} = (M + h^2 L)^{-1},
// run by PETSc TAO (TAOLMVM) with A's Cholesky factor given as H0 (or, with solver.h0: amg, one
// AMG V-cycle of A, an SPD approximation of A^{-1}). Without h0 it is TAO's
// L-BFGS with its own default H0 (in PETSc 3.18 a diagonal scaling updated from the (s, y)
// pairs; -tao_lmvm_mat_lmvm_scale_type scalar gives the classic gamma*I): the ablation
// "lbfgs-identity".
#pragma once
#include <petsctao.h>

#include <memory>

#include "solvers/contact_h0.hpp"
#include "solvers/rigid_mode_h0.hpp"
#include "solvers/streamed_two_loop.hpp"
#include "solvers/solver_spec.hpp"
#include "solvers/factored_system.hpp"
#include "solvers/guarded_tao_solver.hpp"

namespace hyperqn {

class LbfgsSolver : public GuardedTaoSolver {
 public:
  // h0: the factored M + h^2 L (or its V-cycle), or nullptr for TAO's default H0.
  LbfgsSolver(Objective& step, const FactoredSystem* h0) : GuardedTaoSolver(step), h0_(h0) {}
  PetscErrorCode setup(const SolverSpec& spec);
  // With solver.h0_contact, H0 takes the contacts' stiffness at the step's start first, then with
  // solver.h0_rigid the stiff clusters' rotations at x_n.
  PetscErrorCode solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) override;

 private:
  PetscErrorCode retry(Vec x, PetscReal* g, double* alpha, bool* recovered) override;
  PetscErrorCode after_iterate(PetscInt iteration) override;
  PetscErrorCode before_resume(Vec x) override;
  bool reset_on_contact_change_ = false;  // SolverSpec::history_reset
  unsigned long long active_set_ = 0;     // of the last iterate

  const FactoredSystem* h0_;
  std::unique_ptr<ContactH0> contact_h0_;  // solver.h0_contact other than off
  std::unique_ptr<RigidModeH0> rigid_h0_;  // solver.h0_rigid, in a scene with a stiff cluster
  std::unique_ptr<StreamedTwoLoop> streamed_;  // solver.two_loop streamed
};

}  // namespace hyperqn

#include "solvers/lbfgs_solver.hpp"

#include <string>

#include "solvers/line_search.hpp"
#include "solvers/streamed_two_loop.hpp"

namespace hyperqn {

// Sets an option's default unless the user gave it (command line or deck petsc: section).
static PetscErrorCode set_default_option(const char* name, const std::string& value) {
  PetscBool set;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasName(nullptr, nullptr, name, &set));
  if (!set) {
    PetscCall(PetscOptionsSetValue(nullptr, name, value.c_str()));
    // Ours, not the user's: looked up once, so the end-of-run warning about options nobody used
    // does not name it when another TAO type (-tao_type) ignores it.
    PetscCall(PetscOptionsHasName(nullptr, nullptr, name, &set));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode LbfgsSolver::setup(const SolverSpec& spec) {
  PetscFunctionBeginUser;
  PetscCall(create_tao(spec, TAOLMVM, true));
  // The contacts' stiffness (a scene with contact only; woodbury needs A = A1 (x) I3,
  // solvers/contact_h0.hpp).
  Mat h0_inverse = nullptr;
  if (h0_ && spec.h0_contact != H0Contact::off && step_.has_vertex_stiffness() &&
      (h0_->kind() == ConstantMatrix::laplacian || spec.h0_contact == H0Contact::refactor)) {
    contact_h0_ = std::make_unique<ContactH0>(step_, *h0_, spec.h0_contact);
    PetscCall(contact_h0_->setup());
    h0_inverse = contact_h0_->inverse_operator();
  } else if (h0_) {
    h0_inverse = h0_->inverse_operator();
  }
  // The stiff clusters' rotations (solvers/rigid_mode_h0.hpp): a correction of L's A, factored (not
  // amg's V-cycle, which is not A^{-1}), with no held slots; nothing where the scene has no contrast.
  if (h0_inverse && spec.h0_rigid != H0Rigid::off && (spec.h0_rigid == H0Rigid::on || RigidModeH0::kByDefault) &&
      h0_->kind() == ConstantMatrix::laplacian && h0_->package() != FactorPackage::amg && !step_.holds_components()) {
    rigid_h0_ = std::make_unique<RigidModeH0>(step_, h0_inverse);
    bool found = false;
    PetscCall(rigid_h0_->setup(&found));
    if (found)
      h0_inverse = rigid_h0_->inverse_operator();
    else
      rigid_h0_.reset();
  }
  // TAOLMVM's history size is only reachable as an option (no setter for its matrix in 3.18).
  const char* history_option = "-tao_lmvm_mat_lmvm_hist_size";
  PetscCall(set_default_option(history_option, std::to_string(spec.history)));
  // The option may come from the user too (checked as given in app/run_options.cpp: PETSc crashes
  // on a negative size and allocates without bound on a huge one).
  PetscInt history = spec.history;
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, history_option, &history, nullptr));
  reset_on_contact_change_ = spec.history_reset == HistoryReset::contact_change;
  // solver.two_loop streamed: the pairs and H0 are one operator, TAO's H0, and TAO's own BFGS keeps
  // none (it then copies g and applies its H0). The option is TAO's only for finish_setup's read.
  const bool streamed = h0_inverse && spec.two_loop == TwoLoop::streamed;
  if (streamed) {
    streamed_ = std::make_unique<StreamedTwoLoop>(tao_, h0_inverse, (int)history);
    PetscCall(streamed_->setup(step_.layout()));
    h0_inverse = streamed_->operator_mat();
    PetscCall(PetscOptionsSetValue(nullptr, history_option, "0"));
  }
  if (h0_inverse) PetscCall(TaoLMVMSetH0(tao_, h0_inverse));
  PetscCall(finish_setup());
  if (streamed) PetscCall(PetscOptionsSetValue(nullptr, history_option, std::to_string(history).c_str()));
  // Allocate TAO's work space now, so the first frame's timing holds only its iterations.
  Vec x;
  PetscCall(VecDuplicate(step_.layout(), &x));
  PetscCall(TaoSetSolution(tao_, x));
  PetscCall(TaoSetUp(tao_));
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

PetscErrorCode LbfgsSolver::solve(Vec x, const IterationCallback& on_iteration, FrameResult& result) {
  PetscFunctionBeginUser;
  if (contact_h0_) PetscCall(contact_h0_->update());
  if (rigid_h0_) PetscCall(rigid_h0_->update());
  PetscCall(GuardedTaoSolver::solve(x, on_iteration, result));
  PetscFunctionReturn(0);
}

// TAOLMVM's own recovery from a failed line search does not work in 3.18 (it clears the history
// and H0 and retries along the negated failed direction with a clobbered gradient, so it always
// fails again; Armijo does backtrack from a rejected point, More-Thuente does not). So, after
// GuardedTaoSolver::solve's backtracking: along -H0 grad g, then along -grad g; TAO then resumes
// with a cleared L-BFGS history.
PetscErrorCode LbfgsSolver::retry(Vec x, PetscReal* g, double* alpha, bool* recovered) {
  std::string along;
  PetscFunctionBeginUser;
  PetscCall(retry_descent(step_, h0_, -1.0, x, g, grad_, alpha, &along, recovered));
  PetscFunctionReturn(0);
}

// A static step: the contacts' stiffness at the iterate it resumes from, not at x_n. Without inertia
// a body that only contact holds has M alone in H0 along its rigid modes (M/s^2 against s^2 K),
// and at x_n it is not yet in contact: every resumed TaoSolve's first step carried it s^2 g
// (1.6e5 m), the barrier cut that to its clearance, and L-BFGS crawled (a cube on a clamped
// block: no equilibrium within 400 iterations, Newton's fallback 9.4 s; now 0.1 s).
PetscErrorCode LbfgsSolver::before_resume(Vec x) {
  PetscFunctionBeginUser;
  if (contact_h0_ && step_.seeks_equilibrium()) PetscCall(contact_h0_->update(x));
  PetscFunctionReturn(0);
}

// solver.history_reset: contact-change: a new TaoSolve (no (s, y) pairs) from an iterate whose set
// of contacts differs from the previous iterate's.
PetscErrorCode LbfgsSolver::after_iterate(PetscInt iteration) {
  PetscFunctionBeginUser;
  if (!reset_on_contact_change_) PetscFunctionReturn(0);
  const unsigned long long now = step_.active_set();
  if (iteration > 0 && now != active_set_) history_reset_requested_ = true;
  active_set_ = now;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "model/step_lifecycle.hpp"

namespace hyperqn {

StepLifecycle::StepLifecycle(Body& body, double dt, double damping, TimeIntegrator kind)
    : body_(body), dt_(dt), damping_(damping), kind_(kind), integrator_(make_integrator(kind)),
      solve_dt_(integrator_->solve_fraction() * dt) {}

StepLifecycle::~StepLifecycle() {
  for (Vec* v : {&x_n_, &v_n_, &x_hat_, &v_hat_, &kept_hat_}) VecDestroy(v);
}

PetscErrorCode StepLifecycle::setup(Vec layout) {
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(layout, &x_n_));
  PetscCall(VecDuplicate(layout, &v_n_));
  PetscCall(VecDuplicate(layout, &x_hat_));
  PetscCall(VecDuplicate(layout, &v_hat_));
  PetscFunctionReturn(0);
}

// Only with the body at t_n: a step begun after sub-steps that failed, or after another state's step
// to the same time (the study), keeps the motion kept before, or none.
void StepLifecycle::keep_motion(const State& s) {
  if (body_.time() == s.frame * dt_) body_.keep_motion(motion_n_);
}

PetscErrorCode StepLifecycle::begin(const State& s) {
  PetscFunctionBeginUser;
  keep_motion(s);
  body_.begin_element_states(substep_);
  without_history_ = integrator_->keeps_history() && !s.x_prev;
  body_.set_time(solve_time(s));  // prescribed positions of the fixed vertices at the solve's time
  PetscCall(integrator_->start({s.x, s.v, s.x_prev, s.v_prev}, dt_, x_hat_, v_hat_));
  PetscCall(VecCopy(s.x, x_n_));
  PetscCall(VecCopy(s.v, v_n_));
  euler_completed_ = false;
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::begin_substepped(const State& s) {
  PetscFunctionBeginUser;
  keep_motion(s);
  body_.begin_element_states();
  PetscCall(VecCopy(s.x, x_n_));
  PetscCall(VecCopy(s.v, v_n_));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::complete_by_euler(Vec z) {
  PetscFunctionBeginUser;
  euler_completed_ = true;
  PetscCall(VecCopy(z, x_hat_));
  PetscCall(VecWAXPY(v_hat_, -1.0, x_n_, z));  // (z - x_n) / h'
  PetscCall(VecScale(v_hat_, 1.0 / solve_dt_));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::end_map(Vec x, Vec v) const {
  PetscFunctionBeginUser;
  PetscCall(integrator_->finish({x_n_, v_n_, x_hat_, v_hat_, without_history_}, dt_, 1.0 - damping_, x, v));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::accept(State& s, Vec velocity) {
  PetscFunctionBeginUser;
  if (velocity) {  // the fallback chain's sub-steps: s.x and velocity are their end already
    PetscCall(VecCopy(velocity, s.v));
  } else if (euler_completed_) {  // x_hat_ holds z (complete_by_euler)
    PetscCall(VecWAXPY(s.v, -1.0, x_hat_, s.x));
    PetscCall(VecScale(s.v, (1.0 - damping_) / solve_dt_));
  } else {
    PetscCall(end_map(s.x, s.v));
  }
  if (integrator_->keeps_history()) PetscCall(s.set_history(x_n_, v_n_));
  ++s.frame;
  s.time = s.frame * dt_;
  if (integrator_->time_fraction() != 1) body_.set_time(s.time);  // fixed vertices at t_{n+1}
  PetscCall(body_.hold(s.x));  // rollers: an end map that extrapolates (the midpoint's) leaves the held slots where their supports are
  // Once per accepted step: a sub-step's own, or the frame's if no sub-steps solved it (their
  // accepts have moved the state already).
  if (substep_ || !velocity) PetscCall(body_.accept_element_states(s.x));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::keep() {
  PetscFunctionBeginUser;
  kept_euler_completed_ = euler_completed_;
  if (!euler_completed_) PetscFunctionReturn(0);
  if (!kept_hat_) PetscCall(VecDuplicate(x_hat_, &kept_hat_));
  PetscCall(VecCopy(x_hat_, kept_hat_));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::restore() {
  PetscFunctionBeginUser;
  euler_completed_ = kept_euler_completed_;
  if (euler_completed_) PetscCall(VecCopy(kept_hat_, x_hat_));
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::undo(State& s) {
  PetscFunctionBeginUser;
  PetscCall(VecCopy(x_n_, s.x));
  PetscCall(VecCopy(v_n_, s.v));
  if (motion_n_.time == s.frame * dt_)
    body_.restore_motion(motion_n_);
  else
    body_.set_time(s.frame * dt_);
  body_.undo_element_states(substep_);
  PetscFunctionReturn(0);
}

void StepLifecycle::restart_element_states() { body_.undo_element_states(); }

}  // namespace hyperqn

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
  history_at_z_ = false;
  without_history_ = integrator_->keeps_history() && !s.x_prev;
  // The fixed vertices at the solve's time on the step's chord: the midpoint's at (p(t_n) + p(t_{n+1})) / 2.
  body_.set_step(s.frame * dt_, (s.frame + 1) * dt_);
  body_.set_time(solve_time(s));
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

// The terms' element state updated at z (the body at z's time) over the solve's h': for the midpoint,
// the values at t_n + h/2.
PetscErrorCode StepLifecycle::element_states_at_z(Vec z) {
  PetscFunctionBeginUser;
  PetscCall(body_.accept_element_states(z));
  history_at_z_ = true;
  PetscFunctionReturn(0);
}

PetscErrorCode StepLifecycle::complete_by_euler(Vec z) {
  PetscFunctionBeginUser;
  euler_completed_ = true;
  // The second half starts from the history at z, as its positions do (docs/inelastic.md#the-midpoint).
  if (!body_.element_states().empty()) {
    PetscCall(element_states_at_z(z));
    for (ElementState* state : body_.element_states()) state->advance();
  }
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
  // Once per accepted step: a sub-step's own, or the frame's if no sub-steps solved it (their
  // accepts have moved the state already).
  const bool states = (substep_ || !velocity) && !body_.element_states().empty();
  bool updated = false;
  PetscFunctionBeginUser;
  if (velocity) {  // the fallback chain's sub-steps: s.x and velocity are their end already
    PetscCall(VecCopy(velocity, s.v));
  } else if (euler_completed_) {  // x_hat_ holds z (complete_by_euler)
    // A step kept from an earlier solve (the fallback chain's restore) was begun again at z's time:
    // the history at z, and the second half from there, as complete_by_euler does.
    if (states && !history_at_z_) {
      PetscCall(element_states_at_z(x_hat_));
      for (ElementState* state : body_.element_states()) state->advance();
    }
    PetscCall(VecWAXPY(s.v, -1.0, x_hat_, s.x));
    PetscCall(VecScale(s.v, (1.0 - damping_) / solve_dt_));
  } else {
    // The midpoint: the history at z over h/2, then 2 q_{n+1/2} - q_n, the midpoint rule for its ODE
    // (docs/inelastic.md#the-midpoint); the body is still at z's time.
    if (states && integrator_->extrapolates()) {
      PetscCall(element_states_at_z(s.x));
      for (ElementState* state : body_.element_states()) state->extrapolate();
      updated = true;
    }
    PetscCall(end_map(s.x, s.v));
  }
  if (integrator_->keeps_history()) PetscCall(s.set_history(x_n_, v_n_));
  ++s.frame;
  s.time = s.frame * dt_;
  if (integrator_->time_fraction() != 1) body_.set_time(s.time);  // fixed vertices at t_{n+1}
  PetscCall(body_.hold(s.x));  // rollers: an end map that extrapolates (the midpoint's) leaves the held slots where their supports are
  if (states && !updated) PetscCall(body_.accept_element_states(s.x));
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

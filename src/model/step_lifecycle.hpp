// The lifecycle of one time step: what a step keeps from its start to its end, and the moves
// from one accepted state to the next. StepObjective (model/step_objective.hpp) is the step's
// objective g and its solve; this is what the step holds around it.
//
// The accepted state is State (model/state.hpp): x, v at t_n = frame h, the integrator's history
// x_{n-1}, v_{n-1} (BDF2), the fallback chain's sub-step memory (updated by FallbackChain when it
// judges a frame), and what a checkpoint saves. Over one step, the Vecs hold:
//
//              begin(s)                 the solve              accept(s)          undo(s)
//   s.x        x_n -> the initial guess -> z (the minimizer)    -> x_{n+1}         -> x_n
//   s.v        v_n                                              -> v_{n+1}         -> v_n
//   x_n(), v_n()  x_n, v_n (kept)                               (history, BDF2: x_{n-1}, v_{n-1})
//   x_hat(), v_hat()  x^, v^ (the integrator's start; y = x^ + h' v^ + h'^2 a_gravity);
//                 after complete_by_euler: z and (z - x_n) / h'
//
// The fixed vertices move with the step: begin puts them at the solve's time t_n + c h on the step's
// chord (Body::set_step: the midpoint's at (p(t_n) + p(t_{n+1})) / 2, as its z has every vertex), accept at
// t_{n+1}, undo back at t_n with the velocities they had there (Body::keep_motion). So does the
// terms' per-element state (terms/element_state.hpp), once per accepted step: begin takes it as
// the start, accept updates it (EnergyTerm::update_state), undo puts the start back, even after
// accept. The midpoint updates it at z over h/2 and extrapolates it to 2 q_{n+1/2} - q_n (a step
// completed by Euler: from the values at z over the second half). A sub-step's lifecycle does the same for its sub-step; the frame's undo goes back to the
// frame's start, and the frame's accept after sub-steps leaves the state as they left it.
#pragma once
#include <petscvec.h>

#include <cmath>
#include <memory>

#include "model/body.hpp"
#include "model/state.hpp"
#include "model/time_integrator.hpp"

namespace hyperqn {

class StepLifecycle {
 public:
  // A step of h = dt with the integrator `kind`; damping scales v_{n+1} by 1 - damping.
  StepLifecycle(Body& body, double dt, double damping, TimeIntegrator kind);
  ~StepLifecycle();
  StepLifecycle(const StepLifecycle&) = delete;
  StepLifecycle& operator=(const StepLifecycle&) = delete;
  PetscErrorCode setup(Vec layout);  // the step's vectors, in the layout of the free dofs

  const Integrator& integrator() const { return *integrator_; }
  TimeIntegrator kind() const { return kind_; }
  double dt() const { return dt_; }              // a frame's step h
  double solve_dt() const { return solve_dt_; }  // h' of the minimization
  double damping() const { return damping_; }
  // The fixed vertices' time during the solve of the step from s (on the step's chord: Body::set_step).
  double solve_time(const State& s) const { return (s.frame + integrator_->time_fraction()) * dt_; }

  // Starts the step from s: x_n, v_n kept (and the fixed vertices' motion if the body is at t_n),
  // the fixed vertices moved to the solve's time on the step's chord, x^ and v^ formed. An integrator that keeps a
  // history and finds none in s (the first step, after a release, a sub-step's first) takes its
  // starting step.
  PetscErrorCode begin(const State& s);
  // Only what accept (with the sub-steps' velocity) and undo need of a step that its sub-steps
  // solve alone: x_n and v_n (the fallback chain's kept sub-step size).
  PetscErrorCode begin_substepped(const State& s);
  // The step ends by a second implicit Euler step of h' from z instead of the integrator's end
  // map (StepObjective::complete_by_euler): x^ = z, v^ = (z - x_n) / h'.
  PetscErrorCode complete_by_euler(Vec z);
  bool euler_completed() const { return euler_completed_; }
  // The integrator's end map: x holds z and becomes x_{n+1}, v becomes (1 - damping) v_{n+1}.
  PetscErrorCode end_map(Vec x, Vec v) const;
  // Completes the step with the solver's s.x: the end map (or, with velocity given, s.x as it is
  // and a copy of velocity: the last sub-step's; after complete_by_euler, Euler's), the history
  // moves on, frame and time advance, the fixed vertices reach t_{n+1}, and the terms' per-element
  // state is updated from s.x (Body::accept_element_states), unless velocity is given: the
  // sub-steps' lifecycles updated it, once per sub-step.
  PetscErrorCode accept(State& s, Vec velocity = nullptr);
  // Abandons the step: s back at x_n, v_n, the fixed vertices back at t_n (with the velocities
  // they had there, if the step began with the body at t_n), the terms' element state at the
  // step's start.
  PetscErrorCode undo(State& s);
  // What accept needs of the solve at hand beyond its x (whether complete_by_euler ended it, and
  // its z), kept and put back: the fallback chain keeps its first solve's x while it tries others.
  PetscErrorCode keep();
  PetscErrorCode restore();

  // A sub-step's lifecycle (StepObjective::create_substep) moves the terms' element state per
  // sub-step (ElementState::begin_substep, undo_substep); the frame's undo goes back to the frame's start.
  void set_substep() { substep_ = true; }
  // The frame's element state back at the frame's start, before a run of sub-steps (an earlier
  // run of another size may have moved it): the fallback chain's.
  void restart_element_states();

  Vec x_n() const { return x_n_; }
  Vec v_n() const { return v_n_; }
  Vec x_hat() const { return x_hat_; }
  Vec v_hat() const { return v_hat_; }

 private:
  // The fixed vertices' motion into motion_n_ if the body is at s's time t_n.
  void keep_motion(const State& s);
  PetscErrorCode element_states_at_z(Vec z);

  Body& body_;
  double dt_, damping_;
  TimeIntegrator kind_;
  std::unique_ptr<Integrator> integrator_;
  double solve_dt_;  // integrator_->solve_fraction() h
  Vec x_n_ = nullptr, v_n_ = nullptr, x_hat_ = nullptr, v_hat_ = nullptr;
  bool without_history_ = false;  // this step's integrator keeps a history and s had none
  bool euler_completed_ = false;  // this step ends by complete_by_euler
  bool history_at_z_ = false;     // its element state was updated at z (the midpoint's)
  Body::MotionState motion_n_{NAN, {}};  // the fixed vertices' motion at t_n, for undo (NaN: none kept)
  bool kept_euler_completed_ = false;    // keep's
  Vec kept_hat_ = nullptr;
  bool substep_ = false;
};

}  // namespace hyperqn

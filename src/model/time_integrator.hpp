// The time integrators a deck can choose (time.integrator; docs/method.md#time-integrators).
//
// Each one is a single minimization per step (StepObjective, model/step_objective.hpp):
//   z = argmin 1/2 ||z - y||_M^2 + h'^2 E(z),   y = x^ + h' v^ + h'^2 a_gravity,
// with the fixed vertices at t_n + c h on the chord of their prescribed positions of t_n and t_{n+1}
// (Body::set_step; for c = 1 their positions of t_{n+1}), followed by an end map
// that gives x_{n+1} and v_{n+1} from z. An integrator says only what differs: h'/h, c, how x^
// and v^ come from x_n, v_n (and the history x_{n-1}, v_{n-1} if it keeps one), and the end map.
// The constant matrix of every solver is M + h'^2 L. Adding one: docs/architecture.md.
// The static integrator has no inertia: g(z) = s^2 (E(z) - W_gravity(z)) with a pseudo step s
// (TimeSpec::pseudo_step) that only sizes M against s^2 L in the constant matrix; x_{n+1} = z, v = 0.
#pragma once
#include <petscvec.h>

#include <memory>
#include <string>
#include <vector>

namespace hyperqn {

enum class TimeIntegrator { implicit_euler, implicit_midpoint, bdf2, quasi_static };

// Each integrator's deck name and whether a scene with colliders may use it.
struct IntegratorInfo {
  TimeIntegrator kind;
  const char* name;
  bool with_colliders;
};
const std::vector<IntegratorInfo>& integrator_infos();
const IntegratorInfo& integrator_info(TimeIntegrator kind);
// The deck names, in the table's order, and the entry of one (nullptr if no integrator has it).
std::vector<std::string> integrator_names();
const IntegratorInfo* integrator_named(const std::string& name);

// What x^ and v^ are formed from (global free dofs): the state at t_n and the history
// x_{n-1}, v_{n-1} (null unless the integrator keeps one and the state has it).
struct StepStartVectors {
  Vec x_n, v_n, x_prev, v_prev;
};
// The vectors of one step that an end map may read (global free dofs).
struct StepVectors {
  Vec x_n, v_n;      // the state at t_n
  Vec x_hat, v_hat;  // what y was formed from
  bool without_history = false;  // the integrator keeps a history and had none: its starting step
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual double solve_fraction() const = 0;          // h' / h
  virtual double time_fraction() const { return 1; }  // c: the solve's time (fixed vertices, loads)
  // False for the static integrator: g has no inertia, only gravity's work (InertiaTerm), and h'
  // is the pseudo step s, not a fraction of h (StepObjective).
  virtual bool has_inertia() const { return true; }
  // x^, v^ need x_{n-1}, v_{n-1}; where there are none (the first step, after a release, a
  // sub-step's first), start and finish take a starting step of the integrator's own.
  virtual bool keeps_history() const { return false; }
  // The end map extrapolates past z, and z is an implicit Euler step of h' to t_n + h'
  // (time_fraction() == solve_fraction()): where the end would invert or blow up a tet, the step
  // ends by a second implicit Euler step of h' instead (StepObjective::complete_by_euler).
  virtual bool extrapolates() const { return false; }
  // x^ and v^ of a step of h.
  virtual PetscErrorCode start(const StepStartVectors& s, double /*h*/, Vec x_hat, Vec v_hat) const {
    PetscFunctionBeginUser;
    PetscCall(VecCopy(s.x_n, x_hat));
    PetscCall(VecCopy(s.v_n, v_hat));
    PetscFunctionReturn(0);
  }
  // x holds the solve's z: it becomes x_{n+1}, and v becomes keep * v_{n+1} (keep = 1 - damping).
  virtual PetscErrorCode finish(const StepVectors& s, double h, double keep, Vec x, Vec v) const = 0;
};

std::unique_ptr<Integrator> make_integrator(TimeIntegrator kind);

}  // namespace hyperqn

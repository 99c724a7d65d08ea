// The integrators of model/time_integrator.hpp. Derivations: docs/method.md#time-integrators.
#include <stdexcept>

#include "model/time_integrator.hpp"

namespace hyperqn {

namespace {

// x_{n+1} = z, v_{n+1} = (x_{n+1} - x_n) / h. First order, and damps at a rate set by h.
class ImplicitEuler : public Integrator {
 public:
  double solve_fraction() const override { return 1; }
  PetscErrorCode finish(const StepVectors& s, double h, double keep, Vec x, Vec v) const override {
    PetscFunctionBeginUser;
    PetscCall(VecWAXPY(v, -1.0, s.x_n, x));
    PetscCall(VecScale(v, keep / h));
    PetscFunctionReturn(0);
  }
};

// z is the midpoint (x_n + x_{n+1}) / 2: one implicit Euler half step (h' = h/2, the loads at
// t_n + h/2, the fixed vertices at (p(t_n) + p(t_{n+1})) / 2 as every vertex is), then x_{n+1} = 2 z - x_n and v_{n+1} = 2 (x_{n+1} - x_n) / h - v_n. Second order
// and symplectic; keeps the energy of a quadratic E.
class ImplicitMidpoint : public Integrator {
 public:
  double solve_fraction() const override { return 0.5; }
  double time_fraction() const override { return 0.5; }
  bool extrapolates() const override { return true; }
  PetscErrorCode finish(const StepVectors& s, double h, double keep, Vec x, Vec v) const override {
    PetscFunctionBeginUser;
    PetscCall(VecAXPBY(x, -1.0, 2.0, s.x_n));
    PetscCall(VecWAXPY(v, -1.0, s.x_n, x));
    PetscCall(VecAXPBY(v, -keep, 2.0 * keep / h, s.v_n));
    PetscFunctionReturn(0);
  }
};

// BDF2: x_{n+1} = (4 x_n - x_{n-1}) / 3 + h' v_{n+1} and v_{n+1} = (4 v_n - v_{n-1}) / 3 + h' a_{n+1},
// h' = 2h/3. Eliminating v_{n+1} gives the minimization with x^ = (4 x_n - x_{n-1}) / 3 and
// v^ = (4 v_n - v_{n-1}) / 3; then x_{n+1} = z and v_{n+1} = (z - x^) / h'. Second order and
// L-stable: it damps the unresolved (stiff) modes as Euler does, the resolved ones less (docs/method.md).
// Without a history the step starts it, as implicit as the rest and with the same h' (so the
// same constant matrix): x^ = x_n + (h - h') v_n, v^ = v_n make y = x_n + h v_n + h'^2 a_gravity,
// so z = x_n + h v_n + h'^2 a(z), and v_{n+1} = v_n + h a(z) (Newmark with beta = 4/9, gamma = 1).
// Its local errors are O(h^2) in x and v, once, so BDF2 stays second order.
class Bdf2 : public Integrator {
 public:
  double solve_fraction() const override { return 2.0 / 3.0; }
  bool keeps_history() const override { return true; }
  PetscErrorCode start(const StepStartVectors& s, double h, Vec x_hat, Vec v_hat) const override {
    PetscFunctionBeginUser;
    if (!s.x_prev) {
      PetscCall(VecWAXPY(x_hat, (1.0 - solve_fraction()) * h, s.v_n, s.x_n));
      PetscCall(VecCopy(s.v_n, v_hat));
      PetscFunctionReturn(0);
    }
    PetscCall(VecWAXPY(x_hat, -0.25, s.x_prev, s.x_n));  // (4 x_n - x_{n-1}) / 3 = 4/3 (x_n - x_{n-1} / 4)
    PetscCall(VecScale(x_hat, 4.0 / 3.0));
    PetscCall(VecWAXPY(v_hat, -0.25, s.v_prev, s.v_n));
    PetscCall(VecScale(v_hat, 4.0 / 3.0));
    PetscFunctionReturn(0);
  }
  PetscErrorCode finish(const StepVectors& s, double h, double keep, Vec x, Vec v) const override {
    const double hs = solve_fraction() * h;
    PetscFunctionBeginUser;
    if (s.without_history) {  // v_n + h a(z), h'^2 a(z) = z - x^ - h' v^
      PetscCall(VecWAXPY(v, -1.0, s.x_hat, x));
      PetscCall(VecAXPY(v, -hs, s.v_hat));
      PetscCall(VecAYPX(v, h / (hs * hs), s.v_n));
      PetscCall(VecScale(v, keep));
      PetscFunctionReturn(0);
    }
    PetscCall(VecWAXPY(v, -1.0, s.x_hat, x));
    PetscCall(VecScale(v, keep / hs));
    PetscFunctionReturn(0);
  }
};

// Quasi-static: each step is a load step, z = argmin s^2 (E(z) - W_gravity(z)) at the loads and
// fixed vertices of t_{n+1}, with no inertia (StepObjective, InertiaTerm); x_{n+1} = z and v = 0.
class QuasiStatic : public Integrator {
 public:
  double solve_fraction() const override { return 1; }  // unused: h' is the pseudo step s
  bool has_inertia() const override { return false; }
  PetscErrorCode finish(const StepVectors&, double, double, Vec, Vec v) const override {
    PetscFunctionBeginUser;
    PetscCall(VecSet(v, 0.0));
    PetscFunctionReturn(0);
  }
};

}  // namespace

const std::vector<IntegratorInfo>& integrator_infos() {
  static const std::vector<IntegratorInfo> infos = {
      {TimeIntegrator::implicit_euler, "implicit-euler", true},
      // The end map doubles z - x_n: a contact barrier's z is safe, 2 z - x_n need not be.
      {TimeIntegrator::implicit_midpoint, "implicit-midpoint", false},
      {TimeIntegrator::bdf2, "bdf2", true},
      {TimeIntegrator::quasi_static, "static", true},
  };
  return infos;
}

const IntegratorInfo& integrator_info(TimeIntegrator kind) {
  for (const IntegratorInfo& i : integrator_infos())
    if (i.kind == kind) return i;
  throw std::logic_error("integrator without an entry in integrator_infos()");
}

std::vector<std::string> integrator_names() {
  std::vector<std::string> names;
  for (const IntegratorInfo& i : integrator_infos()) names.push_back(i.name);
  return names;
}

const IntegratorInfo* integrator_named(const std::string& name) {
  for (const IntegratorInfo& i : integrator_infos())
    if (name == i.name) return &i;
  return nullptr;
}

std::unique_ptr<Integrator> make_integrator(TimeIntegrator kind) {
  switch (kind) {
    case TimeIntegrator::implicit_euler: return std::make_unique<ImplicitEuler>();
    case TimeIntegrator::implicit_midpoint: return std::make_unique<ImplicitMidpoint>();
    case TimeIntegrator::bdf2: return std::make_unique<Bdf2>();
    case TimeIntegrator::quasi_static: return std::make_unique<QuasiStatic>();
  }
  throw std::logic_error("integrator without a class in make_integrator()");
}

}  // namespace hyperqn

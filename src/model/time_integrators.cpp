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

// z is the midpoint (x_n + x_{n+1}) / 2: one implicit Euler half step (h' = h/2, the fixed vertices
// at t_n + h/2), then x_{n+1} = 2 z - x_n and v_{n+1} = 2 (x_{n+1} - x_n) / h - v_n. Second order
// and symplectic; keeps the energy of a quadratic E.
class ImplicitMidpoint : public Integrator {
 public:
  double solve_fraction() const override { return 0.5; }
  double time_fraction() const override { return 0.5; }
  PetscErrorCode finish(const StepVectors& s, double h, double keep, Vec x, Vec v) const override {
    PetscFunctionBeginUser;
    PetscCall(VecAXPBY(x, -1.0, 2.0, s.x_n));
    PetscCall(VecWAXPY(v, -1.0, s.x_n, x));
    PetscCall(VecAXPBY(v, -keep, 2.0 * keep / h, s.v_n));
    PetscFunctionReturn(0);
  }
};

}  // namespace

const std::vector<IntegratorInfo>& integrator_infos() {
  static const std::vector<IntegratorInfo> infos = {
      {TimeIntegrator::implicit_euler, "implicit-euler", true},
      // The end map doubles z - x_n: a contact barrier's z is safe, 2 z - x_n need not be.
      {TimeIntegrator::implicit_midpoint, "implicit-midpoint", false},
  };
  return infos;
}

const IntegratorInfo& integrator_info(TimeIntegrator kind) {
  for (const IntegratorInfo& i : integrator_infos())
    if (i.kind == kind) return i;
  throw std::logic_error("integrator without an entry in integrator_infos()");
}

std::unique_ptr<Integrator> make_integrator(TimeIntegrator kind) {
  switch (kind) {
    case TimeIntegrator::implicit_euler: return std::make_unique<ImplicitEuler>();
    case TimeIntegrator::implicit_midpoint: return std::make_unique<ImplicitMidpoint>();
  }
  throw std::logic_error("integrator without a class in make_integrator()");
}

}  // namespace hyperqn

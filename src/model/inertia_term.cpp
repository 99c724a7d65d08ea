#include "model/inertia_term.hpp"

#include <cmath>

#include "solvers/factored_system.hpp"

namespace hyperqn {

InertiaTerm::~InertiaTerm() {
  for (Vec* v : {&mass_, &y_, &gravity_step_, &work_, &diff_, &load_}) VecDestroy(v);
}

PetscErrorCode InertiaTerm::setup(const Body& body, double solve_dt, const std::array<double, 3>& gravity, bool inertia) {
  PetscInt lo, hi;
  PetscScalar* a;
  PetscFunctionBeginUser;
  solve_dt_ = solve_dt;
  inertia_ = inertia;
  PetscCall(DMCreateGlobalVector(body.mesh().dm, &mass_));
  PetscCall(PetscObjectSetName((PetscObject)mass_, "mass"));
  PetscCall(body.lumped_mass(mass_));
  PetscCall(VecDuplicate(mass_, &y_));
  PetscCall(VecDuplicate(mass_, &work_));
  PetscCall(VecDuplicate(mass_, &diff_));
  // h'^2 * gravity, repeated for every free vertex (dofs are interleaved x, y, z).
  PetscCall(VecDuplicate(mass_, &gravity_step_));
  PetscCall(VecGetOwnershipRange(gravity_step_, &lo, &hi));
  PetscCall(VecGetArray(gravity_step_, &a));
  for (PetscInt i = lo; i < hi; ++i) a[i - lo] = solve_dt * solve_dt * gravity[i % 3];
  PetscCall(VecRestoreArray(gravity_step_, &a));
  if (!inertia_) {
    PetscCall(VecDuplicate(mass_, &load_));
    PetscCall(VecPointwiseMult(load_, gravity_step_, mass_));
    PetscCall(VecScale(load_, -1.0));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode InertiaTerm::set_target(Vec x_hat, Vec v_hat) {
  PetscFunctionBeginUser;
  if (!inertia_) {  // the origin of gravity's work within the step
    PetscCall(VecCopy(x_hat, y_));
    PetscFunctionReturn(0);
  }
  PetscCall(VecWAXPY(y_, solve_dt_, v_hat, x_hat));
  PetscCall(VecAXPY(y_, 1.0, gravity_step_));
  PetscFunctionReturn(0);
}

PetscErrorCode InertiaTerm::evaluate(Vec x, bool poison, PetscReal* value) {
  PetscReal dot;
  PetscFunctionBeginUser;
  PetscCall(VecWAXPY(diff_, -1.0, y_, x));           // x - y
  if (inertia_)
    PetscCall(VecPointwiseMult(work_, diff_, mass_));  // M (x - y)
  else
    PetscCall(VecCopy(load_, work_));  // -M h'^2 a_gravity
  if (poison) {
    PetscInt n;
    PetscCall(VecGetLocalSize(work_, &n));
    if (n > 0) {
      PetscScalar* w;
      PetscCall(VecGetArray(work_, &w));
      w[0] = NAN;
      PetscCall(VecRestoreArray(work_, &w));
    }
  }
  PetscCall(VecDot(work_, diff_, &dot));
  *value = inertia_ ? 0.5 * dot : dot;
  PetscFunctionReturn(0);
}

// One pass over the dofs and one reduction: the solvers ask for it at every iterate
// (solvers/frame_budget.hpp), where VecWAXPY, VecPointwiseMult and VecNorm took 9 us of an
// iteration's 0.55 ms on input/bar.yaml (-log_view, 1 rank).
PetscErrorCode InertiaTerm::gradient_norm(Vec x, double* norm) const {
  const PetscScalar *xa, *ya, *m;
  PetscInt n;
  double local = 0, global;
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(VecGetArrayRead(y_, &ya));
  PetscCall(VecGetArrayRead(mass_, &m));
  for (PetscInt i = 0; i < n; ++i) {
    const double f = m[i] * (xa[i] - ya[i]);  // M (x - y)
    local += f * f;
  }
  PetscCall(VecRestoreArrayRead(mass_, &m));
  PetscCall(VecRestoreArrayRead(y_, &ya));
  PetscCall(VecRestoreArrayRead(x, &xa));
  PetscCallMPI(MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)x)));
  *norm = std::sqrt(global);
  PetscFunctionReturn(0);
}

PetscErrorCode InertiaTerm::add_to(Mat A, int components) const {
  PetscFunctionBeginUser;
  PetscCall(add_dof_diagonal(A, mass_, components));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "model/time_step.hpp"

#include <cmath>

namespace hyperqn {

TimeStep::TimeStep(Body& body, double dt, const std::array<double, 3>& gravity)
    : body_(body), dt_(dt), gravity_(gravity) {}

TimeStep::~TimeStep() {
  VecDestroy(&mass_);
  VecDestroy(&y_);
  VecDestroy(&gravity_step_);
  VecDestroy(&work_);
  VecDestroy(&diff_);
}

PetscErrorCode TimeStep::setup() {
  DM dm = body_.mesh().dm;
  PetscInt lo, hi;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMCreateGlobalVector(dm, &mass_));
  PetscCall(PetscObjectSetName((PetscObject)mass_, "mass"));
  PetscCall(body_.lumped_mass(mass_));
  PetscCall(VecDuplicate(mass_, &y_));
  PetscCall(VecDuplicate(mass_, &work_));
  PetscCall(VecDuplicate(mass_, &diff_));
  // h^2 * gravity, repeated for every free vertex (dofs are interleaved x, y, z).
  PetscCall(VecDuplicate(mass_, &gravity_step_));
  PetscCall(VecGetOwnershipRange(gravity_step_, &lo, &hi));
  PetscCall(VecGetArray(gravity_step_, &a));
  for (PetscInt i = lo; i < hi; ++i) a[i - lo] = dt_ * dt_ * gravity_[i % 3];
  PetscCall(VecRestoreArray(gravity_step_, &a));
  PetscCall(PetscOptionsGetReal(nullptr, nullptr, "-hyperqn_test_nan_energy_beyond", &test_nan_beyond_, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-hyperqn_test_nan_energy_from_step", &test_nan_from_step_, nullptr));
  PetscFunctionReturn(0);
}

PetscErrorCode TimeStep::set_inertial_target(Vec x_n, Vec v_n) {
  PetscFunctionBeginUser;
  PetscCall(VecWAXPY(y_, dt_, v_n, x_n));
  PetscCall(VecAXPY(y_, 1.0, gravity_step_));
  ++steps_;
  PetscFunctionReturn(0);
}

PetscErrorCode TimeStep::objective(Vec x, PetscReal* g, Vec grad) {
  PetscReal E, inertia;
  PetscFunctionBeginUser;
  const double t0 = MPI_Wtime();
  ++evaluations_;
  PetscCall(body_.energy_gradient(x, &E, grad));
  PetscCall(VecWAXPY(diff_, -1.0, y_, x));                // x - y
  PetscCall(VecPointwiseMult(work_, diff_, mass_));       // M (x - y)
  if (grad) {
    // A non-finite entry of dE/dx on this rank poisons this rank's part of the inertia dot
    // product, so g (reduced over all ranks) says on every rank that the point is rejected,
    // without a reduction of its own.
    const PetscScalar* dE;
    PetscInt n;
    bool finite = true;
    PetscCall(VecGetLocalSize(grad, &n));
    PetscCall(VecGetArrayRead(grad, &dE));
    for (PetscInt i = 0; i < n; ++i) finite = finite && std::isfinite(dE[i]);
    PetscCall(VecRestoreArrayRead(grad, &dE));
    if (!finite && n > 0) {
      PetscScalar* w;
      PetscCall(VecGetArray(work_, &w));
      w[0] = NAN;
      PetscCall(VecRestoreArray(work_, &w));
    }
  }
  PetscCall(VecDot(work_, diff_, &inertia));
  *g = 0.5 * inertia + dt_ * dt_ * E;
  if (test_nan_beyond_ >= 0) {
    PetscReal dist;
    PetscCall(VecNorm(diff_, NORM_INFINITY, &dist));
    if (dist > test_nan_beyond_) *g = NAN;
  }
  if (test_nan_from_step_ >= 0 && steps_ >= test_nan_from_step_) *g = NAN;
  if (rejected(*g)) {
    ++rejected_;
    *g = kRejectedEnergy;
    if (grad) PetscCall(VecSet(grad, 0.0));
  } else if (grad) {
    PetscCall(VecAYPX(grad, dt_ * dt_, work_));  // M (x - y) + h^2 dE/dx
  }
  objective_s_ += MPI_Wtime() - t0;
  PetscFunctionReturn(0);
}

PetscErrorCode TimeStep::assemble_constant_matrix(Mat* A, int components) const {
  PetscFunctionBeginUser;
  PetscCheck(components == 1 || components == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "components must be 1 or 3");
  PetscCall(DMCreateMatrix(components == 3 ? body_.mesh().dm : body_.mesh().vertex_dm, A));
  PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(body_.add_laplacian(*A, dt_ * dt_, components));
  PetscCall(MatAssemblyBegin(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*A, MAT_FINAL_ASSEMBLY));
  if (components == 3) {
    PetscCall(MatDiagonalSet(*A, mass_, ADD_VALUES));
  } else {
    Vec vertex_mass;  // the x component of the lumped mass: one entry per free vertex
    const PetscScalar* m3;
    PetscScalar* m1;
    PetscInt n1;
    PetscCall(MatCreateVecs(*A, &vertex_mass, nullptr));
    PetscCall(VecGetLocalSize(vertex_mass, &n1));
    PetscCall(VecGetArrayRead(mass_, &m3));
    PetscCall(VecGetArray(vertex_mass, &m1));
    for (PetscInt i = 0; i < n1; ++i) m1[i] = m3[3 * i];  // local vertex i holds local dofs 3i..3i+2
    PetscCall(VecRestoreArray(vertex_mass, &m1));
    PetscCall(VecRestoreArrayRead(mass_, &m3));
    PetscCall(MatDiagonalSet(*A, vertex_mass, ADD_VALUES));
    PetscCall(VecDestroy(&vertex_mass));
  }
  PetscCall(MatSetOption(*A, MAT_SPD, PETSC_TRUE));
  PetscFunctionReturn(0);
}

PetscErrorCode TimeStep::create_hessian(Mat* H) const {
  PetscFunctionBeginUser;
  PetscCall(DMCreateMatrix(body_.mesh().dm, H));
  PetscCall(MatSetOption(*H, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscFunctionReturn(0);
}

PetscErrorCode TimeStep::assemble_hessian(Vec x, Mat H, bool exact) {
  PetscFunctionBeginUser;
  const double t0 = MPI_Wtime();
  PetscCall(MatZeroEntries(H));  // keeps the pattern
  PetscCall(body_.add_hessian(x, H, dt_ * dt_, !exact));
  PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
  PetscCall(MatDiagonalSet(H, mass_, ADD_VALUES));
  // Set after every assembly (new values may clear the flags). SPD makes MUMPS use LL^T.
  PetscCall(MatSetOption(H, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(H, MAT_SPD, exact ? PETSC_FALSE : PETSC_TRUE));
  hessian_s_ += MPI_Wtime() - t0;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

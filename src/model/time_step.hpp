// One implicit Euler step as a minimization over the free positions x:
//   g(x) = 1/2 (x - y)^T M (x - y) + h^2 E(x),   y = x_n + h v_n + h^2 a_gravity
// (the paper's 1/(2h^2)||x - y||_M^2 + E(x) times h^2, so g and grad g are in units of M x).
// The solvers only see this interface: g, grad g, and the constant matrix A = M + h^2 L.
#pragma once
#include <petscvec.h>

#include <array>

#include "model/body.hpp"

namespace hyperqn {

class TimeStep {
 public:
  TimeStep(Body& body, double dt, const std::array<double, 3>& gravity);
  ~TimeStep();
  TimeStep(const TimeStep&) = delete;
  TimeStep& operator=(const TimeStep&) = delete;
  PetscErrorCode setup();  // mass vector, work vectors

  Body& body() { return body_; }
  double dt() const { return dt_; }
  Vec mass() const { return mass_; }
  // A template global vector of free dofs.
  Vec layout() const { return mass_; }

  // y = x_n + h v_n + h^2 g for the step about to be taken.
  PetscErrorCode set_inertial_target(Vec x_n, Vec v_n);
  Vec inertial_target() const { return y_; }
  // g(x) and, if grad is not null, its gradient. Counts evaluations.
  // Guardrail: if g or any entry of grad g is not finite (NaN/Inf), the point is *rejected*: g is
  // reported as kRejectedEnergy and grad g as 0, and the rejection is counted. kRejectedEnergy is
  // finite (TAO raises an error on a NaN/Inf objective in its monitor and at the initial point)
  // and larger than any real energy, so every sufficient-decrease test (TAO's More-Thuente and
  // Armijo, ours) rejects the point; a line search that accepts without a test (unit) is caught
  // by the solvers with TimeStep::rejected.
  PetscErrorCode objective(Vec x, PetscReal* g, Vec grad);
  static constexpr double kRejectedEnergy = PETSC_MAX_REAL / 4;  // = PETSC_INFINITY, TAO's own "inf"
  static bool rejected(double g) { return !(g < kRejectedEnergy); }  // true for NaN too
  PetscInt rejected_evaluations() const { return rejected_; }  // over the whole run
  PetscInt evaluations() const { return evaluations_; }
  double objective_seconds() const { return objective_s_; }  // total, over the whole run
  void reset_evaluations() { evaluations_ = 0; }
  // Assembles A = M + h^2 L on the free dofs into a new matrix (once per scene). Since
  // A = A1 (x) I3, components = 1 assembles only the vertex matrix A1 = M1 + h^2 L1 (in the
  // layout of mesh.vertex_dm): a third of the rows, a ninth of the nonzeros.
  PetscErrorCode assemble_constant_matrix(Mat* A, int components = 3) const;
  // A new matrix with the Hessian's nonzero pattern (the mesh's dof graph); inserting outside it
  // is an error, so the pattern, and hence a direct solver's symbolic analysis, never changes.
  PetscErrorCode create_hessian(Mat* H) const;
  // H = M + h^2 K(x) in place (K with the per-element PSD fix; exact = true: the true,
  // possibly indefinite Hessian of g, for tests). Flags H SPD (or only symmetric if exact).
  PetscErrorCode assemble_hessian(Vec x, Mat H, bool exact = false);
  double hessian_seconds() const { return hessian_s_; }  // total, over the whole run

 private:
  Body& body_;
  double dt_;
  std::array<double, 3> gravity_;
  Vec mass_ = nullptr, y_ = nullptr, gravity_step_ = nullptr, work_ = nullptr, diff_ = nullptr;
  PetscInt evaluations_ = 0, rejected_ = 0;
  // Test hooks (PETSc options, for tests/python/test_guardrails.py only): make g NaN where
  // ||x - y||_inf > test_nan_beyond_ (-hyperqn_test_nan_energy_beyond <distance>), or everywhere
  // from the test_nan_from_step_-th time step on (-hyperqn_test_nan_energy_from_step <n>).
  PetscReal test_nan_beyond_ = -1;
  PetscInt test_nan_from_step_ = -1, steps_ = 0;
  double objective_s_ = 0;
  double hessian_s_ = 0;
};

}  // namespace hyperqn

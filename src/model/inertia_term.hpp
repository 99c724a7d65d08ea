// The inertia of a time step: I(x) = 1/2 (x - y)^T M (x - y), its gradient M (x - y) and its
// Hessian M, M the lumped mass (diagonal, per free dof) and y the step's inertial target
//   y = x^ + h' v^ + h'^2 a_gravity
// (model/time_integrator.hpp gives h', x^ and v^). StepObjective sums it with h'^2 E(x):
// g(x) = I(x) + h'^2 E(x). It is a term of the objective beside the body's energy terms, not one
// of them: E is reduced over the ranks and scaled by h'^2, I is not.
// Without inertia (the static integrator) it keeps only the linear part, gravity's work:
// I(x) = -(x - y)^T M (h'^2 a_gravity) with y = x^ (the step's start), gradient -M h'^2 a_gravity;
// M still goes into H0 and Newton's H (add_to), where it only regularizes h'^2 L.
#pragma once
#include <petscmat.h>

#include <array>

#include "model/body.hpp"

namespace hyperqn {

class InertiaTerm {
 public:
  InertiaTerm() = default;
  ~InertiaTerm();
  InertiaTerm(const InertiaTerm&) = delete;
  InertiaTerm& operator=(const InertiaTerm&) = delete;
  // M from the body's terms (Body::lumped_mass), the vectors of one step and h'^2 a_gravity.
  PetscErrorCode setup(const Body& body, double solve_dt, const std::array<double, 3>& gravity, bool inertia = true);

  Vec mass() const { return mass_; }  // M's diagonal: the lumped mass per free dof
  Vec target() const { return y_; }   // y
  // y = x^ + h' v^ + h'^2 a_gravity (without inertia: y = x^).
  PetscErrorCode set_target(Vec x_hat, Vec v_hat);
  // *value = I(x), and M (x - y) into gradient() (valid until the next call). poison: the
  // caller's other gradient is not finite on this rank, so I(x) becomes NaN on every rank through
  // the reduction of its dot product (StepObjective::objective).
  PetscErrorCode evaluate(Vec x, bool poison, PetscReal* value);
  Vec gradient() const { return work_; }
  // |M (x - y)| over all ranks, in one pass and one reduction (collective).
  PetscErrorCode gradient_norm(Vec x, double* norm) const;
  // A += M: in the dof layout (components = 3) or the vertex layout (components = 1: one entry per
  // free vertex, the x component of M).
  PetscErrorCode add_to(Mat A, int components = 3) const;

 private:
  double solve_dt_ = 0;
  bool inertia_ = true;
  Vec load_ = nullptr;  // without inertia: -M h'^2 a_gravity, the constant gradient
  Vec mass_ = nullptr, y_ = nullptr, gravity_step_ = nullptr, work_ = nullptr, diff_ = nullptr;
};

}  // namespace hyperqn

// The viscous branches of a finite-strain generalized Maxwell model (docs/materials.md#viscoelasticity):
// a Prony series of branches in parallel with an equilibrium hyperelastic material. Branch i has a
// shear modulus mu_i and a relaxation time tau_i; its elastic part F_e = F F_v^{-1} stores the
// Hencky energy mu_i |dev eps_e|^2, eps_e = 1/2 log(F_e F_e^T), and it flows isochorically with the
// dissipation potential eta_i |D_v|^2, eta_i = mu_i tau_i (no volumetric relaxation).
//
// The step's update is variational (Fancello, Ponthot and Stainier 2006; Simo's exponential map,
// backward Euler in the log strain): with the trial elastic strain e = 1/2 log(F C_v,n^{-1} F^T) of
// the step's start C_v,n^{-1}, the minimum over the viscous increment of stored + dt * dissipated is
//   W_i(F) = mu_i tau_i / (tau_i + dt) |dev e|^2   (the viscous increment is dev e dt / (tau_i + dt)),
// a function of F alone within a step: the step stays one minimization. At the step's end the history
// becomes C_v^{-1} = F^{-1} b_e F^{-T}, b_e = exp(2 eps_e) coaxial with e, eps_e = tau/(tau + dt) dev e
// + (tr e / 3) I. At small strain each branch is a linear Maxwell element (stress 2 mu eps_e,
// d eps_v/dt = eps_e / tau) integrated by backward Euler: first order in dt.
// One InelasticModel (materials/inelastic_model.hpp). No PETSc: unit-tested alone
// (tests/test_viscoelastic.cpp).
#pragma once
#include <vector>

#include "materials/inelastic_model.hpp"

namespace hyperqn {

struct MaxwellBranch {
  double mu = 0;   // shear modulus (a pressure), > 0
  double tau = 0;  // relaxation time, > 0
};

inline constexpr int kMaxMaxwellBranches = 4;
// A branch's history: C_v^{-1} (symmetric, det 1): xx, yy, zz, xy, yz, xz.
inline constexpr int kViscousValues = 6;

class MaxwellBranches : public InelasticModel {
 public:
  // Throws std::invalid_argument for no branch, more than kMaxMaxwellBranches, mu or tau not > 0.
  explicit MaxwellBranches(std::vector<MaxwellBranch> branches);
  int size() const { return (int)branches_.size(); }
  const std::vector<MaxwellBranch>& branches() const { return branches_; }
  std::string name() const override { return "viscoelastic"; }
  int history_width() const override { return kViscousValues * size(); }
  // The history at rest (C_v = I), kViscousValues per branch.
  void rest(double* history) const override;
  // The branches' condensed energy W(F) of a step of dt from history (per rest volume), and P =
  // dW/dF added to *P if P is not null. dt = 0: the energy stored in the branches as they stand
  // (history the current one). +inf where F F^T is singular (det F = 0); finite for inverted F.
  double energy(const Mat3& F, const double* history, double dt, Mat3* P) const override;
  // The same across a batch's lanes (the same formulas, equal to round-off).
  void energy_batch(StressBatch& b, int n, const double* const* history, double dt) const override;
  double stored_energy(const Mat3& F, const double* history, Mat3* P) const override {
    return energy(F, history, 0.0, P);
  }
  // d2W/dF2 (exact; symmetric, possibly indefinite).
  Mat9 stress_derivative(const Mat3& F, const double* history, double dt) const override;
  // The history at the end of the step of dt from start that ends at F (det F != 0).
  void update(const Mat3& F, const double* start, double dt, double* end) const override;
  // The branches' stress power over the step: per branch, the end's Kirchhoff stress 2 mu dev eps_e
  // times the viscous increment dev e dt / (tau + dt), 2 mu tau dt / (tau + dt)^2 |dev e|^2 (twice the
  // dissipation potential's share of W: the potential is quadratic). end is not read.
  double dissipation(const Mat3& F, const double* start, double dt, const double* end) const override;
  // The instantaneous shear stiffness of the branches in L's weight: sum of 2 mu_i (as a fibre adds k).
  double laplacian_weight() const override;
  // viscous_strain: the largest over the branches of |eps_v|, eps_v = 1/2 log C_v (the flowed log strain).
  bool has_measure(HistoryMeasure m) const override { return m == HistoryMeasure::viscous_strain; }
  double measure(HistoryMeasure m, const double* history) const override;

 private:
  std::vector<MaxwellBranch> branches_;
};

}  // namespace hyperqn

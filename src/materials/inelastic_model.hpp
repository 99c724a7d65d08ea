// An inelastic model (docs/inelastic.md#inelastic-models): a material law with per-element history
// whose step is a variational constitutive update (Ortiz and Stainier 1999). Within a step of dt
// from the history h_n at its start, the internal variables at the step's end minimize a local
// incremental potential; condensed out, they leave an energy W(F; h_n, dt) of F alone, so the step
// stays one minimization over x (terms/inelastic_tets.hpp adds it to the element's energy). At the
// step's accept the history moves to the minimizer (update). The models: the viscoelastic Maxwell
// branches (maxwell_branches.hpp) and J2 plasticity in logarithmic strain
// (log_strain_plasticity.cpp); each is registered with its deck block in material_factory.cpp
// (inelastic_kinds). No PETSc: unit-tested alone.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "materials/material.hpp"

namespace hyperqn {

// What an output field reads from a model's history (terms/inelastic_tets.cpp gives them the
// names of output.fields: viscous_strain, equivalent_plastic_strain).
enum class HistoryMeasure { viscous_strain, equivalent_plastic_strain };

class InelasticModel {
 public:
  virtual ~InelasticModel() = default;
  // Its part of the term's name ("viscoelastic", "plastic").
  virtual std::string name() const = 0;
  // Values of history per element (the ElementState's width) and the history at rest.
  virtual int history_width() const = 0;
  virtual void rest(double* history) const = 0;
  // The condensed energy W(F) of a step of dt from history (per rest volume), P = dW/dF added to
  // *P if P is not null. +inf where no step ends (det F = 0).
  virtual double energy(const Mat3& F, const double* history, double dt, Mat3* P) const = 0;
  // energy() for the first n elements of a batch (materials/material.hpp), element e's history
  // history[e] (its step_values, for a model with a step_width): W added to b.psi and P to b.P (b.psi +inf where no step ends, its P left). This
  // default goes element by element; the Maxwell branches loop over the lanes.
  virtual void energy_batch(StressBatch& b, int n, const double* const* history, double dt) const {
    for (int e = 0; e < n; ++e) {
      Mat3 F, P = Mat3::Zero();
      for (int c = 0; c < 9; ++c) F(c) = b.F[c][e];
      b.psi[e] += energy(F, history[e], dt, &P);
      for (int c = 0; c < 9; ++c) b.P[c][e] += P(c);
    }
  }
  // What a step's energy_batch reads of the history at the step's start, where a model condenses it
  // to fewer values (the Prony series: its step's constant stress Q): values per element (0: none,
  // energy_batch reads the history), and those of a history for a step of dt. The term computes
  // them once per step (terms/inelastic_tets.hpp) and gives energy_batch them in the history's place.
  virtual int step_width() const { return 0; }
  virtual void step_values(const double* /*history*/, double /*dt*/, double* /*out*/) const {}
  // The energy stored at F with the history as it stands (no flow), P added as above: what the
  // output's energies and stresses read at a step's end.
  virtual double stored_energy(const Mat3& F, const double* history, Mat3* P) const = 0;
  // d2W/dF2 of energy() (exact: the consistent tangent; symmetric, possibly indefinite).
  virtual Mat9 stress_derivative(const Mat3& F, const double* history, double dt) const = 0;
  // The history at the end of the step of dt from start that ends at F: energy()'s minimizer.
  virtual void update(const Mat3& F, const double* start, double dt, double* end) const = 0;
  // The energy the step from start to end (at F) dissipated, per rest volume (>= 0).
  virtual double dissipation(const Mat3& F, const double* start, double dt, const double* end) const = 0;
  // Its weight in L (the instantaneous stiffness it adds near rest, as a fibre adds k).
  virtual double laplacian_weight() const = 0;
  // A model whose stored energy and dissipation are small-strain measures (viscoelastic_prony):
  // the largest strain |E| (Frobenius, E = (F^T F - I)/2) any update on this rank has seen since
  // the scene was built; -1 for the others, whose measures hold at every strain.
  virtual double small_strain_reach() const { return -1; }
  // Whether its history has measure m, and m's value for a history (the output fields).
  virtual bool has_measure(HistoryMeasure /*m*/) const { return false; }
  virtual double measure(HistoryMeasure /*m*/, const double* /*history*/) const { return 0; }
};

// A material's inelastic block as the deck gives it (material.<kind>, one kind of
// inelastic_kinds()): its numbers by key, and the maps of its list (viscoelastic.branches).
struct InelasticSpec {
  std::string kind;                                  // the block's key; "" for an elastic material
  int line = 0;                                      // its deck line
  std::map<std::string, double> values;              // "yield_stress" -> ...
  std::vector<std::map<std::string, double>> items;  // the list's maps, in order
  // The value of key, or fallback where the deck leaves it out.
  double value(const std::string& key, double fallback = 0) const {
    const auto it = values.find(key);
    return it == values.end() ? fallback : it->second;
  }
};

}  // namespace hyperqn

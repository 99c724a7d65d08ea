// The energy balance of a run per frame (deck output.energy, energy.csv; docs/inelastic.md#energy-balance):
// kinetic + stored + dissipated against the work of gravity, the loads and the supports.
//
// Each frame's work is the forces of the frame's solve times the frame's displacement, the
// integrator's own quadrature: the forces at z = x_n + c (x_{n+1} - x_n), every vertex's (a fixed one's on
// its support's chord, as the solve has it: Body::set_step), with the loads' curves and the attachments'
// targets at t_n + c h (c = 1/2 for the midpoint, 1 otherwise),
// the inelastic materials' condensed stress from the history at the frame's start over c h. For the
// midpoint, M (v_{n+1} - v_n) = h F(z) and x_{n+1} - x_n = h (v_n + v_{n+1}) / 2 make the kinetic
// energy's change exactly F(z) . (x_{n+1} - x_n) on the free dofs, so the residual is what the
// midpoint rule misses of the stored and dissipated energies' change (third order per step) and the
// solves' tolerance. A fixed vertex (and a roller's held component) is the support's: its mass and
// kinetic energy are not the body's, and the support's work there is (dE/dx - f)(z) . dx, the force
// that holds it against the elements and the loads. An attachment's is -k (x(z) - p(t_n + c h)) . dx.
// A frame the fallback chain solves in sub-steps is taken as one step here (its residual is larger).
// A topology change (a cut, a fracture, a snap, a tear, a removal) happens between frames at a
// state x, v it keeps: kinetic + stored + dissipated before it (the row of the frame before) less
// after it (the changed body's, at the next frame's start) is what it released: the kinetic and
// stored energy of what it took away (a removed tet, a torn edge's hinge; a cut, a fracture and a
// snap keep every element: 0 to round-off). What those elements had dissipated stays in the
// dissipated column. Counted in the residual, so the residual does not jump at a change; each
// change's share is >= 0 if the change adds no energy.
// The terms are evaluated a second time over a copy of the mesh whose dof map covers every local
// vertex (as model/reactions.hpp), so the run's evaluation is untouched and a run without
// output.energy builds nothing of this.
#pragma once
#include <memory>
#include <vector>

#include "model/body.hpp"
#include "model/scene_spec.hpp"
#include "model/state.hpp"

namespace hyperqn {

// One frame's row, the same on every rank (J).
struct EnergyRow {
  double kinetic = 0, stored = 0, dissipated = 0;
  double released = 0;  // what the topology changes took out of the body, since the run began (see above)
  double gravity_work = 0, load_work = 0, support_work = 0;  // since the run began
  double residual = 0;  // kinetic + stored + dissipated + released - the work - (kinetic + stored at frame 0)
};

class EnergyBalance {
 public:
  static const char* columns();  // energy.csv's, after frame,time
  // dissipated_removed: what the elements topology changes took away had dissipated (RunSummary's,
  // kept up to date by the run; part of the dissipated column).
  EnergyBalance(const SceneSpec& spec, double time_fraction, const double& dissipated_removed)
      : spec_(spec), c_(time_fraction), dissipated_removed_(dissipated_removed) {}
  // For the scene's body as built (again after a release; s: its released attachments). Collective.
  PetscErrorCode bind(const Body& body, const State& s);
  // The row of the state s as it stands (frame 0 of a run: its energies, no work); collective.
  PetscErrorCode start(const State& s, EnergyRow& out);
  // A restart: the row of its frame and the start's energy (kinetic + stored at frame 0).
  void resume(const EnergyRow& at_restart, double start_energy);
  // The scene was built again at the state s (LiveScene's rebind): bind to its body; after a
  // topology change the next begin_frame counts what the change released. After another rebuild (a
  // release of supports or attachments, whose vertices bring their kinetic energy in: the residual
  // shows it) the energy before a change is taken afresh. Collective.
  PetscErrorCode rebind(const Body& body, const State& s, bool topology_changed);
  // Before a frame: x_n, v_n and the element states at its start; after a topology change, the
  // energy it released. Collective.
  PetscErrorCode begin_frame(const State& s);
  // After it: the row of the frame's end. Collective.
  PetscErrorCode end_frame(const State& s, EnergyRow& out);

 private:
  // Kinetic and stored energy of s (this rank's part: kinetic over the free dofs, stored of the
  // elastic terms with the body's element states as they stand).
  PetscErrorCode energies(const State& s, double* kinetic, double* stored);
  // The dissipated column: the body's elements' and the removed ones'. Collective.
  PetscErrorCode dissipated(const Body& body, double* total) const;

  const SceneSpec& spec_;
  double c_;  // the solve's time fraction of the step
  const double& dissipated_removed_;
  const Body* body_ = nullptr;
  std::unique_ptr<DistributedMesh> all_;
  std::vector<std::unique_ptr<EnergyTerm>> terms_;  // the elastic terms over all_
  std::vector<std::unique_ptr<EnergyTerm>> loads_;  // every load over all_
  std::vector<double> mass_;                        // 3 per local vertex: this rank's elements' lumped mass
  std::vector<char> free_;                          // 3 per local vertex: a free component (not fixed, not held)
  std::vector<std::vector<PetscInt>> attached_;
  std::vector<ElementState> start_states_;          // the body's at the frame's start
  std::vector<double> pos_n_, pos_, dx_, vel_, grad_, load_grad_, fixed_vel_;
  double start_time_ = 0;
  double start_energy_ = 0;  // kinetic + stored at frame 0
  double last_energy_ = 0;   // kinetic + stored + dissipated of the last row
  double released_ = 0;
  bool changed_ = false;
  double gravity_work_ = 0, load_work_ = 0, support_work_ = 0;
};

}  // namespace hyperqn

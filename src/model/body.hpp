// The body on this rank: its distributed mesh, the prescribed motion of its fixed vertices, and
// the energy terms of the scene. E(x) is the sum of the terms; the body gathers positions for
// them (free vertices from the global vector, fixed ones at their prescribed positions), reduces
// their energies over the ranks, and sums their gradients, Hessians, L and lumped masses.
#pragma once
#include <petscdmplex.h>

#include <array>
#include <memory>
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "materials/material.hpp"
#include "model/regions.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

class Body {
 public:
  Body(const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>> terms);
  ~Body() { VecDestroy(&local_); }
  Body(const Body&) = delete;
  Body& operator=(const Body&) = delete;

  const DistributedMesh& mesh() const { return mesh_; }
  // True if every term is exactly a Projective Dynamics energy with its own L.
  bool projective_dynamics_exact() const;
  std::string inexact_names() const;  // the terms that are not (EnergyTerm::projective_dynamics_exact)
  std::string material_names() const;  // the terms' names, e.g. "corotated, neohookean, strand"

  // Prescribed motion of the fixed regions (fixed[k] moves the vertices fixed by region k).
  void set_fixed_motion(const std::vector<BoxRegion>& fixed) { fixed_regions_ = fixed; }
  // Moves the fixed vertices to their prescribed positions at time t (rest positions if none);
  // their velocities become the mean over the step from the previous time. Again at the same t:
  // nothing changes (the study steps several states to the same t).
  void set_time(double t);
  double time() const { return time_; }
  // The step from t0 to t1 that set_time serves next (StepLifecycle::begin): at a time strictly
  // between them the fixed vertices (and the rollers' held components) stand on the step's chord,
  // p(t0) + (t - t0) / (t1 - t0) (p(t1) - p(t0)), where the midpoint rule has every vertex at z =
  // (x_n + x_{n+1}) / 2 (its solve at t_n + h/2); at t0, t1 and outside the step: at p(t).
  void set_step(double t0, double t1) { step_ = {t0, t1}; }
  // The fixed vertices' motion as it stands (its time, their velocities), and back to it: a step
  // that is undone leaves them as they were at its start (set_time back to that time alone would
  // leave their velocities 0, and a checkpoint or an output frame then says so).
  struct MotionState {
    double time = 0;
    std::vector<double> velocities;
  };
  void keep_motion(MotionState& m) const;
  void restore_motion(const MotionState& m);
  // The prescribed position and velocity at time t (geometry/motion.hpp's moved and velocity_at:
  // the velocity as the motion reaches t; rest position and 0 without a motion) of every local
  // fixed vertex, 3 each into pos and vel; free vertices' entries are left as they are. What a
  // vertex released at t keeps (LiveScene::release_due), whatever set_time's mean velocities are.
  void prescribed_state(double t, std::vector<double>& pos, std::vector<double>& vel) const;
  // A restart (io/checkpoint.hpp): time t and every local vertex's position and velocity (3 each;
  // fixed vertices: the prescribed ones the checkpointed run had, which set_time from a fresh body
  // would not give) into the body and the global vectors x, v of free dofs.
  PetscErrorCode resume(double t, const std::vector<double>& pos, const std::vector<double>& vel, Vec x, Vec v);
  // The terms, for what they report (EnergyTerm::log, report, point_fields).
  const std::vector<std::unique_ptr<EnergyTerm>>& terms() const { return terms_; }
  // The lumped mass per free dof to every term (EnergyTerm::set_masses).
  PetscErrorCode set_masses(Vec mass);
  // The terms' per-step update (EnergyTerm::begin_step); with a term that couples surfaces, the
  // step's local positions at its start and at the solve's start (StepStart::start_positions,
  // positions; the fixed vertices already at the time set by set_time).
  PetscErrorCode begin_step(const StepStart& step);

  // The terms' per-element state (EnergyTerm::element_state), once per accepted step: a step's
  // begin takes its current values as the start; an accepted step ending at x calls each term's
  // update_state; an undone one puts the start back. substep: a sub-step of the fallback chain
  // (ElementState::begin_substep); the frame's undo goes back to the frame's start.
  void begin_element_states(bool substep = false);
  PetscErrorCode accept_element_states(Vec x);
  void undo_element_states(bool substep = false);
  // Every term's element state, in the terms' order (checkpoints).
  std::vector<ElementState*> element_states() const;
  // The energy the terms' elements have dissipated since the run began (J, EnergyTerm::
  // dissipated_energy), summed over the ranks (collective).
  PetscErrorCode dissipated_energy(double* total) const;
  // The values of `from`'s element states (a scene before its rebuild) into this body's states of
  // the same name, element by element through the global ids; then, for the elements this body's
  // change made (set_inherited_elements), their old ones' values (ElementState::inherited), from
  // whichever rank holds them. Collective when that list is not empty.
  void carry_element_states(const Body& from);
  // Elements of this body (a scene rebuilt after a change of the mesh) that carry on an element of
  // the body before it: (new id, old id), the same list on every rank (SeparationResult::inherited).
  void set_inherited_elements(std::vector<std::array<int64_t, 2>> pairs) { inherited_elements_ = std::move(pairs); }
  // Copies of every element state (start, current and a frame's kept start), and back into this
  // body's (the same terms): a study's trajectories each keep their own (app/time_loop.cpp).
  std::vector<ElementState> copy_element_states() const;
  void set_element_states(const std::vector<ElementState>& copies);

  // Rollers (fixed regions with `components`, model/regions.hpp select_held_components): a held
  // component of a free vertex keeps its slot in the global vector, and that slot holds the
  // prescribed value (hold, wherever a step's target, guess or state is formed); its gradient is 0
  // (zero_held) and the constant matrices and Hessians have identity rows and columns there
  // (held_rows), so no solver moves it. Without rollers (every rank alike) none of this runs.
  bool holds_components() const { return mesh_.rollers; }
  // x's held slots = their prescribed positions at the body's time (set_time).
  PetscErrorCode hold(Vec x) const;
  // g's held slots = 0.
  PetscErrorCode zero_held(Vec g) const;
  // The global rows of this rank's held slots.
  const std::vector<PetscInt>& held_rows() const { return held_rows_; }
  // M's rows and columns at the held slots replaced by the identity's (M assembled, square, in the
  // dof layout; collective). Nothing without rollers.
  PetscErrorCode identity_at_held(Mat M) const;

  // Local positions of all local vertices (3 each): free ones from the global vector x (a held
  // component: its prescribed position), fixed ones from their prescribed positions.
  PetscErrorCode local_positions(Vec x, std::vector<double>& pos) const;
  // The free vertices' entries of local values (3 per local vertex) into the global vector of free
  // dofs: the inverse of local_values.
  PetscErrorCode free_values(const std::vector<double>& values, Vec global) const;
  // Local values of a global vector of free dofs (fixed vertices: 0).
  PetscErrorCode local_values(Vec global, std::vector<double>& out) const;
  // Local values of a global velocity vector (fixed vertices: their prescribed velocity).
  PetscErrorCode local_velocities(Vec v, std::vector<double>& vel) const;
  // E(x) summed over all ranks; if grad is not null, also dE/dx on the free dofs. Without contact:
  // the terms that are not EnergyTerm::is_contact only.
  PetscErrorCode energy_gradient(Vec x, PetscReal* energy, Vec grad, bool with_contact = true) const;
  // det F per local tet at the given local positions.
  void cell_jacobians(const std::vector<double>& pos, std::vector<double>& J) const;
  // The smallest det F and the largest |det F| of all tets at x, over all ranks (collective).
  PetscErrorCode volume_ratios(Vec x, double* min_J, double* max_abs_J) const;
  // Whether any term has a capability: any_term(&EnergyTerm::bounds_steps), ... A new capability
  // of the terms is their virtual and its use; the body needs nothing of its own for it.
  bool any_term(bool (EnergyTerm::*capability)() const) const {
    for (const auto& t : terms_)
      if (((*t).*capability)()) return true;
    return false;
  }
  // The terms' active sets at the last evaluated point, over all ranks (collective).
  unsigned long long active_set() const;
  // Largest step alpha <= *alpha along dir from x that every term admits (all ranks agree).
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const;

  // Lumped mass per dof (global vector layout), summed over the terms.
  PetscErrorCode lumped_mass(Vec mass) const;
  // Total mass of the body (all vertices, fixed included).
  double total_mass() const { return total_mass_; }
  // A += scale * L, L the sum of the terms' (see EnergyTerm::add_laplacian for components).
  PetscErrorCode add_laplacian(Mat A, PetscReal scale, int components = 3) const;
  // This rank's tets' parts of scale * L (EnergyTerm::add_tet_laplacians), in the terms' order.
  void tet_laplacians(double scale, double min_weight, std::vector<TetLaplacian>& out) const {
    out.clear();
    for (const auto& term : terms_) term->add_tet_laplacians(scale, min_weight, out);
  }
  void tet_weight_range(double& softest, double& stiffest) const {
    for (const auto& term : terms_) term->tet_weight_range(softest, stiffest);
  }
  // H += scale * K(x) on the free dofs, K = d2E/dx2 with the terms' definiteness fix (psd) or
  // exact. Adds into H's existing pattern.
  PetscErrorCode add_hessian(Vec x, Mat H, PetscReal scale, bool psd = true) const;
  // The terms' couplings at x outside the mesh's pattern into out (unless null) and the sum of
  // their generations (EnergyTerm::add_couplings; collective).
  PetscErrorCode hessian_couplings(Vec x, std::vector<std::array<PetscInt, 2>>* out, unsigned long long* generation) const;
  // The terms' diagonal stiffness blocks at x (EnergyTerm::add_vertex_stiffness) times scale,
  // summed to one per owned free vertex that has any, in the order of the global dofs (collective).
  PetscErrorCode vertex_stiffness(Vec x, PetscReal scale, std::vector<VertexStiffness>& out) const;
  // H += scale * K(x_rest): the PSD-fixed Hessian at the rest shape (every vertex, fixed ones too,
  // at its rest position), on the free dofs.
  PetscErrorCode add_rest_hessian(Mat H, PetscReal scale) const;
  // A += scale * K_vol, the sum of the terms' add_volumetric_h0 (solver.h0: volumetric; dof layout).
  PetscErrorCode add_volumetric_h0(Mat A, PetscReal scale) const;
  // Positions of the rest shape as a global vector of free dofs.
  PetscErrorCode rest_positions(Vec x) const;

 private:
  // The motion of local vertex v if it is fixed by a region that moves, else null.
  const Motion* prescribed_motion(PetscInt v) const;
  // The motion of fixed region `region` (k + 1) if it moves, else null.
  const Motion* region_motion(int32_t region) const;
  // Where motion puts the rest point X at time t: on the step's chord inside it (set_step).
  Vec3 placed(const Motion& motion, const Vec3& X, double t) const;
  // out = fixed_values, then the free vertices' entries overwritten from the global vector.
  PetscErrorCode scatter_to_local(Vec global, const std::vector<double>& fixed_values, std::vector<double>& out) const;

  const DistributedMesh& mesh_;
  std::vector<std::unique_ptr<EnergyTerm>> terms_;
  double total_mass_ = 0;
  std::vector<BoxRegion> fixed_regions_;
  std::vector<double> fixed_pos_;    // 3 per local vertex: prescribed positions (free: unused)
  std::vector<double> fixed_vel_;    // 3 per local vertex: prescribed velocities (free: 0)
  double time_ = 0;
  std::array<double, 2> step_{0, 0};  // set_step's t0, t1
  mutable Vec local_ = nullptr;      // work: local (ghosted) vector
  mutable std::vector<double> pos_;  // work: local positions
  mutable std::vector<double> J_;    // work: det F per local tet
  std::vector<double> rest_measure_;  // per local tet det Dm, then per triangle its rest area: J's denominators
  mutable std::vector<double> zeros_;  // work: 0 at every local vertex (local_values)
  std::vector<double> step_start_, step_positions_;  // begin_step's StepStart::start_positions, positions
  std::vector<std::array<int64_t, 2>> inherited_elements_;  // set_inherited_elements
  // Rollers: every local held component as its entry 3 v + d of the local arrays (ghosts too), and
  // this rank's held slots as global rows, as indices into its part of a global vector, and as local entries.
  std::vector<PetscInt> held_local_, held_rows_, held_at_, held_entry_;
};

}  // namespace hyperqn

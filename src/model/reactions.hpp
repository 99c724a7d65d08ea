// The forces the supports exert on the body (deck output.reactions, reactions.csv): each fixed
// region's and each attachment's, per frame, with their moments. docs/outputs.md#reactionscsv.
//
// A fixed vertex i carries no dof, so the step's equation is not solved there; what is left of it
// is the force its support exerts: r_i = m_i a_i + dE/dx_i - m_i g, with a_i = (v_{n+1} - v_n)/h
// from the velocities the state holds (a fixed vertex's: its prescribed mean velocity over the
// step) and dE/dx at the frame's end. That is implicit Euler's equation at a free vertex, so the
// reactions, gravity and the free vertices' (solved) equations give the body's momentum balance.
// A static step (time.integrator: static) has no inertia: r_i = dE/dx_i - m_i g, whatever the
// supports' speed along the load path.
// The terms add their gradients at free dofs only; the reactions evaluate the scene's elastic terms
// a second time, built over a copy of the mesh whose dof map covers every local vertex, so the
// normal evaluation is untouched and a run without reactions builds nothing of this.
// The loads are evaluated there too (their share at a fixed vertex is a force on the support: r_i
// takes -f_i); loads on vertices select free vertices only. An attachment's force is
// -k (x_i - p_i(t)) summed over its springs.
// A roller's vertex (a fixed region with `components`) is free but for its held components, whose
// slots the solvers leave alone: r_i is the same residual in those components (a load's share
// there included) and 0 in the others. Not yet: an attachment or contact acting at a held
// component is not counted.
// A term with an ElementState (a viscoelastic material) takes the body's values at each frame's
// end (carry_values), as the accepted step left them: its stored stress, the step's own at x_{n+1}.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "model/body.hpp"
#include "model/scene_spec.hpp"
#include "model/state.hpp"

namespace hyperqn {

// The same mesh (its DM shared, for its communicator) with x dof 3 v for every local vertex v: the
// terms built over it add their gradients and masses at fixed vertices too (also model/energy_balance.hpp).
PetscErrorCode mesh_with_every_vertex(const DistributedMesh& mesh, std::unique_ptr<DistributedMesh>& out);

// The scene's loads built over such a mesh (every vertex a dof; the regions as the solver's terms
// select them), a load that scales with the mass (body_force) given the body's lumped masses as the
// scene gives its own (Body::set_masses). Collective.
PetscErrorCode loads_over_every_vertex(const DistributedMesh& all, const SceneSpec& spec, const Body& body,
                                       std::vector<std::unique_ptr<EnergyTerm>>& out);

// One support's force on the body at the end of a frame, the same on every rank.
struct SupportForce {
  std::array<double, 3> force{0, 0, 0};   // sum over its vertices of r_i (N)
  std::array<double, 3> moment{0, 0, 0};  // sum of (x_i - point) x r_i (N m)
  std::array<double, 3> point{0, 0, 0};   // its box's centre moved by its motion to the frame's time
};

class Reactions {
 public:
  // The supports of the scene: spec.fixed, then spec.attachments, as the deck names them
  // ("fixed[0]", "bodies[1].fixed[0]", "attachments[0]"), and their deck lines.
  static std::vector<std::string> names(const SceneSpec& spec);
  static std::vector<int> lines(const SceneSpec& spec);

  explicit Reactions(const SceneSpec& spec) : spec_(spec) {}
  // For the scene's body as built (again after a release; s: its released attachments). Collective.
  PetscErrorCode bind(const Body& body, const State& s);
  // Before a frame: v_n of every local vertex (and the step's start for a load that needs it).
  PetscErrorCode begin_frame(const State& s);
  // After it: one force per support (names' order; a released one's is 0). Collective.
  PetscErrorCode end_frame(const State& s, std::vector<SupportForce>& out);

 private:
  const SceneSpec& spec_;
  const Body* body_ = nullptr;
  std::unique_ptr<DistributedMesh> all_;             // the body's mesh with a dof for every local vertex
  std::vector<std::unique_ptr<EnergyTerm>> terms_;   // the elastic terms and face loads over all_
  size_t first_load_ = 0;                            // terms_[first_load_...]: the face loads
  std::vector<double> mass_;                         // 3 per local vertex: this rank's elements' lumped mass
  std::vector<std::vector<PetscInt>> attached_;      // per attachment: its vertices here (none if released)
  std::vector<double> vel_start_, pos_, vel_, grad_;  // work: local arrays
};

}  // namespace hyperqn

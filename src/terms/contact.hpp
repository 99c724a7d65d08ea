// Contact of the body's vertices with obstacles (geometry/collider.hpp), and friction, as one
// energy term. The scene holds it only when the deck has colliders.
//
// Normal contact, per free vertex i and collider c with signed distance phi (> 0 outside) and
// activation distance d (contact.distance), is one of two energies of phi, both zero for phi >= d
// and twice continuously differentiable there, so TAO's line searches see a smooth g:
//   penalty: E_ic = k_i / 3 * (d - phi)^3 for phi < d,      k_i = stiffness * m_i * g0 / d^2;
//   barrier: E_ic = -k_i (phi - d)^2 ln(phi / d) for 0 < phi < d, +inf for phi <= 0,
//            k_i = stiffness * m_i * g0 / d (IPC's log barrier).
// The stiffness is relative to each vertex's weight (m_i g0, g0 = 9.80665): at a penetration of
// the whole activation distance (penalty), or half of it (barrier), a vertex pushes back with about
// `stiffness` times its weight, whatever the units, masses and time step. Under a resting load of f
// times its own weight a vertex sinks into the activation layer by d sqrt(f / stiffness) (penalty)
// or d sqrt(f / (3 stiffness)) (barrier). The barrier's +inf makes a point where a vertex touches
// or crosses an obstacle a rejected one (solvers/objective.hpp), and limit_step bounds every step
// by exact continuous collision detection, so no iterate ever has a vertex inside an obstacle.
//
// Friction is IPC's lagged smoothed Coulomb model: at the start of each step, for every vertex
// within the activation distance of a collider at x_n, the normal force lambda = k_i (d - phi)^2
// and the tangent plane T (3 x 2) are frozen; the step then adds
//   D_ic = mu_c lambda f0(|u|),   u = T^T ((x_i - x_n,i) - (obstacle motion of that point over the step)),
// with f0' = f1 the smoothed sliding indicator: f1(s) = 2 s/(eps h) - s^2/(eps h)^2 below eps h, 1
// above (eps = contact.friction_velocity). Below eps the contact sticks like a stiff spring.
//
// Contact and friction do not enter L; L-BFGS's H0 takes their blocks per step (add_vertex_stiffness,
// solver.h0_contact: solvers/contact_h0.hpp).
#pragma once
#include <petsclog.h>

#include <memory>
#include <string>
#include <vector>

#include "geometry/collider.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/contact_spec.hpp"
#include "terms/element_kernels.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

// What the contact does at one configuration, per collider, over all ranks.
struct ContactMeasure {
  std::vector<double> normal_force;    // |sum of the normal contact forces on the body|
  std::vector<double> friction_force;  // |sum of the friction forces|
  std::vector<double> penetration;     // max(0, -phi) over the vertices
  std::vector<long> active;            // vertices with phi < d
};

// The normal energy of the model at distance phi < d, per unit stiffness: its value, first and
// second derivative (the penalty's cubic, or the barrier's log, +inf at phi <= 0). Shared with
// self-contact (terms/self_contact.hpp), whose phi is the distance between two primitives.
void contact_profile(const ContactSpec& spec, double phi, double* b, double* db, double* d2b);
// k_i / m_i: stiffness * g0 / d (barrier) or / d^2 (penalty).
double contact_stiffness_per_mass(const ContactSpec& spec);

class ContactTerm : public EnergyTerm {
 public:
  // event: the PETSc log event its work is timed under (hqnContact); bodies: how its start check
  // names each body of mesh.vertex_body (empty: one body, "the body").
  ContactTerm(const DistributedMesh& mesh, std::vector<std::unique_ptr<Collider>> colliders, const ContactSpec& spec,
              PetscLogEvent event, std::vector<std::string> bodies = {});
  std::string name() const override { return "contact"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  // Contact is a step's state, not the rest's stiffness (EnergyTerm::add_rest_stiffness).
  PetscErrorCode add_rest_stiffness(const std::vector<double>&, Mat, double) const override { return 0; }
  // Its whole Hessian (psd): every block is a single vertex's.
  PetscErrorCode add_vertex_stiffness(const std::vector<double>& pos, std::vector<VertexStiffness>& out) const override;
  bool has_vertex_stiffness() const override { return true; }
  bool is_contact() const override { return true; }
  bool projective_dynamics_exact() const override { return false; }
  // The barrier bounds steps (no vertex may reach an obstacle); the penalty does not.
  bool bounds_steps() const override { return barrier_; }
  unsigned long long active_set() const override { return active_set_; }
  // 0.8 of the earliest impact along the step over the rank's vertices and the colliders (a
  // minimum, which Body::limit_step takes over ranks: the same bound at any rank count).
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const override;
  PetscErrorCode begin_step(const StepStart& step) override;

  // Sets the per-vertex penalty stiffness. Until it is called every vertex counts as 1 kg.
  PetscErrorCode set_masses(Vec mass) override;
  // Reports: the console line of its settings; contact.csv, per frame and collider, the total
  // normal and friction force on the body, the deepest penetration and the vertices within the
  // activation distance; summary.json's max_penetration and max_active_contacts; the point field
  // contact_force (N: normal plus friction, of all colliders).
  std::string describe() const override;
  TermLog log() const override { return {"contact.csv", "collider,normal_force,friction_force,max_penetration,active"}; }
  PetscErrorCode report(const std::vector<double>& pos, TermReport& out) const override;
  std::vector<std::string> point_fields() const override { return {"contact_force"}; }
  PetscErrorCode point_field(const std::string& name, const std::vector<double>& pos, Vec out) const override;
  // A body must not start inside an obstacle: at frame 0 (the obstacles at their pose at t = 0) no
  // free vertex may be deeper inside a collider than the model lets it be (too_deep). The problem
  // names the first such collider (its deck line and colliders[i]), the body of the deepest vertex
  // in a scene of bodies, how many of that body's free vertices it holds and the deepest one.
  PetscErrorCode check_start(const std::vector<double>& pos, InputProblem& out) const override;
  // The barrier's energy is infinite where a free vertex is at or inside an obstacle: which
  // colliders hold which vertices (the penalty is always finite: "").
  PetscErrorCode explain_rejection(const std::vector<double>& pos, std::string& why) const override;

  // Forces per collider at the local positions pos (collective). If force is not null (a global
  // vector of free dofs) it gets the contact force (normal + friction) on every free vertex.
  PetscErrorCode measure(const std::vector<double>& pos, ContactMeasure& out, Vec force) const;

 private:
  // Normal contact of vertex slot k with collider c at p: its energy, and, if not null, its
  // gradient and Hessian (psd: the obstacle's curvature part clamped to positive semidefinite).
  double normal_energy(size_t k, size_t c, const Vec3& p, Vec3* grad, Mat3* hess, bool psd) const;
  // The normal energy per unit stiffness at phi < d: b, db/dphi, d2b/dphi2 (inf for the barrier at phi <= 0).
  void profile(double phi, double* b, double* db, double* d2b) const;
  double stiffness_per_mass() const;  // k_i / m_i
  // Deeper inside an obstacle than the model lets a vertex be at the end of a frame: penalty
  // phi < -d (it pushes back with more than 4 times `stiffness` vertex weights there), barrier
  // phi < 0 (no iterate is ever inside; a vertex exactly on the surface is touching).
  bool too_deep(double phi) const { return barrier_ ? phi < 0 : phi < -spec_.distance; }
  std::string too_deep_words() const;  // "deeper than the activation distance 0.0076 (contact.distance)"
  // The free vertices at pos that a collider holds (test(phi)), per collider over all ranks: how
  // many, and the deepest (the lowest vertex id among equals: the same at any rank count).
  // moving_only: colliders without a motion count none. Collective.
  struct HeldVertices {
    long count = 0;
    double depth = 0;          // -phi of the deepest
    long long vertex = -1;     // its id in the input mesh (the output's vertex_id)
    Vec3 position = Vec3::Zero();
  };
  // body >= 0: only that body's vertices (mesh.vertex_body).
  template <typename Test>
  PetscErrorCode held_vertices(const std::vector<double>& pos, bool moving_only, Test test,
                               std::vector<HeldVertices>& out, int body = -1) const;
  // "colliders[1] (box, deck line 23) holds 4 free vertices <what> (the deepest: vertex 840 at
  // (x, y, z), 0.031 inside)".
  std::string held_sentence(size_t c, const HeldVertices& held, const std::string& what) const;
  // Lagged friction of contact point f at p: energy, gradient, Hessian.
  double friction_energy(size_t f, const Vec3& p, Vec3* grad, Mat3* hess) const;

  struct FrictionPoint {
    size_t slot = 0, collider = 0;
    double mu_lambda = 0;         // mu * lambda
    Eigen::Matrix<double, 3, 2> T;  // tangent basis at x_n
    Vec3 anchor;                  // x_n plus the obstacle's motion of that point over the step
  };

  const DistributedMesh& mesh_;
  std::vector<std::unique_ptr<Collider>> colliders_;
  ContactSpec spec_;
  std::vector<std::string> bodies_;  // the bodies' names for messages (empty: one body)
  std::vector<PetscInt> vertices_;   // the owned free local vertices (each vertex on one rank)
  std::vector<double> stiffness_;    // per slot: k_i
  std::vector<FrictionPoint> friction_;
  double eps_h_ = 0;                 // friction_velocity * h of the current step
  bool barrier_ = false;
  mutable unsigned long long active_set_ = 0;
  PetscLogEvent event_;
};

}  // namespace hyperqn

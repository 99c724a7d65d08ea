// Self-contact: the surfaces of all bodies and cloths against each other and themselves, as one
// energy term (deck contact: {self: true}; docs/contact.md#self-contact). The scene holds it only
// when the deck turns it on.
//
// The surface is the tets' boundary faces and the cloth triangles, with their edges and vertices.
// Every vertex against every triangle and every edge against every edge that shares no vertex
// with it is a pair; a pair closer than the activation distance d (contact.distance) has the
// obstacle contact's energy (terms/contact.hpp, contact_profile) of its distance phi = sqrt(D)
// (geometry/pair_distance.hpp), an edge pair's multiplied by IPC's mollifier, which vanishes for
// parallel edges:
//   vertex-triangle: k b(phi),   edge-edge: k m(c) b(phi),
//   k = contact_stiffness_per_mass * (the mean lumped mass of the pair's free points).
// With the barrier every step is bounded by the pairs' continuous collision tests
// (geometry/pair_ccd.hpp), so no iterate has two surfaces pass through each other; so is the jump
// of moving fixed vertices at the start of a step (begin_step): one that would carry a surface
// into another rejects the step (its energy is infinite), which the fallback chain's sub-steps
// then cut into shorter jumps.
//
// Distribution (a first version): every evaluation gathers the positions of all surface vertices
// to every rank (one MPI_Allgatherv of 3 doubles per surface vertex, not the volume's); every rank
// evaluates the pairs it is the owner of: a vertex-triangle pair belongs to the rank owning its
// vertex, an edge pair (e < f in the surface's order) to the rank owning e's first vertex, the
// same rule at any rank count. A pair's gradient at vertices of other ranks is summed by this rank
// and sent to their owners, who add what they receive in the order of the sending ranks (so the
// sums do not depend on the order messages arrive in).
//
// Broad phase: each rank keeps a list of candidate pairs (its own pairs within d + margin at the
// positions where it was built, with their distance then; geometry/box_tree.hpp), built at the
// first evaluation of each step and again only when a surface vertex has moved more than
// kMoveFraction of the margin since; an evaluation visits the candidates whose distance at the
// build less their vertices' moves is below d (refresh_candidates says why no pair within d is
// ever missed). The pairs are visited in a canonical order, so the sums do not depend on where the
// list was built either.
#pragma once
#include <petsclog.h>

#include <array>
#include <string>
#include <vector>

#include "geometry/pair_distance.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/contact_spec.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

enum class PairKind { vertex_triangle, edge_edge };

// One pair's energy per unit stiffness at x (the 12 coordinates in the kernels' order: vertex,
// triangle or edge, edge), 0 at phi >= d, +inf for the barrier at phi = 0; its gradient and
// Hessian if asked. mollifier_eps: the edge pair's eps_x (edge_edge_mollifier_threshold at rest).
double self_contact_pair_energy(const ContactSpec& spec, PairKind kind, const Vector12d& x, double mollifier_eps,
                                Vector12d* gradient = nullptr, Matrix12d* hessian = nullptr);

class SelfContactTerm : public EnergyTerm {
 public:
  // Finds the surface (collective). event: its log event (hqnSelfContact); within it
  // gather_event: the gathers and gradient exchange (hqnSelfGather), pairs_event: building the
  // candidate pairs (hqnSelfPairs). fixed_lines: the deck line of each fixed region (region k at
  // k - 1, as mesh.fixed numbers them), for the messages.
  SelfContactTerm(const DistributedMesh& mesh, const ContactSpec& spec, PetscLogEvent event, PetscLogEvent gather_event,
                  PetscLogEvent pairs_event, std::vector<int> fixed_lines = {});
  ~SelfContactTerm() override;
  SelfContactTerm(const SelfContactTerm&) = delete;
  SelfContactTerm& operator=(const SelfContactTerm&) = delete;

  std::string name() const override { return "self-contact"; }
  // Collective (the gather), with or without gradient alike on every rank.
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  // The pairs' 12 x 12 blocks (psd: each projected to positive semidefinite); collective.
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  bool projective_dynamics_exact() const override { return false; }
  bool bounds_steps() const override { return barrier_; }
  bool couples_surfaces() const override { return true; }
  // The step's margin from its predicted motion (the largest |y - x_n| of a surface vertex); the
  // candidate pairs are built again at the step's first evaluation. With the step's positions
  // (StepStart::positions), the jump of the moving fixed vertices from start_positions to
  // positions, the free ones at x_n, by the pairs' continuous collision tests: if a pair would
  // come within a tenth of its distance, every evaluation of the step is rejected (an infinite
  // energy) and explain_rejection names the region (collective).
  PetscErrorCode begin_step(const StepStart& step) override;
  unsigned long long active_set() const override { return active_set_; }
  // The largest alpha at which no pair touches along the straight path (additive CCD of every
  // pair whose swept boxes overlap). Fixed vertices stay where the step has them (begin_step).
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const override;
  PetscErrorCode set_masses(Vec mass) override;
  std::string describe() const override;
  // The activation distance must be below the rest spacing of the surface: no two primitives of
  // one body that share no vertex may be closer than d at rest (the problem names
  // contact.distance, the gap found and a value that fits). Then, with the barrier, no two
  // surfaces may touch at frame 0 (the problem names contact.self and how many pairs touch).
  // Collective.
  PetscErrorCode check_start(const std::vector<double>& pos, InputProblem& out) const override;
  // The barrier's energy is infinite where pairs touch: how many; or the step was rejected at its
  // start: which fixed region moves its surface into another (collective).
  PetscErrorCode explain_rejection(const std::vector<double>& pos, std::string& why) const override;

  // The surface, the same on every rank: surface vertex indices in the order of their input ids.
  size_t surface_vertices() const { return ids_.size(); }
  size_t surface_triangles() const { return triangles_.size(); }
  size_t surface_edges() const { return edges_.size(); }
  // Pairs within the activation distance at the last evaluation, on this rank.
  size_t active_pairs() const { return active_pairs_; }
  // The fixed region (k + 1 for the deck's k-th, as mesh.fixed) whose jump rejected this step, 0 if none.
  int rejecting_region() const { return rejecting_region_; }
  // This rank's candidate pairs, and how many times they were built (tests).
  size_t candidate_pairs() const { return candidates_.size(); }
  size_t candidate_builds() const { return builds_; }
  // A candidate list may serve until a surface vertex has moved this fraction of its margin.
  static constexpr double kMoveFraction = 0.4;

 private:
  struct Pair {
    PairKind kind;
    int a, b;  // vertex and triangle, or edge and edge (surface indices)
  };
  std::array<int, 4> points(const Pair& p) const;
  Vector12d coordinates(const std::vector<double>& x, const std::array<int, 4>& q) const;
  // The surface's positions (x_) from the local positions pos (collective).
  PetscErrorCode gather_positions(const std::vector<double>& pos) const;
  // Two positions per surface vertex: mine holds 6 per vertex this rank owns (in owned_local_'s
  // order), start and end get them for the whole surface, 3 each (collective).
  PetscErrorCode gather_path(const std::vector<double>& mine, std::vector<double>& start, std::vector<double>& end) const;
  // The jump of the moving fixed vertices at the step's start (begin_step); sets step_at_ and
  // rejecting_region_ (collective).
  PetscErrorCode check_fixed_jump(const std::vector<double>& start_positions, const std::vector<double>& positions);
  // Calls visit(pair) for the pairs of this rank whose boxes overlap: the primitives' boxes at x
  // (edges and vertices inflated by reach), or, if end is not null, the boxes swept from x to end
  // (inflated by reach). Builds the box trees (over the whole surface).
  template <class Visit>
  void broad_phase(const std::vector<double>& x, const std::vector<double>* end, double reach, Visit&& visit) const;
  // Builds the candidate pairs again at x_ unless the list covers x_ (not collective: every rank
  // decides alike from the whole surface's positions).
  PetscErrorCode refresh_candidates() const;
  // True if every surface vertex at x (and end, if given) is within kMoveFraction of the list's
  // margin of where the list was built; moved_: how far each is (the farther of x and end).
  bool candidates_cover(const std::vector<double>& x, const std::vector<double>* end) const;
  // A candidate: a pair and its distance when the list was built.
  struct Candidate {
    Pair pair;
    double distance;
  };
  // False if the candidate's distance at the build less its primitives' moves (moved_) is d or
  // more: it cannot be within d.
  bool may_be_within_d(const Candidate& c) const;
  // Calls visit(pair) for the candidates that may be within d at x_, in the candidates' order
  // (after refresh_candidates).
  template <class Visit>
  void near_pairs(Visit&& visit) const;
  double pair_energy(const Pair& p, const Vector12d& x, Vector12d* g, Matrix12d* H) const;
  double squared_distance(const Pair& p, const std::vector<double>& x) const;
  // The pairs at distance 0 at pos, over all ranks (collective).
  PetscErrorCode touching_pairs(const std::vector<double>& pos, long* count) const;
  // The smallest distance at rest between two primitives of one body that share no vertex (+inf:
  // none within d), over all ranks, and the lowest input id of a vertex of such a pair (collective).
  PetscErrorCode closest_rest_pair(double* distance, int64_t* vertex_id) const;
  // Adds the gradient summed per surface vertex (accumulated_, at touched_) into the local array:
  // this rank's vertices directly, the others' sent to their owners (collective).
  PetscErrorCode exchange_gradient(PetscScalar* gradient) const;

  const DistributedMesh& mesh_;
  ContactSpec spec_;
  bool barrier_ = false;
  PetscLogEvent event_, gather_event_, pairs_event_;
  // The surface (every rank): input ids, triangles and edges (surface vertex indices), rest
  // positions, global dof (-1: fixed), owning rank, lumped mass (free vertices), body per vertex,
  // fixed region per vertex (as mesh.fixed: 0 free).
  std::vector<int64_t> ids_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<std::array<int, 2>> edges_;
  std::vector<double> rest_;
  std::vector<PetscInt> dof_;
  std::vector<int> owner_;
  std::vector<double> mass_;
  std::vector<int32_t> body_;
  std::vector<int32_t> region_;
  std::vector<int> fixed_lines_;
  // This rank's part: the local vertex of each surface vertex it owns (in the order it sends
  // them; local_of_ per surface vertex, -1 if another rank's), and the primitives whose pairs it
  // evaluates.
  std::vector<PetscInt> owned_local_, local_of_;
  std::vector<int> owned_surface_;
  std::vector<int> my_vertices_, my_edges_;
  // The gather: counts and offsets per rank, in surface vertices, and the receive order.
  std::vector<int> counts_, offsets_, received_;
  mutable std::vector<double> x_;      // 3 per surface vertex: positions at the last gather
  std::vector<double> step_at_;        // 3 per surface vertex: where the step starts (its fixed vertices' positions)
  int rejecting_region_ = 0;           // rejecting_region()
  // The candidate pairs (sorted), the positions they were built at, their margin; the margin the
  // current step asks for; stale: build at the next evaluation.
  mutable std::vector<Candidate> candidates_;
  mutable std::vector<double> built_at_, moved_;
  mutable double built_margin_ = 0;
  double step_margin_ = 0;
  mutable bool stale_ = true;
  mutable size_t builds_ = 0;
  // The gradient per surface vertex of this rank's pairs (3 each) and the vertices it touched.
  mutable std::vector<double> accumulated_;
  mutable std::vector<char> touched_;
  mutable std::vector<int> touched_list_;
  mutable std::vector<double> buffer_;  // work
  mutable unsigned long long active_set_ = 0;
  mutable size_t active_pairs_ = 0;
};

}  // namespace hyperqn

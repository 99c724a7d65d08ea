// Self-contact: the surfaces of all bodies and cloths against each other and themselves, as one
// energy term (deck contact: {self: true}; docs/self-contact.md). The scene holds it only
// when the deck turns it on.
//
// The surface is the tets' boundary faces and the cloth triangles, with their edges and vertices.
// Every vertex against every triangle and every edge against every edge that shares no vertex
// with it is a pair; a pair closer than the activation distance d (contact.distance) has the
// obstacle contact's energy (terms/contact.hpp, contact_profile) of its distance phi = sqrt(D)
// (geometry/pair_distance.hpp), an edge pair's multiplied by IPC's mollifier, which vanishes for
// parallel edges:
//   vertex-triangle: k b(phi - xi),   edge-edge: k m(c) b(phi - xi),
//   k = contact_stiffness_per_mass * (the mean lumped mass of the pair's free points),
// xi the pair's thickness offset: half the cloth thickness of each of its two primitives' bodies
// (0 for a solid), so two layers of a cloth of thickness t keep t + d apart (Codimensional IPC's
// offset: the mid-surfaces never come closer than the thickness). With the barrier every step is
// bounded by the pairs' continuous collision tests with minimum separation xi
// (geometry/pair_ccd.hpp), so no iterate has two surfaces pass through each other; so is the jump
// of moving fixed vertices at the start of a step (begin_step): one that would carry a surface
// into another rejects the step (its energy is infinite), which the fallback chain's sub-steps
// then cut into shorter jumps.
//
// Friction (contact.self_friction mu > 0) is IPC's lagged smoothed Coulomb model, as for obstacles
// (terms/smoothed_friction.hpp): at the start of each step every pair within d at x_n freezes its
// normal force lambda = k |b'(phi)| (times the mollifier m(c) for an edge pair), the weights w_i of
// its closest points (+ on the first primitive, - on the second, 0 at fixed points) and the
// tangent plane T of the line between them; the step then adds mu lambda f0(|u|),
// u = T^T sum_i w_i (x_i - x_n,i), the closest points' relative tangential displacement. With
// mu = 0 no pair is frozen and none of this runs.
//
// Distribution (a ghost layer): each rank evaluates the pairs it is the owner of: a
// vertex-triangle pair belongs to the rank owning its vertex, an edge pair (e < f in the surface's
// order) to the rank owning e's first vertex, the same rule at any rank count. It knows the
// positions of its own surface vertices and of a ghost layer, sent by their owners at every
// evaluation: the vertices of every triangle and edge within reach of its own vertices and edges
// (found, when the candidate pairs are built, by the owners of those primitives against each
// rank's region), and its own edges' and triangles' other vertices. The surface's topology (ids,
// triangles, edges, owners) is on every rank; positions only where known. A pair's gradient at
// vertices of other ranks is summed by this rank and sent to their owners, who add what they
// receive in the order of the sending ranks (so the sums do not depend on the order messages
// arrive in).
//
// Broad phase: each rank keeps a list of candidate pairs (its own pairs within d + margin at the
// positions where it was built, with their distance then, all less xi; geometry/box_tree.hpp), built at the
// first evaluation of each step and again only when a surface vertex has moved more than
// kMoveFraction of the margin since, less the translation common to the surface (which moves no
// pair: a falling body keeps its list); an evaluation visits the candidates whose distance at the
// build less their vertices' moves is below d (refresh_candidates says why no pair within d is
// ever missed). The pairs are visited in a canonical order, so the sums do not depend on where the
// list was built either. The margin covers the step's predicted motion less that translation,
// doubles when the list is built again within the step, and is capped by half the mean edge
// (begin_step, refresh_candidates); the step bound visits the same pairs whether it uses the list or a broad phase
// of its own (limit_step), so no result depends on the margin.
//
// L-BFGS's initial Hessian (solver.h0_contact) takes the 3 x 3 diagonal blocks of each pair's
// Hessian (the same PSD projection as add_hessian's) and of its friction at each free point
// (add_vertex_stiffness); the blocks between two points of a pair are left out, since H0's
// correction is per vertex. A block of another rank's vertex is summed and sent to its owner as
// the gradient is, so each vertex gets one sum per rank that has pairs at it, at its owner.
#pragma once
#include <petsclog.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "geometry/box_tree.hpp"
#include "geometry/pair_distance.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/contact_spec.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

enum class PairKind { vertex_triangle, edge_edge };

// One pair's energy per unit stiffness at x (the 12 coordinates in the kernels' order: vertex,
// triangle or edge, edge), 0 at phi - xi >= d, +inf for the barrier at phi <= xi; its gradient and
// Hessian if asked. mollifier_eps: the edge pair's eps_x (edge_edge_mollifier_threshold at rest);
// xi: the pair's thickness offset.
double self_contact_pair_energy(const ContactSpec& spec, PairKind kind, const Vector12d& x, double mollifier_eps,
                                double xi, Vector12d* gradient = nullptr, Matrix12d* hessian = nullptr);

// What self-contact knows of a body (deck bodies[k], or the deck's one body): how the deck names
// it and its cloth's thickness.
struct SelfContactBody {
  std::string key;         // "bodies[k]", or "" for a deck of one body
  double thickness = 0;    // its cloth's thickness (0: a solid, or a cloth without one)
  int thickness_line = 0;  // the deck line of its cloth.thickness, when given
  int line = 0;            // the deck line of bodies[k]
};

// What a pair's lagged friction freezes at x_n (lagged_pair_friction).
struct PairFriction {
  double mu_lambda = 0;                 // mu times the normal force magnitude lambda
  std::array<double, 4> weights{};      // w_i: the closest points' weights per point
  Eigen::Matrix<double, 3, 2> T;        // tangent plane of the pair's normal
  Vector12d start;                      // the four points at x_n
};

// The lagged friction of a pair at x_n (its 12 coordinates) with thickness offset xi, normal
// stiffness k (the k of self_contact_pair_energy's energy) and coefficient mu; false, and nothing
// frozen, if the pair is not within d of xi, touches (no normal) or is mollified away (parallel edges).
bool lagged_pair_friction(const ContactSpec& spec, PairKind kind, const Vector12d& x_start, double mollifier_eps,
                          double xi, double k, double mu, PairFriction* out);
// Its energy mu lambda f0(|u|) at x, with eps_h = friction_velocity times the step; its gradient
// and Hessian (positive semidefinite) if asked.
double pair_friction_energy(const PairFriction& friction, double eps_h, const Vector12d& x, Vector12d* gradient = nullptr,
                            Matrix12d* hessian = nullptr);

class SelfContactTerm : public EnergyTerm {
 public:
  // Finds the surface (collective). event: its log event (hqnSelfContact); within it
  // gather_event: the position and gradient exchanges (hqnSelfGather), pairs_event: building the
  // candidate pairs (hqnSelfPairs). bodies: per body of mesh.vertex_body (none: every body a solid).
  // fixed_lines: the deck line of each fixed region (region k at k - 1, as mesh.fixed numbers
  // them), for the messages.
  SelfContactTerm(const DistributedMesh& mesh, const ContactSpec& spec, PetscLogEvent event, PetscLogEvent gather_event,
                  PetscLogEvent pairs_event, std::vector<SelfContactBody> bodies = {}, std::vector<int> fixed_lines = {});
  ~SelfContactTerm() override;
  SelfContactTerm(const SelfContactTerm&) = delete;
  SelfContactTerm& operator=(const SelfContactTerm&) = delete;

  std::string name() const override { return "self-contact"; }
  // Collective (the exchanges), with or without gradient alike on every rank.
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  // The pairs' 12 x 12 blocks (psd: each projected to positive semidefinite); collective.
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  // Contact is a step's state, not the rest's stiffness (EnergyTerm::add_rest_stiffness).
  PetscErrorCode add_rest_stiffness(const std::vector<double>&, Mat, double) const override { return 0; }
  // The 3 x 3 diagonal blocks of add_hessian (psd) at the free points of the pairs within d and of
  // the frozen friction pairs, at each vertex's owner (collective).
  PetscErrorCode add_vertex_stiffness(const std::vector<double>& pos, std::vector<VertexStiffness>& out) const override;
  bool has_vertex_stiffness() const override { return true; }
  bool is_contact() const override { return true; }
  bool projective_dynamics_exact() const override { return false; }
  bool bounds_steps() const override { return barrier_; }
  bool couples_surfaces() const override { return true; }
  // The vertex pairs of the candidates that may come within d while the list serves and of the
  // friction pairs; the generation counts the list's builds (it is built again after every
  // begin_step, so they count the friction pairs' changes too; collective).
  PetscErrorCode add_couplings(const std::vector<double>& pos, std::vector<std::array<PetscInt, 2>>* out,
                               unsigned long long* generation) const override;
  // The step's margin from its predicted motion (the largest |y - x_n| of a surface vertex); the
  // candidate pairs are built again at the step's first evaluation; with friction, the pairs
  // within d at x_n freeze their friction. With the step's positions (StepStart::positions), the
  // jump of the moving fixed vertices from start_positions to positions, the free ones at x_n, by
  // the pairs' continuous collision tests: if a pair would come within a tenth of its distance,
  // every evaluation of the step is rejected (an infinite energy) and explain_rejection names the
  // region (collective).
  PetscErrorCode begin_step(const StepStart& step) override;
  unsigned long long active_set() const override { return active_set_; }
  // The largest alpha at which no pair comes within its xi along the straight path (additive CCD
  // of every pair whose swept boxes, grown by xi, overlap; collective). Fixed vertices stay where
  // the step has them (begin_step).
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const override { return bound_step(x, dir, alpha, true); }
  // The same bound from a broad phase of the step alone, never the candidate list (tests: the two
  // give the same alpha).
  PetscErrorCode limit_step_without_list(Vec x, Vec dir, double* alpha) const { return bound_step(x, dir, alpha, false); }
  PetscErrorCode set_masses(Vec mass) override;
  std::string describe() const override;
  // No two surface triangles may cross at frame 0, with either model (the problem names the
  // bodies, or contact.self in a deck of one body, how many pairs cross and one of them: checked
  // first, since crossing triangles are also 0 apart at rest, which no distance fits). Then the
  // activation distance and thickness must fit the rest spacing of the surface: no two
  // primitives of one body that share no vertex may be closer than d + xi at rest (the problem
  // names contact.distance, the gap found and a value that fits, or the cloth's thickness when the
  // gap is within xi); and, with the barrier, no pair may be within its xi (the problem names
  // contact.self and how many pairs touch). Collective.
  PetscErrorCode check_start(const std::vector<double>& pos, InputProblem& out) const override;
  // The barrier's energy is infinite where pairs are within their xi: how many; or the step was
  // rejected at its start: which fixed region moves its surface into another (collective).
  PetscErrorCode explain_rejection(const std::vector<double>& pos, std::string& why) const override;
  // The penalty only (the barrier keeps every pair apart): self-contact.csv's row per frame, the
  // surface triangle pairs that cross at the frame's end (as check_start counts them); summary.json's
  // max_self_crossings, and the frame flagged under self_crossing_frames with a warning that says
  // how many cross and where the first does (collective).
  TermLog log() const override { return barrier_ ? TermLog{} : TermLog{"self-contact.csv", "crossing_pairs"}; }
  PetscErrorCode report(const std::vector<double>& pos, TermReport& out) const override;

  // The surface, the same on every rank: surface vertex indices in the order of their input ids.
  size_t surface_vertices() const { return ids_.size(); }
  size_t surface_triangles() const { return triangles_.size(); }
  size_t surface_edges() const { return edges_.size(); }
  // Surface vertices whose positions this rank has at an evaluation: its own and the ghost layer.
  size_t known_vertices() const { return ghosts_.known_list.size(); }
  // Pairs within the activation distance at the last evaluation, on this rank.
  size_t active_pairs() const { return active_pairs_; }
  // This rank's pairs with lagged friction in the current step.
  size_t friction_pairs() const { return friction_.size(); }
  // The fixed region (k + 1 for the deck's k-th, as mesh.fixed) whose jump rejected this step, 0 if none.
  int rejecting_region() const { return rejecting_region_; }
  // This rank's candidate pairs, and how many times they were built (tests).
  size_t candidate_pairs() const { return candidates_.size(); }
  size_t candidate_builds() const { return builds_; }
  size_t step_bounds_from_list() const { return list_bounds_; }
  // A candidate list may serve until a surface vertex has moved this fraction of its margin.
  static constexpr double kMoveFraction = 0.4;
  // The margin's cap in activation distances d: with d far below the mesh's spacing (a body with a
  // narrow gap), half the mean edge listed 40 pairs per surface primitive of the bunny, none of
  // them near d, and cost 5x the time of a 1000 d cap (docs/self-contact.md#cost); every deck whose
  // d is above 1/2000 of the mean edge keeps half the mean edge.
  static constexpr double kMarginPerDistance = 1000;

 private:
  struct Pair {
    PairKind kind;
    int a, b;  // vertex and triangle, or edge and edge (surface indices)
  };
  std::array<int, 4> points(const Pair& p) const;
  Vector12d coordinates(const std::vector<double>& x, const std::array<int, 4>& q) const;
  // Which surface vertices' values this rank sends to and receives from each rank: it sends its
  // own send[send_offsets[r], send_offsets[r + 1]) to rank r and receives recv[recv_offsets[r], ...)
  // from rank r (surface indices, ascending); known: per surface vertex, whether this rank has its
  // values (its own or received).
  struct Exchange {
    std::vector<int> send, send_offsets, recv, recv_offsets;
    std::vector<char> known;
    std::vector<int> known_list;  // the known vertices, ascending
  };
  // The exchange of the (rank, own vertex) pairs sends and (rank, other's vertex) pairs receives.
  Exchange make_exchange(std::vector<std::pair<int, int>> sends, std::vector<std::pair<int, int>> receives) const;
  // The exchange of this rank's own vertices with the halo (the other vertices of its own edges
  // and triangles; needs no message to plan) and, for every rank whose region (the boxes of its
  // own vertices and edges at x, swept to end if given, grown by reach) overlaps one of this
  // rank's triangles or edges (at x, swept to end), that primitive's vertices, asked of their
  // owners (collective). Needs x (and end) at this rank's own vertices and halo.
  PetscErrorCode plan_exchange(const std::vector<double>& x, const std::vector<double>* end, double reach,
                               Exchange* plan) const;
  // Sends width values per vertex (values[width * s ...]) as the plan says: the owners' to the
  // ranks that know the vertex (collective).
  PetscErrorCode exchange(const Exchange& plan, int width, std::vector<double>& values) const;
  // The positions of this rank's surface vertices and ghost layer (x_) from the local positions
  // pos (collective).
  PetscErrorCode gather_positions(const std::vector<double>& pos) const;
  // The jump of the moving fixed vertices at the step's start (begin_step); sets step_at_ and
  // rejecting_region_ (collective).
  PetscErrorCode check_fixed_jump(const std::vector<double>& start_positions, const std::vector<double>& positions);
  // Calls visit(pair) for the pairs of this rank whose boxes overlap: the primitives' boxes at x
  // (edges and vertices inflated by reach), or, if end is not null, the boxes swept from x to end
  // (inflated by reach). Builds the box trees over the primitives whose vertices are all known
  // (known: per surface vertex; nullptr: all).
  template <class Visit>
  void broad_phase(const std::vector<double>& x, const std::vector<double>* end, double reach,
                   const std::vector<char>* known, Visit&& visit) const;
  // A primitive's box in broad_phase: its vertices at x and end (if given), inflated by inflate.
  Box primitive_box(std::initializer_list<int> vertices, const std::vector<double>& x, const std::vector<double>* end,
                    double inflate) const;
  // True if broad_phase(x, end, reach) visits the pair: the same boxes, the same test.
  bool boxes_meet(const Pair& p, const std::vector<double>& x, const std::vector<double>* end, double reach) const;
  // Builds the candidate pairs again at x_ (and the ghost layer for them) unless the list covers
  // x_ (collective: the ranks decide together from their own vertices' moves).
  PetscErrorCode refresh_candidates() const;
  // True if every surface vertex at x (and end, if given) is within kMoveFraction of the list's
  // margin of where the list was built (collective); moved_: how far each known vertex is (the
  // farther of x and end).
  PetscErrorCode candidates_cover(const std::vector<double>& x, const std::vector<double>* end, bool* covered) const;
  // A candidate: a pair and its distance less xi when the list was built.
  struct Candidate {
    Pair pair;
    double distance;
  };
  // False if the candidate's distance (less xi) at the build less its primitives' moves (moved_)
  // is d or more: it cannot be within d.
  bool may_be_within_d(const Candidate& c) const;
  // limit_step, from the candidate list when it covers the step and may_use_list.
  PetscErrorCode bound_step(Vec x, Vec dir, double* alpha, bool may_use_list) const;
  // The most a pair's distance can have changed since the build: its two primitives' largest moves
  // (moved_).
  double pair_moves(const Pair& p) const;
  // Calls visit(pair) for the candidates that may be within d at x_, in the candidates' order
  // (after refresh_candidates).
  template <class Visit>
  void near_pairs(Visit&& visit) const;
  // Calls visit(points, H) with the 12 x 12 Hessian at x_ of every near pair with energy (projected
  // to positive semidefinite if psd), then of every friction pair (semidefinite as it is), in that
  // order: what add_hessian assembles and add_vertex_stiffness takes the diagonal blocks of.
  template <class Visit>
  void pair_hessians(bool psd, Visit&& visit) const;
  double pair_energy(const Pair& p, const Vector12d& x, Vector12d* g, Matrix12d* H) const;
  // k of a pair (the mean lumped mass of its free points times the stiffness per mass; 0 if none
  // is free) and an edge pair's mollifier threshold (0 for a vertex and a triangle).
  double pair_stiffness(const std::array<int, 4>& q) const;
  double mollifier_eps(const Pair& p) const;
  // The pairs of this rank within d (of their xi) at the surface's positions x (known where
  // known is set), with their lagged friction, in the pairs' canonical order (begin_step).
  void freeze_friction(const std::vector<double>& x, const std::vector<char>& known);
  double squared_distance(const Pair& p, const std::vector<double>& x) const;
  // The pair's thickness offset xi: half the thickness of each primitive's body.
  double offset(const Pair& p) const;
  // The pairs within their xi at pos (distance 0 without thickness), over all ranks (collective).
  PetscErrorCode touching_pairs(const std::vector<double>& pos, long* count) const;
  // The smallest distance less xi at rest between two primitives of one body that share no vertex
  // (+inf: none within d), over all ranks; that pair's xi and the lowest input id of a vertex of
  // such a pair (collective).
  PetscErrorCode closest_rest_pair(double* gap, double* xi, int64_t* vertex_id) const;
  // The problem of a rest gap (closest_rest_pair) below d: d too large, or the thickness alone.
  void rest_gap_problem(double gap, double xi, int64_t vertex, InputProblem& out) const;
  // Surface triangles that cross at pos (geometry/triangle_intersection.hpp, with the tolerance of
  // the scene's bounding box there), over all ranks: the problem names the bodies of the first
  // such pair in the surface's order, how many pairs cross and where the first does (collective).
  PetscErrorCode check_intersections(const std::vector<double>& pos, InputProblem& out) const;
  // The surface triangle pairs that cross at pos, over all ranks: how many, the first in the
  // surface's order (the same at any rank count) and a point where it crosses (collective).
  struct Crossings {
    long count = 0;
    std::array<long, 2> first{-1, -1};
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
  };
  PetscErrorCode count_crossings(const std::vector<double>& pos, Crossings& out) const;
  // "N pairs of surface triangles in the scene cross (...); the first: ... near (x, y, z)".
  std::string crossings_sentence(const Crossings& c) const;
  // Adds a pair's gradient g into the sums per surface vertex (accumulated_, touched_) at its free points q.
  void accumulate(const std::array<int, 4>& q, const Vector12d& g) const;
  // Adds the gradient summed per surface vertex (accumulated_, at touched_) into the local array:
  // this rank's vertices directly, the others' sent to their owners (collective).
  PetscErrorCode exchange_gradient(PetscScalar* gradient) const;
  // Hands width values per surface vertex in vertices (sums[width * s ...]) to the vertex's owner:
  // there add(s, values) is called for this rank's own vertices first (in the surface's order),
  // then for those received, in the order of the sending ranks, so the owner's sums do not depend
  // on the order messages arrive in. Sorts vertices (collective).
  template <class Add>
  PetscErrorCode sum_at_owners(int width, const std::vector<double>& sums, std::vector<int>& vertices, Add&& add) const;

  const DistributedMesh& mesh_;
  ContactSpec spec_;
  bool barrier_ = false;
  PetscLogEvent event_, gather_event_, pairs_event_;
  // The surface (every rank): input ids, triangles and edges (surface vertex indices), rest
  // positions, global dof (-1: fixed), owning rank, lumped mass (free vertices), body per vertex,
  // fixed region per vertex (as mesh.fixed: 0 free); the bodies as the deck names them.
  std::vector<int64_t> ids_;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<std::array<int, 2>> edges_;
  std::vector<double> rest_;
  std::vector<PetscInt> dof_;
  std::vector<int> owner_;
  std::vector<double> mass_;
  std::vector<int32_t> body_;
  std::vector<SelfContactBody> bodies_;
  std::vector<double> half_thickness_;  // per surface vertex: half its body's cloth thickness
  double largest_offset_ = 0;           // the largest xi of any pair
  std::vector<int32_t> region_;
  // Per surface vertex, the first surface vertex of its body at its rest position (itself unless
  // spec_.joined_twins finds an earlier one): pairs whose primitives hold the same one share a vertex.
  std::vector<int> joined_;
  std::vector<int> fixed_lines_;
  // This rank's part: the local vertex of each surface vertex it owns (in the order it sends
  // them; local_of_ per surface vertex, -1 if another rank's), and the primitives whose pairs it
  // evaluates.
  std::vector<PetscInt> owned_local_, local_of_;
  std::vector<int> owned_surface_;
  std::vector<int> my_vertices_, my_edges_;
  // The gather of the surface's data at setup (set_masses): the surface vertex of each item received.
  std::vector<int> received_;
  // The triangles whose first vertex this rank owns; the halo: (rank, own vertex) it is sent to.
  std::vector<int> my_triangles_;
  std::vector<std::pair<int, int>> halo_;
  int tag_ = 0;                         // of the exchanges' messages
  mutable Exchange ghosts_;             // the evaluations' exchange, planned with the candidates
  mutable std::vector<double> x_;      // 3 per surface vertex: positions at the last exchange (known ones)
  std::vector<double> step_at_;        // 3 per surface vertex: where the step starts (its own fixed vertices' positions)
  int rejecting_region_ = 0;           // rejecting_region()
  // The candidate pairs (sorted), the positions they were built at, their margin; the margin the
  // current step asks for; stale: build at the next evaluation.
  mutable std::vector<Candidate> candidates_;
  mutable std::vector<double> built_at_, moved_;
  mutable double built_margin_ = 0;
  mutable double step_margin_ = 0;
  double mean_edge_ = 0;  // the surface's mean edge length at rest (caps the margin)
  bool quasi_static_ = false;  // this step's StepStart::quasi_static (bound_step's sweep cap)
  // The largest margin: half the surface's mean edge, and at most kMarginPerDistance d (at least d).
  double margin_cap() const { return std::max(spec_.distance, std::min(mean_edge_ / 2, kMarginPerDistance * spec_.distance)); }
  mutable bool stale_ = true;
  mutable size_t builds_ = 0;
  mutable size_t list_bounds_ = 0;
  // The gradient per surface vertex of this rank's pairs (3 each) and the vertices it touched.
  mutable std::vector<double> accumulated_;
  mutable std::vector<char> touched_;
  mutable std::vector<int> touched_list_;
  mutable std::vector<double> buffer_, out_, path_, end_;  // work
  mutable std::vector<MPI_Request> requests_;                // exchange's, kept between calls
  // This rank's pairs within d at x_n with their lagged friction (mu > 0), in the pairs' order;
  // friction_velocity times the step.
  std::vector<std::pair<Pair, PairFriction>> friction_;
  double eps_h_ = 0;
  mutable unsigned long long active_set_ = 0;
  mutable size_t active_pairs_ = 0;
};

}  // namespace hyperqn

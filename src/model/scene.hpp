// A scene built from its description: the input checked, the mesh distributed, the body with its
// energy terms, the integrator and (when a solver needs it) the factored M + h^2 L. Shared by the
// simulation and the study.
#pragma once
#include <algorithm>
#include <functional>
#include <array>
#include <map>
#include <set>
#include <memory>
#include <string>
#include <vector>

#include "io/partition_file.hpp"
#include "mesh/distributed_mesh.hpp"
#include "materials/fracture_spec.hpp"
#include "mesh/separation.hpp"
#include "model/scene_spec.hpp"
#include "model/body.hpp"
#include "model/step_objective.hpp"
#include "model/state.hpp"
#include "solvers/factored_system.hpp"
#include "solvers/solver_spec.hpp"
#include "mesh/mesh.hpp"
#include "model/memory_estimate.hpp"

namespace hyperqn {

// The deck's mesh as one serial mesh: read or generated, transformed, with its strands, cleaned
// (what was repaired in *repaired). Throws InputError. Rank 0's part of load_scene_mesh, and what
// `hyperqn partition` cuts.
TetMesh read_serial_mesh(const SceneSpec& deck, CleanReport* repaired = nullptr);

// What a partition file of the deck's bodies is stamped with (`hyperqn partition` writes it, a run
// with partition: checks it): their count and mesh_sources_hash of their meshes. Reads every
// body's mesh file as bytes; throws InputError.
BodiesStamp bodies_stamp(const SceneSpec& deck);

// Loads the deck's mesh on rank 0 (file or generated box), applies the transform and cleans it
// (what was repaired in *repaired, on rank 0). Throws InputError on every rank, also when a rank of
// the run would need more memory than it may take (model/memory_estimate.hpp; plan: what the
// run's solver factors, memory_plan in model/memory_estimate.hpp). Other ranks get an empty mesh.
TetMesh load_scene_mesh(MPI_Comm comm, const SceneSpec& deck, CleanReport* repaired = nullptr,
                        const MemoryPlan& plan = MemoryPlan());

// This rank's piece of the mesh (mesh/mesh_piece.hpp) with its fixed-vertex flags and material
// regions: no rank holds the whole mesh once it exists. Throws InputError on every rank if the
// input is wrong; nothing has been written at that point.
struct SceneInput {
  MeshPiece piece;
  std::vector<int32_t> fixed;          // per local vertex, see select_fixed_vertices
  std::vector<int32_t> held;           // 3 per local vertex, see select_held_components (empty: no rollers)
  bool rollers = false;                // a fixed region not released holds only some components (every rank alike)
  std::vector<int32_t> cell_material;  // per local tet, see select_material_regions
  std::vector<int32_t> vertex_body;    // per local vertex, see vertex_bodies (empty: one body)
  CleanReport repaired;                // what cleaning the mesh changed (rank 0)
};
SceneInput load_scene_input(MPI_Comm comm, const SceneSpec& deck, const MemoryPlan& plan = MemoryPlan());
// The same, but an input error is printed ("hyperqn: error: ...") and reported as false.
bool load_scene_input_or_report(MPI_Comm comm, const SceneSpec& deck, SceneInput& input,
                                const MemoryPlan& plan = MemoryPlan());

struct TetFaces;  // model/fracture.hpp

struct Scene {
  DistributedMesh mesh;
  std::unique_ptr<Body> body;
  std::unique_ptr<StepObjective> step;
  // The constant matrices the solvers use, by resolved_h0 (laplacian, rest_stiffness, amg, volumetric).
  std::map<H0, std::unique_ptr<FactoredSystem>> constant_matrices;
  // The Poisson ratio solver.h0: auto goes by (SceneOptions::poisson_ratio).
  double poisson_ratio = 0;
  // And the self-weight deflection scale (SceneOptions::held_weight times D^3 / w^2 of the rest
  // bounding box; 0: not a scene held still, or one with strands or a cloth).
  double weight_deflection = 0;
  // The factored constant matrix a solver with these settings uses (null if the scene has none).
  const FactoredSystem* constant_matrix(const SolverSpec& spec) const;
  // With fracture: its local tets' faces, paired when first asked (model/fracture.hpp).
  std::shared_ptr<TetFaces> fracture_faces;
};

// How to build a scene beside its description.
struct SceneOptions {
  std::vector<H0> h0s;                 // the solvers' constant matrices (solver_h0; automatic resolved at setup)
  // The scene's largest tet Poisson ratio, by which solver.h0: auto resolves (resolved_h0); 0 keeps
  // auto off the volumetric H0 (scene_options: with h0_contact: woodbury, which needs M + h^2 L).
  double poisson_ratio = 0;
  // For a scene held still (held_still_weight), |g| rho / E (1/m), else 0: solver.h0: auto takes
  // the rest stiffness when held_weight D^3 / w^2 (D the rest bounding box's diagonal, w its
  // smallest side) is below kRestStiffnessBelowDeflection (resolved_h0).
  double held_weight = 0;
  FactorPackage h0_package = default_factor_package();  // who factors them (-hyperqn_h0_package)
  H0Precision h0_precision = H0Precision::double_precision;  // their factors' values (solver.h0_precision)
  WarmStart warm_start = WarmStart::inertial;  // where each step's solve starts
  bool upright_guess = true;                   // and whether y is pulled back (StepObjective)
  double element_limit = 0;                    // past which |det F| it is pulled back (-hyperqn_element_limit)
  // Adds terms beyond the elastic ones (e.g. the guardrail tests' NaN injection).
  std::function<void(const DistributedMesh&, std::vector<std::unique_ptr<EnergyTerm>>&)> extra_terms;
};

// The scene of a run as time goes on. Fixed regions with a release time t (fixed[].release) become
// free at the start of the first step that starts at or after t: the scene is rebuilt from the kept serial input
// with those vertices free (same partition, so the same local vertices), the constant matrices
// are factored again, and the states carry over. Attachments with a release time
// (attachments[].release) go the same way: the scene is rebuilt without their springs (they are
// in M + h^2 L). Used by the simulation and the study alike.
class LiveScene {
 public:
  // Distributes the input (which it takes), assembles, and factors the constant matrices asked for.
  PetscErrorCode setup(MPI_Comm comm, const SceneSpec& spec, SceneInput input, SceneOptions options);
  Scene& current() { return *scene_; }
  // s at frame 0: rest positions, then the spec's initial state; zero velocity; nothing released.
  PetscErrorCode initial_state(State& s) const;
  // Whether a new run may start at s (EnergyTerm::check_start: e.g. no body inside an obstacle):
  // if not, *ok = false and the input error, naming the deck's file, line and key, is printed
  // ("hyperqn: error: ..."). Collective. A restart is not checked: it goes on from a state the
  // run reached.
  PetscErrorCode check_start(const State& s, bool* ok) const;
  PetscErrorCode load_acts_after_releases(const std::string& key, bool* acts) const;

  // Called before the step from main (frame n to n + 1, starting at t = n h). If a region or
  // attachment is due (release time <= t) that main has not released yet, the scene is rebuilt
  // with its vertices free or its springs gone, main and every state in others move to the new
  // scene (each vertex keeps its position and velocity; a freed vertex its prescribed position and
  // velocity at t, Body::prescribed_state; the integrator's history is dropped), and rebind(old, fresh) moves what refers
  // to the old scene (solvers, writers, counters) before the old scene goes. *released: it happened.
  using Rebind = std::function<PetscErrorCode(const Scene& old_scene, Scene& fresh)>;
  PetscErrorCode release_due(State& main, const std::vector<State*>& others, const Rebind& rebind, bool* released);
  // A restart: the scene as it was with these regions and attachments released (rebuilt if any
  // is), before anything refers to the scene.
  PetscErrorCode restore_released(const std::vector<char>& regions, const std::vector<char>& attachments);

  // Scripted cuts (spec.cuts, docs/topology.md). Called before the step from main, after
  // release_due: the interior faces whose dual edge a blade crossed over the step before, [t - h, t]
  // at main's positions x(t) (model/cuts.hpp), are separated by separate_due. Nothing happens, and
  // the topology log event is not begun, in a scene without cuts. *cut: it happened.
  PetscErrorCode cut_due(State& main, const std::vector<State*>& others, const Rebind& rebind, bool* cut);
  // Not empty once cut_due found that the blades with remove would take every tet of a scene of
  // tets alone (nothing would be left to simulate): why, for the run's stop. Nothing was changed.
  const std::string& nothing_left() const { return nothing_left_; }
  // Whatever decided them (blades, a fracture criterion): the interior faces `batch` (tet pairs,
  // sorted, none separated before) separate on the kept pieces at the start of main's frame
  // (mesh/separation.hpp), the scene is rebuilt on them and main and every state in others move to
  // it (a copy with its original's position and velocity), as for a release. Its constant matrix
  // follows by a TopologyH0 correction where it can (FactoredSystem::follow), else is factored
  // again. The caller has begun the topology log event.
  PetscErrorCode separate_due(const std::vector<TetPair>& batch, State& main, const std::vector<State*>& others,
                              const Rebind& rebind);
  // Every face separated so far, in order: (the frame at whose start, the face's two tet numbers);
  // a tet t removed (a blade with remove, docs/removal.md) is (the frame, t, t).
  using SeparatedFace = std::array<int64_t, 3>;
  const std::vector<SeparatedFace>& cut_history() const { return history_; }
  // The faces of each batch of cut_history, in order (a frame may have several: fracture's re-solves).
  const std::vector<int64_t>& cut_batches() const { return batch_sizes_; }
  // Re-solves (material.fracture.resolve, docs/topology.md#fracture; cloth.tear.resolve and
  // strand_material.snap.resolve, docs/snapping.md): called after main's step to frame n + 1 has
  // ended, the faces its converged state breaks, the segment it snaps and the edge it tears (none
  // once the step has been solved again that many times), which the caller separates (separate_due,
  // break_due, at the step's start) before it solves the step again. Collective.
  int resolves() const { return std::max({fracture_resolve_, tear_resolve_, snap_resolve_}); }
  PetscErrorCode resolve_breaks(const State& main, std::vector<TetPair>& batch, std::vector<int64_t>& segments,
                                std::vector<std::array<int64_t, 2>>& edges);
  // The strand segments `segments` snap and the cloth edges `edges` tear at main's positions (one
  // break batch, as snap_due's), the scene rebuilt and the states carried. The caller has begun the
  // topology log event. Collective.
  PetscErrorCode break_due(const std::vector<int64_t>& segments, const std::vector<std::array<int64_t, 2>>& edges,
                           State& main, const std::vector<State*>& others, const Rebind& rebind);
  // The re-solves of the step after frame `frame` so far (a checkpoint of `frame` whose next frame
  // a signal gave up after re-solves: header key cuts_resolved); restore_resolved sets them.
  int resolved_after(int64_t frame) const { return resolved_.first == frame ? resolved_.second : 0; }
  void restore_resolved(int64_t frame, int count) { resolved_ = {frame, count}; }
  // Whether cut_due and snap_due have run for the step after frame `frame` (TimeLoop asks before
  // each step): a checkpoint of `frame` that a signal wrote in the next frame holds their changes,
  // which its restart replays and must not decide again (a snap or a tear would take the next
  // segment or edge: header key changes_decided).
  bool changes_decided_after(int64_t frame) const { return decided_after_ == frame; }
  void decide_changes_after(int64_t frame) { decided_after_ = frame; }
  // Totals so far: faces separated, vertices added, batches (each a rebuild of the scene; a
  // restart's replay included); of this run's batches (not replayed), those whose constant matrix
  // followed by a correction and those that factored it again.
  // Of this run's faces, those a fracture criterion broke (not a blade), and the frame of the first
  // such batch (-1: none), for a deck with both.
  struct CutCounts {
    long long faces = 0, vertices = 0, batches = 0;
    long long removed = 0;  // tets removed by blades with remove (docs/removal.md)
    long long corrections = 0, refactorizations = 0;
    long long broken = 0, first_broken = -1;
  };
  const CutCounts& cut_counts() const { return counts_; }
  // A material of the scene has a fracture criterion (material.fracture): its overloaded faces
  // separate in cut_due, after the scripted cuts' (model/fracture.hpp).
  bool fracture() const { return !fracture_.empty(); }
  // The last change of the scene was a cut (not a release): for messages.
  bool last_change_cut() const { return last_change_cut_; }
  // The last change in words, for the console of a run and of a study: what changed (a release, a
  // cut or fracture, snaps, tears, with the totals so far), the free dofs now (`dofs`), and whether
  // the constant matrix followed by a correction or was factored again.
  std::string last_change(long long dofs) const;
  bool last_cut_corrected() const { return last_cut_corrected_; }  // the last cut or break: its H0 followed by a correction
  // The batches separated in the scene whose constant matrix was last factored (a checkpoint's
  // cuts_factored).
  long long factored_batches() const { return factored_batches_; }

  // Snapping strands (strand_material.snap) and tearing cloth (cloth.tear), docs/snapping.md. Called
  // before the step from main, after cut_due: the segment most stretched past its snapping strain
  // and the interior cloth edge most stretched past its tearing strain at main's positions x(t)
  // (model/tearing.hpp) come apart on the kept pieces (mesh/strand_separation.hpp,
  // mesh/cloth_separation.hpp), and the scene is rebuilt as for a cut. Nothing happens, and the
  // topology log event is not begun, in a scene that neither snaps nor tears. *snapped: it happened.
  PetscErrorCode snap_due(State& main, const std::vector<State*>& others, const Rebind& rebind, bool* snapped);
  // Every break so far, in order: (the frame at whose start, kind, element): kind 0, a strand
  // segment snapped (the element is its segment number); kind 1, a cloth edge torn (the element is
  // its two triangles' numbers t1 < t2 as t1 * 2^32 + t2). In a frame, snaps come before tears.
  using Break = std::array<int64_t, 3>;
  const std::vector<Break>& break_history() const { return breaks_; }
  // The breaks of each batch of break_history, in order (a frame may have two: a blade's and a tear's).
  const std::vector<int64_t>& break_batches() const { return break_batch_sizes_; }
  // A restart: the checkpoint's cuts and breaks replayed on the kept pieces, batch by batch in the
  // order the run made them (so the same vertex numbers): by frame, and in a frame the cuts' batches
  // before the breaks' (cut_due separates tets, then breaks a cloth's or strands' edges, then
  // snap_due). Before restore_released, which then rebuilds. The batches after the first
  // `cuts_factored` and `breaks_factored` (those the run followed by corrections, -1: none; every
  // factorization counts both, so they are the run's last batches) are kept for restore_released,
  // which replays them as the run did: the scene rebuilt after each, its constant matrix corrected,
  // so the restart starts from the run's operator bit for bit. cut_batches, break_batches: the
  // size of each batch (empty: a batch per frame, as checkpoints before them).
  PetscErrorCode restore_changes(const std::vector<SeparatedFace>& cuts, long long cuts_factored,
                                 const std::vector<int64_t>& cut_batches, const std::vector<Break>& breaks,
                                 long long breaks_factored, const std::vector<int64_t>& break_batches);
  // Totals so far (a restart's replay included): segments snapped, cloth edges torn, vertices added,
  // batches (each one rebuild of the scene); of this run's batches (not replayed), those whose
  // constant matrix followed by a TopologyH0 correction and those that factored it again.
  struct BreakCounts {
    long long segments = 0, edges = 0, vertices = 0, batches = 0;
    long long corrections = 0, refactorizations = 0;
  };
  const BreakCounts& break_counts() const { return break_counts_; }
  // Strand segments of the scene may snap (strand_material.snap) or cloth edges tear (cloth.tear),
  // or blades cut a cloth or strands (cuts on a mesh with them: its edges separate as torn ones and
  // its segments as snapped ones, and count so).
  bool breaks() const { return !snap_strains_.empty() || !tear_strains_.empty() || cuts_cloth_ || cuts_strands_; }
  // The last change of the scene was a break: for messages.
  bool last_change_break() const { return last_change_break_; }
  // The break batches in the scene whose constant matrix was last factored (a checkpoint's
  // breaks_factored).
  long long factored_breaks() const { return factored_breaks_; }

 private:
  // The scene without the attachments marked in released_attachments. before (a cut): the scene it
  // replaces, whose constant matrix it follows where it can (*corrected: it did).
  PetscErrorCode build(SceneInput input, const std::vector<char>& released_attachments, Scene& s,
                       Scene* before = nullptr, bool* corrected = nullptr) const;
  // The scene rebuilt from the kept input with these regions free and attachments gone.
  PetscErrorCode rebuild(const std::vector<char>& regions, const std::vector<char>& attachments,
                         std::unique_ptr<Scene>& fresh, Scene* before = nullptr, bool* corrected = nullptr) const;

  // One batch of faces separated at the start of `frame` on kept_ (history and counts follow); the
  // source of each local vertex after it and, with an opening, its move (mesh/separation.hpp).
  SeparationResult separate(int64_t frame, const std::vector<TetPair>& batch, const CrackOpening& opening = {});
  // `faces` of a batch at the start of `frame` broken by the fracture criterion (counts_.broken).
  void note_broken(int64_t frame, long long faces);
  // One batch of segments snapped, then of cloth edges torn (pairs of triangle numbers), at the start
  // of `frame` on kept_, as separate; with self-contact the torn edges open by tear_opening_
  // (mesh/cloth_separation.hpp), at `positions` (3 per local vertex before the batch) if given.
  SeparationResult snap(int64_t frame, const std::vector<int64_t>& batch, const std::vector<std::array<int64_t, 2>>& edges,
                        const std::vector<double>* positions = nullptr);
  // Snaps `segments` and separates `edges` (snap) at main's positions `pos` (this rank's local
  // vertices; opened with self-contact), rebuilds the scene and carries the states: a break, or a
  // blade's cut through a cloth (by_blade: for messages). Collective.
  PetscErrorCode break_apart(const std::vector<int64_t>& segments, const std::vector<std::array<int64_t, 2>>& edges,
                             std::vector<double>& pos, State& main, const std::vector<State*>& others, const Rebind& rebind,
                             bool by_blade);
  // A batch of breaks (one frame's) as its snapped segments and torn edges, for snap.
  static void split_breaks(const std::vector<Break>& batch, std::vector<int64_t>& segments,
                           std::vector<std::array<int64_t, 2>>& edges);
  // main and others (at time t) moved to the scene rebuilt on the changed kept_ (source: the local
  // vertex of the current scene whose state each local vertex takes); *corrected: its constant
  // matrix followed the change by a TopologyH0 correction (else it was factored again). shift:
  // 3 per local vertex, added to each state's positions (a crack opened), or empty. inherited:
  // the new elements that carry on old ones' history (SeparationResult::inherited).
  PetscErrorCode move_to_rebuilt(State& main, const std::vector<State*>& others, const Rebind& rebind, double t,
                                 const std::vector<int32_t>& source, bool* corrected,
                                 const std::vector<double>& shift = {},
                                 const std::vector<std::array<int64_t, 2>>& inherited = {});

  MPI_Comm comm_ = MPI_COMM_NULL;
  const SceneSpec* spec_ = nullptr;
  std::vector<SeparatedFace> history_;
  std::vector<int64_t> batch_sizes_;  // of history_'s batches
  int fracture_resolve_ = 0;          // the largest material.fracture.resolve
  int tear_resolve_ = 0;              // the largest cloth.tear.resolve
  int snap_resolve_ = 0;              // the largest strand_material.snap.resolve
  std::pair<int64_t, int> resolved_{-1, 0};  // (frame n, the step to n + 1's re-solves so far)
  int64_t decided_after_ = -1;               // changes_decided_after
  std::set<TetPair> separated_;
  std::vector<FractureSpec> fracture_;  // per material (model/fracture.hpp); empty: no fracture
  std::shared_ptr<const std::vector<int64_t>> original_boundary_;  // the input's boundary faces (DistributedMesh::original_boundary)
  int64_t id_offset_ = 0;  // a copy's vertex id minus its vertex number (ids after the input's)
  CutCounts counts_;
  std::string nothing_left_;  // cut_due's
  bool kept_changed_ = false;  // restore_changes changed kept_: restore_released rebuilds
  bool last_change_cut_ = false, last_cut_corrected_ = false;
  bool last_change_factored_ = false;  // the last change's scene factored a constant matrix anew (not with newton)
  long long factored_batches_ = 0;
  // restore_changes' batches for restore_released, in the run's order: a cut batch's faces or a break batch.
  struct Replay {
    int64_t frame = 0;
    std::vector<TetPair> faces;
    std::vector<std::array<int64_t, 3>> breaks;
  };
  std::vector<Replay> replay_;
  void replay(const Replay& r);  // one batch on the kept pieces, as the run made it
  // In a deck with cuts, fracture, snapping strands or tearing cloth, -hyperqn_topology_h0 (default
  // true: constant matrices follow cuts and breaks by corrections where they can; false: factored
  // again at every change) and its test hooks (TopologyCheck). Without them false: no TopologyH0
  // holds a factor.
  bool follow_cuts_ = false;
  TopologyCheck topology_check_;
  double opening_width_ = 0;  // with self-contact, how far a fresh crack opens (CrackOpening); else 0
  double tear_opening_ = 0;   // with self-contact, how far a torn cloth edge opens: d + the thickest cloth's thickness
  std::vector<double> snap_strains_;  // per segment tag (model/tearing.hpp); empty: nothing snaps
  std::vector<Break> breaks_;
  std::set<int64_t> snapped_;
  std::vector<double> tear_strains_;  // per body (model/tearing.hpp); empty: no cloth tears
  std::set<std::array<int64_t, 2>> torn_;
  BreakCounts break_counts_;
  bool last_change_break_ = false;
  bool last_break_by_blade_ = false;  // the last break was a blade's cut through a cloth or strands (messages)
  bool cuts_cloth_ = false;           // the deck's blades cut a cloth (cloth_edges_crossed)
  bool cuts_strands_ = false;         // the deck's blades cut strands (segments_crossed)
  long long factored_breaks_ = 0;
  std::vector<int64_t> break_batch_sizes_;  // break_batches
  SceneOptions options_;
  SceneInput kept_;  // this rank's input, if a region is released later
  std::unique_ptr<Scene> scene_;
};

}  // namespace hyperqn

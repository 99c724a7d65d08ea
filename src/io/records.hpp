// The records of a run: one per solver iteration (iterations.csv, the study's curves) and the
// run's summary (summary.json). Plain data: solvers produce them, writers write them.
#pragma once
#include <petscsys.h>

#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace hyperqn {

struct IterationRecord {
  PetscInt iteration = 0;    // 0 = the initial guess
  double time_s = 0;         // wall time since this frame's solve started
  double energy = 0;         // g(x_k)
  double grad_norm = 0;      // ||grad g(x_k)||_2 over the free dofs
  double step = 0;           // line-search step length that produced x_k (0 at iteration 0)
  PetscInt evaluations = 0;  // g / grad g evaluations so far in this frame
};

// A support's reaction in summary.json (deck output.reactions; model/reactions.hpp): the last
// frame's force, moment and moment point, and the largest |force| of any frame with that frame.
struct SupportReaction {
  std::string name;
  int line = 0;  // deck line
  std::array<double, 3> force{0, 0, 0}, moment{0, 0, 0}, point{0, 0, 0};
  double max_force = 0;
  long long max_force_frame = 0;
};

// The reason a frame is flagged with when no stage of the fallback chain made it acceptable
// (docs/guardrails.md#fallback); the status then says so.
inline constexpr const char* kFarFromConverged = "far from converged after the fallback chain";

struct RunSummary {
  std::string deck, solver;
  // The run's id (io/checkpoint_store.hpp): which run wrote this directory; a restart keeps it.
  std::string run_id;
  // "ok"; "flagged: N of M frames could not decrease g[ or stayed far from converged] (first: frame K)"
  // (completed, exit 0); or
  // "error: ..." (the run stopped, exit 1).
  std::string status = "ok";
  // The stop signal the run received (SIGTERM or SIGUSR1), "" if none: a run that completed
  // although one arrived says so, since an mpiexec that got SIGTERM exits 1 regardless.
  std::string signal;
  int ranks = 0;
  long long vertices = 0, tets = 0, segments = 0, triangles = 0, dofs = 0, fixed_vertices = 0;
  // The mesh as read was repaired: vertices of no element dropped, tets reoriented to positive volume.
  long long dropped_vertices = 0, reoriented_tets = 0;
  long long hessian_assemblies = 0;  // newton: one M + h^2 K(x) assembly and factorization each
  int frames = 0, factorizations = 0;
  std::string h0_package;  // who factored the constant matrices (-hyperqn_h0_package); "" if none
  double h0_factor_nonzeros = 0;  // entries of that factor (the benchmark's streaming bound)
  long long h0_interface = 0;     // rows of the split factor's dense interface block (0: not split)
  double dt = 0;
  double setup_s = 0, assembly_s = 0, factor_s = 0, solve_s = 0, wall_s = 0;
  double ms_per_frame = 0, ms_per_iteration = 0, mean_iterations = 0;
  long long iterations = 0, evaluations = 0, h0_solves = 0;
  double objective_s = 0, h0_solve_s = 0;     // time in g / grad g evaluations and in A^{-1} solves
  double hessian_s = 0;                       // newton: time assembling M + h^2 K
  long long converged_frames = 0, failed_frames = 0;
  // Guardrails: line searches that failed (each followed by a retry), evaluations rejected for a
  // non-finite g or grad g, and the frames that could not decrease g, stayed far from converged
  // after the fallback chain (kFarFromConverged) or stopped the run, with the reason.
  long long ls_failures = 0, rejected_evaluations = 0;
  // Steps whose initial guess was pulled back from y so as not to invert or blow up elements
  // (StepObjective::upright_guess; the frame-size steps, not the fallback chain's sub-steps).
  long long pulled_back_guesses = 0;
  long long euler_completed_steps = 0;  // midpoint steps ended by implicit Euler (StepObjective::complete_by_euler)
  std::vector<std::pair<int, std::string>> flagged_frames;
  // The fallback chain (model/fallback_chain.hpp): frames that iterated past the budget, that
  // were solved in sub-steps, and by Newton.
  long long extended_frames = 0, substepped_frames = 0, newton_frames = 0;
  long long kept_substep_frames = 0;  // of substepped_frames, those started at the frames before's size
  // Solved frames with an inverted or flat element (det F <= 0); the status says so (docs/guardrails.md).
  std::vector<int> inverted_frames;
  // Contact (scenes with colliders): the deepest penetration of any vertex into any collider at
  // the end of any frame, the most vertices within the activation distance at the end of a frame,
  // and the time and count of contact evaluations (0 without colliders: no contact code ran).
  double max_penetration = 0, contact_s = 0;
  long long max_active_contacts = 0, contact_evaluations = 0;
  // Frames at whose end a moving collider held a vertex deeper than the contact model lets it be
  // (it pushed into the body faster than contact pushed back), the first of them and what was said.
  long long collider_intrusions = 0, first_intrusion_frame = 0;
  std::string first_intrusion;
  // Penalty self-contact (terms/self_contact.hpp, report): the most surface triangle pairs that
  // cross at the end of a frame, the frames that end with any, the first of them and what was said.
  long long max_self_crossings = 0, self_crossing_frames = 0, first_self_crossing_frame = 0;
  std::string first_self_crossing;
  double final_energy = 0, final_grad_norm = 0, min_J = 0;
  // What the iteration budget left undone (docs/method.md#what-the-budget-gives-up): the largest
  // ||grad g|| / S at the end of a frame (StepSolve::residual, S the frame's force scale) and that
  // frame; and, in a free scene (free_scene in model/scene_spec.hpp), whose linear momentum the
  // time step conserves, the momentum P_0 = sum m v at frame 0, the largest |P_n - P_0| at the end
  // of a frame (NaN: unknown, a restart from a checkpoint that did not hold P_0) and that frame,
  // and the largest sum m |v| of a frame, its scale.
  double max_residual = 0;
  long long max_residual_frame = 0;
  bool free_scene = false;
  std::array<double, 3> momentum0{0, 0, 0};
  double momentum_drift = 0, momentum_scale = 0;
  long long momentum_drift_frame = 0;
  std::vector<SupportReaction> reactions;  // output.reactions only (empty: none, and no entry in summary.json)
  // The energy the materials with history dissipated since the run began (J; NaN: a scene without
  // them, and no entry in summary.json), by every element, those a topology change took away
  // included: dissipated_removed is theirs (kept in the checkpoint).
  double dissipated_energy = std::nan("");
  // viscoelastic_prony's tets: the largest strain |E| its updates saw (NaN: a scene without them,
  // and no entry in summary.json). Its dissipation and stored energy are small-strain measures,
  // not the energy lost past a few percent (docs/viscoelastic-prony.md#dissipation-and-energy).
  double small_strain_reach = std::nan("");
  double dissipated_removed = 0;
  // Scripted cuts (deck cuts:; summary.json's "cuts" only with them): faces separated, vertices
  // added (a restart's replay included), the steps with separations whose H0 followed by a
  // TopologyH0 correction and those that factored M + h^2 L again (docs/topology.md), and the time
  // in the topology log event (finding, separating, rebuilding; a restart's replay included).
  bool cuts = false;
  long long faces_separated = 0, cut_vertices = 0, cut_h0_corrections = 0, cut_refactorizations = 0;
  long long tets_removed = 0;  // by blades with remove (docs/removal.md; a restart's replay included)
  // Fracture (material.fracture; summary.json's "fracture" only with it): the same counts (faces
  // broken, vertices added, H0 corrections and refactorizations), and the frame at whose start faces first broke (-1: none).
  bool fracture = false;
  long long first_break_frame = -1;
  long long faces_broken = 0;  // of faces_separated, those the criterion broke (the others: blades')
  double topology_s = 0;
  // Breaks (strand_material.snap, cloth.tear; summary.json's "breaks" only with them): segments snapped, edges torn,
  // vertices added (a restart's replay included), the batches (each a rebuild) whose H0 followed by
  // a TopologyH0 correction and those that factored it again (as for cuts); topology_s as for cuts.
  bool breaks = false;
  long long segments_snapped = 0, edges_torn = 0, break_vertices = 0, break_h0_corrections = 0, break_refactorizations = 0;
  double peak_rss_mb = 0, peak_rss_mb_total = 0;  // max over ranks, sum over ranks
  std::vector<double> peak_rss_mb_by_rank;        // each rank's, in rank order (docs/guardrails.md#memory)
};

}  // namespace hyperqn

#include "app/simulation.hpp"

#include <algorithm>
#include <petscdmplex.h>

#include <csignal>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <type_traits>

#include "app/deck_config.hpp"
#include "app/petsc_errors.hpp"
#include "app/run_checkpoints.hpp"
#include "app/run_observers.hpp"
#include "app/time_loop.hpp"
#include "io/log_events.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/output_directory.hpp"
#include "model/fallback_chain.hpp"
#include "model/scene.hpp"
#include "model/tearing.hpp"
#include "solvers/solver_registry.hpp"
#include "io/vtk_writer.hpp"
#include "io/xdmf_writer.hpp"
#include "io/console.hpp"
#include "mesh/input_error.hpp"
#include "parallel/collectives.hpp"

namespace hyperqn {

namespace {

// summary.json's status of a run that completed: "ok"; "inverted: ..." if it ends with inverted
// or flat elements (inverted_at_end) or, from a start without any, had some in a frame; then how
// many frames were flagged.
std::string completed_status(const RunSummary& summary, bool started_inverted, bool inverted_at_end) {
  std::string status;
  const auto& inverted = summary.inverted_frames;
  if (inverted_at_end || (!started_inverted && !inverted.empty())) {
    char min_J[40];
    std::snprintf(min_J, sizeof min_J, "%.4g", summary.min_J);
    status = "inverted: elements with det F <= 0 in " + std::to_string(inverted.size()) + " of " +
             std::to_string(summary.frames) + " frames (first: frame " + std::to_string(inverted.front()) +
             (inverted_at_end ? ", and the last" : "") + "; min det F " + min_J + ")";
  }
  const auto& flagged = summary.flagged_frames;
  const bool far = std::any_of(flagged.begin(), flagged.end(),
                               [](const auto& f) { return f.second.rfind(kFarFromConverged, 0) == 0; });
  if (!flagged.empty())
    status += (status.empty() ? "" : "; ") + std::string("flagged: ") + std::to_string(flagged.size()) + " of " +
              std::to_string(summary.frames) + " frames could not decrease g" +
              (far ? " or stayed far from converged" : "") + " (first: frame " + std::to_string(flagged.front().first) + ")";
  return status.empty() ? "ok" : status;
}

// What summary.json says of the changes of topology and the mesh they made: the scene's as the
// last frame that stood left it (a frame that began with a cut and then could not stand is not
// written, nor in topology.csv: docs/outputs.md).
struct SceneTotals {
  LiveScene::CutCounts cuts;
  LiveScene::BreakCounts breaks;
  long long vertices = 0, tets = 0, segments = 0, triangles = 0, dofs = 0;  // the mesh's
};

static SceneTotals scene_totals(LiveScene& scene) {
  const DistributedMesh& m = scene.current().mesh;
  return {scene.cut_counts(), scene.break_counts(), m.global_vertices, m.global_cells, m.global_segments,
          m.global_triangles, m.global_dofs};
}

// Takes the totals at the loop's start and after each frame that stands (the last observer: an
// earlier one may find the frame cannot stand).
class AcceptedTotals : public FrameObserver {
 public:
  AcceptedTotals(LiveScene& scene, std::optional<SceneTotals>& out) : scene_(scene), out_(out) {}
  PetscErrorCode begin(LoopControl&) override {
    out_ = scene_totals(scene_);
    return 0;
  }
  PetscErrorCode after_frame(const FrameOutcome&, LoopControl& control) override {
    if (control.stop.empty()) out_ = scene_totals(scene_);
    return 0;
  }

 private:
  LiveScene& scene_;
  std::optional<SceneTotals>& out_;
};

// Everything one simulation run holds while its frames are computed. What it does with a frame
// is its observers' (app/run_observers.hpp, app/run_checkpoints.hpp) of one TimeLoop.
struct Run {
  MPI_Comm comm;
  const Deck& deck;
  RunOptions options;
  LiveScene scene;
  State state;
  std::unique_ptr<TimeStepSolver> solver;
  std::unique_ptr<FallbackChain> chain;  // around solver
  RunSummary summary;
  RunContext context{comm, deck, scene, state, summary};
  RunLogs logs{context};
  FrameWriters frames;

  // Checkpoints and restart (io/checkpoint_store.hpp).
  double t_start = 0;
  std::unique_ptr<CheckpointStore> checkpoints;  // OUTDIR/checkpoints
  CheckpointHeader identity;         // whose run and what scene: run id, physics, mesh, vertex counts
  const CheckpointHeader* restart = nullptr;  // the checkpoint this run continues, if any
  std::string restart_path;
  RunSummary earlier;                // the work (times, factorizations) before the restart
  bool interrupted = false;          // stopped by a signal with a checkpoint (kExitInterrupted)
  std::optional<SceneTotals> accepted;  // the scene's totals at the last frame that stood (AcceptedTotals)

  Run(MPI_Comm c, const Deck& d, const RunOptions& o, bool restarted)
      : comm(c), deck(d), options(o), frames(context, restarted) {}

  // After a release (see LiveScene::release_due): the solver moves to the new scene (the
  // observers follow: FrameObserver::scene_changed).
  PetscErrorCode rebind(const Scene&, Scene& fresh) {
    PetscFunctionBeginUser;
    chain.reset();  // they refer to the old scene
    solver.reset();
    PetscCall(create_solver(deck.solver, *fresh.step, fresh.constant_matrix(deck.solver), solver));
    chain = std::make_unique<FallbackChain>(fresh, deck.solver, *solver, options.element_limit);
    PetscFunctionReturn(0);
  }

  PetscErrorCode time_loop(bool& ok);
};

}  // namespace

// The frames; ok = false (with summary.status set) if the run cannot continue. A frame that
// leaves no finite state (rejected g at every point tried, non-finite positions), a diverged one
// (RunOptions::divergence_limit) or one that cannot be written stops the run: the last good
// frame is written (even if it is not an output frame) and nothing non-finite ever is.
PetscErrorCode Run::time_loop(bool& ok) {
  PetscFunctionBeginUser;
  ok = true;
  bool resumed_inverted = false;
  if (restart) {  // frames up to the checkpoint's were done before
    PetscCall(resume_state(comm, restart_path, *restart, scene.current(), state));
    restore_frame_counters(summary, restart->summary);
    earlier = restart->summary;  // its work counters are added at the end
    resumed_inverted = restart->started_inverted != 0;
  } else {  // the state is the scene's initial state, checked before any output (run_simulation)
    summary.min_J = HUGE_VAL;
  }
  // A run that the deck starts inverted (initial:) is judged by its last frame only.
  double min_J = 0, max_abs_J = 0;
  PetscCall(scene.current().body->volume_ratios(state.x, &min_J, &max_abs_J));
  const bool started_inverted = restart ? resumed_inverted : degenerate(min_J);

  ProgressLog progress(context, degenerate(min_J), options.progress_seconds);
  Checkpointer checkpointer(context, {options, identity, *checkpoints, frames, logs, started_inverted, t_start, earlier,
                                      restart != nullptr});
  // Every iteration of every stage of the chain, as it comes: progress lines of a slow frame, the
  // signal test hook.
  const IterationWatch watch = [&](const IterationRecord& r) {
    progress.watch(r);
    checkpointer.watch(r);
  };
  TimeLoop loop(
      scene, Guardrails::of(options, scene.current(), deck), state,
      [this, &watch](State& st, const IterationCallback& cb, StepSolve& out) {
        return chain->solve_frame(st, cb, out, watch);
      },
      [this](const Scene& o, Scene& f) { return rebind(o, f); });
  // In this order: the console line and counters, the logs (flushed before a checkpoint), the
  // frames (a frame that cannot be written stops the run), then checkpoints and signals.
  loop.observe(progress);
  loop.observe(logs);
  loop.observe(frames);
  loop.observe(checkpointer);
  AcceptedTotals accepted_totals(scene, accepted);
  loop.observe(accepted_totals);
  PetscCall(loop.run(deck.time.frames));
  interrupted = checkpointer.interrupted();
  if (!loop.stop().empty()) {
    summary.status = "error: frame " + std::to_string(loop.stop_frame()) + ": " + loop.stop() +
                     "; stopped, the last frame written is " + std::to_string(frames.last_written());
    ok = false;
  } else if (!interrupted) {
    summary.status = completed_status(summary, started_inverted, progress.inverted_now());
  }
  PetscFunctionReturn(0);
}

// What identifies the scene in a checkpoint, as far as the input tells: the deck's physics
// sections and the mesh, by the sums of its elements' hashes over every rank's piece (the same at
// any rank count, piece_hash_sums).
static CheckpointHeader scene_identity(MPI_Comm comm, const Deck& deck, const SceneInput& input) {
  CheckpointHeader id;
  id.physics = physics_fingerprint(deck.physics);
  std::array<uint64_t, 2> sums = piece_hash_sums(input.piece);
  MPI_Allreduce(MPI_IN_PLACE, sums.data(), 2, MPI_UINT64_T, MPI_SUM, comm);  // wraps modulo 2^64
  char hex[33];
  std::snprintf(hex, sizeof hex, "%016llx%016llx", (unsigned long long)sums[0], (unsigned long long)sums[1]);
  id.mesh_hash = hex;
  return id;
}

// The index file of the series the deck's format writes to: under the name that series started
// with when the checkpoint carries it (a restart whose deck changed its name and its format).
static std::string deck_format_index(const Deck& deck, const CheckpointHeader* saved, const std::string& outdir) {
  const bool vtu = deck.output.format == OutputFormat::vtu;
  std::string name = deck.name;
  if (saved)
    for (const auto& [key, value] : saved->writers)
      if (key == (vtu ? VtkSeries::kRestartKey : XdmfSeries::kRestartKey)) {
        const std::string started_as = vtu ? VtkSeries::series_name(value) : XdmfSeries::series_name(value);
        if (!started_as.empty()) name = started_as;
      }
  return outdir + "/" + name + (vtu ? ".pvd" : ".xdmf");
}

// The frame series of a run: VTK (output.format vtu) or XDMF, if the deck asks for frames
// (output.vtk). A restart (saved: its checkpoint) continues the series the run started, under the
// name it started with, cut back to the checkpoint's frame; a series the deck no longer asks for
// (frames off, or the other format) is still cut back, so that its index never lists the
// abandoned frames, and kept for later checkpoints (FrameWriters::kept_series). Collective.
template <typename Series>
static void add_series(MPI_Comm comm, const Deck& deck, const char* format, const std::string& outdir,
                       const CheckpointHeader* saved, const DistributedMesh& mesh, FrameWriters& frames) {
  const std::string* state = nullptr;
  if (saved)
    for (const auto& [key, value] : saved->writers)
      if (key == Series::kRestartKey) state = &value;
  const std::string started_as = state ? Series::series_name(*state) : "";
  const std::string name = started_as.empty() ? deck.name : started_as;
  const std::string& deck_format = kOutputFormatNames[size_t(deck.output.format)];
  const bool wanted = deck.output.vtk && deck_format == format;
  if (saved && !state) {  // a series of this format here began after the checkpoint: it goes
    std::string error;
    int rank;
    MPI_Comm_rank(comm, &rank);
    if (rank == 0) try {
        if (const int removed = remove_series_begun_later(outdir, format))
          PetscPrintf(PETSC_COMM_SELF, "hyperqn: %d file(s) of a %s series begun after the checkpoint removed\n", removed, format);
      } catch (const std::exception& e) {
        error = e.what();
      }
    throw_if_any_failed(comm, error);
  }
  if (!wanted && started_as.empty()) return;
  std::unique_ptr<Series> series;
  if constexpr (std::is_same_v<Series, VtkSeries>)
    series = std::make_unique<Series>(comm, outdir, name, deck.output.vtu_encoding == VtuEncoding::raw);
  else
    series = std::make_unique<Series>(comm, outdir, name);
  std::string error;
  try {
    series->begin_run(mesh);
    if (state) series->resume(*state, saved->frame);
  } catch (const std::exception& e) {
    error = e.what();
  }
  throw_if_any_failed(comm, error);
  if (state) {
    const std::string kept_name = name + (format == std::string("vtu") ? ".pvd" : ".xdmf");
    const std::string kept = outdir + "/" + kept_name;
    if (!deck.output.vtk)
      PetscPrintf(comm, "hyperqn: output.vtk is false: %s stays as it was at frame %d\n", kept.c_str(), saved->frame);
    else if (!wanted)
      PetscPrintf(comm, "hyperqn: output.format is now %s: %s stays as it was at frame %d; later frames go to %s\n",
                  deck_format.c_str(), kept.c_str(), saved->frame, deck_format_index(deck, saved, outdir).c_str());
    else if (name != deck.name)
      PetscPrintf(comm, "hyperqn: the %s series goes on as %s, the name it started with (the deck now says %s)\n", format,
                  kept_name.c_str(), deck.name.c_str());
  }
  if (wanted)
    frames.writers().push_back(std::move(series));
  else
    frames.kept_series().emplace_back(series->restart_key(), series->restart_state());
}

// The checkpoint a restart continues from (restart: a path, "latest" or "auto"), chosen and
// checked against the deck before anything is written; false (said) if the run cannot go on.
// restart "auto" without a checkpoint to continue: true with path "" (the deck starts afresh).
static bool open_restart(MPI_Comm comm, const std::string& restart, const std::string& outdir,
                         const CheckpointHeader& identity, int deck_frames, std::string& path, CheckpointHeader& saved) {
  const RestartChoice choice = choose_restart(comm, restart, outdir);
  if (!choice.error.empty()) {
    print_error(comm, choice.error);
    return false;
  }
  path = choice.path;
  saved = choice.header;
  if (path.empty()) {
    PetscPrintf(comm, "hyperqn: --restart auto: %s holds no checkpoint of a run to continue: the deck starts afresh\n",
                outdir.c_str());
    return true;
  }
  std::string why = checkpoint_mismatch(saved, identity);
  if (why.empty() && saved.frame > deck_frames)  // a checkpoint of a longer run than this deck's
    why = "its frame " + std::to_string(saved.frame) + " is past the deck's time.frames " + std::to_string(deck_frames);
  if (why.empty()) return true;
  print_error(comm, "cannot restart from " + path + ": " + why);
  return false;
}

// How long ranks that failed wait for the others before the run is aborted (all_ranks_arrive).
constexpr double kErrorMeetingSeconds = 60;

// An input file that the run would overwrite or remove as its own output: one of the names it
// writes in OUTDIR (io/output_directory.hpp's is_run_output, and the deck's own series: NAME.pvd,
// or NAME.xdmf and NAME.h5, before either exists), an earlier run's file there that it removes, or a
// checkpoint's name in OUTDIR/checkpoints. A deck named config.yaml in OUTDIR was replaced by the
// run's config; a partition file OUTDIR/NAME.h5 became the XDMF data of the run reading it.
// Throws InputError naming the deck's key.
static void check_inputs_are_not_outputs(const Deck& deck, const std::string& outdir) {
  const bool xdmf = deck.output.format == OutputFormat::xdmf;
  const std::set<std::string> series =
      !deck.output.vtk ? std::set<std::string>{}
      : xdmf           ? std::set<std::string>{deck.name + ".xdmf", deck.name + ".h5"}
                       : std::set<std::string>{deck.name + ".pvd"};
  const auto check = [&](const std::string& file, int line, const std::string& key) {
    if (file.empty()) return;
    std::error_code ec;
    const std::filesystem::path path(file), dir = path.has_parent_path() ? path.parent_path() : ".";
    const std::string name = path.filename().string();
    const bool in_outdir = std::filesystem::equivalent(dir, outdir, ec) && !ec;
    std::error_code ec2;
    const bool in_checkpoints = !in_outdir && std::filesystem::equivalent(dir, outdir + "/checkpoints", ec2) && !ec2;
    const bool written = (in_outdir && (series.count(name) || is_run_output(outdir, name))) ||
                         (in_checkpoints && checkpoint_frame(name) >= 0);
    if (!written) return;
    throw InputError(deck.path, line, key, (key.empty() ? "the deck " : file + " ") + "is a file that the run writes in "
                     "its output directory " + outdir + ": rename it, move it, or choose another -o");
  };
  check(deck.path, 0, "");
  for (const Deck::InputFile& f : deck.input_files) check(f.path, f.line, f.key);
}

// A file in OUTDIR under a name the run's new frame series takes (the deck's format's: NAME.pvd, or
// NAME.xdmf and NAME.h5; a restart's series that its checkpoint carries goes on, and is that run's)
// that is not a run's output (is_run_output: a NAME.h5 without a NAME.xdmf beside it that uses it, a
// NAME.pvd that lists no NAME_ frames): clearing the directory leaves it, and the series would
// overwrite it. The refusal naming it, "" if there is none. Collective (rank 0 looks).
static std::string foreign_series_file(MPI_Comm comm, const Deck& deck, const CheckpointHeader* saved,
                                       const std::string& outdir) {
  const bool vtu = deck.output.format == OutputFormat::vtu;
  if (!deck.output.vtk) return "";
  if (saved)
    for (const auto& [key, value] : saved->writers)
      if (key == (vtu ? VtkSeries::kRestartKey : XdmfSeries::kRestartKey)) return "";
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string refusal;
  for (const std::string& name : vtu ? std::vector<std::string>{deck.name + ".pvd"}
                                     : std::vector<std::string>{deck.name + ".xdmf", deck.name + ".h5"}) {
    std::error_code ec;
    if (rank != 0 || !refusal.empty() || !std::filesystem::exists(std::filesystem::symlink_status(outdir + "/" + name, ec)) ||
        is_run_output(outdir, name))
      continue;
    // a run killed in its first frame leaves NAME.h5 before NAME.xdmf: the next run writes over it
    if (name == deck.name + ".h5" && XdmfSeries::holds_a_series_alone(outdir + "/" + name)) continue;
    const std::string why = name == deck.name + ".h5"   ? "no " + deck.name + ".xdmf beside it uses it"
                            : name == deck.name + ".pvd" ? "it lists no " + deck.name + "_ frames"
                                                          : "its data are not in " + deck.name + ".h5";
    refusal = outdir + "/" + name + " is not a run's output (" + why + "), and this run would write its " +
              kOutputFormatNames[size_t(deck.output.format)] + " frames over it (name: " + deck.name +
              "): choose another -o or another name, or move or remove the file";
  }
  return broadcast_text(comm, refusal);
}

int run_simulation(MPI_Comm comm, const Deck& deck, const std::string& outdir, const std::string& restart_arg) {
  const double t_start = MPI_Wtime();
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);

  // 1. Everything that can be wrong with the input is checked before any output exists.
  RunOptions options;
  if (read_run_options(comm, &options, &deck)) return 1;
  check_inputs_are_not_outputs(deck, outdir);
  // Another run writing OUTDIR now: said before the setup (taken for good in step 3).
  if (const std::string busy = output_directory_in_use(comm, outdir); !busy.empty()) {
    print_error(comm, busy);
    return 1;
  }
  const std::string config = effective_config(deck, options, outdir);  // OUTDIR/config.yaml
  SceneInput input;
  MemoryPlan plan = memory_plan(deck.solver, options.h0_package, std::any_of(deck.fixed.begin(), deck.fixed.end(), is_roller));
  plan.poisson_ratio = h0_poisson_ratio(deck);
  plan.held_weight = held_still_weight(deck);
  if (!load_scene_input_or_report(comm, deck, input, plan)) return 1;
  const CleanReport repaired = input.repaired;
  if (repaired.dropped_vertices || repaired.reoriented_tets)
    PetscPrintf(comm, "hyperqn: mesh repaired: %lld vertices of no element dropped, %lld tets reoriented to positive volume\n",
                (long long)repaired.dropped_vertices, (long long)repaired.reoriented_tets);

  CheckpointHeader identity = scene_identity(comm, deck, input), saved;
  std::string restart_path;
  if (!restart_arg.empty() && !open_restart(comm, restart_arg, outdir, identity, deck.time.frames, restart_path, saved)) return 1;
  const bool restart = !restart_path.empty();  // else a new run (also --restart auto without a checkpoint)
  if (const std::string foreign = foreign_series_file(comm, deck, restart ? &saved : nullptr, outdir); !foreign.empty()) {
    print_error(comm, foreign);
    return 1;
  }
  identity.run_id = restart ? saved.run_id : new_run_id(comm);
  identity.run_started = restart ? saved.run_started : utc_now(comm);
  identity.deck = restart ? saved.deck : deck.path;

  // 2. Distribute, assemble, factor.
  Run run(comm, deck, options, restart);
  run.t_start = t_start;
  run.checkpoints = std::make_unique<CheckpointStore>(comm, outdir + "/checkpoints", deck.checkpoint.keep);
  run.summary.dropped_vertices = repaired.dropped_vertices;
  run.summary.reoriented_tets = repaired.reoriented_tets;
  {
    PetscErrors errors;
    bool start_ok = true;  // a new run's start is input too (a body inside an obstacle)
    if (run.scene.setup(comm, deck, std::move(input), scene_options(deck, options, {deck.solver.type})) ||
        (restart && run.scene.restore_changes(saved.cuts, saved.cuts_factored, saved.cut_batches, saved.breaks,
                                              saved.breaks_factored, saved.break_batches)) ||
        (restart && run.scene.restore_released(saved.released, saved.released_attachments)) ||
        create_solver(deck.solver, *run.scene.current().step, run.scene.current().constant_matrix(deck.solver), run.solver) ||
        (!restart && (run.scene.initial_state(run.state) || run.scene.check_start(run.state, &start_ok)))) {
      print_error(comm, "setting up the scene failed: " + errors.describe(deck));
      return 1;
    }
    if (!start_ok || !check_element_fields(comm, deck, run.scene.current())) return 1;
  }
  if (const Scene& s = run.scene.current(); solver_h0(deck.solver) == H0::automatic &&
                                            resolved_h0(deck.solver, s.mesh.global_cells, s.poisson_ratio,
                                                        s.weight_deflection) == H0::rest_stiffness)
    PetscPrintf(comm, "hyperqn: solver.h0: auto takes rest-stiffness: a stiff scene held still (self-weight deflection "
                "scale %.2g < %g, docs/method.md#the-initial-hessian-h0)\n", s.weight_deflection,
                kRestStiffnessBelowDeflection);
  if (restart) run.scene.restore_resolved(saved.frame, (int)saved.cuts_resolved);
  if (restart && saved.changes_decided) run.scene.decide_changes_after(saved.frame);
  run.chain = std::make_unique<FallbackChain>(run.scene.current(), deck.solver, *run.solver, options.element_limit);
  const Scene& scene = run.scene.current();
  {  // the vertex counts complete the scene's identity (vertex ids are those of the mesh file)
    long long local_slots = 0;
    for (int64_t id : scene.mesh.vertex_ids) local_slots = std::max<long long>(local_slots, id + 1);
    MPI_Allreduce(&local_slots, &identity.vertex_slots, 1, MPI_LONG_LONG, MPI_MAX, comm);
    identity.vertices = scene.mesh.global_vertices;
    run.identity = identity;
  }
  if (restart) {
    std::string why = checkpoint_mismatch(saved, identity);
    if (why.empty() && saved.dofs != scene.mesh.global_dofs)
      why = "the scene has " + std::to_string(scene.mesh.global_dofs) + " dofs, the checkpoint's " + std::to_string(saved.dofs);
    if (why.empty() && rank == 0) {  // the logs the deck asks for must go on from the checkpoint's frame
      try {
        run.logs.check_restart(outdir, saved.frame);
      } catch (const std::exception& e) {
        why = e.what();
      }
    }
    int refused = !why.empty();
    MPI_Allreduce(MPI_IN_PLACE, &refused, 1, MPI_INT, MPI_MAX, comm);
    if (refused) {  // before anything is written
      print_error(comm, "cannot restart from " + restart_path + ": " + why);
      return 1;
    }
    run.restart = &saved;
    run.restart_path = restart_path;
    PetscPrintf(comm, "hyperqn: restart from %s: frame %d (written at %d rank(s))\n", restart_path.c_str(), saved.frame,
                saved.ranks);
  }
  RunSummary& summary = run.summary;
  summary.deck = deck.path;
  summary.run_id = identity.run_id;
  summary.solver = deck.solver.type;
  if (!run.solver->overridden().empty()) summary.solver += " (" + run.solver->overridden() + ")";
  summary.ranks = size;
  summary.vertices = scene.mesh.global_vertices;
  summary.tets = scene.mesh.global_cells;
  summary.segments = scene.mesh.global_segments;
  summary.triangles = scene.mesh.global_triangles;
  summary.dofs = scene.mesh.global_dofs;
  summary.fixed_vertices = scene.mesh.global_fixed_vertices;
  summary.dt = deck.time.dt;
  summary.free_scene = free_scene(deck);
  if (const FactoredSystem* h0 = scene.constant_matrix(deck.solver)) {
    summary.h0_package = factor_package_name(h0->package());
    summary.h0_factor_nonzeros = h0->factor_nonzeros();
    summary.h0_interface = h0->interface_size();
  }
  read_log_events(summary);
  summary.setup_s = MPI_Wtime() - t_start;
  std::string elements;  // what the mesh (or the bodies) has, each kind named once (a cloth alone has no tets)
  const auto list = [&elements](long long count, const char* what) {
    elements += (elements.empty() ? "" : ", ") + std::to_string(count) + " " + what;
  };
  if (summary.tets || (!summary.triangles && !summary.segments)) list(summary.tets, "tets");
  if (summary.segments) list(summary.segments, "strand segments");
  if (summary.triangles) list(summary.triangles, "cloth triangles");
  PetscPrintf(comm, "hyperqn: %s: %lld vertices (%lld fixed), %s, %lld dofs on %d rank(s); solver %s; setup %.3f s (factor %.3f s)\n",
              deck.name.c_str(), summary.vertices, summary.fixed_vertices, elements.c_str(), summary.dofs, size,
              summary.solver.c_str(), summary.setup_s, summary.factor_s);
  for (const auto& term : scene.body->terms())
    if (const std::string line = term->describe(); !line.empty()) PetscPrintf(comm, "hyperqn: %s\n", line.c_str());
  for (const std::string& key : solver_keys_ignored(deck.solver, deck.rule_sources))
    PetscPrintf(comm, "hyperqn: warning: solver.type %s does not read solver.%s (a key of L-BFGS's, "
                      "docs/deck-run.md#solver)\n", deck.solver.type.c_str(), key.c_str());
  if (deck.output.reactions && Reactions::names(deck).empty())
    PetscPrintf(comm, "hyperqn: warning: output.reactions: the scene has no fixed region or attachment, so reactions.csv "
                      "has no rows\n");
  if (!scene.step->has_inertia())
    PetscPrintf(comm, "hyperqn: static: load steps of %g, pseudo step s = %.6g (%s)\n", deck.time.dt,
                scene.step->solve_dt(), deck.time.pseudo_step > 0 ? "time.pseudo_step" : "automatic");

  // 3. Output directory, writers and logs. Every step that one rank does alone is followed by a
  // collective check, so a failure (unwritable directory, full disk) ends the run on every rank.
  bool ok = true;
  bool have_dir = false;  // summary.json can be written
  OutputLock lock;        // OUTDIR is this run's until it returns
  try {
    create_output_directory(comm, outdir);
    // One run at a time: another that started into OUTDIR since step 1 is refused here, before
    // anything is written; and a restart continues only the run it read its checkpoint of.
    std::string busy = lock.take(comm, outdir, "deck " + deck.path);
    if (busy.empty() && run.restart && rank == 0 && summary_run_id(outdir + "/summary.json") != saved.run_id)
      busy = "cannot restart from " + restart_path + ": another run (" + summary_run_id(outdir + "/summary.json") +
             ") wrote " + outdir + " while this one was set up";
    busy = broadcast_text(comm, busy);
    if (!busy.empty()) {
      print_error(comm, busy);
      return 1;
    }
    have_dir = true;
    std::string error;
    if (rank == 0) {
      try {
        const std::string earlier = summary_run_id(outdir + "/summary.json");
        // A summary from the start: a run that is killed leaves one that says it did not end. It
        // names this run, so from here on no restart takes an earlier run's files for this one's.
        RunSummary started = summary;
        started.status = "incomplete: the run started and did not end (still running, or killed)";
        write_summary(outdir + "/summary.json", started);
        // The frames of two runs must never mix: what an earlier run wrote here goes, its
        // checkpoints first; a restart keeps the frames up to its checkpoint instead (below).
        if (!run.restart) {
          const Cleared cleared = clear_previous_run(outdir);
          if (cleared.files || cleared.checkpoints)
            PetscPrintf(PETSC_COMM_SELF, "hyperqn: %s held an earlier run's output%s: %d file(s) and %d checkpoint(s) removed\n",
                        outdir.c_str(), earlier.empty() ? "" : (" (run " + earlier + ")").c_str(), cleared.files,
                        cleared.checkpoints);
        } else {
          remove_interrupted_writes(outdir);  // a killed part's temporaries
        }
        write_file_atomically(outdir + "/config.yaml", config);
        run.logs.open(outdir, rank, scene, run.restart ? saved.frame : -1, run.restart ? &saved.summary : nullptr);
      } catch (const std::exception& e) {
        error = e.what();
      }
    }
    throw_if_any_failed(comm, error);
    if (run.logs.share_restart(run.restart)) throw std::runtime_error("the logs' restart could not be shared");
    if (run.restart) run.checkpoints->resume(saved.run_id, saved.frame);
    add_series<VtkSeries>(comm, deck, "vtu", outdir, run.restart ? &saved : nullptr, scene.mesh, run.frames);
    add_series<XdmfSeries>(comm, deck, "xdmf", outdir, run.restart ? &saved : nullptr, scene.mesh, run.frames);
    PetscErrors errors;
    if (run.time_loop(ok)) {
      summary.status = "error: PETSc error during the time loop: " + errors.describe(deck);
      ok = false;
    }
  } catch (const std::exception& e) {
    summary.status = std::string("error: ") + e.what();
    ok = false;
  }
  // An error of this rank alone leaves the others in a collective it left: said, then aborted
  // (before, the run hung). One of every rank (a guardrail, a full disk) meets here at once.
  const double meeting = options.rank_error_after_frame >= 0 ? 2.0 : kErrorMeetingSeconds;  // its test waits less
  if (summary.status.rfind("error: ", 0) == 0 && !all_ranks_arrive(comm, meeting)) {
    std::fprintf(stderr, "hyperqn: error on rank %d, which the other ranks did not share: %s\n", rank, summary.status.c_str() + 7);
    MPI_Abort(comm, 1);
  }

  // 4. Summary.
  read_log_events(summary);
  const SceneTotals totals = run.accepted ? *run.accepted : scene_totals(run.scene);
  if (!deck.cuts.empty() || run.scene.fracture()) {  // the counts so far (a restart's replay included) and the mesh they made
    const LiveScene::CutCounts& c = totals.cuts;
    summary.cuts = !deck.cuts.empty();  // a deck has cuts or fracture (deck_rules.cpp)
    summary.fracture = run.scene.fracture();
    if (deck.cuts.empty())  // every face is the criterion's: the first of the history (a replay's included)
      summary.first_break_frame = c.batches == 0 || run.scene.cut_history().empty() ? -1 : run.scene.cut_history().front()[0];
    else if (summary.first_break_frame < 0)  // with cuts: the checkpoint's, else this run's
      summary.first_break_frame = c.first_broken;
    summary.faces_broken = c.broken;  // this run's; a restart's earlier ones are added below
    summary.faces_separated = c.faces;
    summary.cut_vertices = c.vertices;
    summary.tets_removed = c.removed;
    summary.cut_h0_corrections = c.corrections;  // this run's; a restart's earlier ones are added below
    summary.cut_refactorizations = c.refactorizations;
    summary.topology_s = event_seconds(log_events().topology);
  }
  if (run.scene.breaks()) {  // as for cuts (a blade's cut through a cloth counts as its torn edges)
    const LiveScene::BreakCounts& c = totals.breaks;
    summary.breaks = true;
    summary.segments_snapped = c.segments;
    summary.edges_torn = c.edges;
    summary.break_vertices = c.vertices;
    summary.break_h0_corrections = c.corrections;  // this run's; a restart's earlier ones are added below
    summary.break_refactorizations = c.refactorizations;
    summary.topology_s = event_seconds(log_events().topology);
  }
  if (summary.cuts || summary.fracture || summary.breaks) {  // the mesh the changes made (tets: a blade with remove)
    summary.vertices = totals.vertices;
    summary.tets = totals.tets;
    summary.segments = totals.segments;
    summary.triangles = totals.triangles;
    summary.dofs = totals.dofs;
  }
  add_step_counters(summary, *run.scene.current().step);  // the scene in use at the end
  summary.wall_s = MPI_Wtime() - t_start;
  add_earlier_work(summary, run.earlier);  // a restarted run's summary covers the whole run
  if (summary.fracture && !summary.cuts) summary.faces_broken = summary.faces_separated;  // (a replay's included)
  if (summary.frames > 0) {
    summary.ms_per_frame = 1e3 * summary.solve_s / summary.frames;
    summary.mean_iterations = (double)summary.iterations / summary.frames;
  }
  if (summary.iterations > 0) summary.ms_per_iteration = 1e3 * summary.solve_s / summary.iterations;
  double rss = peak_rss_mb();
  MPI_Allreduce(&rss, &summary.peak_rss_mb, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(&rss, &summary.peak_rss_mb_total, 1, MPI_DOUBLE, MPI_SUM, comm);
  summary.peak_rss_mb_by_rank.resize(size);
  MPI_Allgather(&rss, 1, MPI_DOUBLE, summary.peak_rss_mb_by_rank.data(), 1, MPI_DOUBLE, comm);
  const int any_sig = stop_signal_on_any_rank(comm);
  if (any_sig) summary.signal = stop_signal_name(any_sig);
  if (any_sig && ok && !run.interrupted)  // mpiexec (Open MPI) exits 1 after a SIGTERM, whatever the ranks' codes
    PetscPrintf(comm, "hyperqn: %s arrived after the last frame had begun: the run is complete (status below)\n",
                summary.signal.c_str());
  PetscPrintf(comm,
              "hyperqn: %s: %d frames, %.2f iterations/frame, %.3f ms/frame, %.3f ms/iteration, factorizations %d "
              "(%.3f s), wall %.3f s, peak RSS %.0f MB/rank; %s\n",
              deck.name.c_str(), summary.frames, summary.mean_iterations, summary.ms_per_frame, summary.ms_per_iteration,
              summary.factorizations, summary.factor_s, summary.wall_s, summary.peak_rss_mb, summary.status.c_str());
  std::string error;  // every failure is said: each names its path
  const auto add = [&error](const std::exception& e) { error += (error.empty() ? "" : "; ") + std::string(e.what()); };
  try {
    for (auto& w : run.frames.writers()) w->end_run(summary);
  } catch (const std::exception& e) {
    add(e);
  }
  if (rank == 0 && have_dir) {
    try {
      run.logs.write_rows();  // the rows of a frame that stopped the run
    } catch (const std::exception& e) {
      add(e);
    }
    try {
      write_summary(outdir + "/summary.json", summary);
    } catch (const std::exception& e) {
      add(e);
    }
  }
  // What stopped the run first, then what could not be written after it.
  if (!ok && summary.status.rfind("error", 0) == 0) PetscPrintf(comm, "hyperqn: %s\n", summary.status.c_str());
  try {
    throw_if_any_failed(comm, error);  // every rank exits with 1, rank 0 names the path
  } catch (const std::exception& e) {
    print_error(comm, e.what());
    ok = false;
  }
  if (!ok) return 1;
  if (run.interrupted) return kExitInterrupted;
  return summary.status.rfind("inverted", 0) == 0 ? kExitInverted : 0;
}

}  // namespace hyperqn

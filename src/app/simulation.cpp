#include "app/simulation.hpp"

#include <petscdmplex.h>

#include <csignal>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>

#include "app/frame_step.hpp"
#include "app/run_options.hpp"
#include "app/petsc_errors.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint_store.hpp"
#include "io/log_events.hpp"
#include "io/output_directory.hpp"
#include "io/run_log.hpp"
#include "model/fallback_chain.hpp"
#include "model/scene.hpp"
#include "solvers/solver_registry.hpp"
#include "io/vtk_writer.hpp"
#include "io/xdmf_writer.hpp"

namespace hyperqn {

namespace {

double global_min(MPI_Comm comm, const std::vector<double>& v) {
  double local = HUGE_VAL, global;
  for (double x : v) local = std::fmin(local, x);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, comm);
  return global;
}

// The run counters a scene's StepObjective keeps (its sub-steps' included) into a summary.
void add_step_counters(RunSummary& summary, const StepObjective& step) {
  summary.rejected_evaluations += step.rejected_evaluations();
  summary.pulled_back_guesses += step.pulled_back_guesses();
  summary.euler_completed_steps += step.euler_completed_steps();
}

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
  if (!flagged.empty())
    status += (status.empty() ? "" : "; ") + std::string("flagged: ") + std::to_string(flagged.size()) + " of " +
              std::to_string(summary.frames) + " frames could not decrease g (first: frame " +
              std::to_string(flagged.front().first) + ")";
  return status.empty() ? "ok" : status;
}

}  // namespace

// The run's timings and counts so far, from the log events (over every scene of the run).
static void read_log_events(RunSummary& s) {
  const LogEvents& e = log_events();
  s.assembly_s = event_seconds(e.h0_assembly);
  s.factor_s = event_seconds(e.h0_factor);
  s.factorizations = event_count(e.h0_factor);
  s.solve_s = event_seconds(e.step);
  s.objective_s = event_seconds(e.objective);
  s.h0_solve_s = event_seconds(e.h0_solve);
  s.h0_solves = event_count(e.h0_solve);
  s.hessian_s = event_seconds(e.hessian);
  s.hessian_assemblies = event_count(e.hessian);
  s.contact_s = event_seconds(e.contact);
  s.contact_evaluations = event_count(e.contact);
}

// SIGTERM and SIGUSR1 (a batch system's notice, docker/hyperqn.slurm) ask the run to stop after
// the current frame with a checkpoint. The handler only records the signal (async-signal-safe);
// the ranks agree on it once per frame (Run::after_frame).
static volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void record_stop_signal(int sig) { g_stop_signal = sig; }
void catch_stop_signals() {
  struct sigaction action = {};
  action.sa_handler = record_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // blocking calls (MPI, file writes) go on
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGUSR1, &action, nullptr);
}

namespace {

// Everything one simulation run holds while its frames are computed.
struct Run {
  MPI_Comm comm;
  const Deck& deck;
  LiveScene scene;
  State state;
  std::unique_ptr<TimeStepSolver> solver;
  std::unique_ptr<FallbackChain> chain;  // around solver
  std::vector<std::unique_ptr<OutputWriter>> writers;
  IterationLog log;
  // Per term of the scene (Body::terms, the same kinds in the same order after a release): its
  // own log (EnergyTerm::log; null if it keeps none or the deck turned it off).
  std::vector<std::unique_ptr<FrameLog>> term_logs;
  RunSummary summary;
  int last_written = -1;
  std::vector<double> pos, vel, J;                 // work: local arrays of a frame
  std::vector<std::vector<double>> field_values;   // work: the terms' point fields, local
  Vec field = nullptr;                             // work: one point field (global free dofs)
  ~Run() { VecDestroy(&field); }

  RunOptions options;

  // Checkpoints and restart (io/checkpoint_store.hpp).
  double t_start = 0;
  std::unique_ptr<CheckpointStore> checkpoints;  // OUTDIR/checkpoints
  CheckpointHeader identity;         // whose run and what scene: run id, physics, mesh, vertex counts
  const CheckpointHeader* restart = nullptr;  // the checkpoint this run continues, if any
  std::string restart_path;
  RunSummary earlier;                // the work (times, factorizations) before the restart
  double last_checkpoint_wtime = 0;  // rank 0's clock
  int last_checkpoint_frame = -1;    // the frame of the newest checkpoint on disk
  bool interrupted = false;          // stopped by a signal with a checkpoint (kExitInterrupted)

  Run(MPI_Comm c, const Deck& d, const RunOptions& o) : comm(c), deck(d), options(o) {}

  PetscErrorCode write_checkpoint(bool started_inverted);
  PetscErrorCode resume(bool* started_inverted);
  PetscErrorCode after_frame(int frame, bool started_inverted);
  PetscErrorCode stop_for_signal(int sig, int frame, bool started_inverted);

  // Writes frame `frame` from the state, unless a position, velocity or J is not finite.
  PetscErrorCode write_frame(int frame, bool* written) {
    const Scene& s = scene.current();
    PetscFunctionBeginUser;
    PetscCall(s.body->local_positions(state.x, pos));
    PetscCall(s.body->local_velocities(state.v, vel));
    s.body->cell_jacobians(pos, J);
    int local = 1, finite;
    for (const auto* values : {&pos, &vel, &J})
      for (double a : *values) local &= std::isfinite(a) ? 1 : 0;
    PetscCallMPI(MPI_Allreduce(&local, &finite, 1, MPI_INT, MPI_MIN, comm));
    *written = finite == 1;
    if (!*written) PetscFunctionReturn(0);
    summary.min_J = std::fmin(summary.min_J, global_min(comm, J));
    FrameData f{frame, frame * deck.time.dt, &state, &pos, &vel, &J, {}};
    std::vector<std::string> names;
    for (const auto& term : s.body->terms())
      for (const std::string& name : term->point_fields()) {
        if (!field) PetscCall(VecDuplicate(state.x, &field));
        PetscCall(term->point_field(name, pos, field));
        field_values.resize(names.size() + 1);
        PetscCall(s.body->local_values(field, field_values.back()));
        names.push_back(name);
      }
    for (size_t k = 0; k < names.size(); ++k) f.point_fields.emplace_back(names[k], &field_values[k]);
    PetscCall(event_begin(&LogEvents::output));
    for (auto& w : writers) w->write_frame(f);
    PetscCall(event_end(&LogEvents::output));
    last_written = frame;
    PetscFunctionReturn(0);
  }

  // Per frame: what the terms with a log of their own report (EnergyTerm::report: contact.csv's
  // rows, the summary's contact maxima, and a warning for each flag, counted in the summary);
  // nothing at all in a scene without such a term.
  PetscErrorCode record_terms(int frame) {
    const Scene& s = scene.current();
    bool have_positions = false;
    PetscFunctionBeginUser;
    const auto& terms = s.body->terms();
    for (size_t t = 0; t < terms.size(); ++t) {
      if (terms[t]->log().file.empty()) continue;
      if (!have_positions) PetscCall(s.body->local_positions(state.x, pos));
      have_positions = true;
      TermReport r;
      PetscCall(terms[t]->report(pos, r));
      if (t < term_logs.size() && term_logs[t]) term_logs[t]->append(frame, state.time, r.rows);
      for (const auto& [name, value] : r.maxima) raise_summary_maximum(summary, name, value);
      for (const auto& [name, what] : r.flags) {
        count_summary_flag(summary, name, frame, what);
        PetscCall(PetscPrintf(comm, "frame %5d  WARNING: %s\n", frame, what.c_str()));
      }
    }
    PetscFunctionReturn(0);
  }

  // After a release (see LiveScene::release_due): the solver and the writers move to the new
  // scene, the old scene's counters go to the summary.
  PetscErrorCode rebind(const Scene& old_scene, Scene& fresh) {
    PetscFunctionBeginUser;
    chain.reset();  // they refer to the old scene
    solver.reset();
    PetscCall(VecDestroy(&field));  // the layout changed
    PetscCall(create_solver(deck.solver, *fresh.step, fresh.constant_matrix(deck.solver), solver));
    chain = std::make_unique<FallbackChain>(fresh, deck.solver, *solver, options.element_limit);
    add_step_counters(summary, *old_scene.step);
    summary.dofs = fresh.mesh.global_dofs;
    summary.fixed_vertices = fresh.mesh.global_fixed_vertices;
    for (auto& w : writers) w->set_mesh(fresh.mesh);
    PetscCall(PetscPrintf(comm, "t = %g: fixed region(s) released or attachment(s) gone (from this step on); %lld dofs now, constant matrix factored again\n",
                          state.time, (long long)summary.dofs));
    PetscFunctionReturn(0);
  }

  // Writes the logs' rows of the frame (whole lines: a kill leaves complete rows). Collective:
  // a failure on rank 0 ends the run on every rank.
  void flush_logs() {
    std::string error;
    try {
      log.flush();
      for (auto& l : term_logs)
        if (l) l->flush();
    } catch (const std::exception& e) {
      error = e.what();
    }
    throw_if_any_failed(comm, error);
  }

  PetscErrorCode time_loop(bool& ok);
};

}  // namespace

// The frame loop; ok = false (with summary.status set) if the run cannot continue.
// Guardrails: a frame whose solver could not decrease g is flagged (progress line, summary's
// flagged_frames and status) and the run goes on from its last accepted iterate; a frame that
// leaves no finite state (rejected g at every point tried, non-finite positions) or a diverged one
// (RunOptions::divergence_limit) stops the run: the last good frame is written (even if it is not an output
// frame) and nothing non-finite ever is.
PetscErrorCode Run::time_loop(bool& ok) {
  PetscFunctionBeginUser;
  ok = true;
  bool written = false, resumed_inverted = false;
  if (restart) {
    PetscCall(resume(&resumed_inverted));  // frames up to the checkpoint's were done before
  } else {  // the state is the scene's initial state, checked before any output (run_simulation)
    summary.min_J = HUGE_VAL;
    PetscCall(write_frame(0, &written));
  }
  // A run that the deck starts inverted (initial:) is judged by its last frame only.
  double min_J = 0, max_abs_J = 0;
  PetscCall(scene.current().body->volume_ratios(state.x, &min_J, &max_abs_J));
  const bool started_inverted = restart ? resumed_inverted : degenerate(min_J);
  bool inverted_now = degenerate(min_J);

  FrameStepper stepper(Guardrails::of(options, scene.current()));
  const FrameSolve solve_by_chain = [this](State& st, const IterationCallback& cb, StepSolve& out) {
    return chain->solve_frame(st, cb, out);
  };
  const LiveScene::Rebind rebind_run = [this](const Scene& o, Scene& f) { return rebind(o, f); };
  {  // a signal during setup: the run stops before its first frame, with a checkpoint of its start
    if (state.frame == options.signal_after_frame) raise(SIGTERM);  // test hook
    int sig = (int)g_stop_signal, any;
    PetscCallMPI(MPI_Allreduce(&sig, &any, 1, MPI_INT, MPI_MAX, comm));
    PetscCall(stop_for_signal(any, state.frame, started_inverted));
  }
  while (!interrupted && state.frame < deck.time.frames) {
    const int frame = state.frame + 1;
    bool released;
    PetscCall(scene.release_due(state, {}, rebind_run, &released));
    Scene& s = scene.current();

    const auto log_iteration = [&](const IterationRecord& it) {
      if (!Objective::rejected(it.energy) && std::isfinite(it.grad_norm)) log.append(frame, it);  // never NaN
      return false;
    };
    FrameStep f;
    PetscCall(stepper.step(s, solve_by_chain, state, log_iteration, f));
    const StepSolve& step = f.solve;
    const FrameResult& r = step.result;
    if (step.restarted)
      PetscCall(PetscPrintf(comm, "frame %5d  g is not finite at the inertial warm start y; started again from x_n\n", frame));
    const double ms = 1e3 * step.seconds;
    summary.evaluations += step.evaluations;
    summary.iterations += step.iterations;
    summary.extended_frames += step.extended;
    summary.substepped_frames += step.substeps > 1;
    summary.newton_frames += step.newton;
    summary.converged_frames += r.converged;
    summary.failed_frames += r.failed;
    summary.ls_failures += r.ls_failures;
    if (r.failed) summary.flagged_frames.emplace_back(frame, r.reason);
    // A solver that was given no iteration (e.g. -tao_max_it 0) did not solve the frame.
    if (!r.failed && !r.converged && r.iterations == 0) {
      ++summary.failed_frames;
      summary.flagged_frames.emplace_back(frame, "the solver took no iteration (" + r.reason + ")");
    }
    std::string why = f.stop;  // the guardrails (app/frame_step.hpp); the frame has ended if empty
    const bool finite_g = !Objective::rejected(r.energy) && std::isfinite(r.grad_norm);
    if (why.empty()) {
      inverted_now = f.inverted;
      if (inverted_now) summary.inverted_frames.push_back(frame);
      summary.min_J = std::fmin(summary.min_J, f.min_J);
    }

    std::string note;
    if (step.substeps > 1) note += "  [" + std::to_string(step.substeps) + " sub-steps]";
    if (step.newton) note += "  [newton fallback]";
    if (step.iterations != r.iterations) note += "  [" + std::to_string(step.iterations) + " iterations in all]";
    if (r.ls_failures > 0) note += "  [" + std::to_string(r.ls_failures) + " line-search failure(s)]";
    if (r.failed && why.empty()) note += "  FLAGGED: g could not be decreased further";
    if (finite_g)
      PetscCall(PetscPrintf(comm, "frame %5d  it %3d  g %+.9e  |grad| %.3e  %8.2f ms  %s%s\n", frame,
                            (int)r.iterations, r.energy, r.grad_norm, ms, r.reason.c_str(), note.c_str()));
    else
      PetscCall(PetscPrintf(comm, "frame %5d  it %3d  g not finite  %8.2f ms  %s%s\n", frame, (int)r.iterations, ms,
                            r.reason.c_str(), note.c_str()));
    if (why.empty()) {
      summary.frames = frame;
      summary.final_energy = r.energy;
      summary.final_grad_norm = r.grad_norm;
      PetscCall(record_terms(frame));
      const bool last = frame == deck.time.frames;
      if (frame % deck.output.every == 0 || last) {
        PetscCall(write_frame(frame, &written));
        if (!written) why = "non-finite positions, velocities or J";
      }
      if (why.empty()) {
        flush_logs();  // before a checkpoint: a restart cuts the logs at its frame
        PetscCall(after_frame(frame, started_inverted));
        if (interrupted) break;
        continue;
      }
    }
    flush_logs();

    // The run cannot continue: back to the last good frame, which is written if it was not.
    if (!r.failed) {
      ++summary.failed_frames;
      summary.flagged_frames.emplace_back(frame, why);
    }
    summary.frames = frame - 1;
    if (state.frame == frame) {  // completed, but the frame could not be written
      state.frame = frame - 1;
      state.time = state.frame * deck.time.dt;
    }
    PetscCall(s.step->undo_step(state));
    if (last_written != frame - 1) PetscCall(write_frame(frame - 1, &written));
    summary.status = "error: frame " + std::to_string(frame) + ": " + why + "; stopped, the last frame written is " +
                     std::to_string(last_written);
    ok = false;
    break;
  }
  if (ok && !interrupted) summary.status = completed_status(summary, started_inverted, inverted_now);
  PetscFunctionReturn(0);
}

// The run's state, the scene's identity and the counters so far into a checkpoint.
PetscErrorCode Run::write_checkpoint(bool started_inverted) {
  const Scene& s = scene.current();
  int size;
  PetscFunctionBeginUser;
  MPI_Comm_size(comm, &size);
  CheckpointHeader h = identity;
  h.ranks = size;
  h.frame = state.frame;
  h.time = state.time;
  h.body_time = s.body->time();
  h.dofs = s.mesh.global_dofs;
  h.released = state.released;
  h.released_attachments = state.released_attachments;
  h.started_inverted = started_inverted;
  h.summary = summary;
  read_log_events(h.summary);
  h.summary.wall_s = MPI_Wtime() - t_start;
  add_earlier_work(h.summary, earlier);
  add_step_counters(h.summary, *s.step);  // as at the end of a run
  for (const auto& w : writers)
    if (!w->restart_key().empty()) h.writers.emplace_back(w->restart_key(), w->restart_state());
  h.history = state.x_prev ? 1 : 0;
  VertexRows rows(h.vertex_sets());
  PetscCall(s.body->local_positions(state.x, rows[0]));
  PetscCall(s.body->local_velocities(state.v, rows[1]));
  if (h.history) {
    PetscCall(s.body->local_positions(state.x_prev, rows[2]));
    PetscCall(s.body->local_velocities(state.v_prev, rows[3]));
  }
  flush_logs();  // the logs on disk reach the checkpoint's frame: a restart cuts them there
  PetscCall(event_begin(&LogEvents::checkpoint));
  const std::string path = checkpoints->write(h, s.mesh, rows);
  PetscCall(event_end(&LogEvents::checkpoint));
  last_checkpoint_wtime = MPI_Wtime();
  last_checkpoint_frame = state.frame;
  PetscCall(PetscPrintf(comm, "hyperqn: checkpoint %s\n", path.c_str()));
  PetscFunctionReturn(0);
}

// After a completed frame: a checkpoint if one is due (every N frames, every S seconds), and a
// stop if a signal asked for one; every rank learns both from one reduction.
PetscErrorCode Run::after_frame(int frame, bool started_inverted) {
  int rank;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  const CheckpointSpec& c = deck.checkpoint;
  if (frame == options.signal_after_frame) raise(SIGTERM);  // test hook
  int local[2] = {(int)g_stop_signal, 0}, global[2];
  if (rank == 0) local[1] = c.seconds > 0 && MPI_Wtime() - last_checkpoint_wtime >= c.seconds;  // one clock decides
  PetscCallMPI(MPI_Allreduce(local, global, 2, MPI_INT, MPI_MAX, comm));
  if (global[1] || (c.every > 0 && frame % c.every == 0)) PetscCall(write_checkpoint(started_inverted));
  PetscCall(stop_for_signal(global[0], frame, started_inverted));
  if (frame == options.kill_after_frame) raise(SIGKILL);  // test hook
  PetscFunctionReturn(0);
}

// A signal `sig` (0: none) asked to stop: a checkpoint of the state after `frame` unless one was
// just written, and the run ends as interrupted. After the last frame the run is done anyway.
PetscErrorCode Run::stop_for_signal(int sig, int frame, bool started_inverted) {
  PetscFunctionBeginUser;
  if (sig == 0 || frame >= deck.time.frames) PetscFunctionReturn(0);
  if (last_checkpoint_frame != frame) PetscCall(write_checkpoint(started_inverted));
  interrupted = true;
  summary.status = std::string("interrupted: ") + (sig == SIGTERM ? "SIGTERM" : "SIGUSR1") + " after frame " +
                   std::to_string(frame) + " of " + std::to_string(deck.time.frames) +
                   "; a checkpoint was written: continue with --restart latest";
  PetscFunctionReturn(0);
}

// A restart: the state, the fixed vertices' motion and the counters from the checkpoint.
PetscErrorCode Run::resume(bool* started_inverted) {
  const Scene& s = scene.current();
  PetscFunctionBeginUser;
  PetscCall(state.create(s.step->layout()));
  state.frame = restart->frame;
  state.time = restart->time;
  state.released = restart->released;
  state.released_attachments = restart->released_attachments;
  VertexRows rows;
  PetscCall(read_checkpoint_vertices(comm, restart_path, s.mesh, *restart, rows));
  PetscCall(s.body->resume(restart->body_time, rows[0], rows[1], state.x, state.v));
  if (restart->history) {
    PetscCall(VecDuplicate(state.x, &state.x_prev));
    PetscCall(VecDuplicate(state.v, &state.v_prev));
    PetscCall(s.body->free_values(rows[2], state.x_prev));
    PetscCall(s.body->free_values(rows[3], state.v_prev));
  }
  restore_frame_counters(summary, restart->summary);
  earlier = restart->summary;  // its work counters are added at the end
  *started_inverted = restart->started_inverted != 0;
  // As if the run had not stopped: the checkpoint's frame counts as written if it was an output frame.
  last_written = state.frame % deck.output.every == 0 ? state.frame : -1;
  last_checkpoint_wtime = MPI_Wtime();
  last_checkpoint_frame = state.frame;
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

// The frame series of a run: VTK (output.format vtu) or XDMF, if the deck asks for frames
// (output.vtk). A restart (saved: its checkpoint) continues the series the run started, under the
// name it started with, cut back to the checkpoint's frame; a series the deck no longer asks for
// (frames off, or the other format) is still cut back, so that its index never lists the
// abandoned frames. Collective.
template <typename Series>
static void add_series(MPI_Comm comm, const Deck& deck, const char* format, const std::string& outdir,
                       const CheckpointHeader* saved, const DistributedMesh& mesh,
                       std::vector<std::unique_ptr<OutputWriter>>& writers) {
  const std::string* state = nullptr;
  if (saved)
    for (const auto& [key, value] : saved->writers)
      if (key == Series::kRestartKey) state = &value;
  const std::string started_as = state ? Series::series_name(*state) : "";
  const std::string name = started_as.empty() ? deck.name : started_as;
  const std::string& deck_format = kOutputFormatNames[size_t(deck.output.format)];
  const bool wanted = deck.output.vtk && deck_format == format;
  if (!wanted && started_as.empty()) return;
  auto series = std::make_unique<Series>(comm, outdir, name);
  const std::string index = outdir + "/" + deck.name + (deck.output.format == OutputFormat::vtu ? ".pvd" : ".xdmf");
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
                  deck_format.c_str(), kept.c_str(), saved->frame, index.c_str());
    else if (name != deck.name)
      PetscPrintf(comm, "hyperqn: the %s series goes on as %s, the name it started with (the deck now says %s)\n", format,
                  kept_name.c_str(), deck.name.c_str());
  }
  if (wanted) writers.push_back(std::move(series));
}

// The checkpoint a restart continues from (restart: a path, "latest" or "auto"), chosen and
// checked against the deck before anything is written; false (said) if the run cannot go on.
// restart "auto" without a checkpoint to continue: true with path "" (the deck starts afresh).
static bool open_restart(MPI_Comm comm, const std::string& restart, const std::string& outdir,
                         const CheckpointHeader& identity, int deck_frames, std::string& path, CheckpointHeader& saved) {
  const RestartChoice choice = choose_restart(comm, restart, outdir);
  if (!choice.error.empty()) {
    PetscPrintf(comm, "hyperqn: error: %s\n", choice.error.c_str());
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
  PetscPrintf(comm, "hyperqn: error: cannot restart from %s: %s\n", path.c_str(), why.c_str());
  return false;
}

int run_simulation(MPI_Comm comm, const Deck& deck, const std::string& outdir, const std::string& restart_arg) {
  const double t_start = MPI_Wtime();
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);

  // 1. Everything that can be wrong with the input is checked before any output exists.
  RunOptions options;
  if (read_run_options(comm, &options, &deck)) return 1;
  SceneInput input;
  if (!load_scene_input_or_report(comm, deck, input, memory_plan(deck.solver, options.h0_package))) return 1;
  const CleanReport repaired = input.repaired;
  if (repaired.dropped_vertices || repaired.reoriented_tets)
    PetscPrintf(comm, "hyperqn: mesh repaired: %lld vertices of no element dropped, %lld tets reoriented to positive volume\n",
                (long long)repaired.dropped_vertices, (long long)repaired.reoriented_tets);

  CheckpointHeader identity = scene_identity(comm, deck, input), saved;
  std::string restart_path;
  if (!restart_arg.empty() && !open_restart(comm, restart_arg, outdir, identity, deck.time.frames, restart_path, saved)) return 1;
  const bool restart = !restart_path.empty();  // else a new run (also --restart auto without a checkpoint)
  identity.run_id = restart ? saved.run_id : new_run_id(comm);
  identity.run_started = restart ? saved.run_started : utc_now(comm);
  identity.deck = restart ? saved.deck : deck.path;

  // 2. Distribute, assemble, factor.
  Run run(comm, deck, options);
  run.t_start = t_start;
  run.checkpoints = std::make_unique<CheckpointStore>(comm, outdir + "/checkpoints", deck.checkpoint.keep);
  run.summary.dropped_vertices = repaired.dropped_vertices;
  run.summary.reoriented_tets = repaired.reoriented_tets;
  {
    PetscErrors errors;
    bool start_ok = true;  // a new run's start is input too (a body inside an obstacle)
    if (run.scene.setup(comm, deck, std::move(input), scene_options(deck, options, {deck.solver.type})) ||
        (restart && run.scene.restore_released(saved.released, saved.released_attachments)) ||
        create_solver(deck.solver, *run.scene.current().step, run.scene.current().constant_matrix(deck.solver), run.solver) ||
        (!restart && (run.scene.initial_state(run.state) || run.scene.check_start(run.state, &start_ok)))) {
      PetscPrintf(comm, "hyperqn: error: setting up the scene failed: %s\n", errors.describe(deck).c_str());
      return 1;
    }
    if (!start_ok) return 1;
  }
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
    if (!why.empty()) {
      PetscPrintf(comm, "hyperqn: error: cannot restart from %s: %s\n", restart_path.c_str(), why.c_str());
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
  if (const FactoredSystem* h0 = scene.constant_matrix(deck.solver)) {
    summary.h0_package = factor_package_name(h0->package());
    summary.h0_factor_nonzeros = h0->factor_nonzeros();
    summary.h0_interface = h0->interface_size();
  }
  read_log_events(summary);
  summary.setup_s = MPI_Wtime() - t_start;
  std::string elements = summary.triangles ? "" : std::to_string(summary.tets) + " tets";
  if (summary.segments) elements += ", " + std::to_string(summary.segments) + " strand segments";
  if (summary.triangles) elements += std::to_string(summary.triangles) + " cloth triangles";
  PetscPrintf(comm, "hyperqn: %s: %lld vertices (%lld fixed), %s, %lld dofs on %d rank(s); solver %s; setup %.3f s (factor %.3f s)\n",
              deck.name.c_str(), summary.vertices, summary.fixed_vertices, elements.c_str(), summary.dofs, size,
              summary.solver.c_str(), summary.setup_s, summary.factor_s);
  for (const auto& term : scene.body->terms())
    if (const std::string line = term->describe(); !line.empty()) PetscPrintf(comm, "hyperqn: %s\n", line.c_str());

  // 3. Output directory, writers and logs. Every step that one rank does alone is followed by a
  // collective check, so a failure (unwritable directory, full disk) ends the run on every rank.
  bool ok = true;
  bool have_dir = false;  // summary.json can be written
  try {
    create_output_directory(comm, outdir);
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
        if (run.restart) {  // the logs as they were at the checkpoint's frame, then continued
          if (deck.output.iterations_csv) run.log.resume(outdir + "/iterations.csv", rank, saved.frame);
        } else {
          if (deck.output.iterations_csv) run.log.open(outdir + "/iterations.csv", rank);
        }
        for (const auto& term : scene.body->terms()) {
          const TermLog l = term->log();
          run.term_logs.emplace_back();
          if (l.file.empty() || (l.file == "contact.csv" && !deck.output.contact_csv)) continue;  // output.contact_csv
          run.term_logs.back() = std::make_unique<FrameLog>();
          if (run.restart) {
            run.term_logs.back()->resume(outdir + "/" + l.file, l.columns, rank, saved.frame);
          } else {
            run.term_logs.back()->open(outdir + "/" + l.file, l.columns, rank);
          }
        }
      } catch (const std::exception& e) {
        error = e.what();
      }
    }
    throw_if_any_failed(comm, error);
    if (run.restart) run.checkpoints->resume(saved.run_id, saved.frame);
    add_series<VtkSeries>(comm, deck, "vtu", outdir, run.restart ? &saved : nullptr, scene.mesh, run.writers);
    add_series<XdmfSeries>(comm, deck, "xdmf", outdir, run.restart ? &saved : nullptr, scene.mesh, run.writers);
    PetscErrors errors;
    if (run.time_loop(ok)) {
      summary.status = "error: PETSc error during the time loop: " + errors.describe(deck);
      ok = false;
    }
  } catch (const std::exception& e) {
    summary.status = std::string("error: ") + e.what();
    ok = false;
  }

  // 4. Summary.
  read_log_events(summary);
  add_step_counters(summary, *run.scene.current().step);  // the scene in use at the end
  summary.wall_s = MPI_Wtime() - t_start;
  add_earlier_work(summary, run.earlier);  // a restarted run's summary covers the whole run
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
  int sig = (int)g_stop_signal, any_sig;
  MPI_Allreduce(&sig, &any_sig, 1, MPI_INT, MPI_MAX, comm);
  if (any_sig) summary.signal = any_sig == SIGTERM ? "SIGTERM" : "SIGUSR1";
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
    for (auto& w : run.writers) w->end_run(summary);
  } catch (const std::exception& e) {
    add(e);
  }
  if (rank == 0 && have_dir) {
    try {
      run.log.flush();  // the rows of a frame that stopped the run
      for (auto& l : run.term_logs)
        if (l) l->flush();
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
    PetscPrintf(comm, "hyperqn: error: %s\n", e.what());
    ok = false;
  }
  if (!ok) return 1;
  if (run.interrupted) return kExitInterrupted;
  return summary.status.rfind("inverted", 0) == 0 ? kExitInverted : 0;
}

}  // namespace hyperqn

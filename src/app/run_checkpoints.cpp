#include "app/run_checkpoints.hpp"

#include <csignal>
#include <cstdio>

#include "app/simulation.hpp"
#include "io/log_events.hpp"

namespace hyperqn {

// SIGTERM and SIGUSR1 (a batch system's notice, docker/hyperqn.slurm), and SIGINT (Ctrl-C at a
// terminal) ask the run to stop with a checkpoint of its last whole frame; a second SIGINT ends the
// process at once (the system's default, restored by the first). The handler only records the signal (async-signal-safe,
// solvers/stop_request.hpp); the ranks agree on it at the next evaluation of g during a frame's
// solve (which then ends), or between frames once per frame (Checkpointer::after_frame).
extern "C" void on_stop_signal(int sig) { record_stop_signal(sig); }
void catch_stop_signals() {
  struct sigaction action = {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // blocking calls (MPI, file writes) go on
  sigaction(SIGTERM, &action, nullptr);
  sigaction(SIGUSR1, &action, nullptr);
  action.sa_flags |= SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
}

Checkpointer::Checkpointer(const RunContext& run, const Setup& setup) : run_(run), setup_(setup) {
  if (setup.restarted) {
    last_checkpoint_wtime_ = MPI_Wtime();
    last_checkpoint_frame_ = run.state.frame;
  }
}

// A signal during setup: the run stops before its first frame, with a checkpoint of its start.
PetscErrorCode Checkpointer::begin(LoopControl& control) {
  const int frame = run_.state.frame;
  PetscFunctionBeginUser;
  if (frame == setup_.options.signal_after_frame) raise(SIGTERM);  // test hook
  PetscCall(stop_for_signal(stop_signal_on_any_rank(run_.comm), frame));
  control.interrupted = interrupted_;
  PetscFunctionReturn(0);
}

PetscErrorCode Checkpointer::after_frame(const FrameOutcome& outcome, LoopControl& control) {
  const int frame = outcome.frame;
  int rank;
  PetscFunctionBeginUser;
  if (!control.stop.empty()) PetscFunctionReturn(0);
  MPI_Comm_rank(run_.comm, &rank);
  const CheckpointSpec& c = run_.deck.checkpoint;
  if (frame == setup_.options.signal_after_frame) raise(SIGTERM);  // test hook
  if (frame == setup_.options.rank_error_after_frame) {  // test hook
    int size;
    MPI_Comm_size(run_.comm, &size);
    PetscCheck(rank != size - 1, PETSC_COMM_SELF, PETSC_ERR_LIB, "-hyperqn_test_rank_error_after_frame %d", frame);
  }
  int local[2] = {stop_signal(), 0}, global[2];
  if (rank == 0) local[1] = c.seconds > 0 && MPI_Wtime() - last_checkpoint_wtime_ >= c.seconds;  // one clock decides
  PetscCallMPI(MPI_Allreduce(local, global, 2, MPI_INT, MPI_MAX, run_.comm));
  if (global[1] || (c.every > 0 && frame % c.every == 0)) PetscCall(write_checkpoint());
  PetscCall(stop_for_signal(global[0], frame));
  control.interrupted = interrupted_;
  if (frame == setup_.options.kill_after_frame) raise(SIGKILL);  // test hook
  PetscFunctionReturn(0);
}

// A checkpoint of the state after `frame` unless one was just written, and the run ends as
// interrupted. After the last frame the run is done anyway.
PetscErrorCode Checkpointer::stop_for_signal(int sig, int frame) {
  PetscFunctionBeginUser;
  if (sig == 0 || frame >= run_.deck.time.frames) PetscFunctionReturn(0);
  if (last_checkpoint_frame_ != frame) PetscCall(write_checkpoint());
  interrupted_ = true;
  run_.summary.status = std::string("interrupted: ") + stop_signal_name(sig) + " after frame " + std::to_string(frame) +
                        " of " + std::to_string(run_.deck.time.frames) +
                        "; a checkpoint was written: continue with --restart latest";
  PetscFunctionReturn(0);
}

PetscErrorCode Checkpointer::before_frame(int frame) {
  PetscFunctionBeginUser;
  frame_ = frame;
  iterations_ = 0;
  PetscFunctionReturn(0);
}

void Checkpointer::watch(const IterationRecord& r) {
  if (r.iteration == 0 || frame_ != setup_.options.signal_in_frame) return;
  if (++iterations_ != setup_.options.signal_at_iteration) return;
  int rank, size;
  MPI_Comm_rank(run_.comm, &rank);
  MPI_Comm_size(run_.comm, &size);
  if (rank == size - 1) raise(SIGTERM);  // test hook: one rank only, the others learn it from it
}

// The frame whose solve a signal ended is undone: the state is the frame before's, of which a
// checkpoint is written unless there is one.
PetscErrorCode Checkpointer::interrupted(const FrameOutcome& outcome) {
  const int frame = outcome.frame, done = run_.state.frame;
  PetscFunctionBeginUser;
  const int any = stop_signal_on_any_rank(run_.comm);  // which signal: once, at the end
  if (last_checkpoint_frame_ != done) PetscCall(write_checkpoint());
  interrupted_ = true;
  char text[200];
  std::snprintf(text, sizeof text,
                "interrupted: %s during frame %d of %d (its solve stopped after %lld iterations, %.3g s, and was undone); ",
                stop_signal_name(any), frame, run_.deck.time.frames, (long long)outcome.lead.solve.iterations,
                outcome.lead.solve.seconds);
  run_.summary.status = text + std::string("frame ") + std::to_string(done) +
                        " is the last done and checkpointed: continue with --restart latest";
  PetscFunctionReturn(0);
}

// The terms' element states (EnergyTerm::element_state) as a checkpoint's plain rows, their
// current values or (values false) only their names, widths and ids.
static std::vector<ElementRows> element_rows(const Body& body, bool values = true) {
  std::vector<ElementRows> rows;
  for (const ElementState* s : body.element_states())
    rows.push_back({s->name(), s->per_element(), s->ids(), values ? s->current_values() : std::vector<double>()});
  return rows;
}

// The run's state, the scene's identity and the counters so far into a checkpoint.
PetscErrorCode Checkpointer::write_checkpoint() {
  const Scene& s = run_.scene.current();
  const State& state = run_.state;
  int size;
  PetscFunctionBeginUser;
  MPI_Comm_size(run_.comm, &size);
  CheckpointHeader h = setup_.identity;
  h.ranks = size;
  h.frame = state.frame;
  h.time = state.time;
  h.body_time = s.body->time();
  h.dofs = s.mesh.global_dofs;
  h.released = state.released;
  h.released_attachments = state.released_attachments;
  h.cuts = run_.scene.cut_history();
  h.breaks = run_.scene.break_history();
  if (!h.cuts.empty() || !h.breaks.empty()) {  // the cut mesh's vertices (a restart replays the cuts before it compares)
    long long slots = 0;
    for (int64_t id : s.mesh.vertex_ids) slots = std::max<long long>(slots, id + 1);
    MPI_Allreduce(MPI_IN_PLACE, &slots, 1, MPI_LONG_LONG, MPI_MAX, run_.comm);
    h.vertex_slots = slots;
    h.vertices = s.mesh.global_vertices;
    h.cuts_factored = run_.scene.factored_batches();
    h.breaks_factored = run_.scene.factored_breaks();
    h.cut_batches = run_.scene.cut_batches();
    h.break_batches = run_.scene.break_batches();
    h.cuts_resolved = run_.scene.resolved_after(state.frame);
    h.changes_decided = run_.scene.changes_decided_after(state.frame);
  }
  h.started_inverted = setup_.started_inverted;
  h.summary = run_.summary;
  read_log_events(h.summary);
  h.summary.wall_s = MPI_Wtime() - setup_.t_start;
  add_earlier_work(h.summary, setup_.earlier);
  add_step_counters(h.summary, *s.step);  // as at the end of a run
  h.summary.cut_h0_corrections += run_.scene.cut_counts().corrections;  // (0 in the summary until the run's end)
  h.summary.cut_refactorizations += run_.scene.cut_counts().refactorizations;
  h.summary.break_h0_corrections += run_.scene.break_counts().corrections;
  h.summary.break_refactorizations += run_.scene.break_counts().refactorizations;
  h.summary.faces_broken += run_.scene.cut_counts().broken;
  if (h.summary.first_break_frame < 0) h.summary.first_break_frame = run_.scene.cut_counts().first_broken;
  for (const auto& w : setup_.frames.writers())
    if (!w->restart_key().empty()) h.writers.emplace_back(w->restart_key(), w->restart_state());
  for (const auto& kept : setup_.frames.kept_series()) h.writers.push_back(kept);
  h.history = state.x_prev ? 1 : 0;
  h.substep_halvings = state.substeps.halvings;
  h.substep_kept = state.substeps.kept;
  h.substep_hold = state.substeps.hold;
  h.substep_trying = state.substeps.trying;
  VertexRows rows(h.vertex_sets());
  PetscCall(s.body->local_positions(state.x, rows[0]));
  PetscCall(s.body->local_velocities(state.v, rows[1]));
  if (h.history) {
    PetscCall(s.body->local_positions(state.x_prev, rows[2]));
    PetscCall(s.body->local_velocities(state.v_prev, rows[3]));
  }
  setup_.logs.flush();  // the logs on disk reach the checkpoint's frame: a restart cuts them there
  PetscCall(event_begin(&LogEvents::checkpoint));
  const std::string path = setup_.store.write(h, s.mesh, rows, element_rows(*s.body));
  PetscCall(event_end(&LogEvents::checkpoint));
  last_checkpoint_wtime_ = MPI_Wtime();
  last_checkpoint_frame_ = state.frame;
  PetscCall(PetscPrintf(run_.comm, "hyperqn: checkpoint %s\n", path.c_str()));
  PetscFunctionReturn(0);
}

PetscErrorCode resume_state(MPI_Comm comm, const std::string& path, const CheckpointHeader& h, const Scene& scene,
                            State& state) {
  PetscFunctionBeginUser;
  PetscCall(state.create(scene.step->layout()));
  state.frame = h.frame;
  state.time = h.time;
  state.released = h.released;
  state.released_attachments = h.released_attachments;
  state.substeps = SubstepMemory{h.substep_halvings, h.substep_kept, h.substep_hold, h.substep_trying != 0};
  VertexRows rows;
  PetscCall(read_checkpoint_vertices(comm, path, scene.mesh, h, rows));
  PetscCall(scene.body->resume(h.body_time, rows[0], rows[1], state.x, state.v));
  if (h.history) {
    PetscCall(VecDuplicate(state.x, &state.x_prev));
    PetscCall(VecDuplicate(state.v, &state.v_prev));
    PetscCall(scene.body->free_values(rows[2], state.x_prev));
    PetscCall(scene.body->free_values(rows[3], state.v_prev));
  }
  std::vector<ElementRows> elements = element_rows(*scene.body, false);
  PetscCall(read_checkpoint_elements(comm, path, h, elements));
  const std::vector<ElementState*> states = scene.body->element_states();
  for (size_t k = 0; k < states.size(); ++k) states[k]->restore(std::move(elements[k].values));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

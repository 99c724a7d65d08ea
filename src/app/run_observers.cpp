#include "app/run_observers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/log_events.hpp"
#include "model/time_integrator.hpp"
#include "mesh/input_error.hpp"
#include "io/console.hpp"

namespace hyperqn {

namespace {

double global_min(MPI_Comm comm, const std::vector<double>& v) {
  double local = HUGE_VAL, global;
  for (double x : v) local = std::fmin(local, x);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, comm);
  return global;
}

}  // namespace

void read_log_events(RunSummary& s) {
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

void add_step_counters(RunSummary& summary, const StepObjective& step) {
  summary.rejected_evaluations += step.rejected_evaluations();
  summary.pulled_back_guesses += step.pulled_back_guesses();
  summary.euler_completed_steps += step.euler_completed_steps();
}

// --- ProgressLog

// A new run's P_0 (at frame 0: also a restart from a checkpoint written during setup, whose state
// is frame 0's); a restart's comes from its checkpoint.
PetscErrorCode ProgressLog::begin(LoopControl&) {
  double mass_speed;
  PetscFunctionBeginUser;
  if (run_.summary.free_scene && run_.state.frame == 0) PetscCall(measure_momentum(0));
  else if (run_.summary.free_scene) PetscCall(run_.scene.current().step->momentum(run_.state.v, momentum_now_, &mass_speed));
  PetscFunctionReturn(0);
}

PetscErrorCode ProgressLog::measure_momentum(int frame) {
  RunSummary& summary = run_.summary;
  std::array<double, 3> P;
  double mass_speed;
  PetscFunctionBeginUser;
  PetscCall(run_.scene.current().step->momentum(run_.state.v, P, &mass_speed));
  momentum_now_ = P;
  if (frame == 0) summary.momentum0 = P;
  const double drift = std::hypot(P[0] - summary.momentum0[0], P[1] - summary.momentum0[1], P[2] - summary.momentum0[2]);
  if (drift > summary.momentum_drift) {  // (false once unknown: NaN)
    summary.momentum_drift = drift;
    summary.momentum_drift_frame = frame;
  }
  summary.momentum_scale = std::fmax(summary.momentum_scale, mass_speed);
  PetscFunctionReturn(0);
}

PetscErrorCode ProgressLog::scene_changed(const Scene& old_scene, Scene& fresh) {
  RunSummary& summary = run_.summary;
  PetscFunctionBeginUser;
  if (summary.free_scene) {  // what the change took away (a kerf's tets, with their momentum) is no solve's error
    std::array<double, 3> P;
    double mass_speed;
    PetscCall(fresh.step->momentum(run_.state.v, P, &mass_speed));
    for (int d = 0; d < 3; ++d) summary.momentum0[d] += P[d] - momentum_now_[d];
    momentum_now_ = P;
  }
  add_step_counters(summary, *old_scene.step);
  summary.dofs = fresh.mesh.global_dofs;
  summary.fixed_vertices = fresh.mesh.global_fixed_vertices;
  // The factor in use from here on (followed or factored again), as a restart from here sets up.
  if (const FactoredSystem* h0 = fresh.constant_matrix(run_.deck.solver)) {
    summary.h0_factor_nonzeros = h0->factor_nonzeros();
    summary.h0_interface = h0->interface_size();
  }
  PetscCall(PetscPrintf(run_.comm, "t = %g: %s\n", run_.state.time, run_.scene.last_change(summary.dofs).c_str()));
  PetscFunctionReturn(0);
}

PetscErrorCode ProgressLog::before_frame(int frame) {
  PetscFunctionBeginUser;
  frame_ = frame;
  frame_start_ = MPI_Wtime();
  next_line_ = frame_start_ + progress_seconds_;
  PetscFunctionReturn(0);
}

// Iteration numbers start again at each stage of the fallback chain (sub-steps, Newton).
void ProgressLog::watch(const IterationRecord& r) {
  if (progress_seconds_ <= 0) return;
  const double now = MPI_Wtime();
  if (now < next_line_) return;
  int rank;
  MPI_Comm_rank(run_.comm, &rank);
  if (rank == 0)
    PetscPrintf(PETSC_COMM_SELF, "frame %5d  solving: it %4d  g %+.9e  |grad| %.3e  %.1f s so far\n", frame_,
                (int)r.iteration, r.energy, r.grad_norm, now - frame_start_);
  next_line_ = now + progress_seconds_;
}

// The frame a stop signal ended is not done: one line says so (the counters stay the frame before's).
PetscErrorCode ProgressLog::interrupted(const FrameOutcome& outcome) {
  PetscFunctionBeginUser;
  PetscCall(PetscPrintf(run_.comm, "frame %5d  interrupted by a stop signal after %d iterations, %.2f ms: given up\n",
                        outcome.frame, (int)outcome.lead.solve.iterations, 1e3 * outcome.lead.solve.seconds));
  PetscFunctionReturn(0);
}

// Guardrails: a frame whose solver could not decrease g is flagged (progress line, summary's
// flagged_frames and status) and the run goes on from its last accepted iterate.
PetscErrorCode ProgressLog::after_frame(const FrameOutcome& outcome, LoopControl&) {
  const int frame = outcome.frame;
  const MPI_Comm comm = run_.comm;
  RunSummary& summary = run_.summary;
  const StepSolve& step = outcome.lead.solve;
  const FrameResult& r = step.result;
  const std::string& why = outcome.lead.stop;  // the guardrails (app/frame_step.hpp); the frame has ended if empty
  PetscFunctionBeginUser;
  if (step.restarted)
    PetscCall(PetscPrintf(comm, "frame %5d  g is not finite at the inertial warm start y; started again from x_n\n", frame));
  const double ms = 1e3 * step.seconds;
  summary.evaluations += step.evaluations;
  summary.iterations += step.iterations;
  summary.extended_frames += step.extended;
  summary.substepped_frames += step.substeps > 1;
  summary.kept_substep_frames += step.kept_substeps;
  summary.newton_frames += step.newton;
  summary.converged_frames += r.converged;
  summary.failed_frames += r.failed;
  summary.ls_failures += r.ls_failures;
  if (r.failed) summary.flagged_frames.emplace_back(frame, r.reason);
  const bool unresolved = step.unresolved && !r.failed;  // (a failure is flagged as such)
  if (unresolved) {
    char residual[32];
    std::snprintf(residual, sizeof residual, "%.3g", step.residual);
    summary.flagged_frames.emplace_back(frame, std::string(kFarFromConverged) + " (" + r.reason + ", |grad g| " +
                                                   residual + " of the force scale)");
  }
  // A solver that was given no iteration (e.g. -tao_max_it 0) did not solve the frame.
  if (!r.failed && !r.converged && r.iterations == 0) {
    ++summary.failed_frames;
    summary.flagged_frames.emplace_back(frame, "the solver took no iteration (" + r.reason + ")");
  }
  const bool finite_g = !Objective::rejected(r.energy) && std::isfinite(r.grad_norm);
  if (why.empty()) {
    inverted_now_ = outcome.lead.inverted;
    if (inverted_now_) summary.inverted_frames.push_back(frame);
    summary.min_J = std::fmin(summary.min_J, outcome.lead.min_J);
    if (step.residual > summary.max_residual) {
      summary.max_residual = step.residual;
      summary.max_residual_frame = frame;
    }
    if (summary.free_scene) PetscCall(measure_momentum(frame));
  }

  std::string note;
  if (step.substeps > 1) note += "  [" + std::to_string(step.substeps) + (step.kept_substeps ? " sub-steps, kept]" : " sub-steps]");
  if (step.newton) note += "  [newton fallback]";
  if (step.iterations != r.iterations) note += "  [" + std::to_string(step.iterations) + " iterations in all]";
  if (r.ls_failures > 0) note += "  [" + std::to_string(r.ls_failures) + " line-search failure(s)]";
  if (r.failed && why.empty()) note += "  FLAGGED: g could not be decreased further";
  if (unresolved && why.empty()) note += std::string("  FLAGGED: ") + kFarFromConverged;
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
  }
  PetscFunctionReturn(0);
}

// A frame that leaves no finite state, a diverged one, or one that could not be written, stops
// the run; it counts as flagged (once) and the frames done end before it.
PetscErrorCode ProgressLog::stopped(const FrameOutcome& outcome, const std::string& why) {
  RunSummary& summary = run_.summary;
  PetscFunctionBeginUser;
  if (!outcome.lead.solve.result.failed) {
    ++summary.failed_frames;
    summary.flagged_frames.emplace_back(outcome.frame, why);
  }
  summary.frames = outcome.frame - 1;
  PetscFunctionReturn(0);
}

// --- RunLogs

namespace {

const char kReactionColumns[] = "region,fx,fy,fz,mx,my,mz,px,py,pz";

// A support's force of `frame` into the summary: the last one, and the largest |force|.
void note_reaction(SupportReaction& r, int frame, const SupportForce& f) {
  r.force = f.force;
  r.moment = f.moment;
  r.point = f.point;
  const double size = std::hypot(f.force[0], f.force[1], f.force[2]);
  if (size > r.max_force || r.max_force_frame == 0) {
    r.max_force = size;
    r.max_force_frame = frame;
  }
}

// A log's row as its cells (the logs hold no quoted commas).
std::vector<std::string> csv_cells(const std::string& line) {
  std::istringstream row(line);
  std::vector<std::string> cells;
  for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
  return cells;
}

// A cell read back at a restart: true with *value if it is a finite number, nothing more.
bool finite_cell(const std::string& cell, double* value) {
  char* end = nullptr;
  *value = std::strtod(cell.c_str(), &end);
  return end != cell.c_str() && *end == '\0' && std::isfinite(*value);
}

// The summary's reactions of the frames reactions.csv holds (a restart's, cut at its frame).
void read_reactions(const std::string& path, std::vector<SupportReaction>& reactions) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = csv_cells(line);
    if (cells.size() != 12) continue;
    SupportForce f;
    for (int d = 0; d < 3; ++d) {
      f.force[d] = std::strtod(cells[3 + d].c_str(), nullptr);
      f.moment[d] = std::strtod(cells[6 + d].c_str(), nullptr);
      f.point[d] = std::strtod(cells[9 + d].c_str(), nullptr);
    }
    for (SupportReaction& r : reactions)
      if (r.name == cells[2]) note_reaction(r, std::atoi(cells[0].c_str()), f);
  }
}

// reactions.csv's rows of frames <= `frame` (a restart's, > 0): "" if each is 12 cells of numbers
// after the support's name and every support has one at `frame`; else the line that is not, or
// the support that has none.
std::string check_reactions(const std::string& path, int frame, const std::vector<std::string>& supports) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // the header
  std::set<std::string> at_frame;
  for (int number = 2; std::getline(in, line); ++number) {
    const std::vector<std::string> cells = csv_cells(line);
    if (cells.empty() || std::atoi(cells[0].c_str()) > frame) continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (cells.size() != 12) return where + "a row of " + std::to_string(cells.size()) + " cells, not 12";
    double v;
    for (size_t k = 0; k < cells.size(); ++k)
      if (k != 2 && !finite_cell(cells[k], &v)) return where + "'" + cells[k] + "' is not a finite number";  // 2: the name
    if (std::atoi(cells[0].c_str()) == frame) at_frame.insert(cells[2]);
  }
  if (frame > 0)
    for (const std::string& name : supports)
      if (!at_frame.count(name)) return path + " has no row of " + name + " at frame " + std::to_string(frame);
  return "";
}

// energy.csv's rows of frame 0 and of `frame` (a restart's): "" if it holds both, each of ten
// numbers; else what it lacks, or the line that is not such a row.
std::string read_energy(const std::string& path, int frame, EnergyRow& start, EnergyRow& at) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // the header
  bool have_start = false, have_at = false;
  for (int number = 2; std::getline(in, line); ++number) {
    const std::vector<std::string> cells = csv_cells(line);
    const int row_frame = cells.empty() ? -1 : std::atoi(cells[0].c_str());
    if (row_frame != 0 && row_frame != frame) continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (cells.size() != 10) return where + "a row of " + std::to_string(cells.size()) + " cells, not 10";
    double v[10];
    for (int k = 0; k < 10; ++k)
      if (!finite_cell(cells[k], &v[k])) return where + "'" + cells[k] + "' is not a finite number";
    const EnergyRow r{v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9]};
    if (row_frame == 0) start = r, have_start = true;
    if (row_frame == frame) at = r, have_at = true;
  }
  if (have_start && have_at) return "";
  const std::string missing = !have_start && !have_at && frame != 0 ? "frames 0 and " + std::to_string(frame)
                              : "frame " + std::to_string(have_start ? frame : 0);
  return path + " has no row of " + missing;
}

const char kTopologyColumns[] =
    "faces_separated,faces_total,vertices_added,segments_snapped,edges_torn,h0_corrections,refactorizations,tets_removed";

// The sums of topology.csv's rows of frames <= `frame` (a restart's); false if it has no row of
// `frame` itself. A file written before the column tets_removed (9 cells a row) counts 0 there.
bool read_topology(const std::string& path, int frame, long long sums[7]) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // the header
  bool have_frame = false;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = csv_cells(line);
    if ((cells.size() != 9 && cells.size() != 10) || std::atoi(cells[0].c_str()) > frame) continue;
    have_frame |= std::atoi(cells[0].c_str()) == frame;
    const int per_frame[7] = {2, 4, 5, 6, 7, 8, 9};  // faces_total is a running sum of faces_separated
    for (int k = 0; k < 7; ++k) sums[k] += per_frame[k] < (int)cells.size() ? std::atoll(cells[per_frame[k]].c_str()) : 0;
  }
  return have_frame;
}

}  // namespace

RunLogs::RunLogs(const RunContext& run) : run_(run) {
  if (run.deck.output.energy)
    energy_ = std::make_unique<EnergyBalance>(run.deck, make_integrator(run.deck.time.integrator)->time_fraction(),
                                              run.summary.dissipated_removed);
  if (!run.deck.output.reactions) return;
  reactions_ = std::make_unique<Reactions>(run.deck);
  const std::vector<std::string> names = Reactions::names(run.deck);
  const std::vector<int> lines = Reactions::lines(run.deck);
  run_.summary.reactions.clear();
  for (size_t k = 0; k < names.size(); ++k) run_.summary.reactions.push_back({names[k], lines[k]});
}

bool RunLogs::writes_topology() const {
  return run_.deck.output.topology_csv && (!run_.deck.cuts.empty() || run_.scene.fracture() || run_.scene.breaks());
}

void RunLogs::check_restart(const std::string& outdir, int restart_frame) const {
  const std::string from = " to go on from (output.";
  const std::string written = ": the checkpointed run must have written it)";
  long long sums[7] = {0, 0, 0, 0, 0, 0, 0};
  if (writes_topology() && restart_frame > 0 && !read_topology(outdir + "/topology.csv", restart_frame, sums))
    throw std::runtime_error(outdir + "/topology.csv has no row of frame " + std::to_string(restart_frame) + from +
                             "topology_csv" + written);
  EnergyRow start, at;
  if (energy_)
    if (const std::string why = read_energy(outdir + "/energy.csv", restart_frame, start, at); !why.empty())
      throw std::runtime_error(why + from + "energy" + written);
  if (reactions_ && !std::ifstream(outdir + "/reactions.csv"))
    throw std::runtime_error(outdir + "/reactions.csv is missing: no rows" + from + "reactions" + written);
  if (reactions_)
    if (const std::string why = check_reactions(outdir + "/reactions.csv", restart_frame, Reactions::names(run_.deck));
        !why.empty())
      throw std::runtime_error(why + from + "reactions" + written);
}

void RunLogs::open(const std::string& outdir, int rank, const Scene& scene, int restart_frame,
                   const RunSummary* earlier) {
  const OutputSpec& output = run_.deck.output;
  const bool restart = restart_frame >= 0;
  restarted_ = restart;
  topology_ = writes_topology();
  if (topology_) {
    const std::string path = outdir + "/topology.csv";
    if (restart) {  // check_restart found what it needs
      long long sums[7] = {0, 0, 0, 0, 0, 0, 0};
      read_topology(path, restart_frame, sums);
      topology_rows_ = {sums[0], sums[1], sums[2], sums[3], sums[4], sums[5], sums[6]};
      if (earlier)
        topology_earlier_ = {0, 0, 0, 0, earlier->cut_h0_corrections + earlier->break_h0_corrections,
                             earlier->cut_refactorizations + earlier->break_refactorizations, 0};
      topology_log_.resume(path, kTopologyColumns, rank, restart_frame, true);  // an older file's rows padded
    } else {
      topology_log_.open(path, kTopologyColumns, rank);
    }
  }
  if (energy_) {
    const std::string path = outdir + "/energy.csv";
    if (restart) {
      EnergyRow start, at;
      read_energy(path, restart_frame, start, at);
      energy_at_restart_ = at;
      energy_at_start_ = start.kinetic + start.stored + start.dissipated;
      energy_log_.resume(path, EnergyBalance::columns(), rank, restart_frame);
    } else {
      energy_log_.open(path, EnergyBalance::columns(), rank);
    }
  }
  if (reactions_) {
    const std::string path = outdir + "/reactions.csv";
    if (restart) {
      reaction_log_.resume(path, kReactionColumns, rank, restart_frame);
      read_reactions(path, run_.summary.reactions);
    } else {
      reaction_log_.open(path, kReactionColumns, rank);
    }
  }
  if (output.iterations_csv) {  // at a restart, the log as it was at the checkpoint's frame, then continued
    if (restart)
      log_.resume(outdir + "/iterations.csv", rank, restart_frame);
    else
      log_.open(outdir + "/iterations.csv", rank);
  }
  // The logs an earlier part of the run wrote and this one does not: cut back to the checkpoint's
  // frame, so that none holds rows of the abandoned trajectory (nor a later part, writing it
  // again, goes on from them).
  if (restart) {
    std::vector<std::string> unwritten;
    if (!topology_) unwritten.push_back("topology.csv");
    if (!energy_) unwritten.push_back("energy.csv");
    if (!reactions_) unwritten.push_back("reactions.csv");
    if (!output.iterations_csv) unwritten.push_back("iterations.csv");
    for (const auto& term : scene.body->terms())
      if (!term->log().file.empty() && !output.contact_csv) unwritten.push_back(term->log().file);
    for (const std::string& file : unwritten) cut_log_back(outdir + "/" + file, restart_frame, rank);
  }
  for (const auto& term : scene.body->terms()) {
    const TermLog l = term->log();
    term_logs_.emplace_back();
    if (l.file.empty() || !output.contact_csv) continue;  // contact.csv and self-contact.csv
    term_logs_.back() = std::make_unique<FrameLog>();
    if (restart)
      term_logs_.back()->resume(outdir + "/" + l.file, l.columns, rank, restart_frame);
    else
      term_logs_.back()->open(outdir + "/" + l.file, l.columns, rank);
  }
}

IterationCallback RunLogs::iterations(int frame) {
  return [this, frame](const IterationRecord& it) {
    if (!Objective::rejected(it.energy) && std::isfinite(it.grad_norm)) log_.append(frame, it);  // never NaN
    return false;
  };
}

PetscErrorCode RunLogs::share_restart(bool restart) {
  PetscFunctionBeginUser;
  restarted_ = restart;
  if (energy_ && restart) {
    EnergyRow& r = energy_at_restart_;
    double v[9] = {r.kinetic, r.stored, r.dissipated, r.released, r.gravity_work, r.load_work, r.support_work, r.residual,
                   energy_at_start_};
    PetscCallMPI(MPI_Bcast(v, 9, MPI_DOUBLE, 0, run_.comm));
    r = EnergyRow{v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]};
    energy_->resume(r, v[8]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode RunLogs::begin(LoopControl&) {
  PetscFunctionBeginUser;
  if (restarted_) PetscCall(note_dissipated());  // a restart at the run's last frame computes no frame
  if (reactions_) PetscCall(reactions_->bind(*run_.scene.current().body, run_.state));
  if (energy_) {
    PetscCall(energy_->bind(*run_.scene.current().body, run_.state));
    if (!restarted_) {  // frame 0: the energies the balance starts from
      EnergyRow row;
      PetscCall(energy_->start(run_.state, row));
      append_energy(run_.state.frame, run_.state.time, row);
      flush();
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode RunLogs::scene_changed(const Scene& old_scene, Scene& fresh) {
  PetscFunctionBeginUser;
  const bool topology = run_.scene.last_change_cut() || run_.scene.last_change_break();
  if (topology && !old_scene.body->element_states().empty()) {
    // What the elements the change took away had dissipated stays in the run's total (collective:
    // every rank's body has the same terms with history).
    double before = 0, after = 0;
    PetscCall(old_scene.body->dissipated_energy(&before));
    PetscCall(fresh.body->dissipated_energy(&after));
    run_.summary.dissipated_removed += before - after;
  }
  if (reactions_) PetscCall(reactions_->bind(*fresh.body, run_.state));
  if (energy_)
    PetscCall(energy_->rebind(*fresh.body, run_.state, topology));
  PetscFunctionReturn(0);
}

PetscErrorCode RunLogs::before_frame(int) {
  PetscFunctionBeginUser;
  if (reactions_) PetscCall(reactions_->begin_frame(run_.state));
  if (energy_) PetscCall(energy_->begin_frame(run_.state));
  PetscFunctionReturn(0);
}

void RunLogs::append_energy(int frame, double time, const EnergyRow& r) {
  char row[512];
  std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", r.kinetic, r.stored, r.dissipated,
                r.released, r.gravity_work, r.load_work, r.support_work, r.residual);
  energy_log_.append(frame, time, {row});
}

PetscErrorCode RunLogs::note_dissipated() {
  PetscFunctionBeginUser;
  const Body& body = *run_.scene.current().body;
  if (!body.element_states().empty()) {
    PetscCall(body.dissipated_energy(&run_.summary.dissipated_energy));
    run_.summary.dissipated_energy += run_.summary.dissipated_removed;
    // viscoelastic_prony's small-strain measures: the largest strain reached, and a warning the first
    // time it passes kSmallStrain (docs/viscoelastic-prony.md#dissipation-and-energy).
    constexpr double kSmallStrain = 0.05;
    double reach = -1;
    for (const auto& t : body.terms()) reach = std::max(reach, t->small_strain_reach());
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &reach, 1, MPI_DOUBLE, MPI_MAX, run_.comm));
    if (reach >= 0) {
      double& kept = run_.summary.small_strain_reach;  // a restart's from its checkpoint
      const double before = std::isnan(kept) ? 0.0 : kept;
      kept = std::max(before, reach);
      if (before < kSmallStrain && kept >= kSmallStrain)
        PetscCall(PetscPrintf(run_.comm,
                              "WARNING: viscoelastic_prony tets reached a strain |E| of %.3g: their dissipated_energy "
                              "(summary.json, energy.csv) and the branches' stored energy are small-strain measures, "
                              "not the energy lost; at this strain they may be off by more than %.0f %% of the work "
                              "(summary.json's prony_largest_strain; docs/viscoelastic-prony.md#dissipation-and-energy)\n",
                              kept, 100 * kSmallStrain));
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode RunLogs::after_frame(const FrameOutcome& outcome, LoopControl&) {
  PetscFunctionBeginUser;
  if (outcome.lead.stop.empty()) PetscCall(record_terms(outcome.frame));
  if (outcome.lead.stop.empty()) PetscCall(note_dissipated());
  if (outcome.lead.stop.empty() && reactions_) PetscCall(record_reactions(outcome.frame));
  if (outcome.lead.stop.empty() && energy_) {
    EnergyRow row;
    PetscCall(energy_->end_frame(run_.state, row));
    append_energy(outcome.frame, run_.state.time, row);
  }
  if (outcome.lead.stop.empty() && topology_) record_topology(outcome.frame);
  flush();  // also the rows of a frame that stops the run; before a checkpoint, which cuts the logs at its frame
  PetscFunctionReturn(0);
}

// As summary.json counts them (app/simulation.cpp): faces, vertices, segments and edges are the
// scene's (a restart's replay included); the H0 corrections and refactorizations of cuts and breaks
// are this run's, after those before a restart.
RunLogs::TopologyTotals RunLogs::topology_totals() const {
  const LiveScene::CutCounts& c = run_.scene.cut_counts();
  const LiveScene::BreakCounts& b = run_.scene.break_counts();
  return {c.faces, c.vertices + b.vertices, b.segments, b.edges, topology_earlier_.corrections + c.corrections + b.corrections,
          topology_earlier_.refactorizations + c.refactorizations + b.refactorizations, c.removed};
}

// topology.csv's row of the frame: what changed since the row before (at a restart, since the
// rows up to its frame: a change at the start of a frame that a signal gave up, which the
// checkpoint holds, is in the row of the frame redone).
void RunLogs::record_topology(int frame) {
  const TopologyTotals now = topology_totals(), &before = topology_rows_;
  char row[256];
  std::snprintf(row, sizeof row, "%lld,%lld,%lld,%lld,%lld,%lld,%lld,%lld", now.faces - before.faces, now.faces,
                now.vertices - before.vertices, now.segments - before.segments, now.edges - before.edges,
                now.corrections - before.corrections,
                now.refactorizations - before.refactorizations, now.removed - before.removed);
  topology_log_.append(frame, run_.state.time, {row});
  topology_rows_ = now;
}

void RunLogs::write_rows() {
  log_.flush();
  reaction_log_.flush();
  energy_log_.flush();
  topology_log_.flush();
  for (auto& l : term_logs_)
    if (l) l->flush();
}

void RunLogs::flush() {
  std::string error;
  try {
    write_rows();
  } catch (const std::exception& e) {
    error = e.what();
  }
  throw_if_any_failed(run_.comm, error);
}

// Per frame: what the terms with a log of their own report (EnergyTerm::report: contact.csv's
// rows, the summary's contact maxima, and a warning for each flag, counted in the summary);
// nothing at all in a scene without such a term.
PetscErrorCode RunLogs::record_terms(int frame) {
  const Scene& s = run_.scene.current();
  bool have_positions = false;
  PetscFunctionBeginUser;
  const auto& terms = s.body->terms();
  for (size_t t = 0; t < terms.size(); ++t) {
    if (terms[t]->log().file.empty()) continue;
    if (!have_positions) PetscCall(s.body->local_positions(run_.state.x, pos_));
    have_positions = true;
    TermReport r;
    PetscCall(terms[t]->report(pos_, r));
    if (t < term_logs_.size() && term_logs_[t]) term_logs_[t]->append(frame, run_.state.time, r.rows);
    for (const auto& [name, value] : r.maxima) raise_summary_maximum(run_.summary, name, value);
    for (const auto& [name, what] : r.flags) {
      count_summary_flag(run_.summary, name, frame, what);
      PetscCall(PetscPrintf(run_.comm, "frame %5d  WARNING: %s\n", frame, what.c_str()));
    }
  }
  PetscFunctionReturn(0);
}

// reactions.csv's rows of the frame (one per support, in the deck's order) and the summary's.
PetscErrorCode RunLogs::record_reactions(int frame) {
  std::vector<SupportForce> forces;
  PetscFunctionBeginUser;
  PetscCall(reactions_->end_frame(run_.state, forces));
  std::vector<std::string> rows;
  for (size_t k = 0; k < forces.size(); ++k) {
    const SupportForce& f = forces[k];
    char row[512];
    std::snprintf(row, sizeof row, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", f.force[0], f.force[1],
                  f.force[2], f.moment[0], f.moment[1], f.moment[2], f.point[0], f.point[1], f.point[2]);
    rows.push_back(run_.summary.reactions[k].name + row);
    note_reaction(run_.summary.reactions[k], frame, f);
  }
  reaction_log_.append(frame, run_.state.time, rows);
  PetscFunctionReturn(0);
}

// --- FrameWriters

bool check_element_fields(MPI_Comm comm, const Deck& deck, const Scene& scene) {
  const std::vector<std::string>& asked = deck.output.fields;
  const std::vector<std::string> names = element_field_names();
  std::vector<int> given(names.size(), 0);
  for (const auto& term : scene.body->terms())
    for (ElementField f : term->element_fields()) given[size_t(f)] = 1;
  MPI_Allreduce(MPI_IN_PLACE, given.data(), (int)given.size(), MPI_INT, MPI_MAX, comm);
  for (size_t i = 0; i < asked.size(); ++i) {
    const size_t f = size_t(std::find(names.begin(), names.end(), asked[i]) - names.begin());
    if (given.at(f)) continue;
    const InputError error(deck.path, deck.output.field_lines.at(i), "output.fields[" + std::to_string(i) + "]",
                           asked[i] + " is a field of " + element_field_infos()[f].elements + ", and the scene has none");
    print_error(comm, error.what());
    return false;
  }
  return true;
}

PetscErrorCode FrameWriters::begin(LoopControl&) {
  const State& state = run_.state;
  PetscFunctionBeginUser;
  if (restarted_) {  // as if the run had not stopped
    last_written_ = state.frame % run_.deck.output.every == 0 ? state.frame : -1;
    // A restart at its last frame steps none, and the last frame is always written: where the
    // run that wrote the checkpoint did not write it (it went on past it), it is written now.
    if (state.frame == run_.deck.time.frames) {
      bool written;
      PetscCall(write_frame(state.frame, &written, true));
    }
  } else {
    bool written;
    PetscCall(write_frame(0, &written));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode FrameWriters::scene_changed(const Scene&, Scene& fresh) {
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&field_));  // the layout changed
  for (auto& w : writers_) w->set_mesh(fresh.mesh);
  PetscFunctionReturn(0);
}

PetscErrorCode FrameWriters::after_frame(const FrameOutcome& outcome, LoopControl& control) {
  const int frame = outcome.frame;
  PetscFunctionBeginUser;
  if (!control.stop.empty() || (frame % run_.deck.output.every != 0 && frame != run_.deck.time.frames))
    PetscFunctionReturn(0);
  bool written;
  PetscCall(write_frame(frame, &written));
  if (!written) control.stop = "non-finite positions, velocities or J";
  PetscFunctionReturn(0);
}

PetscErrorCode FrameWriters::stopped(const FrameOutcome& outcome, const std::string&) {
  PetscFunctionBeginUser;
  if (last_written_ != outcome.frame - 1) {
    bool written;
    PetscCall(write_frame(outcome.frame - 1, &written));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode FrameWriters::write_frame(int frame, bool* written, bool unlisted_only) {
  const Scene& s = run_.scene.current();
  const State& state = run_.state;
  const MPI_Comm comm = run_.comm;
  PetscFunctionBeginUser;
  PetscCall(s.body->local_positions(state.x, pos_));
  PetscCall(s.body->local_velocities(state.v, vel_));
  s.body->cell_jacobians(pos_, J_);
  int local = 1, finite;
  for (const auto* values : {&pos_, &vel_, &J_})
    for (double a : *values) local &= std::isfinite(a) ? 1 : 0;
  PetscCallMPI(MPI_Allreduce(&local, &finite, 1, MPI_INT, MPI_MIN, comm));
  *written = finite == 1;
  if (!*written) PetscFunctionReturn(0);
  run_.summary.min_J = std::fmin(run_.summary.min_J, global_min(comm, J_));
  FrameData f{frame, frame * run_.deck.time.dt, &state, &pos_, &vel_, &J_, {}, {}};
  std::vector<std::string> names;
  for (const auto& term : s.body->terms())
    for (const std::string& name : term->point_fields()) {
      if (!field_) PetscCall(VecDuplicate(state.x, &field_));
      PetscCall(term->point_field(name, pos_, field_));
      field_values_.resize(names.size() + 1);
      PetscCall(s.body->local_values(field_, field_values_.back()));
      names.push_back(name);
    }
  for (size_t k = 0; k < names.size(); ++k) f.point_fields.emplace_back(names[k], &field_values_[k]);
  PetscCall(event_begin(&LogEvents::output));
  const std::vector<std::string>& asked = run_.deck.output.fields;
  if (!asked.empty() && !writers_.empty()) {  // each term fills its own elements; NaN where none does
    const std::vector<std::string> all = element_field_names();
    const size_t elements = size_t(s.mesh.num_cells + s.mesh.num_segments + s.mesh.num_triangles);
    element_values_.resize(asked.size());
    for (size_t i = 0; i < asked.size(); ++i) {
      element_values_[i].field = ElementField(std::find(all.begin(), all.end(), asked[i]) - all.begin());
      element_values_[i].values.assign(field_info(element_values_[i].field).components * elements, NAN);
    }
    PetscCall(event_begin(&LogEvents::fields));
    for (const auto& term : s.body->terms()) term->fill_element_fields(pos_, element_values_);
    PetscCall(event_end(&LogEvents::fields));
    for (size_t i = 0; i < asked.size(); ++i)
      f.element_fields.push_back({asked[i], field_info(element_values_[i].field).components, &element_values_[i].values,
                                  run_.deck.output.field_precision == FieldPrecision::single_precision});
  }
  for (auto& w : writers_)
    if (!unlisted_only || !w->lists_frame(frame)) w->write_frame(f);
  PetscCall(event_end(&LogEvents::output));
  last_written_ = frame;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

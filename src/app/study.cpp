#include "app/study.hpp"

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <cmath>
#include <sstream>
#include <functional>
#include <memory>

#include "app/frame_step.hpp"
#include "app/simulation.hpp"
#include "app/time_loop.hpp"
#include "app/run_options.hpp"
#include "app/petsc_errors.hpp"
#include "model/scene.hpp"
#include "solvers/solver_registry.hpp"
#include "solvers/stop_request.hpp"
#include "io/atomic_file.hpp"
#include "io/output_directory.hpp"
#include "io/study_writer.hpp"
#include "io/console.hpp"

namespace hyperqn {

namespace {

// What study.json's "material" says: the mesh's model, or each body's ("ball: neohookean, bar: hencky").
std::string material_label(const Deck& deck) {
  const auto of = [](const MeshSpec& mesh, const ClothSpec& cloth, bool has_material, const MaterialSpec& material) {
    if (mesh.has_cloth()) return "cloth " + kClothModelNames[size_t(cloth.model)];
    if (!has_material && mesh.has_strands()) return std::string("strands");
    // with its inelastic block ("hencky + plastic"): the report tells it from the elastic model
    return material.model + (material.inelastic.kind.empty() ? "" : " + " + material.inelastic.kind);
  };
  if (deck.bodies.empty()) return of(deck.mesh, deck.cloth, true, deck.material);
  std::string label;
  for (const BodySpec& b : deck.bodies)
    label += (label.empty() ? "" : ", ") + b.name + ": " + of(b.mesh, b.cloth, b.has_material, b.material);
  return label;
}

// A solver under study: one instance for the per-frame comparison, one at its trajectory
// budget with its own state.
struct Contender {
  std::string type;
  std::unique_ptr<TimeStepSolver> per_frame, trajectory;
  State state;
  double time_s = 0;
  long long iterations = 0;
};

// One frame of s with the solver alone at its budget (no fallback chain: the study compares
// solvers at fixed budgets), through the run's guardrails (app/frame_step.hpp). If f.stop says
// s cannot go on, the step is undone.
PetscErrorCode advance(FrameStepper& stepper, const Scene& scene, TimeStepSolver& solver, State& s,
                       const IterationCallback& cb, FrameStep& f) {
  StepObjective& objective = *scene.step;
  PetscFunctionBeginUser;
  const FrameSolve solve = [&](State& st, const IterationCallback& c, StepSolve& out) {
    return objective.solve_step(solver, st, c, out);
  };
  PetscCall(stepper.step(scene, solve, s, cb, f));
  if (!f.stop.empty()) PetscCall(objective.lifecycle().undo(s));
  PetscFunctionReturn(0);
}

SolverSpec spec_for(const Deck& deck, const std::string& type, int iterations, double rtol) {
  SolverSpec s = deck.solver;
  s.type = type;
  s.iterations = iterations;
  s.grad_atol = 0;
  s.grad_rtol = rtol;
  use_fixed_budget(s);  // no fallback chain: the study compares solvers at fixed budgets
  return s;
}

// study.json: what the report needs to label the study; `stopped` (if not empty) says that a signal
// ended it early and after which frame its files end.
void write_study_meta(const std::string& outdir, const Deck& deck, const Scene& scene, const std::string& stopped = "") {
  int size;
  MPI_Comm_size(PetscObjectComm((PetscObject)scene.mesh.dm), &size);
  std::ostringstream out;
  const char* integrator = integrator_info(deck.time.integrator).name;
  double factor_s = 0;  // the factors' time (a V-cycle factors nothing)
  for (const auto& [h0, matrix] : scene.constant_matrices)
    if (h0 != H0::amg) factor_s += matrix->factor_seconds();
  out << "{\n  \"title\": \"" << deck.name << (deck.study.integrators.empty() ? "" : std::string(", ") + integrator)
      << " (" << size << (size == 1 ? " rank" : " ranks") << ")\",\n"
      << "  \"integrator\": \"" << integrator << "\",\n"
      << "  \"deck\": \"" << deck.path << "\",\n  \"material\": \"" << material_label(deck) << "\",\n"
      << "  \"ranks\": " << size << ",\n  \"vertices\": " << scene.mesh.global_vertices << ",\n"
      << "  \"tets\": " << scene.mesh.global_cells << ",\n  \"segments\": " << scene.mesh.global_segments << ",\n"
      << "  \"triangles\": " << scene.mesh.global_triangles << ",\n"
      << "  \"dt\": " << deck.time.dt << ",\n"
      << (stopped.empty() ? std::string() : "  \"stopped\": \"" + stopped + "\",\n")
      << "  \"factor_s\": "
      << factor_s << "\n}\n";
  write_file_atomically(outdir + "/study.json", out.str());
}

// Everything a study holds while it runs.
struct Study {
  MPI_Comm comm;
  const Deck& deck;
  LiveScene scene;
  std::unique_ptr<TimeStepSolver> reference;
  std::vector<std::unique_ptr<Contender>> contenders;
  State ref, probe;  // the converged trajectory; a per-frame start copied from it
  Guardrails limits;
  std::string failure;  // why the converged reference could not go on ("": it could)
  std::string signal;   // the stop signal that ended the study early ("": none)
  int last_frame = 0;   // the last frame whose rows the files hold
  int signal_after_frame = -1;  // test hook: -hyperqn_test_signal_after_frame raises SIGTERM after it

  Study(MPI_Comm c, const Deck& d) : comm(c), deck(d) {}

  // The reference's cap: study.iterations, at least 100 (Newton with the exact Hessian converges
  // in far fewer; the cap is met only where it cannot reach reference_rtol).
  int reference_iterations() const { return std::max(deck.study.iterations, 100); }

  // The reference solver and every contender's two solvers, on scene s.
  PetscErrorCode make_solvers(Scene& s) {
    const StudySpec& st = deck.study;
    PetscFunctionBeginUser;
    // The reference: Newton with the exact Hessian converges quadratically (the PSD fix would
    // make it linear wherever it is active near the solution).
    SolverSpec spec = spec_for(deck, "newton", reference_iterations(), st.reference_rtol);
    spec.newton_hessian = NewtonHessian::exact;
    PetscCall(create_solver(spec, *s.step, nullptr, reference));
    for (auto& c : contenders) {
      auto budget = st.trajectory_iterations.find(c->type);
      const int traj_its = budget != st.trajectory_iterations.end() ? budget->second : deck.solver.iterations;
      const SolverSpec per_frame = spec_for(deck, c->type, st.iterations, st.reference_rtol);
      SolverSpec trajectory = spec_for(deck, c->type, traj_its, deck.solver.grad_rtol);
      trajectory.quiet = true;  // the same solver as per_frame's, which has said what it runs
      PetscCall(create_solver(per_frame, *s.step, s.constant_matrix(per_frame), c->per_frame));
      PetscCall(create_solver(trajectory, *s.step, s.constant_matrix(trajectory), c->trajectory));
    }
    PetscFunctionReturn(0);
  }

  // After a release, a cut or a break: the solvers move to the new scene; a trajectory's time
  // includes what its solver's H0 took to follow (a factorization, or a TopologyH0 correction).
  // The scene's rebuild is common to every solver and not charged.
  PetscErrorCode rebind(const Scene&, Scene& fresh) {
    PetscFunctionBeginUser;
    for (auto& c : contenders) {
      c->per_frame.reset();
      c->trajectory.reset();
      if (const FactoredSystem* h0 = fresh.constant_matrix(spec_for(deck, c->type, 1, 0))) c->time_s += h0->factor_seconds();
    }
    reference.reset();
    PetscCall(make_solvers(fresh));
    PetscCall(PetscPrintf(comm, "study: t = %g: %s\n", ref.time, scene.last_change(fresh.mesh.global_dofs).c_str()));
    PetscFunctionReturn(0);
  }

  PetscErrorCode run(StudyWriter& out);
};

// How far the converged reference may end above the lowest g any solver reached, as a share of
// g(x0) - g*, before the study warns: far above its round-off (it converges to reference_rtol).
constexpr double kReferenceAboveLowest = 1e-6;

// The per-frame comparison (study.csv, study.h5): at each frame of study.frames, before the
// reference steps, every solver solves the frame from the reference's state; the reference's own
// solve of the frame gives g*.
class FrameComparison : public FrameObserver {
 public:
  FrameComparison(Study& study, StudyWriter& out) : study_(study), out_(out), stepper_(study.limits) {}

  PetscErrorCode scene_changed(const Scene&, Scene&) override {
    warmed_up_ = false;  // new solvers
    return 0;
  }

  PetscErrorCode before_frame(int frame) override {
    const std::vector<int>& frames = study_.deck.study.frames;
    const Scene& scene = study_.scene.current();
    PetscFunctionBeginUser;
    compare_here_ = std::find(frames.begin(), frames.end(), frame) != frames.end();
    curves_.clear();
    if (!compare_here_) PetscFunctionReturn(0);
    // Each solve starts from the reference's element history too, and the reference keeps it.
    const std::vector<ElementState> elements = scene.body->copy_element_states();
    const auto from_reference = [&](TimeStepSolver& solver, const IterationCallback& cb, FrameStep& f) {
      PetscFunctionBeginUser;
      PetscCall(study_.probe.copy_from(study_.ref));
      scene.body->set_element_states(elements);
      PetscCall(advance(stepper_, scene, solver, study_.probe, cb, f));
      PetscFunctionReturn(0);
    };
    // One untimed run first, so one-time costs (allocations, Newton's symbolic analysis) are not
    // charged to the first compared frame.
    if (!warmed_up_) {
      for (auto& c : study_.contenders) {
        FrameStep f;
        PetscCall(from_reference(*c->per_frame, IterationCallback(), f));
      }
      warmed_up_ = true;
    }
    for (auto& c : study_.contenders) {
      StudyCurve curve{c->type, frame, {}, 0, 0};
      FrameStep f;
      PetscCall(from_reference(*c->per_frame, recorder(curve), f));
      if (!f.stop.empty())
        PetscCall(PetscPrintf(study_.comm, "study frame %4d  %-15s stopped by a guardrail: %s\n", frame, c->type.c_str(),
                              f.stop.c_str()));
      curves_.push_back(std::move(curve));
    }
    scene.body->set_element_states(elements);
    PetscFunctionReturn(0);
  }

  // The reference's iterations, at every frame: its solve too stops at study.time_limit.
  IterationCallback iterations(int frame) override {
    reference_ = StudyCurve{"reference", frame, {}, 0, 0};
    return recorder(reference_);
  }

  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl&) override {
    PetscFunctionBeginUser;
    // A signal cut a solve of this frame short (a follower's): the frame is not written (StudyStop).
    if (!outcome.lead.stop.empty() || stop_agreed()) PetscFunctionReturn(0);
    if (!compare_here_) {  // the trajectories' path: a reference stopped short there is said too
      const IterationRecord& end = reference_.iterations.back();
      PetscCall(warn_if_reference_short(outcome.frame, end.grad_norm / reference_.iterations.front().grad_norm,
                                        reference_.iterations.front().energy > end.energy));
      PetscFunctionReturn(0);
    }
    // g* is the lowest g anyone reached (the reference's, unless another solver went below it
    // by round-off); g0 is the common starting value.
    double g_star = reference_.iterations.back().energy;
    for (const StudyCurve& c : curves_)
      for (const IterationRecord& r : c.iterations) g_star = std::min(g_star, r.energy);
    const double g0 = reference_.iterations.front().energy;
    // A solver far below the converged reference: on a step that is not convex (a compressed
    // rope, a buckling shell) Newton with the exact Hessian can converge to a saddle or a higher
    // minimum. Said, since the trajectory follows the reference there.
    const double above = (reference_.iterations.back().energy - g_star) / (g0 - g_star);
    const IterationRecord& end = reference_.iterations.back();
    const double reached = end.grad_norm / reference_.iterations.front().grad_norm;
    // (A reference that stopped short, below, is above the lowest for that reason.)
    if (above > kReferenceAboveLowest && reached <= study_.deck.study.reference_rtol)
      PetscCall(PetscPrintf(study_.comm,
                            "study frame %4d  warning: a solver went below the converged reference by %.3e of "
                            "g(x0) - g*: the reference (Newton, exact Hessian) converged to a stationary point that is "
                            "not the lowest found (a step that is not convex); errors are measured from the lowest, "
                            "and the trajectories are compared with the reference's path\n",
                            outcome.frame, above));
    // Else a frame with g(x0) = g* starts at its answer.
    bool short_of_rtol = false;
    PetscCall(warn_if_reference_short(outcome.frame, reached, g0 > g_star, &short_of_rtol));
    if (!short_of_rtol && !(g0 > g_star)) {
      PetscCall(PetscPrintf(study_.comm, "study frame %4d  note: the frame starts at its answer (g(x0) = g*, nothing to "
                                         "solve): every error is 0\n", outcome.frame));
    }
    curves_.push_back(reference_);
    for (StudyCurve& c : curves_) {
      c.g0 = g0;
      c.g_star = g_star;
      out_.add(c);
      const IterationRecord& last = c.iterations.back();
      PetscCall(PetscPrintf(study_.comm, "study frame %4d  %-15s %4d it  %9.3f ms  rel. error %.3e\n", outcome.frame,
                            c.solver.c_str(), (int)last.iteration, 1e3 * last.time_s, c.rel_error(last)));
    }
    out_.check(study_.comm);  // rank 0's write failure ends every rank's study
    PetscFunctionReturn(0);
  }

 private:
  // The reference stopped short of reference_rtol (its cap, the time limit, or a line search that
  // found no descent): errors below its own are not resolved, and at a frame of the trajectories
  // only, their path is not the converged one. Said on the console (*said: whether it was).
  PetscErrorCode warn_if_reference_short(int frame, double reached, bool decreased, bool* said = nullptr) const {
    const IterationRecord& end = reference_.iterations.back();
    const bool capped = end.iteration >= study_.reference_iterations() || end.time_s > study_.deck.study.time_limit;
    const bool short_of_rtol = !(reached <= study_.deck.study.reference_rtol) && (decreased || capped);
    PetscFunctionBeginUser;
    if (said) *said = short_of_rtol;
    if (!short_of_rtol) PetscFunctionReturn(0);
    const char* why = end.iteration >= study_.reference_iterations() ? "its iteration cap"
                      : end.time_s > study_.deck.study.time_limit     ? "study.time_limit"
                                                                      : "a line search that found no descent";
    PetscCall(PetscPrintf(study_.comm,
                          "study frame %4d  warning: the reference stopped at %s (%d iterations, %.3g s) with "
                          "||grad g|| / ||grad g(x0)|| = %.3e, not at study.reference_rtol = %.3g: %s\n",
                          frame, why, (int)end.iteration, end.time_s, reached, study_.deck.study.reference_rtol,
                          compare_here_ ? "errors smaller than its own are not resolved"
                                        : "the scene goes on from a point not converged (the trajectories' path, the "
                                          "next frames' start)"));
    PetscFunctionReturn(0);
  }

  IterationCallback recorder(StudyCurve& curve) const {
    const double limit = study_.deck.study.time_limit;
    return [&curve, limit](const IterationRecord& r) {
      curve.iterations.push_back(r);
      return r.time_s > limit;
    };
  }

  Study& study_;
  StudyWriter& out_;
  FrameStepper stepper_;   // the per-frame solves', through the same guardrails
  bool warmed_up_ = false;  // one untimed per-frame run per set of solvers
  bool compare_here_ = false;
  std::vector<StudyCurve> curves_;  // this frame's, one per contender
  StudyCurve reference_;
};

// The trajectories at each solver's budget (the loop's followers, in the contenders' order),
// compared with the converged reference after every frame (trajectory.csv); a trajectory that a
// guardrail stops gets one point saying why, and no later one.
class TrajectoryErrors : public FrameObserver {
 public:
  TrajectoryErrors(Study& study, StudyWriter& out)
      : study_(study), out_(out), diagonal_(rest_diagonal(study.scene.current().mesh)) {}

  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl&) override {
    const PetscInt free_vertices = study_.scene.current().mesh.global_dofs / 3;
    PetscFunctionBeginUser;
    if (!outcome.lead.stop.empty()) PetscFunctionReturn(0);  // nothing stepped
    if (stop_agreed()) PetscFunctionReturn(0);  // a signal cut a solve short: not written (StudyStop)
    for (size_t k = 0; k < outcome.followers.size(); ++k) {
      const FollowerStep& f = outcome.followers[k];
      if (!f.stepped) continue;  // stopped before
      Contender& c = *study_.contenders[k];
      c.time_s += f.seconds;
      c.iterations += f.step.solve.iterations;
      TrajectoryPoint p;
      p.solver = c.type;
      p.frame = outcome.frame;
      p.iterations = c.iterations;
      p.time_s = c.time_s;
      if (f.step.stop.empty()) {
        PetscReal dist;
        PetscCall(VecWAXPY(study_.probe.x, -1.0, study_.ref.x, c.state.x));  // probe: work
        PetscCall(VecNorm(study_.probe.x, NORM_2, &dist));
        p.rms_error = dist / std::sqrt((double)std::max<PetscInt>(free_vertices, 1));
        p.rel_rms_error = p.rms_error / diagonal_;
      } else {
        p.rms_error = p.rel_rms_error = NAN;
        p.status = f.step.stop;
        PetscCall(PetscPrintf(study_.comm, "study frame %4d  %-15s trajectory stopped by a guardrail: %s\n",
                              outcome.frame, c.type.c_str(), f.step.stop.c_str()));
      }
      out_.add(p);
    }
    out_.check(study_.comm);  // rank 0's write failure ends every rank's study
    PetscFunctionReturn(0);
  }

 private:
  Study& study_;
  StudyWriter& out_;
  double diagonal_;  // the rest bounding-box diagonal
};

// A stop signal (SIGTERM, SIGUSR1, SIGINT) ends the study after the last frame all of whose solves it did not
// cut short; the files hold the frames up to it (Study::signal, last_frame). Observes last.
class StudyStop : public FrameObserver {
 public:
  explicit StudyStop(Study& study) : study_(study) {}

  PetscErrorCode begin(LoopControl& control) override { return check(0, control); }

  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override {
    // A solve of this frame cut short (stop_agreed): the frame is not written, the files end before it.
    if (outcome.frame == study_.signal_after_frame) raise(SIGTERM);  // test hook
    return check(stop_agreed() ? outcome.frame - 1 : outcome.frame, control);
  }

  PetscErrorCode interrupted(const FrameOutcome& outcome) override {
    LoopControl control;
    return check(outcome.frame - 1, control);
  }

 private:
  PetscErrorCode check(int whole_frame, LoopControl& control) {
    PetscFunctionBeginUser;
    study_.last_frame = whole_frame;
    if (const int any = stop_signal_on_any_rank(study_.comm)) {
      study_.signal = stop_signal_name(any);
      control.interrupted = true;
    }
    PetscFunctionReturn(0);
  }

  Study& study_;
};

}  // namespace

PetscErrorCode Study::run(StudyWriter& out) {
  const StudySpec& st = deck.study;
  PetscFunctionBeginUser;  // ref holds the initial state (run_one_study)
  PetscCall(probe.copy_from(ref));
  for (auto& c : contenders) {
    // A trajectory's run time includes the one factorization of the constant matrix its solver needs.
    if (const FactoredSystem* h0 = scene.current().constant_matrix(spec_for(deck, c->type, 1, 0)))
      c->time_s = h0->factor_seconds();
    PetscCall(c->state.copy_from(ref));
  }
  const int last_frame = st.trajectory ? deck.time.frames : *std::max_element(st.frames.begin(), st.frames.end());

  // One loop stepping the reference (its lead) and, in lockstep, each trajectory (app/time_loop.hpp).
  TimeLoop loop(
      scene, limits, ref,
      [this](State& s, const IterationCallback& cb, StepSolve& o) { return scene.current().step->solve_step(*reference, s, cb, o); },
      [this](const Scene& o, Scene& f) { return rebind(o, f); });
  loop.carry(probe);
  if (st.trajectory)
    for (auto& c : contenders) {
      Contender* one = c.get();
      loop.follow(one->state, [this, one](State& s, const IterationCallback& cb, StepSolve& o) {
        return scene.current().step->solve_step(*one->trajectory, s, cb, o);
      });
    }
  FrameComparison comparison(*this, out);
  TrajectoryErrors trajectories(*this, out);
  StudyStop stop(*this);
  loop.observe(comparison);
  if (st.trajectory) loop.observe(trajectories);
  loop.observe(stop);
  PetscCall(loop.run(last_frame));
  if (!loop.stop().empty())
    failure = "frame " + std::to_string(loop.stop_frame()) + ": the converged reference cannot go on: " + loop.stop();
  PetscFunctionReturn(0);
}

// The study of one integrator (deck.time.integrator) into outdir.
// The files of a study written into `root` before (in it, and in its integrators' directories),
// which the report would otherwise read beside this study's (a plain study's study.csv was left
// beside the integrators' studies, and the report showed it alone). Rank 0; how many removed.
int clear_earlier_study(const std::string& root) {
  int removed = 0;
  std::vector<std::string> dirs{root};
  for (const std::string& name : integrator_names()) dirs.push_back(root + "/" + name);
  const std::vector<std::string> files{"study.csv", "trajectory.csv", "study.h5", "study.json"};
  const auto remove = [&removed](const std::string& path) {
    std::error_code ec;
    if (std::filesystem::remove(path, ec)) ++removed;
    if (ec) throw std::runtime_error("cannot remove " + path + " (an earlier study's): " + ec.message());
  };
  for (const std::string& dir : dirs) {
    for (const std::string& file : files) remove(dir + "/" + file);
    // and their temporaries, which a study killed while writing left (io/atomic_file.hpp)
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
      const std::string name = entry.path().filename().string();
      if (is_atomic_temporary(name) && std::count(files.begin(), files.end(), temporary_target(name)))
        remove(entry.path().string());
    }
  }
  return removed;
}

// root: the directory of the whole study (outdir, or its parent for one integrator's), cleared of
// an earlier study once this one's checks have passed (clear: the first integrator's), when the
// study takes root's lock (held by run_study until its last integrator ends).
int run_one_study(MPI_Comm comm, const Deck& deck, const std::string& outdir, const std::string& root, bool clear,
                  OutputLock& lock) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  const StudySpec& st = deck.study;

  RunOptions options;
  if (read_run_options(comm, &options, &deck)) return 1;
  if (clear)  // a study running into root now: refused before the minutes of setup
    if (const std::string busy = output_directory_in_use(comm, root); !busy.empty()) {
      print_error(comm, busy);
      return 1;
    }
  SceneInput input;
  MemoryPlan plan;  // M + h^2 L factored for the contenders, and the reference's Newton
  plan.split = splits_on_many_ranks(options.h0_package);
  plan.newton = deck.solver.linear_solver != LinearSolver::cg_amg;
  plan.newton_auto = deck.solver.linear_solver == LinearSolver::automatic;
  if (!load_scene_input_or_report(comm, deck, input, plan)) return 1;

  Study study(comm, deck);
  study.signal_after_frame = options.signal_after_frame;
  for (const std::string& type : st.solvers) {
    study.contenders.push_back(std::make_unique<Contender>());
    study.contenders.back()->type = type;
  }
  {
    PetscErrors errors;
    bool start_ok = true;  // the start is input too (a body inside an obstacle)
    if (study.scene.setup(comm, deck, std::move(input), scene_options(deck, options, st.solvers)) ||
        study.make_solvers(study.scene.current()) || study.scene.initial_state(study.ref) ||
        study.scene.check_start(study.ref, &start_ok)) {
      print_error(comm, "setting up the study failed: " + errors.describe(deck));
      return 1;
    }
    if (!start_ok) return 1;
  }
  try {
    create_output_directory(comm, outdir);
    if (clear) {  // one run or study at a time in root, as a run's OUTDIR (docs/outputs.md)
      const std::string busy = lock.take(comm, root, "study of deck " + deck.path);
      if (!busy.empty()) {
        print_error(comm, busy);
        return 1;
      }
    }
    // An integrator's directory is this study's too while it runs there: a study or run into it is refused.
    OutputLock own;
    if (outdir != root) {
      const std::string busy = own.take(comm, outdir, "study of deck " + deck.path);
      if (!busy.empty()) {
        print_error(comm, busy);
        return 1;
      }
    }
    // Rank 0 writes alone: its failure must end the study on every rank.
    std::unique_ptr<StudyWriter> writer;
    std::string error;
    try {
      if (clear && rank == 0)
        if (const int removed = clear_earlier_study(root))
          PetscPrintf(PETSC_COMM_SELF, "hyperqn: %s held an earlier study: %d file(s) removed\n", root.c_str(), removed);
      writer = std::make_unique<StudyWriter>(outdir, rank);
      if (rank == 0) write_study_meta(outdir, deck, study.scene.current());
    } catch (const std::exception& e) {
      error = e.what();
    }
    throw_if_any_failed(comm, error);
    StudyWriter& out = *writer;
    PetscErrors errors;
    study.limits = Guardrails::of(options, study.scene.current(), deck);
    if (study.run(out)) {
      print_error(comm, "the study failed: " + errors.describe(deck));
      return 1;
    }
    if (!study.failure.empty()) {
      out.finish();  // what it compared so far
      print_error(comm, "the study stopped at " + study.failure);
      return 1;
    }
    if (!study.signal.empty()) {  // what it compared up to the last whole frame, and study.json says so
      out.finish();
      out.check(comm);
      const std::string stopped = study.signal + " after frame " + std::to_string(study.last_frame);
      if (rank == 0) write_study_meta(outdir, deck, study.scene.current(), stopped);
      PetscPrintf(comm, "hyperqn: study stopped by %s: %s (study.csv, trajectory.csv, study.h5) holds the frames up "
                        "to %d (study.json's \"stopped\")\n", study.signal.c_str(), outdir.c_str(), study.last_frame);
      return kExitInterrupted;
    }
    out.finish();
    out.check(comm);
  } catch (const std::exception& e) {
    print_error(comm, e.what());
    return 1;
  }
  PetscPrintf(comm, "hyperqn: study written to %s (study.csv, trajectory.csv, study.h5)\n", outdir.c_str());
  return 0;
}

int run_study(MPI_Comm comm, const Deck& deck, const std::string& outdir) {
  OutputLock lock;  // outdir is this study's until it returns
  if (deck.study.integrators.empty()) return run_one_study(comm, deck, outdir, outdir, true, lock);
  for (TimeIntegrator kind : deck.study.integrators) {
    Deck one = deck;
    one.time.integrator = kind;
    const std::string name = integrator_info(kind).name;
    PetscPrintf(comm, "hyperqn: study with %s\n", name.c_str());
    if (const int status = run_one_study(comm, one, outdir + "/" + name, outdir, kind == deck.study.integrators.front(), lock))
      return status;
  }
  return 0;
}

}  // namespace hyperqn

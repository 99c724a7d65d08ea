#include "app/study.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>

#include "model/initial_state.hpp"
#include "model/scene.hpp"
#include "solvers/solver_factory.hpp"
#include "io/study_writer.hpp"

namespace hyperqn {

namespace {

// A solver under study: one instance for the per-frame comparison, one at its trajectory
// budget with its own state (x, v).
struct Contender {
  std::string type;
  std::unique_ptr<TimeStepSolver> per_frame, trajectory;
  Vec x = nullptr, v = nullptr;
  double time_s = 0;
  long long iterations = 0;
  ~Contender() {
    VecDestroy(&x);
    VecDestroy(&v);
  }
};

// Takes one implicit Euler step of (x, v) with the solver; records its iterations.
PetscErrorCode advance(const Deck& deck, TimeStep& step, TimeStepSolver& solver, Vec x, Vec v, Vec work,
                       const IterationCallback& cb, FrameResult& r) {
  PetscFunctionBeginUser;
  // (The caller has set the prescribed positions of moving fixed regions for this step.)
  PetscCall(step.set_inertial_target(x, v));
  PetscCall(VecCopy(x, work));  // x_n
  if (deck.solver.warm_start == "inertial") PetscCall(VecCopy(step.inertial_target(), x));
  PetscCall(solver.solve(x, cb, r));
  PetscCall(VecWAXPY(v, -1.0, work, x));
  PetscCall(VecScale(v, (1.0 - deck.time.damping) / deck.time.dt));
  PetscFunctionReturn(0);
}

SolverSpec spec_for(const Deck& deck, const std::string& type, int iterations, double rtol) {
  SolverSpec s = deck.solver;
  s.type = type;
  s.iterations = iterations;
  s.grad_atol = 0;
  s.grad_rtol = rtol;
  return s;
}

// study.json: what the report needs to label the study.
void write_study_meta(const std::string& outdir, const Deck& deck, const Scene& scene) {
  int size;
  MPI_Comm_size(PetscObjectComm((PetscObject)scene.mesh.dm), &size);
  std::ofstream out(outdir + "/study.json");
  out << "{\n  \"title\": \"" << deck.name << " (" << size << (size == 1 ? " rank" : " ranks") << ")\",\n"
      << "  \"deck\": \"" << deck.path << "\",\n  \"material\": \"" << deck.material.model << "\",\n"
      << "  \"ranks\": " << size << ",\n  \"vertices\": " << scene.mesh.global_vertices << ",\n"
      << "  \"tets\": " << scene.mesh.global_cells << ",\n  \"segments\": " << scene.mesh.global_segments << ",\n"
      << "  \"dt\": " << deck.time.dt << ",\n"
      << "  \"factor_s\": " << (scene.factored ? scene.factored->factor_seconds() : 0.0) << "\n}\n";
  if (!out) throw std::runtime_error("cannot write " + outdir + "/study.json");
}

}  // namespace

// Everything a study runs with; replaced as a whole when fixed regions are released.
struct StudyScene {
  std::unique_ptr<Scene> scene;
  std::unique_ptr<TimeStepSolver> reference;
};

// Builds the reference solver and every contender's two solvers on scene.
using SolverMaker = std::function<PetscErrorCode(StudyScene&, std::vector<std::unique_ptr<Contender>>&)>;

// Replaces the vectors *x, *v of the old scene by the same state in the new one.
static PetscErrorCode carry(const Scene& from, const Scene& to, Vec* x, Vec* v) {
  Vec x_new, v_new;
  PetscFunctionBeginUser;
  PetscCall(carry_state(from, *x, *v, to, &x_new, &v_new));
  PetscCall(VecDestroy(x));
  PetscCall(VecDestroy(v));
  *x = x_new;
  *v = v_new;
  PetscFunctionReturn(0);
}

static PetscErrorCode study_loop(MPI_Comm comm, const Deck& deck, const SceneInput& kept, bool factor, StudyScene& ss,
                                 const SolverMaker& make_solvers, std::vector<std::unique_ptr<Contender>>& contenders,
                                 StudyWriter& out) {
  const StudySpec& st = deck.study;
  Vec x_ref, v_ref, x0, v0, work;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(ss.scene->step->layout(), &x_ref));
  PetscCall(VecDuplicate(x_ref, &v_ref));
  PetscCall(VecDuplicate(x_ref, &x0));
  PetscCall(VecDuplicate(x_ref, &v0));
  PetscCall(VecDuplicate(x_ref, &work));
  PetscCall(ss.scene->body->rest_positions(x_ref));
  PetscCall(apply_initial_state(deck.initial, *ss.scene->body, x_ref));
  PetscCall(VecSet(v_ref, 0.0));
  for (auto& c : contenders) {
    // A trajectory's run time includes the one factorization of M + h^2 L its solver needs.
    if (solver_uses_constant_matrix(c->type)) c->time_s = ss.scene->factored->factor_seconds();
    PetscCall(VecDuplicate(x_ref, &c->x));
    PetscCall(VecDuplicate(x_ref, &c->v));
    PetscCall(VecCopy(x_ref, c->x));
    PetscCall(VecSet(c->v, 0.0));
  }
  const double diag = rest_diagonal(ss.scene->mesh);
  const int last_frame = st.trajectory ? deck.time.frames : *std::max_element(st.frames.begin(), st.frames.end());
  std::vector<char> released(deck.fixed.size(), 0);
  bool warmed_up = false;  // one untimed per-frame run per set of solvers

  for (int frame = 1; frame <= last_frame; ++frame) {
    if (regions_due(deck, frame, released)) {
      // The same rebuild as the simulation's, then every state moves to the new scene.
      const double t = (frame - 1) * deck.time.dt;
      StudyScene fresh;
      fresh.scene = std::make_unique<Scene>();
      PetscCall(build_released_scene(comm, deck, kept, released, t, factor, *fresh.scene));
      PetscCall(carry(*ss.scene, *fresh.scene, &x_ref, &v_ref));
      for (auto& c : contenders) {
        PetscCall(carry(*ss.scene, *fresh.scene, &c->x, &c->v));
        if (solver_uses_constant_matrix(c->type)) c->time_s += fresh.scene->factored->factor_seconds();
      }
      for (Vec* w : {&x0, &v0, &work}) {  // work vectors in the new layout
        PetscCall(VecDestroy(w));
        PetscCall(VecDuplicate(x_ref, w));
      }
      PetscCall(make_solvers(fresh, contenders));  // the old solvers refer to the old scene
      ss.reference = std::move(fresh.reference);   // so the old reference goes before the old scene
      ss.scene = std::move(fresh.scene);
      warmed_up = false;
      PetscCall(PetscPrintf(comm, "study: t = %g: fixed region(s) released; %lld dofs now, M + h^2 L factored again\n", t,
                            (long long)ss.scene->mesh.global_dofs));
    }
    Scene& scene = *ss.scene;
    TimeStep& step = *scene.step;
    const PetscInt free_vertices = scene.mesh.global_dofs / 3;
    const bool compare_here = std::find(st.frames.begin(), st.frames.end(), frame) != st.frames.end();
    scene.body->set_time(frame * deck.time.dt);  // prescribed positions of moving fixed regions
    std::vector<StudyCurve> curves;
    auto recorder = [&](StudyCurve& curve) {
      return [&curve, &st](const IterationRecord& r) {
        curve.iterations.push_back(r);
        return r.time_s > st.time_limit;
      };
    };

    // The per-frame comparison starts every solver from the reference state (x_ref, v_ref).
    // One untimed run first, so one-time costs (allocations, Newton's symbolic analysis) are not
    // charged to the first compared frame.
    if (compare_here && !warmed_up) {
      for (auto& c : contenders) {
        FrameResult r;
        PetscCall(VecCopy(x_ref, x0));
        PetscCall(VecCopy(v_ref, v0));
        PetscCall(advance(deck, step, *c->per_frame, x0, v0, work, IterationCallback(), r));
      }
      warmed_up = true;
    }
    if (compare_here) {
      for (auto& c : contenders) {
        StudyCurve curve{c->type, frame, {}, 0, 0};
        FrameResult r;
        PetscCall(VecCopy(x_ref, x0));
        PetscCall(VecCopy(v_ref, v0));
        PetscCall(advance(deck, step, *c->per_frame, x0, v0, work, recorder(curve), r));
        curves.push_back(std::move(curve));
      }
    }

    // The converged reference step; at a compared frame it also gives g*.
    StudyCurve ref_curve{"reference", frame, {}, 0, 0};
    FrameResult ref_result;
    PetscCall(advance(deck, step, *ss.reference, x_ref, v_ref, work, recorder(ref_curve), ref_result));
    if (compare_here) {
      // g* is the lowest g anyone reached (the reference's, unless another solver went below it
      // by round-off); g0 is the common starting value.
      double g_star = ref_curve.iterations.back().energy;
      for (const StudyCurve& c : curves)
        for (const IterationRecord& r : c.iterations) g_star = std::min(g_star, r.energy);
      const double g0 = ref_curve.iterations.front().energy;
      curves.push_back(ref_curve);
      for (StudyCurve& c : curves) {
        c.g0 = g0;
        c.g_star = g_star;
        out.add(c);
        const IterationRecord& last = c.iterations.back();
        PetscCall(PetscPrintf(comm, "study frame %4d  %-15s %4d it  %9.3f ms  rel. error %.3e\n", frame, c.solver.c_str(),
                              (int)last.iteration, 1e3 * last.time_s, c.rel_error(last)));
      }
    }

    // Trajectories at each solver's budget, compared with the converged one.
    if (st.trajectory) {
      for (auto& c : contenders) {
        FrameResult r;
        const double t0 = MPI_Wtime();
        PetscCall(advance(deck, step, *c->trajectory, c->x, c->v, work, IterationCallback(), r));
        c->time_s += MPI_Wtime() - t0;
        PetscReal dist;
        PetscCall(VecWAXPY(work, -1.0, x_ref, c->x));
        PetscCall(VecNorm(work, NORM_2, &dist));
        TrajectoryPoint p;
        p.solver = c->type;
        p.frame = frame;
        c->iterations += r.iterations;
        p.iterations = c->iterations;
        p.time_s = c->time_s;
        p.rms_error = dist / std::sqrt((double)std::max<PetscInt>(free_vertices, 1));
        p.rel_rms_error = p.rms_error / diag;
        out.add(p);
      }
    }
  }
  PetscCall(VecDestroy(&x_ref));
  PetscCall(VecDestroy(&v_ref));
  PetscCall(VecDestroy(&x0));
  PetscCall(VecDestroy(&v0));
  PetscCall(VecDestroy(&work));
  PetscFunctionReturn(0);
}

int run_study(MPI_Comm comm, const Deck& deck, const std::string& outdir) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  const StudySpec& st = deck.study;

  SceneInput input;
  if (!load_scene_input_or_report(comm, deck, input)) return 1;
  bool factor = false;
  for (const std::string& s : st.solvers) factor = factor || solver_uses_constant_matrix(s);
  // Released fixed regions rebuild the scene from the serial input, so it is kept for them.
  const SceneInput kept = deck_releases_regions(deck) ? input : SceneInput();

  StudyScene ss;
  std::vector<std::unique_ptr<Contender>> contenders;
  const SolverMaker make_solvers = [&](StudyScene& s, std::vector<std::unique_ptr<Contender>>& cs) -> PetscErrorCode {
    PetscFunctionBeginUser;
    // The reference: Newton with the exact Hessian converges quadratically (the PSD fix would
    // make it linear wherever it is active near the solution).
    SolverSpec ref = spec_for(deck, "newton", std::max(st.iterations, 100), st.reference_rtol);
    ref.newton_hessian = "exact";
    PetscCall(create_solver(ref, *s.scene->step, nullptr, s.reference));
    for (auto& c : cs) {
      auto budget = st.trajectory_iterations.find(c->type);
      const int traj_its = budget != st.trajectory_iterations.end() ? budget->second : deck.solver.iterations;
      PetscCall(create_solver(spec_for(deck, c->type, st.iterations, st.reference_rtol), *s.scene->step,
                              s.scene->factored.get(), c->per_frame));
      PetscCall(create_solver(spec_for(deck, c->type, traj_its, deck.solver.grad_rtol), *s.scene->step,
                              s.scene->factored.get(), c->trajectory));
    }
    PetscFunctionReturn(0);
  };
  for (const std::string& type : st.solvers) {
    contenders.push_back(std::make_unique<Contender>());
    contenders.back()->type = type;
  }
  ss.scene = std::make_unique<Scene>();
  if (build_scene(comm, deck, input, factor, *ss.scene) || make_solvers(ss, contenders)) {
    PetscPrintf(comm, "hyperqn: error: setting up the study failed (see PETSc's message above)\n");
    return 1;
  }

  try {
    if (rank == 0) std::filesystem::create_directories(outdir);
    MPI_Barrier(comm);
    StudyWriter out(outdir, rank);
    if (rank == 0) write_study_meta(outdir, deck, *ss.scene);
    if (study_loop(comm, deck, kept, factor, ss, make_solvers, contenders, out)) {
      PetscPrintf(comm, "hyperqn: error: the study failed (see PETSc's message above)\n");
      return 1;
    }
    out.finish();
  } catch (const std::exception& e) {
    PetscPrintf(comm, "hyperqn: error: %s\n", e.what());
    return 1;
  }
  PetscPrintf(comm, "hyperqn: study written to %s (study.csv, trajectory.csv, study.h5)\n", outdir.c_str());
  return 0;
}

}  // namespace hyperqn

#include "app/simulation.hpp"

#include <petscdmplex.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>

#include "model/initial_state.hpp"
#include "io/run_log.hpp"
#include "model/scene.hpp"
#include "solvers/solver_factory.hpp"
#include "io/vtk_writer.hpp"

namespace hyperqn {

namespace {

double global_min(MPI_Comm comm, const std::vector<double>& v) {
  double local = HUGE_VAL, global;
  for (double x : v) local = std::fmin(local, x);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, comm);
  return global;
}

// Divergence: an element edge (tet edge or strand segment) longer than this many rest bounding-box
// diagonals D. At rest every edge is at most D long and rigid motions (free fall, prescribed
// rotation or translation, pieces moving apart) keep edge lengths, so a longer edge needs the body
// itself stretched about that much. Measured on the stability suite: at most 0.91 D in the runs
// that stay bounded (random start), up to 1e9 D in those that run away. README, "Guardrails".
constexpr double kDivergenceLimit = 10.0;

// Longest element edge (tet edge or strand segment) over all ranks at the local positions pos.
double longest_edge(MPI_Comm comm, const DistributedMesh& mesh, const std::vector<double>& pos) {
  static const int tet_edges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double local = 0, global;
  const auto measure = [&](PetscInt a, PetscInt b) {
    local = std::fmax(local, std::hypot(pos[3 * a] - pos[3 * b], pos[3 * a + 1] - pos[3 * b + 1],
                                        pos[3 * a + 2] - pos[3 * b + 2]));
  };
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    for (const auto& e : tet_edges) measure(mesh.cells[4 * c + e[0]], mesh.cells[4 * c + e[1]]);
  for (PetscInt k = 0; k < mesh.num_segments; ++k) measure(mesh.segments[2 * k], mesh.segments[2 * k + 1]);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, comm);
  return global;
}

// Why the run has diverged when its longest edge is `edge` rest diagonals long, or "".
std::string divergence(double edge, double limit) {
  if (edge <= limit) return "";
  char text[120];
  std::snprintf(text, sizeof text, "diverged: an element edge is %.4g rest bounding-box diagonals long (limit %g)", edge,
                limit);
  return text;
}

// summary.json's status of a run that completed: "ok", or how many frames were flagged.
std::string completed_status(const RunSummary& summary) {
  const auto& flagged = summary.flagged_frames;
  if (flagged.empty()) return "ok";
  return "flagged: " + std::to_string(flagged.size()) + " of " + std::to_string(summary.frames) +
         " frames could not decrease g (first: frame " + std::to_string(flagged.front().first) + ")";
}

}  // namespace

// Whether every entry of a global vector is finite, on all ranks.
static PetscErrorCode all_finite(MPI_Comm comm, Vec x, bool* finite) {
  const PetscScalar* a;
  PetscInt n;
  int local = 1, global;
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &a));
  for (PetscInt i = 0; i < n; ++i) local &= std::isfinite(a[i]) ? 1 : 0;
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCallMPI(MPI_Allreduce(&local, &global, 1, MPI_INT, MPI_MIN, comm));
  *finite = global == 1;
  PetscFunctionReturn(0);
}

// Counters of a scene's objects, added to the summary when the scene is replaced or at the end.
static void add_scene_counters(const Scene& s, RunSummary& summary) {
  summary.objective_s += s.step->objective_seconds();
  summary.hessian_s += s.step->hessian_seconds();
  summary.rejected_evaluations += s.step->rejected_evaluations();
  if (s.factored) {
    summary.h0_solves += s.factored->solves();
    summary.h0_solve_s += s.factored->solve_seconds();
  }
}

// Frees the vertices of the fixed regions whose release time has come (see
// build_released_scene): the scene is rebuilt and factored again, x and v carry over, and the
// solver and the VTK writer move to the new scene.
static PetscErrorCode release_regions(MPI_Comm comm, const Deck& deck, const SceneInput& kept, double t,
                                      const std::vector<char>& released, std::unique_ptr<Scene>& s,
                                      std::unique_ptr<TimeStepSolver>& solver, Vec* x, Vec* v, VtkWriter* vtk,
                                      RunSummary& summary) {
  auto fresh = std::make_unique<Scene>();
  std::unique_ptr<TimeStepSolver> fresh_solver;
  Vec x_new, v_new;
  PetscFunctionBeginUser;
  PetscCall(build_released_scene(comm, deck, kept, released, t, solver_uses_constant_matrix(deck.solver.type), *fresh));
  PetscCall(create_solver(deck.solver, *fresh->step, fresh->factored.get(), fresh_solver));
  PetscCall(carry_state(*s, *x, *v, *fresh, &x_new, &v_new));
  PetscCall(VecDestroy(x));
  PetscCall(VecDestroy(v));
  *x = x_new;
  *v = v_new;

  add_scene_counters(*s, summary);
  if (fresh->factored) {
    summary.factorizations += fresh->factored->factorizations();
    summary.factor_s += fresh->factored->factor_seconds();
  }
  summary.dofs = fresh->mesh.global_dofs;
  summary.fixed_vertices = fresh->mesh.global_fixed_vertices;
  if (vtk) vtk->set_mesh(fresh->mesh);
  solver.reset();  // it refers to the old scene
  s = std::move(fresh);
  solver = std::move(fresh_solver);
  PetscCall(PetscPrintf(comm, "t = %g: fixed region(s) released (free from this step on); %lld dofs now, M + h^2 L factored again\n", t,
                        (long long)summary.dofs));
  PetscFunctionReturn(0);
}

// The frame loop; ok = false (with summary.status set) if the run cannot continue.
// Guardrails: a frame whose solver could not decrease g is flagged (progress line, summary's
// flagged_frames and status) and the run goes on from its last accepted iterate; a frame that
// leaves no finite state (rejected g at every point tried, non-finite positions) or a diverged one
// (kDivergenceLimit) stops the run: the last good frame is written (even if it is not an output
// frame) and nothing non-finite ever is.
static PetscErrorCode time_loop(MPI_Comm comm, const Deck& deck, const SceneInput& kept, std::unique_ptr<Scene>& s,
                                std::unique_ptr<TimeStepSolver>& solver, VtkWriter* vtk, IterationLog& log,
                                RunSummary& summary, bool& ok) {
  PetscMPIInt rank;
  Vec x, v, x_prev, v_prev;
  std::vector<double> pos, vel, J;
  PetscFunctionBeginUser;
  ok = true;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(VecDuplicate(s->step->layout(), &x));
  PetscCall(VecDuplicate(x, &v));
  PetscCall(VecDuplicate(x, &x_prev));
  PetscCall(VecDuplicate(x, &v_prev));
  PetscCall(s->body->rest_positions(x));
  PetscCall(apply_initial_state(deck.initial, *s->body, x));
  PetscCall(VecSet(v, 0.0));

  int last_written = -1;
  // Writes frame `frame` from x and v, unless a position, velocity or J is not finite.
  auto write_frame = [&](int frame, bool* written) -> PetscErrorCode {
    PetscFunctionBeginUser;
    PetscCall(s->body->local_positions(x, pos));
    PetscCall(s->body->local_velocities(v, vel));
    s->body->cell_jacobians(pos, J);
    int local = 1, finite;
    for (const auto* values : {&pos, &vel, &J})
      for (double a : *values) local &= std::isfinite(a) ? 1 : 0;
    PetscCallMPI(MPI_Allreduce(&local, &finite, 1, MPI_INT, MPI_MIN, comm));
    *written = finite == 1;
    if (!*written) PetscFunctionReturn(0);
    summary.min_J = std::fmin(summary.min_J, global_min(comm, J));
    if (vtk) vtk->write({frame, frame * deck.time.dt, &pos, &vel, &J});
    last_written = frame;
    PetscFunctionReturn(0);
  };
  summary.min_J = HUGE_VAL;
  bool written = false;
  PetscCall(write_frame(0, &written));

  const double h = deck.time.dt;
  const double diagonal = rest_diagonal(s->mesh);
  PetscReal limit = kDivergenceLimit;  // <= 0: no divergence check
  PetscCall(PetscOptionsGetReal(nullptr, nullptr, "-hyperqn_divergence_limit", &limit, nullptr));
  std::vector<char> released(deck.fixed.size(), 0);
  for (int frame = 1; frame <= deck.time.frames; ++frame) {
    if (regions_due(deck, frame, released)) {
      PetscCall(VecDestroy(&x_prev));
      PetscCall(VecDestroy(&v_prev));
      PetscCall(release_regions(comm, deck, kept, (frame - 1) * h, released, s, solver, &x, &v, vtk, summary));
      PetscCall(VecDuplicate(x, &x_prev));
      PetscCall(VecDuplicate(x, &v_prev));
    }
    s->body->set_time(frame * h);  // prescribed positions of the fixed vertices at t_{n+1}
    PetscCall(s->step->set_inertial_target(x, v));
    PetscCall(VecCopy(x, x_prev));
    PetscCall(VecCopy(v, v_prev));
    const bool inertial = deck.solver.warm_start == "inertial";
    if (inertial) PetscCall(VecCopy(s->step->inertial_target(), x));

    FrameResult r;
    const auto log_iteration = [&](const IterationRecord& it) {
      if (!TimeStep::rejected(it.energy) && std::isfinite(it.grad_norm)) log.append(frame, it);  // never NaN
      return false;
    };
    const double t0 = MPI_Wtime();
    PetscCall(solver->solve(x, log_iteration, r));
    summary.evaluations += s->step->evaluations();
    if (inertial && r.reason == "REJECTED_INITIAL_GUESS") {
      // g is not finite at y (e.g. y inverts elements of a material without an extension):
      // start from x_n instead.
      PetscCall(PetscPrintf(comm, "frame %5d  g is not finite at the inertial warm start y; starting from x_n\n", frame));
      PetscCall(VecCopy(x_prev, x));
      PetscCall(solver->solve(x, log_iteration, r));
      summary.evaluations += s->step->evaluations();
    }
    const double ms = 1e3 * (MPI_Wtime() - t0);
    summary.solve_s += ms / 1e3;
    summary.iterations += r.iterations;
    summary.converged_frames += r.converged;
    summary.failed_frames += r.failed;
    summary.ls_failures += r.ls_failures;
    if (r.failed) summary.flagged_frames.emplace_back(frame, r.reason);

    // Can the run continue from this frame's x?
    std::string why;
    bool finite_x = false;
    PetscCall(all_finite(comm, x, &finite_x));
    const bool finite_g = !TimeStep::rejected(r.energy) && std::isfinite(r.grad_norm);
    if (!finite_g) {
      why = "non-finite energy or gradient at every point tried (" + r.reason + ")";
    } else if (!finite_x) {
      why = "the solver left non-finite positions (" + r.reason + ")";
    } else if (limit > 0) {
      PetscCall(s->body->local_positions(x, pos));
      why = divergence(longest_edge(comm, s->mesh, pos) / diagonal, limit);
    }

    std::string note;
    if (r.ls_failures > 0) note += "  [" + std::to_string(r.ls_failures) + " line-search failure(s)]";
    if (r.failed && why.empty()) note += "  FLAGGED: g could not be decreased further";
    if (finite_g)
      PetscCall(PetscPrintf(comm, "frame %5d  it %3d  g %+.9e  |grad| %.3e  %8.2f ms  %s%s\n", frame,
                            (int)r.iterations, r.energy, r.grad_norm, ms, r.reason.c_str(), note.c_str()));
    else
      PetscCall(PetscPrintf(comm, "frame %5d  it %3d  g not finite  %8.2f ms  %s%s\n", frame, (int)r.iterations, ms,
                            r.reason.c_str(), note.c_str()));
    if (why.empty()) {
      // v_{n+1} = (x_{n+1} - x_n) / h, then optional damping.
      PetscCall(VecWAXPY(v, -1.0, x_prev, x));
      PetscCall(VecScale(v, (1.0 - deck.time.damping) / h));
      summary.frames = frame;
      summary.final_energy = r.energy;
      summary.final_grad_norm = r.grad_norm;
      const bool last = frame == deck.time.frames;
      if (frame % deck.output.every == 0 || last) {
        PetscCall(write_frame(frame, &written));
        if (!written) why = "non-finite positions, velocities or J";
      }
      if (why.empty()) continue;
    }

    // The run cannot continue: back to the last good frame, which is written if it was not.
    if (!r.failed) {
      ++summary.failed_frames;
      summary.flagged_frames.emplace_back(frame, why);
    }
    summary.frames = frame - 1;
    PetscCall(VecCopy(x_prev, x));
    PetscCall(VecCopy(v_prev, v));
    s->body->set_time((frame - 1) * h);
    if (last_written != frame - 1) PetscCall(write_frame(frame - 1, &written));
    summary.status = "error: frame " + std::to_string(frame) + ": " + why + "; stopped, the last frame written is " +
                     std::to_string(last_written);
    ok = false;
    break;
  }
  if (ok) summary.status = completed_status(summary);
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&v));
  PetscCall(VecDestroy(&x_prev));
  PetscCall(VecDestroy(&v_prev));
  PetscFunctionReturn(0);
}

int run_simulation(MPI_Comm comm, const Deck& deck, const std::string& outdir) {
  const double t_start = MPI_Wtime();
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);

  // 1. Everything that can be wrong with the input is checked before any output exists.
  SceneInput input;
  if (!load_scene_input_or_report(comm, deck, input)) return 1;

  // 2. Distribute, assemble, factor. (Fixed regions that are released later need the serial
  // input again then.)
  const SceneInput kept = deck_releases_regions(deck) ? input : SceneInput();
  auto scene_ptr = std::make_unique<Scene>();
  Scene& scene = *scene_ptr;
  std::unique_ptr<TimeStepSolver> solver;
  if (build_scene(comm, deck, input, solver_uses_constant_matrix(deck.solver.type), scene) ||
      create_solver(deck.solver, *scene.step, scene.factored.get(), solver)) {
    PetscPrintf(comm, "hyperqn: error: setting up the scene failed (see PETSc's message above)\n");
    return 1;
  }

  RunSummary summary;
  summary.deck = deck.path;
  summary.solver = solver->name();
  summary.ranks = size;
  summary.vertices = scene.mesh.global_vertices;
  summary.tets = scene.mesh.global_cells;
  summary.segments = scene.mesh.global_segments;
  summary.dofs = scene.mesh.global_dofs;
  summary.fixed_vertices = scene.mesh.global_fixed_vertices;
  summary.dt = deck.time.dt;
  if (scene.factored) {
    summary.factorizations = scene.factored->factorizations();
    summary.assembly_s = scene.factored->assembly_seconds();
    summary.factor_s = scene.factored->factor_seconds();
  }
  summary.setup_s = MPI_Wtime() - t_start;
  const std::string segments = summary.segments ? ", " + std::to_string(summary.segments) + " strand segments" : "";
  PetscPrintf(comm, "hyperqn: %s: %lld vertices (%lld fixed), %lld tets%s, %lld dofs on %d rank(s); solver %s; setup %.3f s (factor %.3f s)\n",
              deck.name.c_str(), summary.vertices, summary.fixed_vertices, summary.tets, segments.c_str(), summary.dofs, size,
              summary.solver.c_str(), summary.setup_s, summary.factor_s);

  // 3. Output directory and logs.
  std::unique_ptr<VtkWriter> vtk;
  IterationLog log;
  bool ok = true;
  try {
    if (rank == 0) std::filesystem::create_directories(outdir);
    MPI_Barrier(comm);
    if (deck.output.vtk) vtk = std::make_unique<VtkWriter>(comm, scene.mesh, outdir, deck.name);
    if (deck.output.iterations_csv) log.open(outdir + "/iterations.csv", rank);
    if (time_loop(comm, deck, kept, scene_ptr, solver, vtk.get(), log, summary, ok)) {
      summary.status = "error: PETSc error during the time loop";
      ok = false;
    }
  } catch (const std::exception& e) {
    summary.status = std::string("error: ") + e.what();
    ok = false;
  }

  // 4. Summary.
  summary.wall_s = MPI_Wtime() - t_start;
  if (summary.frames > 0) {
    summary.ms_per_frame = 1e3 * summary.solve_s / summary.frames;
    summary.mean_iterations = (double)summary.iterations / summary.frames;
  }
  if (summary.iterations > 0) summary.ms_per_iteration = 1e3 * summary.solve_s / summary.iterations;
  add_scene_counters(*scene_ptr, summary);  // the scene in use at the end (see release_regions)
  double rss = peak_rss_mb();
  MPI_Allreduce(&rss, &summary.peak_rss_mb, 1, MPI_DOUBLE, MPI_MAX, comm);
  MPI_Allreduce(&rss, &summary.peak_rss_mb_total, 1, MPI_DOUBLE, MPI_SUM, comm);
  PetscPrintf(comm,
              "hyperqn: %s: %d frames, %.2f iterations/frame, %.3f ms/frame, %.3f ms/iteration, factorizations %d "
              "(%.3f s), wall %.3f s, peak RSS %.0f MB/rank; %s\n",
              deck.name.c_str(), summary.frames, summary.mean_iterations, summary.ms_per_frame, summary.ms_per_iteration,
              summary.factorizations, summary.factor_s, summary.wall_s, summary.peak_rss_mb, summary.status.c_str());
  if (rank == 0 && std::filesystem::exists(outdir)) {
    try {
      write_summary(outdir + "/summary.json", summary);
    } catch (const std::exception& e) {
      PetscPrintf(PETSC_COMM_SELF, "hyperqn: error: %s\n", e.what());
      ok = false;
    }
  }
  if (!ok) {  // the status already says "error: ..." (unless only summary.json could not be written)
    const bool says_error = summary.status.rfind("error", 0) == 0;
    PetscPrintf(comm, "hyperqn: %s%s\n", says_error ? "" : "error: ", summary.status.c_str());
  }
  return ok ? 0 : 1;
}

}  // namespace hyperqn

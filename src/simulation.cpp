#include "simulation.hpp"

#include <petscdmplex.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>

#include "input_error.hpp"
#include "run_log.hpp"
#include "scene.hpp"
#include "solver_factory.hpp"
#include "vtk_writer.hpp"

namespace hyperqn {

namespace {

double global_min(MPI_Comm comm, const std::vector<double>& v) {
  double local = HUGE_VAL, global;
  for (double x : v) local = std::fmin(local, x);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MIN, comm);
  return global;
}

}  // namespace

// The frame loop. Returns false (with summary.status set) if the run cannot continue.
static PetscErrorCode time_loop(MPI_Comm comm, const Deck& deck, Scene& s, TimeStepSolver& solver, VtkWriter* vtk,
                                IterationLog& log, RunSummary& summary, bool& ok) {
  PetscMPIInt rank;
  Vec x, v, x_prev;
  std::vector<double> pos, vel, J;
  PetscFunctionBeginUser;
  ok = true;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &v));
  PetscCall(VecDuplicate(x, &x_prev));
  PetscCall(s.body->rest_positions(x));
  PetscCall(VecSet(v, 0.0));

  auto write_frame = [&](int frame) -> PetscErrorCode {
    PetscFunctionBeginUser;
    PetscCall(s.body->local_positions(x, pos));
    PetscCall(s.body->local_velocities(v, vel));
    s.body->cell_jacobians(pos, J);
    summary.min_J = std::fmin(summary.min_J, global_min(comm, J));
    if (vtk) vtk->write({frame, frame * deck.time.dt, &pos, &vel, &J});
    PetscFunctionReturn(0);
  };
  summary.min_J = HUGE_VAL;
  PetscCall(write_frame(0));

  const double h = deck.time.dt;
  for (int frame = 1; frame <= deck.time.frames; ++frame) {
    s.body->set_time(frame * h);  // prescribed positions of the fixed vertices at t_{n+1}
    PetscCall(s.step->set_inertial_target(x, v));
    PetscCall(VecCopy(x, x_prev));
    if (deck.solver.warm_start == "inertial") PetscCall(VecCopy(s.step->inertial_target(), x));

    FrameResult r;
    const double t0 = MPI_Wtime();
    PetscCall(solver.solve(x, [&](const IterationRecord& it) {
      log.append(frame, it);
      return false;
    }, r));
    const double ms = 1e3 * (MPI_Wtime() - t0);
    summary.solve_s += ms / 1e3;
    summary.iterations += r.iterations;
    summary.evaluations += s.step->evaluations();
    summary.converged_frames += r.converged;
    summary.failed_frames += r.failed;
    summary.frames = frame;
    summary.final_energy = r.energy;
    summary.final_grad_norm = r.grad_norm;

    // v_{n+1} = (x_{n+1} - x_n) / h, then optional damping.
    PetscCall(VecWAXPY(v, -1.0, x_prev, x));
    PetscCall(VecScale(v, (1.0 - deck.time.damping) / h));
    PetscCall(PetscPrintf(comm, "frame %5d  it %3d  g %+.9e  |grad| %.3e  %8.2f ms  %s\n", frame, (int)r.iterations,
                          r.energy, r.grad_norm, ms, r.reason.c_str()));

    if (!std::isfinite(r.energy) || !std::isfinite(r.grad_norm)) {
      summary.status = "error: non-finite energy or gradient at frame " + std::to_string(frame) +
                       "; output stops at the last finite frame";
      ok = false;
      break;
    }
    const bool last = frame == deck.time.frames;
    if (frame % deck.output.every == 0 || last) PetscCall(write_frame(frame));
  }
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&v));
  PetscCall(VecDestroy(&x_prev));
  PetscFunctionReturn(0);
}

int run_simulation(MPI_Comm comm, const Deck& deck, const std::string& outdir) {
  const double t_start = MPI_Wtime();
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);

  // 1. Everything that can be wrong with the input is checked before any output exists.
  SceneInput input;
  try {
    input = load_scene_input(comm, deck);
  } catch (const InputError& e) {
    PetscPrintf(comm, "hyperqn: error: %s\n", e.what());
    return 1;
  }

  // 2. Distribute, assemble, factor.
  Scene scene;
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
  summary.dofs = scene.mesh.global_dofs;
  summary.fixed_vertices = scene.mesh.global_fixed_vertices;
  summary.dt = deck.time.dt;
  if (scene.factored) {
    summary.factorizations = scene.factored->factorizations();
    summary.assembly_s = scene.factored->assembly_seconds();
    summary.factor_s = scene.factored->factor_seconds();
  }
  summary.setup_s = MPI_Wtime() - t_start;
  PetscPrintf(comm, "hyperqn: %s: %lld vertices (%lld fixed), %lld tets, %lld dofs on %d rank(s); solver %s; setup %.3f s (factor %.3f s)\n",
              deck.name.c_str(), summary.vertices, summary.fixed_vertices, summary.tets, summary.dofs, size,
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
    if (time_loop(comm, deck, scene, *solver, vtk.get(), log, summary, ok)) {
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
  summary.objective_s = scene.step->objective_seconds();
  if (scene.factored) {
    summary.h0_solves = scene.factored->solves();
    summary.h0_solve_s = scene.factored->solve_seconds();
    summary.factorizations = scene.factored->factorizations();
  }
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
  if (!ok) PetscPrintf(comm, "hyperqn: error: %s\n", summary.status.c_str());
  return ok ? 0 : 1;
}

}  // namespace hyperqn

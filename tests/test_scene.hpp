// A small distributed test scene (a 2 x 1 x 1 box of 4 x 2 x 2 cubes) and rank-independent
// deformed poses, shared by the MPI test programs.
#pragma once
#include <petscdmplex.h>

#include <functional>
#include <memory>
#include <random>
#include <string>

#include "check.hpp"

#include "mesh/distributed_mesh.hpp"
#include "model/body.hpp"
#include "model/elastic_terms.hpp"
#include "model/regions.hpp"
#include "model/step_objective.hpp"

namespace test_scene {

using namespace hyperqn;

struct TestScene {
  DistributedMesh mesh;
  std::unique_ptr<Body> body;
  std::unique_ptr<StepObjective> step;
};

// Strands of the scene with_strands: one hanging off the box's corner (2, 1, 1), one free.
constexpr double kStrandLength = 1.2 + 0.5;  // total rest length of the two strands
constexpr double kStrandDensity = 0.4, kStrandStiffness = 20.0;

inline bool with_strands(const std::string& scene) {
  return scene.size() > 8 && scene.compare(scene.size() - 8, 8, "+strands") == 0;
}
inline double expected_mass(const std::string& scene) { return 7.5 + (with_strands(scene) ? kStrandDensity * kStrandLength : 0.0); }

// Adds terms to a scene's (as SceneOptions::extra_terms does).
using ExtraTerms = std::function<void(const DistributedMesh&, std::vector<std::unique_ptr<EnergyTerm>>&)>;

// A 2 x 1 x 1 box of 4 x 2 x 2 cubes of material `scene` (total mass 7.5), optionally fixed at
// x = 0; scene "<model>+strands" adds the strands above (total mass kStrandDensity * kStrandLength).
// gravity and extra (terms added after the elastic ones) are for tests of new energy terms; cells
// refines the box (for solvers that need more than a few dozen vertices, such as multigrid).
inline PetscErrorCode make_scene(const std::string& scene, bool fix_end, TestScene& s,
                                 std::array<double, 3> gravity = {0, -9.81, 0},
                                 const ExtraTerms& extra = nullptr, std::array<int, 3> cells = {4, 2, 2}) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  const bool strands = with_strands(scene);
  const std::string model = strands ? scene.substr(0, scene.size() - 8) : scene;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  TetMesh serial;
  std::vector<BoxRegion> boxes;
  if (fix_end) boxes.push_back({{-0.1, -0.1, -0.1}, {0.01, 1.1, 1.1}, 0});
  if (rank == 0) {
    serial = generate_box({2.0, 1.0, 1.0}, cells);
    if (strands) {
      add_strand(serial, {{2.0, 1.0, 1.0}, {2.72, 1.96, 1.0}, 5, 0});  // length 1.2
      add_strand(serial, {{0.0, 1.5, 0.0}, {0.3, 1.5, 0.4}, 3, 0});    // length 0.5
    }
  }
  const MeshPiece piece = scatter_serial_mesh(PETSC_COMM_WORLD, serial);
  const std::vector<int32_t> fixed = select_fixed_vertices(PETSC_COMM_WORLD, piece.mesh, boxes, "test");
  PetscCall(distribute_mesh(PETSC_COMM_WORLD, piece, fixed, {}, s.mesh));
  MaterialSpec mat;
  mat.model = model;
  mat.mu = 3.0;
  mat.lambda = 5.0;
  mat.has_density = false;
  mat.total_mass = 7.5;
  StrandMaterial strand_material;
  strand_material.axial_stiffness = kStrandStiffness;
  strand_material.linear_density = kStrandDensity;
  std::vector<std::unique_ptr<EnergyTerm>> terms = elastic_terms(s.mesh, {mat}, strand_material);
  if (extra) extra(s.mesh, terms);
  s.body = std::make_unique<Body>(s.mesh, std::move(terms));
  s.step = std::make_unique<StepObjective>(*s.body, 0.05, gravity);
  PetscCall(s.step->setup());
  PetscCall(s.body->set_masses(s.step->mass()));  // as LiveScene::build does
  PetscFunctionReturn(0);
}

// Begins a time step from positions x and velocities v, so that g has the inertial target
// y = x + h v + h^2 g (the state itself is not kept).
inline PetscErrorCode set_inertial_target(TestScene& s, Vec x, Vec v) {
  State state;
  PetscFunctionBeginUser;
  PetscCall(state.create(x));
  PetscCall(VecCopy(x, state.x));
  PetscCall(VecCopy(v, state.v));
  PetscCall(s.step->begin_step(state));
  PetscFunctionReturn(0);
}

// Rest positions plus a smooth, rank-independent deformation and a random-looking wiggle
// that depends only on the vertex's input index.
inline PetscErrorCode deformed_positions(const TestScene& s, Vec x, double amplitude) {
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v) {
    const PetscInt off = s.mesh.local_dof[v];
    if (off < 0) continue;
    const double* X = &s.mesh.rest[3 * v];
    std::mt19937 gen((unsigned)s.mesh.vertex_ids[v]);
    std::uniform_real_distribution<double> u(-1, 1);
    a[off + 0] = X[0] + amplitude * (0.3 * X[1] * X[0] + 0.1 * u(gen));
    a[off + 1] = X[1] + amplitude * (-0.2 * X[0] * X[0] + 0.1 * u(gen));
    a[off + 2] = X[2] + amplitude * (0.4 * X[2] * X[1] + 0.1 * u(gen));
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
  PetscFunctionReturn(0);
}

// Checks grad = dE/dx at x along 3 random directions d: d . grad against the central difference
// (E(x + eps d) - E(x - eps d)) / (2 eps), to 1e-6 relative.
inline PetscErrorCode check_gradient(Body& body, Vec x, Vec grad, PetscRandom rnd, double eps = 1e-7) {
  Vec dir, xp;
  PetscReal Ep, Em, analytic;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecDuplicate(x, &xp));
  for (int trial = 0; trial < 3; ++trial) {
    PetscCall(VecSetRandom(dir, rnd));
    PetscCall(VecDot(grad, dir, &analytic));
    PetscCall(VecWAXPY(xp, eps, dir, x));
    PetscCall(body.energy_gradient(xp, &Ep, nullptr));
    PetscCall(VecWAXPY(xp, -eps, dir, x));
    PetscCall(body.energy_gradient(xp, &Em, nullptr));
    const double fd = (Ep - Em) / (2 * eps);
    CHECK_MSG(std::fabs(fd - analytic) <= 1e-6 * std::fabs(analytic),
              "dE/dx . d " + std::to_string(analytic) + " vs FD " + std::to_string(fd));
  }
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&xp));
  PetscFunctionReturn(0);
}

using Gradient = std::function<PetscErrorCode(Vec x, Vec grad)>;

// max over 3 random directions d of |H d - FD| / |H d|, FD = (grad(x + eps d) - grad(x - eps d)) / (2 eps).
inline PetscErrorCode fd_error(Mat H, Vec x, const Gradient& grad, PetscRandom rnd, double* worst, double eps = 1e-6) {
  Vec d, Hd, gp, gm, xs;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &d));
  PetscCall(VecDuplicate(x, &Hd));
  PetscCall(VecDuplicate(x, &gp));
  PetscCall(VecDuplicate(x, &gm));
  PetscCall(VecDuplicate(x, &xs));
  *worst = 0;
  for (int trial = 0; trial < 3; ++trial) {
    PetscReal err, norm;
    PetscCall(VecSetRandom(d, rnd));
    PetscCall(MatMult(H, d, Hd));
    PetscCall(VecWAXPY(xs, eps, d, x));
    PetscCall(grad(xs, gp));
    PetscCall(VecWAXPY(xs, -eps, d, x));
    PetscCall(grad(xs, gm));
    PetscCall(VecAXPY(gp, -1.0, gm));
    PetscCall(VecAXPY(Hd, -0.5 / eps, gp));  // H d - FD
    PetscCall(VecNorm(Hd, NORM_2, &err));
    PetscCall(VecScale(gp, 0.5 / eps));
    PetscCall(VecNorm(gp, NORM_2, &norm));
    *worst = std::fmax(*worst, err / norm);
  }
  PetscCall(VecDestroy(&d));
  PetscCall(VecDestroy(&Hd));
  PetscCall(VecDestroy(&gp));
  PetscCall(VecDestroy(&gm));
  PetscCall(VecDestroy(&xs));
  PetscFunctionReturn(0);
}

// K(x) alone (no mass), exact or with the PSD fix, in the Hessian's pattern.
inline PetscErrorCode stiffness(const TestScene& s, Vec x, bool psd, Mat* K) {
  PetscFunctionBeginUser;
  PetscCall(s.step->create_hessian(K));
  PetscCall(MatZeroEntries(*K));
  PetscCall(s.body->add_hessian(x, *K, 1.0, psd));
  PetscCall(MatAssemblyBegin(*K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

// The end of an MPI test program: the checks failed on any rank, tallied and printed by rank 0
// as "<program> (<N> ranks): ..."; the process's exit code (call PetscFinalize after it).
inline int tally(const std::string& program) {
  int local = check::failures(), total = 0, rank, size;
  MPI_Allreduce(&local, &total, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD);
  check::failures() = total;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  const std::string name = program + " (" + std::to_string(size) + " ranks)";
  return rank == 0 ? check::summary(name.c_str()) : (total == 0 ? 0 : 1);
}

}  // namespace test_scene

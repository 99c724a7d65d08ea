// A small distributed test scene (a 2 x 1 x 1 box of 4 x 2 x 2 cubes) and rank-independent
// deformed poses, shared by the MPI test programs.
#pragma once
#include <petscdmplex.h>

#include <memory>
#include <random>

#include "distributed_mesh.hpp"
#include "elastic_body.hpp"
#include "regions.hpp"
#include "time_step.hpp"

namespace test_scene {

using namespace hyperqn;

struct TestScene {
  DistributedMesh mesh;
  std::unique_ptr<ElasticBody> body;
  std::unique_ptr<TimeStep> step;
};

// A 2 x 1 x 1 box of 4 x 2 x 2 cubes, optionally fixed at x = 0.
inline PetscErrorCode make_scene(const std::string& model, bool fix_end, TestScene& s) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  TetMesh serial;
  std::vector<int32_t> fixed;
  if (rank == 0) {
    serial = generate_box({2.0, 1.0, 1.0}, {4, 2, 2});
    std::vector<BoxRegion> boxes;
    if (fix_end) boxes.push_back({{-0.1, -0.1, -0.1}, {0.01, 1.1, 1.1}, 0});
    fixed = select_fixed_vertices(serial, boxes, "test");
  }
  PetscCall(distribute_mesh(PETSC_COMM_WORLD, serial, fixed, {}, s.mesh));
  MaterialSpec mat;
  mat.model = model;
  mat.mu = 3.0;
  mat.lambda = 5.0;
  mat.has_density = false;
  mat.total_mass = 7.5;
  s.body = std::make_unique<ElasticBody>(s.mesh, mat);
  s.step = std::make_unique<TimeStep>(*s.body, 0.05, std::array<double, 3>{0, -9.81, 0});
  PetscCall(s.step->setup());
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

}  // namespace test_scene

// A scene built from a deck: the input checked, the mesh distributed, the body, the time-step
// objective and (when a solver needs it) the factored M + h^2 L. Shared by the simulation and
// the study.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "model/scene_spec.hpp"
#include "model/body.hpp"
#include "solvers/factored_system.hpp"
#include "mesh/mesh.hpp"
#include "model/time_step.hpp"

namespace hyperqn {

// Loads the deck's mesh on rank 0 (file or generated box), applies the transform and cleans it.
// Throws InputError. Other ranks get an empty mesh.
TetMesh load_scene_mesh(MPI_Comm comm, const SceneSpec& deck);

// The serial mesh and its fixed-vertex flags (rank 0). Throws InputError on every rank if the
// input is wrong; nothing has been written at that point.
struct SceneInput {
  TetMesh mesh;
  std::vector<int32_t> fixed;          // per vertex, see select_fixed_vertices
  std::vector<int32_t> cell_material;  // per tet, see select_material_regions
};
SceneInput load_scene_input(MPI_Comm comm, const SceneSpec& deck);
// The same, but an input error is printed ("hyperqn: error: ...") and reported as false.
bool load_scene_input_or_report(MPI_Comm comm, const SceneSpec& deck, SceneInput& input);

struct Scene {
  DistributedMesh mesh;
  std::unique_ptr<Body> body;
  std::unique_ptr<TimeStep> step;
  std::unique_ptr<FactoredSystem> factored;  // only if a solver needs M + h^2 L
};

// Distributes the input (which it frees), assembles, and factors M + h^2 L if factor is true.
PetscErrorCode build_scene(MPI_Comm comm, const SceneSpec& deck, SceneInput& input, bool factor, Scene& scene);

// Fixed regions with a release time (fixed[].release). At the start of step `frame`
// (t = (frame - 1) dt) every region whose release time is <= frame dt becomes free; the scene is
// rebuilt from the kept serial input with those vertices free (same partition, so the same local
// vertices) and M + h^2 L is factored again. Used by the simulation and the study alike.
bool deck_releases_regions(const SceneSpec& deck);
// Marks the regions due at step `frame` in released (one flag per fixed region); true if any is new.
bool regions_due(const SceneSpec& deck, int frame, std::vector<char>& released);
// fresh = the scene with the released regions' vertices free, its fixed motion set to time t.
PetscErrorCode build_released_scene(MPI_Comm comm, const SceneSpec& deck, const SceneInput& kept,
                                    const std::vector<char>& released, double t, bool factor, Scene& fresh);
// x, v of scene `from` as new vectors x_to, v_to of scene `to` (same local vertices): every vertex
// keeps its position and velocity; a vertex freed in `to` keeps the prescribed ones it had.
PetscErrorCode carry_state(const Scene& from, Vec x, Vec v, const Scene& to, Vec* x_to, Vec* v_to);

}  // namespace hyperqn

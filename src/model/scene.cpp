#include "model/scene.hpp"

#include <functional>

#include "model/elastic_terms.hpp"
#include "model/regions.hpp"
#include "io/input_error.hpp"
#include "mesh/mesh_gmsh.hpp"

namespace hyperqn {

namespace {

// Runs fn on rank 0 only; an InputError there is re-thrown on every rank, so all ranks stop
// together with the same message.
void on_root(MPI_Comm comm, const std::function<void()>& fn) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  if (rank == 0) {
    try {
      fn();
    } catch (const InputError& e) {
      error = e.what();
      if (error.empty()) error = "input error";
    }
  }
  int n = (int)error.size();
  MPI_Bcast(&n, 1, MPI_INT, 0, comm);
  if (n == 0) return;
  error.resize(n);
  MPI_Bcast(error.data(), n, MPI_CHAR, 0, comm);
  throw InputError(error);
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

TetMesh load_scene_mesh(MPI_Comm comm, const SceneSpec& deck) {
  TetMesh mesh;
  on_root(comm, [&] {
    const MeshSpec& spec = deck.mesh;
    if (spec.is_box)
      mesh = generate_box(spec.box_size, spec.box_cells);
    else if (ends_with(spec.file, ".msh"))
      mesh = read_gmsh(spec.file);
    else if (!spec.file.empty())
      mesh = read_medit(spec.file, spec.edges_as_strands);
    apply_transform(mesh, spec.transform);
    for (const StrandLine& strand : spec.strands) add_strand(mesh, strand);
    clean_mesh(mesh, spec.file.empty() ? deck.path : spec.file);
    if (mesh.num_tets() > 0 && !deck.has_material)
      throw InputError(deck.path, 0, "material", "missing: the mesh file " + spec.file + " has " +
                                                     std::to_string(mesh.num_tets()) + " tetrahedra");
  });
  return mesh;
}

SceneInput load_scene_input(MPI_Comm comm, const SceneSpec& deck) {
  SceneInput in;
  in.mesh = load_scene_mesh(comm, deck);
  on_root(comm, [&] {
    in.fixed = select_fixed_vertices(in.mesh, deck.fixed, deck.path);
    in.cell_material = select_material_regions(in.mesh, deck.regions, deck.path);
    size_t nfixed = 0;
    for (int32_t f : in.fixed) nfixed += f != 0;
    if (nfixed == in.fixed.size())
      throw InputError(deck.path, deck.fixed.empty() ? 0 : deck.fixed[0].line, "fixed",
                       "every vertex is fixed: nothing to simulate");
  });
  return in;
}

bool load_scene_input_or_report(MPI_Comm comm, const SceneSpec& deck, SceneInput& input) {
  try {
    input = load_scene_input(comm, deck);
    return true;
  } catch (const InputError& e) {
    PetscPrintf(comm, "hyperqn: error: %s\n", e.what());
    return false;
  }
}

PetscErrorCode build_scene(MPI_Comm comm, const SceneSpec& deck, SceneInput& input, bool factor, Scene& s) {
  PetscFunctionBeginUser;
  PetscCall(distribute_mesh(comm, input.mesh, input.fixed, input.cell_material, s.mesh));
  input = SceneInput();  // the serial copy is no longer needed
  std::vector<MaterialSpec> materials{deck.material};
  for (const MaterialRegion& r : deck.regions) materials.push_back(r.material);
  s.body = std::make_unique<Body>(s.mesh, elastic_terms(s.mesh, materials, deck.strand_material));
  s.body->set_fixed_motion(deck.fixed);
  s.step = std::make_unique<TimeStep>(*s.body, deck.time.dt, deck.gravity);
  PetscCall(s.step->setup());
  if (factor) {
    s.factored = std::make_unique<FactoredSystem>();
    PetscCall(s.factored->setup(*s.step));
  }
  PetscFunctionReturn(0);
}

bool deck_releases_regions(const SceneSpec& deck) {
  for (const BoxRegion& b : deck.fixed)
    if (b.release > 0) return true;
  return false;
}

bool regions_due(const SceneSpec& deck, int frame, std::vector<char>& released) {
  const double h = deck.time.dt;
  released.resize(deck.fixed.size(), 0);
  bool any = false;
  for (size_t k = 0; k < deck.fixed.size(); ++k)
    if (!released[k] && deck.fixed[k].release > 0 && deck.fixed[k].release <= frame * h + 1e-12 * h) {
      released[k] = 1;
      any = true;
    }
  return any;
}

PetscErrorCode build_released_scene(MPI_Comm comm, const SceneSpec& deck, const SceneInput& kept,
                                    const std::vector<char>& released, double t, bool factor, Scene& fresh) {
  PetscFunctionBeginUser;
  SceneInput input = kept;
  for (int32_t& f : input.fixed)
    if (f > 0 && released[f - 1]) f = 0;
  PetscCall(build_scene(comm, deck, input, factor, fresh));
  fresh.body->set_time(t);
  PetscFunctionReturn(0);
}

PetscErrorCode carry_state(const Scene& from, Vec x, Vec v, const Scene& to, Vec* x_to, Vec* v_to) {
  std::vector<double> pos, vel;
  Vec xl, vl;
  PetscScalar *a, *b;
  PetscFunctionBeginUser;
  // The partition is the same, so the local vertices are too; check rather than assume.
  PetscCheck(to.mesh.vertex_ids == from.mesh.vertex_ids, PETSC_COMM_SELF, PETSC_ERR_PLIB,
             "the local vertices changed when fixed regions were released");
  PetscCall(from.body->local_positions(x, pos));
  PetscCall(from.body->local_velocities(v, vel));
  PetscCall(DMGetLocalVector(to.mesh.dm, &xl));
  PetscCall(DMGetLocalVector(to.mesh.dm, &vl));
  PetscCall(VecGetArray(xl, &a));
  PetscCall(VecGetArray(vl, &b));
  for (PetscInt i = 0; i < to.mesh.num_vertices; ++i) {
    const PetscInt off = to.mesh.local_dof[i];
    if (off < 0) continue;
    for (int d = 0; d < 3; ++d) {
      a[off + d] = pos[3 * i + d];
      b[off + d] = vel[3 * i + d];
    }
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(VecRestoreArray(vl, &b));
  PetscCall(DMCreateGlobalVector(to.mesh.dm, x_to));
  PetscCall(VecDuplicate(*x_to, v_to));
  PetscCall(DMLocalToGlobal(to.mesh.dm, xl, INSERT_VALUES, *x_to));
  PetscCall(DMLocalToGlobal(to.mesh.dm, vl, INSERT_VALUES, *v_to));
  PetscCall(DMRestoreLocalVector(to.mesh.dm, &xl));
  PetscCall(DMRestoreLocalVector(to.mesh.dm, &vl));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "scene.hpp"

#include <functional>

#include "regions.hpp"
#include "input_error.hpp"
#include "mesh_gmsh.hpp"

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

TetMesh load_scene_mesh(MPI_Comm comm, const Deck& deck) {
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

SceneInput load_scene_input(MPI_Comm comm, const Deck& deck) {
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

bool load_scene_input_or_report(MPI_Comm comm, const Deck& deck, SceneInput& input) {
  try {
    input = load_scene_input(comm, deck);
    return true;
  } catch (const InputError& e) {
    PetscPrintf(comm, "hyperqn: error: %s\n", e.what());
    return false;
  }
}

PetscErrorCode build_scene(MPI_Comm comm, const Deck& deck, SceneInput& input, bool factor, Scene& s) {
  PetscFunctionBeginUser;
  PetscCall(distribute_mesh(comm, input.mesh, input.fixed, input.cell_material, s.mesh));
  input = SceneInput();  // the serial copy is no longer needed
  std::vector<MaterialSpec> materials{deck.material};
  for (const MaterialRegion& r : deck.regions) materials.push_back(r.material);
  s.body = std::make_unique<ElasticBody>(s.mesh, materials, deck.strand_material);
  s.body->set_fixed_motion(deck.fixed);
  s.step = std::make_unique<TimeStep>(*s.body, deck.time.dt, deck.gravity);
  PetscCall(s.step->setup());
  if (factor) {
    s.factored = std::make_unique<FactoredSystem>();
    PetscCall(s.factored->setup(*s.step));
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

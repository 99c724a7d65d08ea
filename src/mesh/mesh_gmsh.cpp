#include "mesh/mesh_gmsh.hpp"

#include <petscdmplex.h>

#include "mesh/input_error.hpp"

namespace hyperqn {

static PetscErrorCode extract_tets(DM dm, TetMesh& mesh) {
  PetscInt cStart, cEnd, vStart, vEnd;
  DMLabel cell_sets;
  Vec coords;
  const PetscScalar* xc;
  PetscFunctionBeginUser;
  PetscCall(DMPlexGetHeightStratum(dm, 0, &cStart, &cEnd));
  PetscCall(DMPlexGetDepthStratum(dm, 0, &vStart, &vEnd));
  PetscCall(DMGetLabel(dm, "Cell Sets", &cell_sets));
  for (PetscInt c = cStart; c < cEnd; ++c) {
    PetscInt n, *closure = nullptr, count = 0, tag = 0;
    PetscInt verts[4];
    PetscCall(DMPlexGetTransitiveClosure(dm, c, PETSC_TRUE, &n, &closure));
    for (PetscInt i = 0; i < 2 * n; i += 2)
      if (closure[i] >= vStart && closure[i] < vEnd && count < 4) verts[count++] = closure[i] - vStart;
    PetscCall(DMPlexRestoreTransitiveClosure(dm, c, PETSC_TRUE, &n, &closure));
    PetscCheck(count == 4, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "element %" PetscInt_FMT " is not a tetrahedron", c + 1);
    if (cell_sets) PetscCall(DMLabelGetValue(cell_sets, c, &tag));
    mesh.tets.insert(mesh.tets.end(), verts, verts + 4);
    mesh.tet_tags.push_back(tag < 0 ? 0 : tag);
  }
  PetscCall(DMGetCoordinatesLocal(dm, &coords));
  PetscCall(VecGetArrayRead(coords, &xc));
  mesh.coords.assign(xc, xc + 3 * (vEnd - vStart));
  PetscCall(VecRestoreArrayRead(coords, &xc));
  mesh.vertex_ids.resize(vEnd - vStart);
  for (PetscInt v = 0; v < vEnd - vStart; ++v) mesh.vertex_ids[v] = v;
  PetscFunctionReturn(0);
}

TetMesh read_gmsh(const std::string& path) {
  TetMesh mesh;
  DM dm = nullptr;
  PetscInt dim = 0;
  // Errors come back as codes, without PETSc's traceback: the user gets one clear line.
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  PetscErrorCode ierr = DMPlexCreateFromFile(PETSC_COMM_SELF, path.c_str(), "mesh", PETSC_FALSE, &dm);
  if (!ierr) ierr = DMGetDimension(dm, &dim);
  if (!ierr && dim == 3) ierr = extract_tets(dm, mesh);
  PetscPopErrorHandler();
  DMDestroy(&dm);
  if (ierr) {
    const char* text = nullptr;
    PetscErrorMessage(ierr, &text, nullptr);
    throw InputError(path, 0, "", std::string("cannot read Gmsh mesh (") + (text ? text : "PETSc error") + ")");
  }
  if (dim != 3) throw InputError(path, 0, "", "Gmsh mesh is " + std::to_string(dim) + "-D; a tetrahedral (3-D) mesh is needed");
  return mesh;
}

}  // namespace hyperqn

// Fracture (deck material.fracture, docs/topology.md#fracture): which interior faces break after an
// accepted step. The faces go to the scripted cuts' separation and rebuild (LiveScene::cut_due).
#pragma once
#include <petscvec.h>

#include <array>
#include <set>
#include <vector>

#include "materials/fracture_spec.hpp"
#include "mesh/distributed_mesh.hpp"
#include "mesh/separation.hpp"
#include "model/body.hpp"
#include "model/scene_spec.hpp"

namespace hyperqn {

// The fracture criteria of the scene's tet materials, in cell_material's order (the default
// material, then the regions'; or the bodies' materials); a material without one has given false.
// Empty if no material has one: such a scene runs no fracture code.
std::vector<FractureSpec> fracture_specs(const SceneSpec& spec);

// The faces of a scene's local tets, paired once per scene (its mesh changes only when the scene
// is rebuilt, and the table goes with it: Scene::fracture_faces).
struct TetFaces {
  using Key = std::array<int64_t, 3>;   // a face by its vertex ids, ascending
  std::vector<std::array<PetscInt, 2>> pairs;  // the faces of two local tets (local tet numbers)
  std::vector<Key> pair_keys;                  // and their keys
  std::vector<PetscInt> lone;                  // the faces of one local tet: the tet
  std::vector<Key> lone_keys;                  // and the face
  std::vector<PetscInt> exported;              // the local tets with a lone face that has a ghost vertex
};
TetFaces tet_faces(const DistributedMesh& mesh);

// The interior faces, not in `separated`, that break at the positions x of the scene (mesh, body):
// a face breaks when, for one of its two tets whose material has a criterion, the face's value
// exceeds that criterion's threshold for the face (fracture_face_threshold). Sorted by tet numbers,
// the same on every rank: each face is judged on a rank that holds one of its tets, from the two
// tets' values (a tet on another rank is gathered from it when the face has a ghost vertex), in an
// order that does not depend on the rank. Collective.
PetscErrorCode overloaded_faces(MPI_Comm comm, const DistributedMesh& mesh, const TetFaces& table, const Body& body, Vec x,
                                const std::vector<FractureSpec>& specs, const std::set<TetPair>& separated,
                                std::vector<TetPair>& faces);

}  // namespace hyperqn

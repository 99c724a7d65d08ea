// The boundary faces of a rank's tets: faces that no other local tet shares, each with its local
// vertices in outward order (the rest normal (b - a) x (c - a) points out of the tet). A face
// between two ranks' tets is one of these on both ranks; the body's surface faces on one only.
#pragma once
#include <array>
#include <vector>

#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

// In the order of their sorted input vertex ids (the same at any rank count). tet_faces, if given,
// gets each face's 4 × its tet's cell_id + its index in the tet (0-3), which cuts do not change.
std::vector<std::array<PetscInt, 3>> local_boundary_faces(const DistributedMesh& mesh,
                                                          std::vector<int64_t>* tet_faces = nullptr);

// Of faces (local vertex numbers), which one rank alone holds: a face between two ranks' tets is a
// boundary face of each rank's piece and of neither's body. Collective.
std::vector<char> held_by_one_rank(const DistributedMesh& mesh, const std::vector<std::array<PetscInt, 3>>& faces);

// The body's boundary faces on this rank's tets (a face between two ranks' tets is none), as
// tet_faces above, sorted. Collective.
std::vector<int64_t> boundary_tet_faces(const DistributedMesh& mesh);

}  // namespace hyperqn

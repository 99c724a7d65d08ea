// The boundary faces of a rank's tets: faces that no other local tet shares, each with its local
// vertices in outward order (the rest normal (b - a) x (c - a) points out of the tet). A face
// between two ranks' tets is one of these on both ranks; the body's surface faces on one only.
#pragma once
#include <array>
#include <vector>

#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

// In the order of their sorted input vertex ids (the same at any rank count).
std::vector<std::array<PetscInt, 3>> local_boundary_faces(const DistributedMesh& mesh);

}  // namespace hyperqn

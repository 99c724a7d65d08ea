// The vertex matrix's nonzero pattern (A1 of A = A1 (x) I3, one dof per free vertex) made from the
// mesh's cells, without the DMPlex's preallocation (DMCreateMatrix: about 1.3 ms for the sliced
// bar's 460 rows, at every scene rebuilt after a cut).
#pragma once
#include <petscmat.h>

#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

// A new assembled matrix with the pattern DMCreateMatrix(m.vertex_dm) gives on one rank: row
// global_dof / 3 of each free vertex holds, as explicit zeros, the columns of every free vertex
// that shares a cell (tet, segment, triangle or hinge) with it, itself included. Inserting outside
// the pattern is an error. One rank only (m.dm on a communicator of size 1).
PetscErrorCode create_vertex_matrix(const DistributedMesh& m, Mat* A);

}  // namespace hyperqn

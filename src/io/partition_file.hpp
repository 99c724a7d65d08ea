// The partition file (`hyperqn partition DECK -n N -o FILE.h5`): a mesh cut into N pieces
// (mesh/mesh_piece.hpp), read back in parallel so that no rank holds the whole mesh.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <string>

#include "mesh/mesh.hpp"
#include "mesh/mesh_piece.hpp"

namespace hyperqn {

struct PartitionFileInfo {
  int parts = 0;
  int64_t vertices = 0, tets = 0, segments = 0, triangles = 0;
};

// Writes serial cut into nparts pieces to path.
void write_partition_file(const std::string& path, const TetMesh& serial, int nparts, const std::string& source);
// The file's counts; InputError naming the file if it is not a readable partition file.
PartitionFileInfo read_partition_info(const std::string& path);
// This rank's piece (collective): part r if the file has as many parts as comm has ranks, else a
// chunk (final false) for distribute_mesh to repartition.
MeshPiece read_partition_piece(MPI_Comm comm, const std::string& path);

}  // namespace hyperqn

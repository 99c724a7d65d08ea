// Placeholder until the partition file lands: every call is an input error.
#include "io/partition_file.hpp"

#include "mesh/input_error.hpp"

namespace hyperqn {

void write_partition_file(const std::string& path, const TetMesh&, int, const std::string&) {
  throw InputError(path, 0, "mesh.file", "partition files are not supported by this build");
}
PartitionFileInfo read_partition_info(const std::string& path) {
  throw InputError(path, 0, "mesh.file", "partition files are not supported by this build");
}
MeshPiece read_partition_piece(MPI_Comm, const std::string& path) {
  throw InputError(path, 0, "mesh.file", "partition files are not supported by this build");
}

}  // namespace hyperqn

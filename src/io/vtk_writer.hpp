// ParaView output: per output frame one .vtu (1 rank) or a .pvtu with one .vtu piece per rank,
// and a .pvd collection listing all frames with their times. XML VTK, inline base64 binary.
// Points are the deformed positions; point fields displacement, velocity, vertex_id; cells are
// the tets (VTK_TETRA) then the strand segments (VTK_LINE), with cell fields rank and J (det F of
// a tet, stretch l / L of a segment).
#pragma once
#include <petscsys.h>

#include <string>
#include <utility>
#include <vector>

#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

struct VtkFrame {
  int frame = 0;
  double time = 0;
  const std::vector<double>* positions = nullptr;   // 3 per local vertex
  const std::vector<double>* velocities = nullptr;  // 3 per local vertex
  const std::vector<double>* J = nullptr;           // per local tet
};

class VtkWriter {
 public:
  VtkWriter(MPI_Comm comm, const DistributedMesh& mesh, std::string directory, std::string name);
  // Writes one frame and rewrites the .pvd so it is valid even if the run stops later.
  // Throws std::runtime_error if a file cannot be written.
  void write(const VtkFrame& f);
  // The mesh whose local arrays the next frames hold (after fixed regions were released).
  void set_mesh(const DistributedMesh& mesh) { mesh_ = &mesh; }

 private:
  void write_piece(const std::string& path, const VtkFrame& f) const;
  void write_pvtu(const std::string& path, const std::string& stem, int nranks) const;
  void write_pvd() const;

  MPI_Comm comm_;
  const DistributedMesh* mesh_;
  std::string dir_, name_;
  std::vector<std::pair<double, std::string>> written_;  // (time, file) for the .pvd
};

}  // namespace hyperqn

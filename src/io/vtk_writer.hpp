// ParaView output: per output frame one .vtu (1 rank) or a .pvtu with one .vtu piece per rank,
// and a .pvd collection listing all frames with their times. XML VTK, inline base64 binary (or
// raw appended data, output.vtu_encoding raw).
// Points are the deformed positions; point fields displacement, velocity, vertex_id; cells are
// the tets (VTK_TETRA) then the strand segments (VTK_LINE), with cell fields rank and J (det F of
// a tet, stretch l / L of a segment).
#pragma once
#include <petscsys.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/output_writer.hpp"
#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

class VtkSeries : public OutputWriter {
 public:
  // raw: the pieces' arrays as raw appended data (output.vtu_encoding raw), else inline base64.
  VtkSeries(MPI_Comm comm, std::string directory, std::string name, bool raw = false);
  void begin_run(const DistributedMesh& mesh) override { set_mesh(mesh); }
  // Writes one frame and rewrites the .pvd so it is valid even if the run stops later.
  void write_frame(const FrameData& f) override;
  // The mesh whose local arrays the next frames hold (after fixed regions were released).
  void set_mesh(const DistributedMesh& mesh) override {
    mesh_ = &mesh;
    mesh_arrays_.reset();  // built again for this mesh at its first frame
  }
  // The .pvd's entries ("time file" lines); resume keeps them and removes the files of frames
  // after `frame` (rank 0), so the series goes on as if the run had not stopped.
  static constexpr const char* kRestartKey = "vtk_pvd";
  std::string restart_key() const override { return kRestartKey; }
  std::string restart_state() const override;
  void resume(const std::string& state, int frame) override;
  bool lists_frame(int frame) const override;
  // The name of the series a restart state lists (its files are NAME_NNNNN...), "" if it lists none.
  static std::string series_name(const std::string& state);

 private:
  void write_piece(const std::string& path, const FrameData& f) const;
  void write_pvtu(const std::string& path, const std::string& stem, const std::vector<int>& pieces, const FrameData& f) const;
  void write_pvd() const;

  MPI_Comm comm_;
  const DistributedMesh* mesh_ = nullptr;
  // A mesh of cloth triangles only (as in the XDMF frames): then a "stretch" cell field.
  bool cloth() const { return mesh_->global_triangles > 0 && mesh_->global_cells + mesh_->global_segments == 0; }
  std::string dir_, name_;
  std::vector<std::pair<double, std::string>> written_;  // (time, file) for the .pvd
  // A piece's arrays that only the mesh determines (the cells' connectivity, offsets and types,
  // each element's rank and body, vertex_id) and, inline, their encoded <DataArray> elements
  // (vertex_id, rank, body, connectivity, offsets, types): the same at every frame of a mesh, so
  // built once, at its first frame, and dropped by set_mesh. Inline, the arrays themselves are
  // freed once encoded (box130k: 14 MB would be held, 8 MB are).
  struct MeshArrays {
    std::vector<int64_t> conn, offsets;
    std::vector<uint8_t> types;
    std::vector<int32_t> ranks, body;
    std::array<std::string, 6> encoded;
  };
  mutable std::unique_ptr<MeshArrays> mesh_arrays_;
  mutable std::vector<double> disp_;  // the frame's displacements, a buffer kept from frame to frame
  mutable std::string xml_;  // write_piece's buffer of the piece's text: its capacity serves the next
  mutable std::vector<std::vector<float>> single_;  // the element fields written as Float32, rounded
  bool raw_ = false;
};

}  // namespace hyperqn

// Output for many ranks (deck output.format: xdmf): every frame goes into ONE HDF5 file per run,
// DIR/NAME.h5, which all ranks write together through MPI-IO, each rank its own block of rows of
// each dataset; DIR/NAME.xdmf is the index (XDMF 3, a temporal collection) that ParaView and meshio
// open. Rows are in a global order that does not depend on the rank count: points by vertex_id
// (input vertices that no element uses are left out), elements by kind (tets, strand segments,
// cloth triangles) and their order in the input mesh. So the same run at 1 and at 1024 ranks
// writes the same arrays.
//
// NAME.h5:
//   /mesh/topology        int64; tets (n, 4), segments (n, 2) or triangles (n, 3) when the mesh
//                         has one kind, else XDMF's Mixed list (6 a b c d | 2 2 a b | 4 a b c)
//   /mesh/rest            (points, 3) rest positions
//   /mesh/vertex_id       (points) each point's index in the input mesh
//   /frames/NNNNN/positions, displacement, velocity, and the terms' point fields (contact_force
//   with colliders): (points, 3)
//   /frames/NNNNN/J       per element: det F of a tet, l / L of a segment, the area ratio of a
//                         triangle; stretch (cloth meshes): the largest principal stretch
//   /mesh/K/topology, rest, vertex_id (K = 1, 2, ...): the mesh after a topology change (cuts,
//                         fracture, snaps, tears: docs/outputs.md#xdmf-output-for-many-ranks), written
//                         at the first frame that shows it; the same layout, with its own points
//                         (copies have vertex ids after the input's). Elements keep their rows;
//                         after a removal (cuts[].remove) the block has its own element rows, and
//                         /mesh/K/body with bodies, and its frames' element fields its rows.
// Each frame's grid has the frame's positions as its geometry and the topology and vertex_id of
// the mesh block current at that frame. The VTK series' per-cell "rank" field is not written: it
// would make the output depend on the rank count.
//
// The file is opened and closed for each frame, and the index (written whole, atomically, by
// rank 0) lists a frame only once its data are in the file and the file is closed.
#pragma once
#include <petscsys.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/global_rows.hpp"
#include "io/output_writer.hpp"

namespace hyperqn {

class XdmfSeries : public OutputWriter {
 public:
  XdmfSeries(MPI_Comm comm, std::string directory, std::string name);
  ~XdmfSeries() override;
  // Throws std::runtime_error if this build's HDF5 cannot write in parallel.
  void begin_run(const DistributedMesh& mesh) override;
  void write_frame(const FrameData& f) override;
  // After a release (the same mesh, fewer fixed vertices) or a topology change (other points, or
  // other elements after a removal: the next frame writes a new mesh block).
  void set_mesh(const DistributedMesh& mesh) override;
  // The frames listed ("xdmf NAME" then "time frame FIELD... NAME@COMPONENTS[/4]... [mesh=K]" lines:
  // point, then element fields, /4 for one written as floats, the mesh block if not 0) and, once
  // the topology changed, the mesh blocks ("mesh K POINTS [TETS SEGMENTS TRIANGLES]" lines, the
  // counts of elements when not the mesh's; a state without them: one block, the mesh's); resume
  // keeps the frames up to `frame` and their blocks, removes the later frames' data and blocks
  // from NAME.h5 and rewrites NAME.xdmf.
  static constexpr const char* kRestartKey = "xdmf";
  std::string restart_key() const override { return kRestartKey; }
  std::string restart_state() const override;
  void resume(const std::string& state, int frame) override;
  bool lists_frame(int frame) const override {
    for (const Listed& l : written_)
      if (l.frame == frame) return true;
    return false;
  }
  // The name of the series a restart state names, "" if none.
  static std::string series_name(const std::string& state);
  // Whether the HDF5 file at path holds a series' data alone (its root only the groups "mesh" and
  // "frames"): the NAME.h5 a run killed before its first index was written leaves, which the next
  // run may write over, unlike a user's file of that name.
  static bool holds_a_series_alone(const std::string& path);

 private:
  struct Layout;  // where this rank's vertices and elements go (global_rows.hpp)
  void write_mesh(size_t block) const;  // block 0 creates NAME.h5
  void write_index() const;
  std::string h5_path() const { return dir_ + "/" + name_ + ".h5"; }

  MPI_Comm comm_;
  std::string dir_, name_;
  const DistributedMesh* mesh_ = nullptr;
  std::unique_ptr<Layout> layout_;
  struct MeshBlock {  // a mesh block in NAME.h5 (/mesh, /mesh/1, ...)
    PetscInt points;
    PetscInt cells[3];  // its tets, segments and triangles
    bool operator==(const MeshBlock& o) const {
      return points == o.points && cells[0] == o.cells[0] && cells[1] == o.cells[1] && cells[2] == o.cells[2];
    }
  };
  MeshBlock current_block() const;  // mesh_'s
  // A block whose cells are not the first block's (tets removed) has its own /mesh/K/body.
  bool own_cells(const MeshBlock& b) const;
  std::vector<MeshBlock> blocks_;
  bool block_current_ = false;  // mesh_ is the last block's mesh (its points and cells are in NAME.h5)
  struct ListedField {  // one of the deck's element fields of a frame
    std::string name;
    int components;
    bool single;  // written as floats (FrameElementField::single)
  };
  struct Listed {
    double time;
    int frame;
    std::vector<std::string> fields;  // the terms' point fields the frame has (FrameData::point_fields)
    std::vector<ListedField> element_fields;
    size_t block;  // its mesh block
  };
  std::vector<Listed> written_;  // the index's frames
};

}  // namespace hyperqn

// Where a scene's mesh comes from: a file, a generated box or sheet, its transform, and strands.
// A field that shapes the mesh belongs in mesh_sources_hash (io/partition_file.cpp) too: a
// partition file of bodies is checked against it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace hyperqn {

struct MeshSpec {
  std::string file;                  // .mesh (Medit), .msh (Gmsh), .obj (a cloth) or .h5 (a partition file); resolved relative to the deck
  bool is_box = false;               // generated box instead of a file
  std::array<double, 3> box_size{1, 1, 1};
  std::array<int, 3> box_cells{1, 1, 1};
  bool is_sheet = false;             // generated cloth sheet instead of a file
  std::array<double, 2> sheet_size{1, 1};
  std::array<int, 2> sheet_cells{1, 1};
  bool surface_as_cloth = false;     // the file's triangles are a cloth (surface: cloth; always for .obj)
  int line = 0;                      // deck line of mesh.box.cells, mesh.sheet.cells or mesh.file (memory check)
  MeshTransform transform;           // applied to the file or box mesh (not to the strands below)
  bool edges_as_strands = false;     // Medit file: its Edges section becomes strand segments
  std::vector<StrandLine> strands;   // generated strands, world coordinates, after the transform
  // file is a partition file (.h5, hyperqn partition: io/partition_file.hpp), already transformed,
  // with its strands and cloth; what its header says the mesh holds (surface_as_cloth: it has triangles).
  bool is_partition_file = false;
  int64_t file_tets = 0, file_segments = 0, file_triangles = 0;
  bool has_strands() const { return edges_as_strands || !strands.empty() || file_segments > 0; }
  bool has_cloth() const { return is_sheet || surface_as_cloth; }
  bool has_solid() const { return is_box || (is_partition_file ? file_tets > 0 : !file.empty() && !surface_as_cloth); }
};

}  // namespace hyperqn

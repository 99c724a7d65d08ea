// Serial tetrahedral mesh as read from a file or generated, before partitioning.
// Lives on rank 0 only; the distributed mesh is built from it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hyperqn {

struct TetMesh {
  std::vector<double> coords;        // 3 per vertex, x y z
  std::vector<int32_t> tets;         // 4 vertex indices (0-based) per tet
  std::vector<int32_t> tet_tags;     // element reference tag per tet (Medit "ref"; 0 if none)
  std::vector<int64_t> vertex_ids;   // per vertex: its 0-based index in the input file
  int64_t num_vertices() const { return (int64_t)coords.size() / 3; }
  int64_t num_tets() const { return (int64_t)tets.size() / 4; }
};

// Reads the Vertices and Tetrahedra sections of an INRIA Medit .mesh file (1-based indices);
// other sections and '#' comments are skipped. Counts, indices and truncation are checked:
// throws InputError naming the file and line.
TetMesh read_medit(const std::string& path);

// Axis-aligned box [0,size] split into cells[0] x cells[1] x cells[2] cubes of 6 tets each
// (Kuhn subdivision, conforming across cubes).
TetMesh generate_box(const std::array<double, 3>& size, const std::array<int, 3>& cells);

struct MeshTransform {
  double scale = 1.0;
  std::array<double, 3> rotate_deg{0, 0, 0};  // applied about x, then y, then z
  std::array<double, 3> translate{0, 0, 0};
};
// x <- Rz Ry Rx (scale * x) + translate
void apply_transform(TetMesh& mesh, const MeshTransform& t);

struct CleanReport {
  int64_t dropped_vertices = 0;   // vertices referenced by no tet
  int64_t reoriented_tets = 0;    // tets whose orientation was flipped to positive
};
// Drops unreferenced vertices (a massless vertex without stiffness makes M + h^2 L singular),
// reorients tets to positive volume det[X1-X0, X2-X0, X3-X0] > 0, and rejects degenerate tets
// (|volume| <= 1e-12 * (mean edge length)^3) with an InputError naming the tet (1-based) and file.
CleanReport clean_mesh(TetMesh& mesh, const std::string& source);

}  // namespace hyperqn

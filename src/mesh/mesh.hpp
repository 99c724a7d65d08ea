// Serial mesh as read from a file or generated, before partitioning: tetrahedra (solids) and
// strand segments (two-vertex line elements: ropes, hair), either or both; or cloth triangles
// (a surface in 3D) alone.
// Lives on rank 0 only; the distributed mesh is built from it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace hyperqn {

// Triangles of a tet mesh's file kept for their tag (Medit Triangles' reference, Gmsh's physical
// group), which a deck's face_tag selects boundary faces by (docs/loads.md#face-tags). Read only
// for the tags a deck names (none: nothing is read); a rank keeps those that touch its piece.
struct TaggedFaces {
  std::vector<int64_t> vertices;  // 3 per triangle: its vertices' ids (TetMesh::vertex_ids), ascending
  std::vector<int32_t> tags;      // per triangle: the tag (a triangle of several Gmsh groups: once per group)
  std::vector<int32_t> file_tags; // every tag the file's triangles carry, ascending (rank 0: messages)
  std::vector<std::pair<int32_t, int64_t>> file_counts;  // per tag kept: its distinct triangles in the file
  int64_t size() const { return (int64_t)tags.size(); }
  bool empty() const { return tags.empty(); }
  int64_t count_in_file(int32_t tag) const {
    for (const auto& [t, n] : file_counts)
      if (t == tag) return n;
    return 0;
  }
  // The sorted vertex ids of the triangles of this tag.
  std::vector<int64_t> vertex_ids_of(int32_t tag) const;
  // A reader's triangle of vertex ids a, b, c and this tag: noted in file_tags, kept if its tag is
  // in wanted (ascending).
  void read(const std::vector<int32_t>& wanted, int32_t tag, int64_t a, int64_t b, int64_t c);
};

// TetMesh::triangle_edges: bit kTornEdgeBit + k marks edge k of a triangle as one side of a torn edge.
constexpr int kTornEdgeBit = 3;
// The global id of the spring that triangle number `triangle` carries on its edge `slot` (the
// history of a cloth's yielding edge springs: terms/cloth_springs.hpp).
inline int64_t edge_spring_id(int64_t triangle, int slot) { return 3 * triangle + slot; }

// The file line of each record of one element kind, as runs of records on consecutive lines (one
// run for a file with one record per line): what lets clean_mesh's errors name the line.
class RecordLines {
 public:
  void add(int64_t record, int line);   // records in increasing order, from 0
  int line_of(int64_t record) const;    // 0 if unknown (a generated element, or none recorded)

 private:
  struct Run {
    int64_t first, count;  // records first .. first + count - 1,
    int line;              // the first at this line, record r at line + r - first
  };
  std::vector<Run> runs_;
};

struct TetMesh {
  std::vector<double> coords;        // 3 per vertex, x y z
  std::vector<int32_t> tets;         // 4 vertex indices (0-based) per tet
  std::vector<int32_t> tet_tags;     // element reference tag per tet (Medit "ref"; 0 if none)
  std::vector<int32_t> segments;     // 2 vertex indices (0-based) per strand segment
  std::vector<int32_t> segment_tags; // element reference tag per segment (Medit "ref"; 0 if none)
  std::vector<int32_t> triangles;    // 3 vertex indices (0-based) per cloth triangle
  std::vector<int32_t> triangle_tags; // element reference tag per triangle (0 if none)
  std::vector<int64_t> vertex_ids;   // per vertex: its 0-based index in the input file
  // Derived from the triangles by clean_mesh (connect_surface):
  std::vector<int32_t> hinges;          // 4 per interior edge: its ends a, b; c opposite it in the
                                        // triangle (a, b, c); d opposite it in the other triangle
  std::vector<uint8_t> triangle_edges;  // per triangle: bit k if it carries its edge k = (v_k, v_{k+1 mod 3});
                                        // every edge is carried by exactly one triangle, but a torn
                                        // one by both: then bit 3 + k too (kTornEdgeBit: each side
                                        // carries half the edge's spring, mesh/cloth_separation.hpp)
  TaggedFaces tagged_faces;             // read for the deck's face tags only (empty otherwise)
  // Filled by the file readers (empty for generated meshes), for clean_mesh's messages.
  RecordLines tet_lines, segment_lines, triangle_lines;
  int64_t num_vertices() const { return (int64_t)coords.size() / 3; }
  int64_t num_tets() const { return (int64_t)tets.size() / 4; }
  int64_t num_segments() const { return (int64_t)segments.size() / 2; }
  int64_t num_triangles() const { return (int64_t)triangles.size() / 3; }
  int64_t num_hinges() const { return (int64_t)hinges.size() / 4; }
};

// Reads the Vertices and Tetrahedra sections of an INRIA Medit .mesh file (1-based indices),
// and its Edges section as strand segments if edges_as_strands (otherwise Edges, which tet mesh
// generators write for feature lines, are skipped like the other sections and '#' comments).
// With triangles_as_cloth its Triangles section is read as a cloth surface instead, and its
// Tetrahedra (if any) are skipped.
// With face_tags (ascending), the Triangles whose reference is one of them are kept in
// tagged_faces (a tet mesh's boundary faces; not with triangles_as_cloth).
// Counts, indices and truncation are checked: throws InputError naming the file and line.
TetMesh read_medit(const std::string& path, bool edges_as_strands = false, bool triangles_as_cloth = false,
                   const std::vector<int32_t>& face_tags = {});

// The bounding box [lo, hi] of points stored x y z one after the other (lo > hi if there are none).
void bounding_box(const std::vector<double>& coords, double lo[3], double hi[3]);
// Diagonal of the bounding box of the vertices (0 for an empty mesh).
double bounding_box_diagonal(const TetMesh& mesh);

// A straight strand from `from` to `to` cut into `segments` equal segments. An end that lies
// on an existing vertex (within 1e-9 of the bounding-box diagonal) is joined to it, which is
// how a strand is attached to a body or to another strand.
struct StrandLine {
  std::array<double, 3> from{0, 0, 0}, to{0, 0, 0};
  int segments = 1;
  int line = 0;                      // deck line, for error messages
};
void add_strand(TetMesh& mesh, const StrandLine& strand);

// Axis-aligned box [0,size] split into cells[0] x cells[1] x cells[2] cubes of 6 tets each
// (Kuhn subdivision, conforming across cubes).
TetMesh generate_box(const std::array<double, 3>& size, const std::array<int, 3>& cells);
// The tetrahedra generate_box makes of `cells`: 6 per cell.
int64_t box_tets(const std::array<int, 3>& cells);

// A flat sheet of cloth in the x-z plane from (0, 0, 0) to (size[0], 0, size[1]): (cells[0] + 1) x
// (cells[1] + 1) vertices, each cell cut into 2 triangles along alternating diagonals (so the sheet
// has no preferred shear direction), all oriented with normal -y.
TetMesh generate_sheet(const std::array<double, 2>& size, const std::array<int, 2>& cells);

struct MeshTransform {
  double scale = 1.0;
  std::array<double, 3> rotate_deg{0, 0, 0};  // applied about x, then y, then z
  std::array<double, 3> translate{0, 0, 0};
};
// x <- Rz Ry Rx (scale * x) + translate
void apply_transform(TetMesh& mesh, const MeshTransform& t);

struct CleanReport {
  int64_t dropped_vertices = 0;   // vertices referenced by no tet and no segment
  int64_t reoriented_tets = 0;    // tets whose orientation was flipped to positive
};
// Drops unreferenced vertices (a massless vertex without stiffness makes M + h^2 L singular),
// reorients tets to positive volume det[X1-X0, X2-X0, X3-X0] > 0, and rejects degenerate tets
// (|volume| <= 1e-12 * (mean edge length)^3), segments (length <= 1e-12 of the bounding-box
// diagonal) and triangles (area <= 1e-12 * (mean edge length)^2) with an InputError naming the
// element (1-based) and file. A mesh with no element is an error too, and so is a cloth surface
// whose edge is shared by more than two triangles. Fills hinges and triangle_edges.
CleanReport clean_mesh(TetMesh& mesh, const std::string& source);

// clean_mesh's last step: the hinges and carried edges of the triangles (each edge is carried by
// the first triangle holding it; a hinge's first triangle, which hinge_triangles gets if not null,
// holds its first three vertices). An edge of three or more triangles is an InputError.
void connect_surface(TetMesh& mesh, const std::string& source, std::vector<int64_t>* hinge_triangles);

}  // namespace hyperqn

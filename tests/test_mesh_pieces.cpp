// Pieces of a mesh (mesh/mesh_piece.hpp): whichever way a mesh is cut (METIS on the serial mesh,
// blocks of a generated box or sheet) and however its pieces are merged or sent, they hold every
// element of the whole mesh exactly once, on the same vertices and coordinates, with the
// cloth's hinges and carried edges the whole mesh has, in the order the piece's rule fixes; and
// the per-element hash sums do not depend on the cut.
#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "mesh/mesh.hpp"
#include "mesh/mesh_piece.hpp"

using namespace hyperqn;

namespace {

constexpr int kSize[4] = {4, 2, 3, 4};
const std::vector<int32_t>& kind(const TetMesh& m, int k) {
  return k == 0 ? m.tets : k == 1 ? m.segments : k == 2 ? m.triangles : m.hinges;
}

// An element by its global vertex numbers (hinges have no number: they are keyed by vertices).
using Element = std::vector<int64_t>;

// Checks the pieces against the whole mesh: every tet, segment and triangle exactly once by
// number, on the same vertices; every hinge exactly once; carried edges and coordinates equal;
// the order rule (vertices ascending, elements ascending within a kind).
void check_cover(const TetMesh& whole, const std::vector<MeshPiece>& pieces, const std::string& what) {
  std::map<int64_t, int> seen[3];
  std::multiset<Element> hinges, whole_hinges;
  bool same_vertices = true, same_coords = true, same_edges = true, ordered = true;
  for (const MeshPiece& p : pieces) {
    const TetMesh& m = p.mesh;
    ordered = ordered && std::is_sorted(p.vertex_numbers.begin(), p.vertex_numbers.end()) &&
              std::adjacent_find(p.vertex_numbers.begin(), p.vertex_numbers.end()) == p.vertex_numbers.end();
    for (int64_t v = 0; v < m.num_vertices(); ++v)
      for (int d = 0; d < 3; ++d) same_coords = same_coords && m.coords[3 * v + d] == whole.coords[3 * p.vertex_numbers[v] + d];
    size_t e = 0;
    for (int k = 0; k < 3; ++k) {
      int64_t last = -1;
      for (size_t i = 0; i < kind(m, k).size() / kSize[k]; ++i, ++e) {
        const int64_t n = p.element_numbers[e];
        ordered = ordered && n > last;
        last = n;
        seen[k][n]++;
        for (int j = 0; j < kSize[k]; ++j)
          same_vertices = same_vertices && p.vertex_numbers[kind(m, k)[kSize[k] * i + j]] == kind(whole, k)[kSize[k] * n + j];
        if (k == 2) same_edges = same_edges && m.triangle_edges[i] == whole.triangle_edges[n];
      }
    }
    for (size_t h = 0; h < m.hinges.size() / 4; ++h) {
      Element x;
      for (int j = 0; j < 4; ++j) x.push_back(p.vertex_numbers[m.hinges[4 * h + j]]);
      hinges.insert(x);
    }
  }
  for (size_t h = 0; h < whole.hinges.size() / 4; ++h)
    whole_hinges.insert(Element(whole.hinges.begin() + 4 * h, whole.hinges.begin() + 4 * h + 4));
  for (int k = 0; k < 3; ++k) {
    bool once = seen[k].size() == kind(whole, k).size() / kSize[k];
    for (const auto& [n, count] : seen[k]) once = once && count == 1;
    CHECK_MSG(once, what + ": every element of kind " + std::to_string(k) + " exactly once");
  }
  CHECK_MSG(same_vertices, what + ": elements on the whole mesh's vertices");
  CHECK_MSG(same_coords, what + ": coordinates");
  CHECK_MSG(same_edges, what + ": carried edges");
  CHECK_MSG(hinges == whole_hinges, what + ": hinges");
  CHECK_MSG(ordered, what + ": vertices and elements in ascending order");
  std::array<uint64_t, 2> sums{0, 0};
  for (const MeshPiece& p : pieces) {
    const auto s = piece_hash_sums(p);
    sums[0] += s[0];
    sums[1] += s[1];
  }
  MeshPiece one;
  pieces_of_serial_mesh(whole, 1, [&](int, MeshPiece& p) { one = std::move(p); });
  CHECK_MSG(sums == piece_hash_sums(one), what + ": hash sums as of the whole mesh");
}

std::vector<MeshPiece> metis_pieces(const TetMesh& whole, int parts) {
  std::vector<MeshPiece> pieces;
  pieces_of_serial_mesh(whole, parts, [&](int part, MeshPiece& p) {
    CHECK(part == (int)pieces.size());
    pieces.push_back(std::move(p));
  });
  return pieces;
}

void test_box_blocks() {
  const std::array<double, 3> size{2.0, 1.0, 0.5};
  const std::array<int, 3> cells{6, 4, 3};
  TetMesh whole = generate_box(size, cells);
  for (int parts : {1, 2, 3, 4, 6, 8}) {
    std::vector<MeshPiece> pieces;
    for (int p = 0; p < parts; ++p) pieces.push_back(box_piece(size, cells, p, parts));
    check_cover(whole, pieces, "box in " + std::to_string(parts) + " blocks");
    check_cover(whole, metis_pieces(whole, parts), "box cut by METIS in " + std::to_string(parts));
  }
  // The grid with the least interface: two parts cut the longest axis, 6 x 4 x 3 cells in 12
  // parts are 3 x 2 x 2 blocks, and a part count no grid fits gives none.
  CHECK((box_block_grid(cells, 2) == std::array<int, 3>{2, 1, 1}));
  CHECK((box_block_grid(cells, 12) == std::array<int, 3>{3, 2, 2}));
  CHECK((box_block_grid({2, 2, 2}, 27) == std::array<int, 3>{0, 0, 0}));
}

void test_sheet_blocks() {
  const std::array<double, 2> size{1.0, 0.8};
  for (const std::array<int, 2>& cells : {std::array<int, 2>{7, 5}, std::array<int, 2>{1, 9}}) {
    TetMesh whole = generate_sheet(size, cells);
    clean_mesh(whole, "sheet");
    for (int parts : {1, 2, 3, 4, 6}) {
      if (box_block_grid({cells[0], cells[1], 1}, parts)[0] == 0) continue;
      std::vector<MeshPiece> pieces;
      for (int p = 0; p < parts; ++p) pieces.push_back(sheet_piece(size, cells, p, parts));
      check_cover(whole, pieces, "sheet in " + std::to_string(parts) + " blocks");
      check_cover(whole, metis_pieces(whole, parts), "sheet cut by METIS in " + std::to_string(parts));
    }
  }
}

void test_strands_pack_merge() {
  TetMesh whole = generate_box({1, 1, 1}, {3, 3, 3});
  add_strand(whole, {{1, 1, 1}, {1.5, 2, 1}, 6, 0});
  whole.tet_tags[5] = 7;
  clean_mesh(whole, "box with a strand");
  std::vector<MeshPiece> pieces = metis_pieces(whole, 3);
  check_cover(whole, pieces, "box with a strand by METIS");
  // Sent as bytes and back: the same piece.
  std::vector<MeshPiece> unpacked;
  for (MeshPiece& p : pieces) {
    std::vector<char> bytes = pack_piece(p);
    unpacked.push_back(unpack_piece(bytes));
    CHECK(pack_piece(unpacked.back()) == bytes);
  }
  check_cover(whole, unpacked, "unpacked pieces");
  bool refused = false;
  try {
    std::vector<char> bytes = pack_piece(pieces[0]);
    bytes.resize(bytes.size() - 3);
    unpack_piece(bytes);
  } catch (const std::runtime_error&) {
    refused = true;
  }
  CHECK_MSG(refused, "a truncated buffer is refused");
  // Merged: one chunk that covers the mesh (element order by piece, so only the cover is checked).
  std::vector<MeshPiece> two(pieces.begin(), pieces.begin() + 2);
  MeshPiece merged = merge_pieces(two);
  CHECK(!merged.final);
  std::vector<MeshPiece> cover{merged, pieces[2]};
  std::map<int64_t, int> tets;
  for (size_t e = 0; e < merged.mesh.tet_tags.size(); ++e) tets[merged.element_numbers[e]]++;
  for (size_t e = 0; e < pieces[2].mesh.tet_tags.size(); ++e) tets[pieces[2].element_numbers[e]]++;
  CHECK(tets.size() == whole.tet_tags.size());
  const auto a = piece_hash_sums(merged), b = piece_hash_sums(pieces[2]);
  MeshPiece one = metis_pieces(whole, 1)[0];
  CHECK_MSG((std::array<uint64_t, 2>{a[0] + b[0], a[1] + b[1]} == piece_hash_sums(one)), "merged hash sums");
  // A changed coordinate changes the hash.
  one.mesh.coords[7] += 1e-12;
  CHECK(piece_hash_sums(one) != piece_hash_sums(metis_pieces(whole, 1)[0]));
}

}  // namespace

int main() {
  test_box_blocks();
  test_sheet_blocks();
  test_strands_pack_merge();
  return check::summary("test_mesh_pieces");
}

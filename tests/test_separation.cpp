// Unit test of mesh/separation.hpp at any rank count: a 6 x 2 x 2 box cut in two across x = 3.01
// (every face between tets whose centroids lie on the two sides of that plane) in two batches, on
// the distributed pieces (box_piece, one per rank) and on the whole box on this rank alone. The
// distributed mesh must equal the serial one: the same tets on the same vertex numbers and ids,
// the same rest positions and fixed flags; the copies' count is the section's vertices; lumped
// masses (a quarter of each tet's rest volume) sum to the uncut total, each vertex's being its own
// tets' quarters; the cut box falls into exactly two pieces. Then remove_tets takes out the tets
// of two cell layers (centroids in 1 < x < 3) the same way: the same mesh at any rank count, the
// orphans (the vertices at x = 2, and the originals at x = 3 whose copies took the other side)
// gone from every piece, the mass of the rest. With a CrackOpening (self-contact's kerf), the rest
// positions move apart but MeshPiece::unopened keeps every vertex's (a copy's: its original's)
// position before the opening, so each tet's volume from it, which its mass comes from, is the
// uncut tet's bit for bit, at any rank count, through a later removal too.
#include <mpi.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <vector>

#include "check.hpp"
#include "mesh/mesh_piece.hpp"
#include "mesh/separation.hpp"
#include "parallel/collectives.hpp"

using namespace hyperqn;

namespace {

const std::array<double, 3> kSize{6.0, 2.0, 2.0};
const std::array<int, 3> kCells{6, 2, 2};
constexpr double kPlane = 3.01;

double centroid_x(const MeshPiece& p, int64_t e) {
  double x = 0;
  for (int j = 0; j < 4; ++j) x += p.mesh.coords[3 * size_t(p.mesh.tets[4 * e + j])];
  return x / 4;
}

// Every face across the plane, as tet pairs, from the whole box (the same list on every rank); the
// first batch those with y < 1 at their shared vertices' mean, the second the rest.
std::vector<std::vector<TetPair>> batches() {
  const MeshPiece whole = box_piece(kSize, kCells, 0, 1);
  std::map<std::array<int32_t, 3>, std::vector<int64_t>> faces;
  for (int64_t e = 0; e < whole.mesh.num_tets(); ++e)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int32_t, 3> f;
      for (int j = 0, k = 0; j < 4; ++j)
        if (j != skip) f[k++] = whole.mesh.tets[4 * e + j];
      std::sort(f.begin(), f.end());
      faces[f].push_back(e);
    }
  std::vector<std::vector<TetPair>> out(2);
  for (const auto& [f, tets] : faces) {
    if (tets.size() != 2 || (centroid_x(whole, tets[0]) < kPlane) == (centroid_x(whole, tets[1]) < kPlane)) continue;
    double y = 0;
    for (int32_t v : f) y += whole.mesh.coords[3 * size_t(v) + 1] / 3;
    const int64_t a = whole.element_numbers[tets[0]], b = whole.element_numbers[tets[1]];
    out[y < 1 ? 0 : 1].push_back({std::min(a, b), std::max(a, b)});
  }
  for (auto& b : out) std::sort(b.begin(), b.end());
  return out;
}

// A piece cut by the batches; fixed: vertices with x = 0 flagged 1, carried to their copies.
struct Cut {
  MeshPiece piece;
  std::vector<int32_t> fixed;
  int64_t copies = 0;
  std::set<TetPair> separated;
};
Cut cut(MPI_Comm comm, MeshPiece piece, double opening = 0) {
  Cut c;
  for (int64_t v = 0; v < piece.mesh.num_vertices(); ++v) c.fixed.push_back(piece.mesh.coords[3 * size_t(v)] == 0);
  std::set<TetPair> separated;
  for (const std::vector<TetPair>& batch : batches()) {
    separated.insert(batch.begin(), batch.end());
    const int64_t before = piece.mesh.num_vertices();
    const SeparationResult r = separate_faces(comm, piece, batch, separated, 1000, {{&c.fixed, 1}}, {nullptr, opening});
    c.copies += r.new_vertices;
    CHECK((int64_t)r.source.size() == piece.mesh.num_vertices());
    for (int32_t s : r.source) CHECK(s >= 0 && s < before);
  }
  c.piece = std::move(piece);
  c.separated = separated;
  return c;
}

// The tets with centroids in 1 < x < 3 (from the whole box: the same list on every rank) removed.
void remove(MPI_Comm comm, Cut& c) {
  const MeshPiece whole = box_piece(kSize, kCells, 0, 1);
  std::vector<int64_t> tets;
  for (int64_t e = 0; e < whole.mesh.num_tets(); ++e)
    if (centroid_x(whole, e) > 1 && centroid_x(whole, e) < 3) tets.push_back(whole.element_numbers[e]);
  std::sort(tets.begin(), tets.end());
  std::vector<int32_t> per_tet(c.piece.mesh.num_tets());
  for (size_t e = 0; e < per_tet.size(); ++e) per_tet[e] = (int32_t)c.piece.element_numbers[e];
  const int64_t before = c.piece.mesh.num_vertices();
  const SeparationResult r = remove_tets(comm, c.piece, tets, c.separated, 1000, {{&c.fixed, 1}}, {&per_tet});
  CHECK(r.new_vertices == 0 && (int64_t)r.source.size() == c.piece.mesh.num_vertices());
  for (int32_t s : r.source) CHECK(s >= 0 && s < before);
  // the per-tet array followed its tets; every local vertex is a local tet's (no orphan)
  CHECK((int64_t)per_tet.size() == c.piece.mesh.num_tets());
  for (size_t e = 0; e < per_tet.size(); ++e) CHECK(per_tet[e] == c.piece.element_numbers[e]);
  std::vector<char> used(c.piece.mesh.num_vertices(), 0);
  for (int32_t v : c.piece.mesh.tets) used[v] = 1;
  CHECK(std::count(used.begin(), used.end(), 0) == 0);
}

// tet number -> (vertex numbers, ids, rest positions, fixed flags) of its 4 vertices, over all ranks.
std::map<int64_t, std::vector<double>> tets_of(MPI_Comm comm, const Cut& c) {
  std::vector<double> mine;
  const MeshPiece& p = c.piece;
  for (int64_t e = 0; e < p.mesh.num_tets(); ++e) {
    mine.push_back((double)p.element_numbers[e]);
    for (int j = 0; j < 4; ++j) {
      const int32_t v = p.mesh.tets[4 * e + j];
      mine.push_back((double)p.vertex_numbers[v]);
      mine.push_back((double)p.mesh.vertex_ids[v]);
      for (int d = 0; d < 3; ++d) mine.push_back(p.mesh.coords[3 * size_t(v) + d]);
      mine.push_back(c.fixed[v]);
    }
  }
  const std::vector<double> all = all_gathered(comm, mine, MPI_DOUBLE);
  std::map<int64_t, std::vector<double>> out;
  for (size_t i = 0; i < all.size(); i += 25) out[(int64_t)all[i]] = std::vector<double>(all.begin() + i + 1, all.begin() + i + 25);
  return out;
}

// tet number -> the 12 coordinates of its vertices in `coords` (the piece's or its unopened), over all ranks.
std::map<int64_t, std::vector<double>> tet_coords(MPI_Comm comm, const MeshPiece& p, const std::vector<double>& coords) {
  std::vector<double> mine;
  for (int64_t e = 0; e < p.mesh.num_tets(); ++e) {
    mine.push_back((double)p.element_numbers[e]);
    for (int j = 0; j < 4; ++j)
      for (int d = 0; d < 3; ++d) mine.push_back(coords[3 * size_t(p.mesh.tets[4 * e + j]) + d]);
  }
  const std::vector<double> all = all_gathered(comm, mine, MPI_DOUBLE);
  std::map<int64_t, std::vector<double>> out;
  for (size_t i = 0; i < all.size(); i += 13) out[(int64_t)all[i]] = std::vector<double>(all.begin() + i + 1, all.begin() + i + 13);
  return out;
}

double tet_volume(const std::vector<double>& X) {
  double D[3][3];
  for (int j = 0; j < 3; ++j)
    for (int d = 0; d < 3; ++d) D[j][d] = X[3 * (j + 1) + d] - X[d];
  return (D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) - D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
          D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0])) / 6;
}

// The kerf: opened cuts' pieces keep the rest positions before the opening for the tets' masses.
void check_opening(int rank, int size) {
  const MeshPiece whole = box_piece(kSize, kCells, 0, 1);
  const auto uncut = tet_coords(MPI_COMM_SELF, whole, whole.mesh.coords);
  for (MPI_Comm comm : {MPI_COMM_SELF, MPI_COMM_WORLD}) {
    Cut c = cut(comm, comm == MPI_COMM_SELF ? box_piece(kSize, kCells, 0, 1) : box_piece(kSize, kCells, rank, size), 0.1);
    CHECK(c.piece.unopened.size() == c.piece.mesh.coords.size());
    const auto opened = tet_coords(comm, c.piece, c.piece.mesh.coords);
    const auto unopened = tet_coords(comm, c.piece, c.piece.unopened);
    CHECK(opened.size() == uncut.size() && unopened == uncut);  // the same positions, bit for bit
    double moved = 0, kerfed = 0, total = 0;
    for (const auto& [tet, X] : opened) {
      for (size_t i = 0; i < X.size(); ++i) moved = std::fmax(moved, std::fabs(X[i] - uncut.at(tet)[i]));
      kerfed += tet_volume(X);
      total += tet_volume(unopened.at(tet));
    }
    CHECK(moved > 0.01 && kerfed < total - 1e-3);  // the rest shape opened and lost volume
    CHECK_NEAR(total, kSize[0] * kSize[1] * kSize[2], 1e-13);
    // a removal after the opening: the remaining tets keep their unopened positions
    remove(comm, c);
    CHECK(c.piece.unopened.size() == c.piece.mesh.coords.size());
    const auto left = tet_coords(comm, c.piece, c.piece.unopened);
    CHECK(left.size() == size_t(6 * 24 - 48));
    for (const auto& [tet, X] : left) CHECK(X == uncut.at(tet));
  }
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const Cut serial = cut(MPI_COMM_SELF, box_piece(kSize, kCells, 0, 1));
  const Cut distributed = cut(MPI_COMM_WORLD, box_piece(kSize, kCells, rank, size));
  const int64_t section = int64_t(kCells[1] + 1) * (kCells[2] + 1);
  CHECK(serial.copies == section && distributed.copies == section);
  CHECK(serial.piece.global_vertices == 7 * section + section && distributed.piece.global_vertices == serial.piece.global_vertices);
  const auto a = tets_of(MPI_COMM_SELF, serial), b = tets_of(MPI_COMM_WORLD, distributed);
  CHECK(a.size() == size_t(6 * 24) && a == b);  // the same mesh, numbers and ids at any rank count

  // Lumped masses: every vertex gets a quarter of each of its tets' volumes.
  std::map<int64_t, double> mass;
  double total = 0;
  for (const auto& [tet, v] : a) {
    double X[4][3];
    for (int j = 0; j < 4; ++j)
      for (int d = 0; d < 3; ++d) X[j][d] = v[6 * j + 2 + d];
    double D[3][3];
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) D[j][d] = X[j + 1][d] - X[0][d];
    const double volume = std::fabs(D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) - D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
                                    D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0])) / 6;
    for (int j = 0; j < 4; ++j) mass[(int64_t)v[6 * j]] += volume / 4;
  }
  for (const auto& [vertex, m] : mass) total += m;
  CHECK((int64_t)mass.size() == 8 * section);  // every vertex, the copies too, has tets
  CHECK_NEAR(total, kSize[0] * kSize[1] * kSize[2], 1e-13);
  // The section's originals and copies: each has half the mass of an uncut section vertex.
  double section_mass = 0;
  for (const auto& [vertex, m] : mass)
    if (vertex >= 7 * section) section_mass += m;
  CHECK_NEAR(section_mass, 0.5 * (kSize[1] * kSize[2]), 1e-13);  // half a cell layer's volume on the copies' side

  // Two pieces: tets joined through shared vertices.
  std::vector<int64_t> parent(8 * section);
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int64_t(int64_t)> root = [&](int64_t i) { return parent[i] == i ? i : parent[i] = root(parent[i]); };
  for (const auto& [tet, v] : a)
    for (int j = 1; j < 4; ++j) parent[root((int64_t)v[6 * j])] = root((int64_t)v[0]);
  std::set<int64_t> roots;
  for (int64_t i = 0; i < 8 * section; ++i) roots.insert(root(i));
  CHECK(roots.size() == 2);

  // Removal: two cell layers (48 tets) go; the vertices at x = 2 and the originals at x = 3 are orphans.
  Cut serial_removed = serial, distributed_removed = distributed;
  remove(MPI_COMM_SELF, serial_removed);
  remove(MPI_COMM_WORLD, distributed_removed);
  const auto ra = tets_of(MPI_COMM_SELF, serial_removed), rb = tets_of(MPI_COMM_WORLD, distributed_removed);
  CHECK(ra.size() == size_t(6 * 24 - 48) && ra == rb);
  std::set<int64_t> left;
  for (const auto& [tet, v] : ra) {
    for (int j = 0; j < 4; ++j) left.insert((int64_t)v[6 * j]);
    CHECK(v[2] < 1 + 1e-12 || v[2] > 3 - 1e-12);  // no vertex of a remaining tet inside 1 < x < 3
  }
  CHECK((int64_t)left.size() == 8 * section - 2 * section);
  double total_left = 0;  // the remaining tets' volume: the box less the two layers
  for (const auto& [tet, v] : ra) {
    double D[3][3];
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) D[j][d] = v[6 * (j + 1) + 2 + d] - v[2 + d];
    total_left += std::fabs(D[0][0] * (D[1][1] * D[2][2] - D[1][2] * D[2][1]) - D[0][1] * (D[1][0] * D[2][2] - D[1][2] * D[2][0]) +
                            D[0][2] * (D[1][0] * D[2][1] - D[1][1] * D[2][0])) / 6;
  }
  CHECK_NEAR(total_left, kSize[0] * kSize[1] * kSize[2] - 2 * kSize[1] * kSize[2], 1e-13);
  // every piece holds only vertices its tets use, and together exactly those of the remaining tets
  std::vector<int64_t> mine(distributed_removed.piece.vertex_numbers.begin(), distributed_removed.piece.vertex_numbers.end());
  std::vector<int64_t> held = all_gathered(MPI_COMM_WORLD, mine, MPI_INT64_T);
  CHECK(std::set<int64_t>(held.begin(), held.end()) == left);
  check_opening(rank, size);
  const int code = check::summary("test_separation");
  MPI_Finalize();
  return code;
}

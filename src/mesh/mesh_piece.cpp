#include "mesh/mesh_piece.hpp"

#include <metis.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace hyperqn {

PieceArrays piece_arrays(MeshPiece& p) {
  TetMesh& m = p.mesh;
  PieceArrays a;
  a.doubles = {{"coords", &m.coords}};
  a.ints = {{"tets", &m.tets},           {"tet_tags", &m.tet_tags},         {"segments", &m.segments},
            {"segment_tags", &m.segment_tags}, {"triangles", &m.triangles}, {"triangle_tags", &m.triangle_tags},
            {"hinges", &m.hinges}};
  a.longs = {{"vertex_ids", &m.vertex_ids}, {"vertex_numbers", &p.vertex_numbers}, {"element_numbers", &p.element_numbers}};
  a.bytes = {{"triangle_edges", &m.triangle_edges}};
  return a;
}

namespace {

// The elements of a mesh by kind, in the order pieces (and the DMPlex) hold them.
constexpr int kKinds = 4;  // tets, segments, triangles, hinges
constexpr int kKindSize[kKinds] = {4, 2, 3, 4};
std::array<const std::vector<int32_t>*, kKinds> kind_vertices(const TetMesh& m) {
  return {&m.tets, &m.segments, &m.triangles, &m.hinges};
}
std::array<std::vector<int32_t>*, kKinds> kind_vertices(TetMesh& m) { return {&m.tets, &m.segments, &m.triangles, &m.hinges}; }

// Element partition (elements in kind order): METIS k-way on the dual graph. Tets are neighbours
// when they share a face, triangles (and hinges) an edge; with strands, elements sharing a vertex
// are, since consecutive segments share only that.
std::vector<int32_t> metis_partition(const TetMesh& mesh, int nparts) {
  const auto kinds = kind_vertices(mesh);
  int64_t total = 0;
  for (int k = 0; k < kKinds; ++k) total += (int64_t)kinds[k]->size() / kKindSize[k];
  std::vector<int32_t> part(total, 0);
  if (nparts == 1 || total == 0) return part;
  idx_t ne = (idx_t)total, nn = (idx_t)mesh.num_vertices();
  std::vector<idx_t> eptr(1, 0), eind;
  eind.reserve(4 * size_t(ne));
  for (int k = 0; k < kKinds; ++k) {
    eind.insert(eind.end(), kinds[k]->begin(), kinds[k]->end());
    for (size_t e = 0; e < kinds[k]->size() / kKindSize[k]; ++e) eptr.push_back(eptr.back() + kKindSize[k]);
  }
  idx_t ncommon = mesh.num_segments() > 0 ? 1 : mesh.num_triangles() > 0 ? 2 : 3, np = nparts, objval = 0;
  idx_t opts[METIS_NOPTIONS];
  METIS_SetDefaultOptions(opts);
  opts[METIS_OPTION_SEED] = 7;  // fixed seed: the same partition on every run
  std::vector<idx_t> epart(ne), npart(nn);
  if (METIS_PartMeshDual(&ne, &nn, eptr.data(), eind.data(), nullptr, nullptr, &ncommon, &np, nullptr, opts, &objval,
                         epart.data(), npart.data()) != METIS_OK)
    throw std::runtime_error("METIS could not partition the mesh");
  std::copy(epart.begin(), epart.end(), part.begin());
  // A hinge goes with the triangle that carries its edge (connect_surface's triangle_edges): a
  // yielding bending spring keeps its state under that edge's id, which its rank must hold.
  const int64_t first_triangle = (int64_t)(mesh.tets.size() / 4 + mesh.segments.size() / 2);
  const int64_t first_hinge = first_triangle + mesh.num_triangles();
  std::vector<std::pair<std::pair<int32_t, int32_t>, int64_t>> carried;  // (edge, its triangle), sorted by edge
  for (int64_t t = 0; t < mesh.num_triangles(); ++t)
    for (int e = 0; e < 3; ++e)
      if (mesh.triangle_edges[t] & (1u << e)) {
        const int32_t a = mesh.triangles[3 * t + e], b = mesh.triangles[3 * t + (e + 1) % 3];
        carried.push_back({{std::min(a, b), std::max(a, b)}, t});
      }
  std::sort(carried.begin(), carried.end());
  for (int64_t h = 0; h < mesh.num_hinges(); ++h) {
    const int32_t a = mesh.hinges[4 * h], b = mesh.hinges[4 * h + 1];
    const std::pair<int32_t, int32_t> edge{std::min(a, b), std::max(a, b)};
    const auto it = std::lower_bound(carried.begin(), carried.end(), std::make_pair(edge, int64_t(-1)));
    if (it != carried.end() && it->first == edge) part[first_hinge + h] = part[first_triangle + it->second];
  }
  return part;
}

template <typename T>
void put(std::vector<char>& out, const std::vector<T>& v) {
  const uint64_t n = v.size();
  const size_t at = out.size();
  out.resize(at + sizeof n + n * sizeof(T));
  std::memcpy(out.data() + at, &n, sizeof n);
  if (n) std::memcpy(out.data() + at + sizeof n, v.data(), n * sizeof(T));
}

template <typename T>
void take(const std::vector<char>& in, size_t& at, std::vector<T>& v) {
  uint64_t n;
  if (at + sizeof n > in.size()) throw std::runtime_error("unpack_piece: truncated buffer");
  std::memcpy(&n, in.data() + at, sizeof n);
  at += sizeof n;
  if (n > (in.size() - at) / sizeof(T)) throw std::runtime_error("unpack_piece: truncated buffer");
  v.resize(n);
  if (n) std::memcpy(v.data(), in.data() + at, n * sizeof(T));
  at += n * sizeof(T);
}

}  // namespace

void pieces_of_serial_mesh(const TetMesh& serial, int nparts, const std::function<void(int, MeshPiece&)>& fn) {
  const std::vector<int32_t> part = metis_partition(serial, nparts);
  const auto kinds = kind_vertices(serial);
  const std::vector<int32_t>* tags[kKinds] = {&serial.tet_tags, &serial.segment_tags, &serial.triangle_tags, nullptr};
  // The elements of each part, in kind order (a counting sort keeps the mesh's order in a part).
  std::vector<int64_t> start(nparts + 1, 0);
  for (int32_t p : part) start[p + 1]++;
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<int64_t> by_part(part.size()), next(start.begin(), start.end() - 1);
  for (int64_t e = 0; e < (int64_t)part.size(); ++e) by_part[next[part[e]]++] = e;
  int64_t kind_start[kKinds + 1] = {0};
  for (int k = 0; k < kKinds; ++k) kind_start[k + 1] = kind_start[k] + (int64_t)kinds[k]->size() / kKindSize[k];

  std::vector<int32_t> local_of(serial.num_vertices(), -1);  // reset after each part
  for (int p = 0; p < nparts; ++p) {
    MeshPiece piece;
    piece.global_vertices = serial.num_vertices();
    std::vector<int64_t>& used = piece.vertex_numbers;
    for (int64_t i = start[p]; i < start[p + 1]; ++i) {
      const int64_t e = by_part[i];
      const int k = int(std::upper_bound(kind_start, kind_start + kKinds + 1, e) - kind_start) - 1;
      for (int j = 0; j < kKindSize[k]; ++j) {
        const int32_t v = (*kinds[k])[kKindSize[k] * (e - kind_start[k]) + j];
        if (local_of[v] < 0) {
          local_of[v] = 0;
          used.push_back(v);
        }
      }
    }
    std::sort(used.begin(), used.end());
    TetMesh& m = piece.mesh;
    for (size_t l = 0; l < used.size(); ++l) {
      local_of[used[l]] = int32_t(l);
      m.coords.insert(m.coords.end(), &serial.coords[3 * used[l]], &serial.coords[3 * used[l]] + 3);
      m.vertex_ids.push_back(serial.vertex_ids[used[l]]);
    }
    auto local = kind_vertices(m);
    std::vector<int32_t>* local_tags[kKinds] = {&m.tet_tags, &m.segment_tags, &m.triangle_tags, nullptr};
    for (int64_t i = start[p]; i < start[p + 1]; ++i) {
      const int64_t e = by_part[i];
      const int k = int(std::upper_bound(kind_start, kind_start + kKinds + 1, e) - kind_start) - 1;
      const int64_t index = e - kind_start[k];
      for (int j = 0; j < kKindSize[k]; ++j) local[k]->push_back(local_of[(*kinds[k])[kKindSize[k] * index + j]]);
      if (tags[k]) local_tags[k]->push_back((*tags[k])[index]);
      if (k == 2) m.triangle_edges.push_back(serial.triangle_edges[index]);
      if (k < 3) piece.element_numbers.push_back(index);
    }
    for (int64_t v : used) local_of[v] = -1;
    fn(p, piece);
  }
}

std::array<int, 3> box_block_grid(const std::array<int, 3>& cells, int nparts) {
  std::array<int, 3> best{0, 0, 0};
  double best_area = HUGE_VAL;
  for (int px = 1; px <= nparts; ++px) {
    if (nparts % px || px > cells[0]) continue;
    for (int py = 1; py <= nparts / px; ++py) {
      if ((nparts / px) % py || py > cells[1]) continue;
      const int pz = nparts / px / py;
      if (pz > cells[2]) continue;
      // Interface faces: each cut across an axis crosses the other two axes' cells.
      const double area = double(px - 1) * cells[1] * cells[2] + double(py - 1) * cells[0] * cells[2] +
                          double(pz - 1) * cells[0] * cells[1];
      if (area < best_area) {
        best_area = area;
        best = {px, py, pz};
      }
    }
  }
  return best;
}

MeshPiece box_piece(const std::array<double, 3>& size, const std::array<int, 3>& cells, int part, int nparts) {
  const std::array<int, 3> grid = box_block_grid(cells, nparts);
  if (grid[0] == 0) throw std::invalid_argument("box_piece: no grid of blocks fits the box");
  const int b[3] = {part % grid[0], (part / grid[0]) % grid[1], part / (grid[0] * grid[1])};
  int lo[3], hi[3];  // this block's cells along each axis: [lo, hi)
  for (int d = 0; d < 3; ++d) {
    lo[d] = int(int64_t(cells[d]) * b[d] / grid[d]);
    hi[d] = int(int64_t(cells[d]) * (b[d] + 1) / grid[d]);
  }
  const int64_t n[3] = {cells[0] + int64_t(1), cells[1] + int64_t(1), cells[2] + int64_t(1)};
  const int64_t ln[3] = {hi[0] - lo[0] + int64_t(1), hi[1] - lo[1] + int64_t(1), hi[2] - lo[2] + int64_t(1)};
  if (ln[0] * ln[1] * ln[2] > std::numeric_limits<int32_t>::max()) throw std::invalid_argument("box_piece: too many cells");
  MeshPiece piece;
  piece.global_vertices = n[0] * n[1] * n[2];
  TetMesh& m = piece.mesh;
  // The block's vertices in the box's order (x fastest, then y, then z): ascending numbers.
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t i = lo[0]; i <= hi[0]; ++i) {
        // As generate_box: i * size / cells, so that the far faces land exactly on size.
        m.coords.push_back(size[0] * double(i) / cells[0]);
        m.coords.push_back(size[1] * double(j) / cells[1]);
        m.coords.push_back(size[2] * double(k) / cells[2]);
        const int64_t v = i + n[0] * (j + n[1] * k);
        m.vertex_ids.push_back(v);
        piece.vertex_numbers.push_back(v);
      }
  // generate_box's Kuhn subdivision, in local vertex indices; tet 6 c + p of cube c as there.
  static const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  const int32_t stride[3] = {1, int32_t(ln[0]), int32_t(ln[0] * ln[1])};
  for (int k = lo[2]; k < hi[2]; ++k)
    for (int j = lo[1]; j < hi[1]; ++j)
      for (int i = lo[0]; i < hi[0]; ++i) {
        const int32_t v0 = (i - lo[0]) * stride[0] + (j - lo[1]) * stride[1] + (k - lo[2]) * stride[2];
        const int64_t cube = i + int64_t(cells[0]) * (j + int64_t(cells[1]) * k);
        for (int p = 0; p < 6; ++p) {
          const int32_t v1 = v0 + stride[perms[p][0]];
          const int32_t v2 = v1 + stride[perms[p][1]];
          const int32_t v3 = v2 + stride[perms[p][2]];
          const bool odd = p >= 3;
          m.tets.insert(m.tets.end(), {v0, v1, odd ? v3 : v2, odd ? v2 : v3});
          piece.element_numbers.push_back(6 * cube + p);
        }
      }
  m.tet_tags.assign(m.tets.size() / 4, 0);
  return piece;
}

MeshPiece sheet_piece(const std::array<double, 2>& size, const std::array<int, 2>& cells, int part, int nparts) {
  for (int d = 0; d < 2; ++d) {
    if (!(size[d] > 0) || !std::isfinite(size[d])) throw std::invalid_argument("generate_sheet: sheet size must be positive");
    if (cells[d] < 1) throw std::invalid_argument("generate_sheet: need at least one cell per axis");
  }
  const std::array<int, 3> grid = box_block_grid({cells[0], cells[1], 1}, nparts);
  if (grid[0] == 0) throw std::invalid_argument("sheet_piece: no grid of blocks fits the sheet");
  const int b[2] = {part % grid[0], part / grid[0]};
  int lo[2], hi[2], plo[2], phi[2];  // the block's cells [lo, hi), and with a halo of one cell [plo, phi)
  for (int d = 0; d < 2; ++d) {
    lo[d] = int(int64_t(cells[d]) * b[d] / grid[d]);
    hi[d] = int(int64_t(cells[d]) * (b[d] + 1) / grid[d]);
    plo[d] = std::max(lo[d] - 1, 0);
    phi[d] = std::min(hi[d] + 1, cells[d]);
  }
  const int64_t nx = cells[0] + int64_t(1), nz = cells[1] + int64_t(1);
  if (nx * nz > std::numeric_limits<int32_t>::max() || 6 * int64_t(cells[0]) * cells[1] > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument("generate_sheet: too many cells");
  // The patch (block and halo) as a mesh in the sheet's order: vertices x fastest, then z; two
  // triangles per cell. Every edge of a block triangle has all its triangles in the patch, so
  // connect_surface finds the block's hinges and carried edges as on the whole sheet.
  const int64_t pnx = phi[0] - plo[0] + 1;
  TetMesh patch;
  for (int64_t k = plo[1]; k <= phi[1]; ++k)
    for (int64_t i = plo[0]; i <= phi[0]; ++i) {
      // i * size / cells rather than accumulating h: the far edges land exactly on size.
      patch.coords.insert(patch.coords.end(), {size[0] * double(i) / cells[0], 0.0, size[1] * double(k) / cells[1]});
      patch.vertex_ids.push_back(i + nx * k);
    }
  std::vector<int64_t> triangle_numbers;
  std::vector<char> in_block;
  for (int32_t k = plo[1]; k < phi[1]; ++k)
    for (int32_t i = plo[0]; i < phi[0]; ++i) {
      const int32_t a = int32_t((i - plo[0]) + pnx * (k - plo[1])), b1 = a + 1, c = int32_t(a + pnx), d = c + 1;
      // (a, b, d) has normal (x) x (z) = -y; the diagonal alternates like a checkerboard.
      const int32_t t[2][3] = {{a, b1, d}, {a, d, c}}, u[2][3] = {{a, b1, c}, {b1, d, c}};
      const int32_t(*cell)[3] = (i + k) % 2 == 0 ? t : u;
      const bool inside = i >= lo[0] && i < hi[0] && k >= lo[1] && k < hi[1];
      for (int q = 0; q < 2; ++q) {
        patch.triangles.insert(patch.triangles.end(), cell[q], cell[q] + 3);
        triangle_numbers.push_back(2 * (i + int64_t(cells[0]) * k) + q);
        in_block.push_back(inside);
      }
    }
  std::vector<int64_t> hinge_triangles;
  connect_surface(patch, "generated sheet", &hinge_triangles);

  // The block's triangles and hinges, on the vertices they use (in the patch's, i.e. the sheet's, order).
  MeshPiece piece;
  piece.global_vertices = nx * nz;
  std::vector<int32_t> local_of(patch.num_vertices(), -1);
  for (int64_t f = 0; f < patch.num_triangles(); ++f)
    if (in_block[f])
      for (int j = 0; j < 3; ++j) local_of[patch.triangles[3 * f + j]] = 0;
  for (int64_t h = 0; h < patch.num_hinges(); ++h)
    if (in_block[hinge_triangles[h]])
      for (int j = 0; j < 4; ++j) local_of[patch.hinges[4 * h + j]] = 0;
  TetMesh& m = piece.mesh;
  for (int64_t v = 0; v < patch.num_vertices(); ++v) {
    if (local_of[v] < 0) continue;
    local_of[v] = int32_t(m.num_vertices());
    m.coords.insert(m.coords.end(), &patch.coords[3 * v], &patch.coords[3 * v] + 3);
    m.vertex_ids.push_back(patch.vertex_ids[v]);
    piece.vertex_numbers.push_back(patch.vertex_ids[v]);
  }
  for (int64_t f = 0; f < patch.num_triangles(); ++f) {
    if (!in_block[f]) continue;
    for (int j = 0; j < 3; ++j) m.triangles.push_back(local_of[patch.triangles[3 * f + j]]);
    m.triangle_edges.push_back(patch.triangle_edges[f]);
    piece.element_numbers.push_back(triangle_numbers[f]);
  }
  for (int64_t h = 0; h < patch.num_hinges(); ++h)
    if (in_block[hinge_triangles[h]])
      for (int j = 0; j < 4; ++j) m.hinges.push_back(local_of[patch.hinges[4 * h + j]]);
  m.triangle_tags.assign(m.triangles.size() / 3, 0);
  return piece;
}

std::vector<char> pack_piece(MeshPiece& piece) {
  std::vector<char> out;
  for_each_array(piece, [&](const std::string&, auto& v) { put(out, v); });
  put(out, std::vector<int64_t>{piece.global_vertices});
  return out;
}

MeshPiece unpack_piece(const std::vector<char>& in) {
  MeshPiece piece;
  size_t at = 0;
  for_each_array(piece, [&](const std::string&, auto& v) { take(in, at, v); });
  std::vector<int64_t> tail;
  take(in, at, tail);
  if (tail.size() != 1 || at != in.size()) throw std::runtime_error("unpack_piece: malformed buffer");
  piece.global_vertices = tail[0];
  return piece;
}

void split_piece(const MeshPiece& piece, int nparts, const std::function<void(int, MeshPiece&)>& fn) {
  // The piece's local indices are a whole mesh of their own; its sub-pieces get back the
  // numbers of the whole mesh (both ascending, so the order rule holds).
  int64_t kind_start[3] = {0, piece.mesh.num_tets(), piece.mesh.num_tets() + piece.mesh.num_segments()};
  pieces_of_serial_mesh(piece.mesh, nparts, [&](int part, MeshPiece& sub) {
    for (int64_t& v : sub.vertex_numbers) v = piece.vertex_numbers[v];
    size_t e = 0;
    const int64_t count[3] = {sub.mesh.num_tets(), sub.mesh.num_segments(), sub.mesh.num_triangles()};
    for (int k = 0; k < 3; ++k)
      for (int64_t i = 0; i < count[k]; ++i, ++e) sub.element_numbers[e] = piece.element_numbers[kind_start[k] + sub.element_numbers[e]];
    sub.global_vertices = piece.global_vertices;
    fn(part, sub);
  });
}

std::array<uint64_t, 2> piece_hash_sums(const MeshPiece& piece) {
  auto mix = [](uint64_t x) {  // splitmix64's finalizer
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
  };
  const TetMesh& m = piece.mesh;
  const auto kinds = kind_vertices(m);
  const std::vector<int32_t>* tags[3] = {&m.tet_tags, &m.segment_tags, &m.triangle_tags};
  std::array<uint64_t, 2> sums{0, 0};
  size_t e = 0;
  for (int k = 0; k < 3; ++k)
    for (size_t i = 0; i < kinds[k]->size() / kKindSize[k]; ++i, ++e) {
      uint64_t h[2] = {0x9e3779b97f4a7c15ULL, 0x243f6a8885a308d3ULL};
      auto add = [&](uint64_t word) {
        h[0] = mix(h[0] ^ word);
        h[1] = mix(h[1] + word * 0xff51afd7ed558ccdULL);
      };
      add(uint64_t(k));
      add(uint64_t(piece.element_numbers[e]));
      add(uint64_t(int64_t((*tags[k])[i])));
      for (int j = 0; j < kKindSize[k]; ++j) {
        const int32_t v = (*kinds[k])[kKindSize[k] * i + j];
        add(uint64_t(m.vertex_ids[v]));
        for (int d = 0; d < 3; ++d) {
          uint64_t bits;
          std::memcpy(&bits, &m.coords[3 * size_t(v) + d], sizeof bits);
          add(bits);
        }
      }
      sums[0] += h[0];
      sums[1] += h[1];
    }
  return sums;
}

MeshPiece merge_pieces(std::vector<MeshPiece>& pieces) {
  MeshPiece merged;
  if (pieces.empty()) return merged;
  merged.global_vertices = pieces[0].global_vertices;
  // The union of the vertices, by number.
  std::vector<std::pair<int64_t, std::pair<size_t, int32_t>>> all;  // number, (piece, local index)
  for (size_t p = 0; p < pieces.size(); ++p)
    for (size_t v = 0; v < pieces[p].vertex_numbers.size(); ++v) all.push_back({pieces[p].vertex_numbers[v], {p, int32_t(v)}});
  std::sort(all.begin(), all.end());
  std::vector<std::vector<int32_t>> local_of(pieces.size());
  for (size_t p = 0; p < pieces.size(); ++p) local_of[p].resize(pieces[p].vertex_numbers.size());
  TetMesh& m = merged.mesh;
  for (size_t i = 0; i < all.size(); ++i) {
    const auto [p, v] = all[i].second;
    if (i == 0 || all[i].first != all[i - 1].first) {
      merged.vertex_numbers.push_back(all[i].first);
      m.vertex_ids.push_back(pieces[p].mesh.vertex_ids[v]);
      m.coords.insert(m.coords.end(), &pieces[p].mesh.coords[3 * v], &pieces[p].mesh.coords[3 * v] + 3);
    }
    local_of[p][v] = int32_t(merged.vertex_numbers.size() - 1);
  }
  auto into = kind_vertices(m);
  for (int k = 0; k < kKinds; ++k)
    for (size_t p = 0; p < pieces.size(); ++p)
      for (int32_t v : *kind_vertices(pieces[p].mesh)[k]) into[k]->push_back(local_of[p][v]);
  for (int k = 0; k < 3; ++k)  // element numbers are stored tets, then segments, then triangles
    for (MeshPiece& piece : pieces) {
      int64_t before = 0;
      for (int j = 0; j < k; ++j) before += (int64_t)kind_vertices(piece.mesh)[j]->size() / kKindSize[j];
      const int64_t count = (int64_t)kind_vertices(piece.mesh)[k]->size() / kKindSize[k];
      merged.element_numbers.insert(merged.element_numbers.end(), piece.element_numbers.begin() + before,
                                    piece.element_numbers.begin() + before + count);
    }
  for (MeshPiece& piece : pieces) {
    m.tet_tags.insert(m.tet_tags.end(), piece.mesh.tet_tags.begin(), piece.mesh.tet_tags.end());
    m.segment_tags.insert(m.segment_tags.end(), piece.mesh.segment_tags.begin(), piece.mesh.segment_tags.end());
  }
  for (MeshPiece& piece : pieces) {
    m.triangle_tags.insert(m.triangle_tags.end(), piece.mesh.triangle_tags.begin(), piece.mesh.triangle_tags.end());
    m.triangle_edges.insert(m.triangle_edges.end(), piece.mesh.triangle_edges.begin(), piece.mesh.triangle_edges.end());
  }
  return merged;
}

}  // namespace hyperqn

#include "mesh/strand_separation.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "parallel/collectives.hpp"

namespace hyperqn {

SeparationResult snap_segments(MPI_Comm comm, MeshPiece& piece, const std::vector<int64_t>& batch,
                               const std::set<int64_t>& snapped, int64_t id_offset,
                               const std::vector<VertexArray>& arrays) {
  TetMesh& m = piece.mesh;
  const int64_t nt = m.num_tets(), ns = m.num_segments();
  const std::set<int64_t> in_batch(batch.begin(), batch.end());
  auto number = [&](int32_t v) { return piece.vertex_numbers[v]; };
  SeparationResult result;

  // The ends of the batch's segments (the only vertices that change), from the pieces holding them.
  std::vector<int64_t> ends;
  for (int64_t s = 0; s < ns; ++s)
    if (in_batch.count(piece.element_numbers[nt + s]))
      for (int j = 0; j < 2; ++j) ends.push_back(number(m.segments[2 * s + j]));
  std::vector<int64_t> affected = all_gathered(comm, ends, MPI_INT64_T);
  std::sort(affected.begin(), affected.end());
  affected.erase(std::unique(affected.begin(), affected.end()), affected.end());
  auto is_affected = [&](int32_t v) { return std::binary_search(affected.begin(), affected.end(), number(v)); };

  // What uses them, from every rank: (vertex, a snapped segment's number, or -1 for any other element).
  std::vector<int64_t> users;
  for (int64_t e = 0; e < nt; ++e)
    for (int j = 0; j < 4; ++j)
      if (is_affected(m.tets[4 * e + j])) users.insert(users.end(), {number(m.tets[4 * e + j]), -1});
  for (int64_t s = 0; s < ns; ++s) {
    const int64_t n = piece.element_numbers[nt + s];
    for (int j = 0; j < 2; ++j)
      if (is_affected(m.segments[2 * s + j])) users.insert(users.end(), {number(m.segments[2 * s + j]), snapped.count(n) ? n : -1});
  }
  for (int32_t v : m.triangles)
    if (is_affected(v)) throw std::logic_error("snap_segments: a strand's vertex is on a cloth triangle");
  const std::vector<int64_t> all = all_gathered(comm, users, MPI_INT64_T);
  std::map<int64_t, std::set<int64_t>> at;  // vertex -> its users, -1 (others) first, then snapped segments ascending
  for (size_t i = 0; i < all.size(); i += 2) at[all[i]].insert(all[i + 1]);

  // The global list of copies, by (vertex, segment): every snapped segment but the one keeping v.
  std::vector<std::array<int64_t, 2>> copies;
  for (const auto& [vertex, u] : at)
    for (auto it = std::next(u.begin()); it != u.end(); ++it) copies.push_back({vertex, *it});
  result.new_vertices = (int64_t)copies.size();

  // The local part: copies of the vertices whose segments this piece holds.
  std::unordered_map<int64_t, int64_t> local_segment;
  for (int64_t s = 0; s < ns; ++s) local_segment[piece.element_numbers[nt + s]] = s;
  const int64_t nv0 = m.num_vertices();
  std::vector<int32_t> source(nv0);
  std::iota(source.begin(), source.end(), 0);
  for (size_t k = 0; k < copies.size(); ++k) {
    const auto found = local_segment.find(copies[k][1]);
    if (found == local_segment.end()) continue;
    const auto where = std::lower_bound(piece.vertex_numbers.begin(), piece.vertex_numbers.begin() + nv0, copies[k][0]);
    const int32_t original = int32_t(where - piece.vertex_numbers.begin());
    const int32_t copy = append_vertex_copy(piece, original, piece.global_vertices + (int64_t)k, id_offset, arrays, source);
    for (int j = 0; j < 2; ++j)
      if (m.segments[2 * found->second + j] == original) m.segments[2 * found->second + j] = copy;
  }
  piece.global_vertices += result.new_vertices;
  drop_unused_vertices(piece, source, arrays);
  result.source = std::move(source);
  return result;
}

}  // namespace hyperqn

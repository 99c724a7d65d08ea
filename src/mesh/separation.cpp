#include "mesh/separation.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "parallel/collectives.hpp"

namespace hyperqn {

namespace {

// A tet as every rank sees it: its number and its vertices' numbers.
struct GlobalTet {
  int64_t number;
  std::array<int64_t, 4> v;
};

// The local tets that `keep` selects, gathered from every rank, sorted by number.
template <typename Keep>
std::vector<GlobalTet> gather_tets(MPI_Comm comm, const MeshPiece& piece, Keep&& keep) {
  std::vector<int64_t> mine;
  const TetMesh& m = piece.mesh;
  for (int64_t e = 0; e < m.num_tets(); ++e) {
    std::array<int64_t, 4> v;
    for (int j = 0; j < 4; ++j) v[j] = piece.vertex_numbers[m.tets[4 * e + j]];
    if (!keep(piece.element_numbers[e], v)) continue;
    mine.push_back(piece.element_numbers[e]);
    mine.insert(mine.end(), v.begin(), v.end());
  }
  const std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);
  std::vector<GlobalTet> tets(all.size() / 5);
  for (size_t i = 0; i < tets.size(); ++i) {
    tets[i].number = all[5 * i];
    for (int j = 0; j < 4; ++j) tets[i].v[j] = all[5 * i + 1 + j];
  }
  std::sort(tets.begin(), tets.end(), [](const GlobalTet& a, const GlobalTet& b) { return a.number < b.number; });
  return tets;
}

int shared_vertices(const GlobalTet& a, const GlobalTet& b) {
  int n = 0;
  for (int64_t x : a.v) n += std::count(b.v.begin(), b.v.end(), x) > 0;
  return n;
}

// One copy of the global list: the original vertex and the tets (ascending) that move to the copy.
struct Copy {
  int64_t vertex;
  std::vector<int64_t> tets;
};

}  // namespace

void drop_unused_vertices(MeshPiece& piece, std::vector<int32_t>& source, const std::vector<VertexArray>& arrays) {
  TetMesh& m = piece.mesh;
  std::vector<char> used(m.num_vertices(), 0);
  for (const std::vector<int32_t>* kind : {&m.tets, &m.segments, &m.triangles, &m.hinges})
    for (int32_t v : *kind) used[v] = 1;
  std::vector<int32_t> new_index(m.num_vertices(), -1);
  int32_t kept = 0;
  for (int64_t v = 0; v < m.num_vertices(); ++v) {
    if (!used[v]) continue;
    new_index[v] = kept;
    for (int d = 0; d < 3; ++d) m.coords[3 * size_t(kept) + d] = m.coords[3 * size_t(v) + d];
    m.vertex_ids[kept] = m.vertex_ids[v];
    piece.vertex_numbers[kept] = piece.vertex_numbers[v];
    source[kept] = source[v];
    for (const VertexArray& a : arrays)
      if (!a.values->empty())
        for (int j = 0; j < a.width; ++j) (*a.values)[size_t(a.width) * kept + j] = (*a.values)[size_t(a.width) * v + j];
    ++kept;
  }
  m.coords.resize(3 * size_t(kept));
  m.vertex_ids.resize(kept);
  piece.vertex_numbers.resize(kept);
  source.resize(kept);
  for (const VertexArray& a : arrays)
    if (!a.values->empty()) a.values->resize(size_t(a.width) * kept);
  for (std::vector<int32_t>* kind : {&m.tets, &m.segments, &m.triangles, &m.hinges})
    for (int32_t& v : *kind) v = new_index[v];
}

SeparationResult separate_faces(MPI_Comm comm, MeshPiece& piece, const std::vector<TetPair>& batch,
                                const std::set<TetPair>& separated, int64_t id_offset,
                                const std::vector<VertexArray>& arrays) {
  TetMesh& m = piece.mesh;
  const int64_t nt = m.num_tets();
  SeparationResult result;

  // The batch's tets, and the vertices of its faces (the only stars that change).
  std::set<int64_t> in_batch;
  for (const TetPair& f : batch) in_batch.insert(f.begin(), f.end());
  const std::vector<GlobalTet> faced = gather_tets(comm, piece, [&](int64_t n, const auto&) { return in_batch.count(n) > 0; });
  std::unordered_map<int64_t, const GlobalTet*> by_number;
  for (const GlobalTet& t : faced) by_number[t.number] = &t;
  std::set<int64_t> affected;
  for (const TetPair& f : batch) {
    const auto a = by_number.find(f[0]), b = by_number.find(f[1]);
    if (a == by_number.end() || b == by_number.end()) throw std::logic_error("separate_faces: a face's tet is on no rank");
    for (int64_t x : a->second->v)
      if (std::count(b->second->v.begin(), b->second->v.end(), x)) affected.insert(x);
  }

  // Their stars, from every rank; each star's components through faces not separated.
  const std::vector<GlobalTet> star_tets = gather_tets(comm, piece, [&](int64_t, const std::array<int64_t, 4>& v) {
    for (int64_t x : v)
      if (affected.count(x)) return true;
    return false;
  });
  std::map<int64_t, std::vector<int>> star;  // vertex -> indices into star_tets, ascending tet number
  for (int i = 0; i < (int)star_tets.size(); ++i)
    for (int64_t x : star_tets[i].v)
      if (affected.count(x)) star[x].push_back(i);
  std::vector<Copy> copies;
  for (const auto& [vertex, tets] : star) {
    const int n = (int)tets.size();
    std::vector<int> parent(n);
    std::iota(parent.begin(), parent.end(), 0);
    const std::function<int(int)> root = [&](int i) { return parent[i] == i ? i : parent[i] = root(parent[i]); };
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const GlobalTet &a = star_tets[tets[i]], &b = star_tets[tets[j]];
        if (shared_vertices(a, b) == 3 && !separated.count({a.number, b.number})) parent[root(j)] = root(i);
      }
    // Components in the order of their smallest tet (tets are ascending): the first keeps the vertex.
    std::map<int, std::vector<int64_t>> components;  // by the first member's index
    std::vector<int> order;
    for (int i = 0; i < n; ++i) {
      const int r = root(i);
      if (!components.count(r)) order.push_back(r);
      components[r].push_back(star_tets[tets[i]].number);
    }
    for (size_t c = 1; c < order.size(); ++c) copies.push_back({vertex, components[order[c]]});
  }
  result.new_vertices = (int64_t)copies.size();

  // The local part: copies of the vertices whose tets this piece holds.
  std::unordered_map<int64_t, int64_t> local_tet;
  for (int64_t e = 0; e < nt; ++e) local_tet[piece.element_numbers[e]] = e;
  const int64_t nv0 = m.num_vertices();
  std::vector<int32_t> source(nv0);
  std::iota(source.begin(), source.end(), 0);
  for (size_t k = 0; k < copies.size(); ++k) {
    const int64_t number = piece.global_vertices + (int64_t)k;
    int32_t copy = -1;
    for (int64_t tet : copies[k].tets) {
      const auto found = local_tet.find(tet);
      if (found == local_tet.end()) continue;
      const auto at = std::lower_bound(piece.vertex_numbers.begin(), piece.vertex_numbers.begin() + nv0, copies[k].vertex);
      const int32_t original = int32_t(at - piece.vertex_numbers.begin());
      if (copy < 0) {
        copy = (int32_t)m.num_vertices();
        for (int d = 0; d < 3; ++d) m.coords.push_back(m.coords[3 * size_t(original) + d]);
        m.vertex_ids.push_back(number + id_offset);
        piece.vertex_numbers.push_back(number);
        for (const VertexArray& a : arrays)
          if (!a.values->empty())
            for (int j = 0; j < a.width; ++j) a.values->push_back((*a.values)[size_t(a.width) * original + j]);
        source.push_back(original);
      }
      for (int j = 0; j < 4; ++j)
        if (m.tets[4 * found->second + j] == original) m.tets[4 * found->second + j] = copy;
    }
  }
  piece.global_vertices += result.new_vertices;

  drop_unused_vertices(piece, source, arrays);
  result.source = std::move(source);
  return result;
}

}  // namespace hyperqn

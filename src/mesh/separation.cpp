#include "mesh/separation.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include "parallel/collectives.hpp"

namespace hyperqn {

namespace {

// A tet as every rank sees it: its number, its vertices' numbers and (if gathered) their positions.
struct GlobalTet {
  int64_t number;
  std::array<int64_t, 4> v;
  std::array<double, 12> rest{}, x{};  // if gathered
};

// The local tets that `keep` selects, gathered from every rank, sorted by number; with_rest: their
// vertices' rest positions too; with positions (3 per local vertex), their positions there.
template <typename Keep>
std::vector<GlobalTet> gather_tets(MPI_Comm comm, const MeshPiece& piece, Keep&& keep, bool with_rest = false,
                                   const std::vector<double>* positions = nullptr) {
  std::vector<int64_t> mine;
  std::vector<double> mine_rest, mine_x;
  const TetMesh& m = piece.mesh;
  for (int64_t e = 0; e < m.num_tets(); ++e) {
    std::array<int64_t, 4> v;
    for (int j = 0; j < 4; ++j) v[j] = piece.vertex_numbers[m.tets[4 * e + j]];
    if (!keep(piece.element_numbers[e], v)) continue;
    mine.push_back(piece.element_numbers[e]);
    mine.insert(mine.end(), v.begin(), v.end());
    for (int j = 0; j < 4; ++j)
      for (int d = 0; d < 3; ++d) {
        if (with_rest) mine_rest.push_back(m.coords[3 * size_t(m.tets[4 * e + j]) + d]);
        if (positions) mine_x.push_back((*positions)[3 * size_t(m.tets[4 * e + j]) + d]);
      }
  }
  const std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);
  const std::vector<double> all_rest = with_rest ? all_gathered(comm, mine_rest, MPI_DOUBLE) : std::vector<double>();
  const std::vector<double> all_x = positions ? all_gathered(comm, mine_x, MPI_DOUBLE) : std::vector<double>();
  std::vector<GlobalTet> tets(all.size() / 5);
  for (size_t i = 0; i < tets.size(); ++i) {
    tets[i].number = all[5 * i];
    for (int j = 0; j < 4; ++j) tets[i].v[j] = all[5 * i + 1 + j];
    if (with_rest) std::copy(all_rest.begin() + 12 * i, all_rest.begin() + 12 * (i + 1), tets[i].rest.begin());
    if (positions) std::copy(all_x.begin() + 12 * i, all_x.begin() + 12 * (i + 1), tets[i].x.begin());
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

using Vec3 = std::array<double, 3>;
Vec3 sub(const double* a, const double* b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3 unit(const Vec3& a) {
  const double n = std::sqrt(dot(a, a));
  return n > 0 ? Vec3{a[0] / n, a[1] / n, a[2] / n} : Vec3{0, 0, 0};
}

// The unit direction u that the unit normals n most recede from: the largest min_f (-u . n_f).
// The optimum on the sphere is a -n_f, or equally far from two or from three of them: every such
// candidate is tried, in a fixed order (the first best kept).
Vec3 most_receding(const std::vector<Vec3>& n) {
  Vec3 best{0, 0, 0};
  double best_margin = -HUGE_VAL;
  auto consider = [&](const Vec3& u) {
    if (dot(u, u) == 0) return;
    double margin = HUGE_VAL;
    for (const Vec3& f : n) margin = std::min(margin, -dot(u, f));
    if (margin > best_margin) {
      best_margin = margin;
      best = u;
    }
  };
  const size_t k = n.size();
  for (size_t i = 0; i < k; ++i) {
    consider(unit({-n[i][0], -n[i][1], -n[i][2]}));
    for (size_t j = i + 1; j < k; ++j) {
      consider(unit({-n[i][0] - n[j][0], -n[i][1] - n[j][1], -n[i][2] - n[j][2]}));
      for (size_t l = j + 1; l < k; ++l) {
        const Vec3 a = {n[i][0] - n[j][0], n[i][1] - n[j][1], n[i][2] - n[j][2]};
        const Vec3 b = {n[i][0] - n[l][0], n[i][1] - n[l][1], n[i][2] - n[l][2]};
        Vec3 u = unit(cross(a, b));  // as far from all three
        if (dot(u, n[i]) > 0) u = {-u[0], -u[1], -u[2]};
        consider(u);
      }
    }
  }
  return best;
}

struct SideShift {
  Vec3 shift;
  double margin;  // min over its boundary faces of -u . n: > 0, they all recede
};

// The move of one side of a splitting vertex (CrackOpening) at the positions `at` of the gathered
// tets (GlobalTet::rest or ::x): `side` indexes star_tets (ascending). Its boundary faces at the
// vertex (faces of its tets there that no other of its tets shares: the new crack, earlier cracks,
// the body's surface) give the directions: the vertex moves along the one they all recede most
// from (most_receding), into the side's own tets, so each crack face moves away from its twin, by
// width / 2 (at most a tenth of the side's least height above the vertex) over the margin (at most
// kMostLean): each boundary face's plane then recedes by width / 2, where the crack meets the
// body's surface (a wedge) as inside it.
SideShift side_shift(int64_t vertex, const std::vector<GlobalTet>& star_tets, std::array<double, 12> GlobalTet::*at,
                     const std::vector<int>& side, double width) {
  std::vector<Vec3> normals;  // unit, out of the side
  double reach = width / 2;
  for (int i : side) {
    const GlobalTet& a = star_tets[i];
    const double* x = (a.*at).data();
    const int v = int(std::find(a.v.begin(), a.v.end(), vertex) - a.v.begin());
    // The height above the vertex: 3 V / the opposite face's area.
    const double* q[3];
    for (int j = 0, k = 0; j < 4; ++j)
      if (j != v) q[k++] = &x[3 * j];
    const Vec3 opposite = cross(sub(q[1], q[0]), sub(q[2], q[0]));
    const double area2 = std::sqrt(dot(opposite, opposite));
    if (area2 > 0) reach = std::min(reach, kOpeningHeightFraction * std::abs(dot(opposite, sub(&x[3 * v], q[0]))) / area2);
    // Its faces at the vertex that no other tet of the side shares: the side's boundary there
    // (the new crack, earlier cracks and the body's surface).
    std::array<bool, 4> inner{};  // by the index of the tet's vertex off the face
    inner[v] = true;              // the face off the vertex
    for (int j : side) {
      if (j == i || shared_vertices(a, star_tets[j]) != 3) continue;
      int away = 0;
      while (std::count(star_tets[j].v.begin(), star_tets[j].v.end(), a.v[away])) ++away;
      inner[away] = true;
    }
    for (int away = 0; away < 4; ++away) {
      if (inner[away]) continue;
      const double* f[3];
      for (int k = 0, m = 0; k < 4; ++k)
        if (k != away) f[m++] = &x[3 * k];
      Vec3 n = unit(cross(sub(f[1], f[0]), sub(f[2], f[0])));
      if (dot(n, sub(&x[3 * away], f[0])) > 0) n = {-n[0], -n[1], -n[2]};  // out of a
      if (dot(n, n) > 0) normals.push_back(n);
    }
  }
  const Vec3 u = most_receding(normals);
  double margin = HUGE_VAL;
  for (const Vec3& f : normals) margin = std::min(margin, -dot(u, f));
  const double move = margin > 0 ? reach * std::min(kMostLean, 1 / margin) : reach;
  return {{move * u[0], move * u[1], move * u[2]}, margin};
}

}  // namespace

int32_t append_vertex_copy(MeshPiece& piece, int32_t original, int64_t number, int64_t id_offset,
                           const std::vector<VertexArray>& arrays, std::vector<int32_t>& source) {
  TetMesh& m = piece.mesh;
  const int32_t copy = (int32_t)m.num_vertices();
  for (int d = 0; d < 3; ++d) m.coords.push_back(m.coords[3 * size_t(original) + d]);
  if (!piece.unopened.empty())
    for (int d = 0; d < 3; ++d) piece.unopened.push_back(piece.unopened[3 * size_t(original) + d]);
  m.vertex_ids.push_back(number + id_offset);
  piece.vertex_numbers.push_back(number);
  for (const VertexArray& a : arrays)
    if (!a.values->empty())
      for (int j = 0; j < a.width; ++j) a.values->push_back((*a.values)[size_t(a.width) * original + j]);
  source.push_back(original);
  return copy;
}

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
    if (!piece.unopened.empty())
      for (int d = 0; d < 3; ++d) piece.unopened[3 * size_t(kept) + d] = piece.unopened[3 * size_t(v) + d];
    m.vertex_ids[kept] = m.vertex_ids[v];
    piece.vertex_numbers[kept] = piece.vertex_numbers[v];
    source[kept] = source[v];
    for (const VertexArray& a : arrays)
      if (!a.values->empty())
        for (int j = 0; j < a.width; ++j) (*a.values)[size_t(a.width) * kept + j] = (*a.values)[size_t(a.width) * v + j];
    ++kept;
  }
  m.coords.resize(3 * size_t(kept));
  if (!piece.unopened.empty()) piece.unopened.resize(3 * size_t(kept));
  m.vertex_ids.resize(kept);
  piece.vertex_numbers.resize(kept);
  source.resize(kept);
  for (const VertexArray& a : arrays)
    if (!a.values->empty()) a.values->resize(size_t(a.width) * kept);
  for (std::vector<int32_t>* kind : {&m.tets, &m.segments, &m.triangles, &m.hinges})
    for (int32_t& v : *kind) v = new_index[v];
}

namespace {

// The stars of the vertices `affected` (global numbers), from every rank, split into their
// components through faces not separated: a copy for each component but the first (see the header),
// and the vertices no local element uses leave the piece. Collective.
SeparationResult split_stars(MPI_Comm comm, MeshPiece& piece, const std::set<int64_t>& affected,
                             const std::set<TetPair>& separated, int64_t id_offset,
                             const std::vector<VertexArray>& arrays, const CrackOpening& opening) {
  TetMesh& m = piece.mesh;
  const int64_t nt = m.num_tets();
  SeparationResult result;
  // Their stars, from every rank; each star's components through faces not separated.
  const std::vector<GlobalTet> star_tets = gather_tets(comm, piece, [&](int64_t, const std::array<int64_t, 4>& v) {
    for (int64_t x : v)
      if (affected.count(x)) return true;
    return false;
  }, opening.width > 0, opening.positions);
  std::map<int64_t, std::vector<int>> star;  // vertex -> indices into star_tets, ascending tet number
  for (int i = 0; i < (int)star_tets.size(); ++i)
    for (int64_t x : star_tets[i].v)
      if (affected.count(x)) star[x].push_back(i);
  std::vector<Copy> copies;
  std::vector<std::array<Vec3, 2>> copy_shift;            // per copy, with an opening: at rest, now
  std::map<int64_t, std::array<Vec3, 2>> original_shift;  // per vertex that splits, its original's
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
    // Components (star_tets indices, ascending) in the order of their smallest tet.
    std::vector<std::vector<int>> sides;
    {
      std::map<int, size_t> of_root;
      for (int i = 0; i < n; ++i) {
        const auto [at, fresh] = of_root.emplace(root(i), sides.size());
        if (fresh) sides.emplace_back();
        sides[at->second].push_back(tets[i]);
      }
    }
    std::vector<SideShift> rest_shift;  // with an opening, per side
    if (opening.width > 0 && sides.size() > 1) {
      // A side whose boundary faces cannot all recede in the rest shape (margin <= 0: it wraps
      // around the vertex, a saddle of a jagged crack) falls apart into groups that can, each
      // with its own copy: a tet's faces at the vertex always recede from a direction into it, so
      // every side opens (docs/records/2026-12-04-bunny-saddle.md). Decided from the rest shape
      // alone (a restart replays it), from the stars in their tets' order (any rank count).
      std::vector<std::vector<int>> split;
      for (const std::vector<int>& side : sides) {
        const SideShift s = side_shift(vertex, star_tets, &GlobalTet::rest, side, opening.width);
        if (s.margin > 0 || side.size() == 1) {
          split.push_back(side);
          rest_shift.push_back(s);
        } else {
          // Into groups that can recede, grown greedily from the side's smallest tet left through
          // its faces not separated, tets in ascending order (a single tet always can).
          std::vector<int> left = side;
          while (!left.empty()) {
            std::vector<int> group = {left[0]};
            left.erase(left.begin());
            SideShift group_shift = side_shift(vertex, star_tets, &GlobalTet::rest, group, opening.width);
            for (bool grown = true; grown;) {
              grown = false;
              for (size_t k = 0; k < left.size(); ++k) {
                const GlobalTet& t = star_tets[left[k]];
                bool joined = false;
                for (int g : group)
                  joined |= shared_vertices(t, star_tets[g]) == 3 && !separated.count({std::min(t.number, star_tets[g].number),
                                                                                        std::max(t.number, star_tets[g].number)});
                if (!joined) continue;
                std::vector<int> bigger = group;
                bigger.insert(std::lower_bound(bigger.begin(), bigger.end(), left[k]), left[k]);
                const SideShift s2 = side_shift(vertex, star_tets, &GlobalTet::rest, bigger, opening.width);
                if (!(s2.margin > 0)) continue;
                group = std::move(bigger);
                group_shift = s2;
                left.erase(left.begin() + k);
                grown = true;
                break;
              }
            }
            split.push_back(std::move(group));
            rest_shift.push_back(group_shift);
          }
        }
      }
      std::vector<size_t> by_first(split.size());
      std::iota(by_first.begin(), by_first.end(), 0);
      std::sort(by_first.begin(), by_first.end(), [&](size_t a, size_t b) { return split[a][0] < split[b][0]; });
      sides.clear();
      std::vector<SideShift> shifts;
      for (size_t k : by_first) {
        sides.push_back(std::move(split[k]));
        shifts.push_back(rest_shift[k]);
      }
      rest_shift = std::move(shifts);
    }
    // The first side keeps the vertex; each other gets a copy.
    for (size_t c = 1; c < sides.size(); ++c) {
      std::vector<int64_t> numbers;
      for (int i : sides[c]) numbers.push_back(star_tets[i].number);
      copies.push_back({vertex, std::move(numbers)});
    }
    if (!(opening.width > 0) || sides.size() < 2) continue;
    // Each side's move in the rest shape (the blade's kerf: replayed on a restart from the rest
    // shape alone) and at the positions. A side that still cannot recede (a degenerate tet) stays;
    // where two or more stay, they keep one rest position, and self-contact treats them as one
    // vertex.
    for (size_t c = 0; c < sides.size(); ++c) {
      const SideShift& rest = rest_shift[c];
      std::array<Vec3, 2> moves = {rest.shift, Vec3{0, 0, 0}};
      if (opening.positions) moves[1] = side_shift(vertex, star_tets, &GlobalTet::x, sides[c], opening.width).shift;
      if (!(rest.margin > 0)) moves = {};
      if (c == 0) original_shift[vertex] = moves;
      else copy_shift.push_back(moves);
    }
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
      if (copy < 0) copy = append_vertex_copy(piece, original, number, id_offset, arrays, source);
      for (int j = 0; j < 4; ++j)
        if (m.tets[4 * found->second + j] == original) m.tets[4 * found->second + j] = copy;
    }
  }
  const int64_t first_copy = piece.global_vertices;
  piece.global_vertices += result.new_vertices;

  drop_unused_vertices(piece, source, arrays);
  result.source = std::move(source);
  if (opening.width > 0) {
    // The rest positions before the first opening, kept for the tets' masses (MeshPiece::unopened).
    if (piece.unopened.empty()) piece.unopened = m.coords;
    if (opening.positions) result.shift.assign(3 * piece.vertex_numbers.size(), 0.0);
    for (size_t i = 0; i < piece.vertex_numbers.size(); ++i) {
      const int64_t number = piece.vertex_numbers[i];
      const auto original = original_shift.find(number);
      const std::array<Vec3, 2>* moves = number >= first_copy ? &copy_shift[size_t(number - first_copy)]
                                         : original == original_shift.end() ? nullptr : &original->second;
      if (!moves) continue;
      for (int d = 0; d < 3; ++d) m.coords[3 * i + d] += (*moves)[0][d];
      if (opening.positions) std::copy((*moves)[1].begin(), (*moves)[1].end(), result.shift.begin() + 3 * i);
    }
  }
  return result;
}

}  // namespace

SeparationResult separate_faces(MPI_Comm comm, MeshPiece& piece, const std::vector<TetPair>& batch,
                                const std::set<TetPair>& separated, int64_t id_offset,
                                const std::vector<VertexArray>& arrays, const CrackOpening& opening) {
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
  return split_stars(comm, piece, affected, separated, id_offset, arrays, opening);
}

SeparationResult remove_tets(MPI_Comm comm, MeshPiece& piece, const std::vector<int64_t>& tets,
                             const std::set<TetPair>& separated, int64_t id_offset,
                             const std::vector<VertexArray>& arrays, const std::vector<std::vector<int32_t>*>& tet_arrays,
                             const CrackOpening& opening) {
  TetMesh& m = piece.mesh;
  const std::set<int64_t> removed(tets.begin(), tets.end());
  // The removed tets' vertices, from every rank: the only stars that change.
  const std::vector<GlobalTet> gone = gather_tets(comm, piece, [&](int64_t n, const auto&) { return removed.count(n) > 0; });
  if (gone.size() != removed.size()) throw std::logic_error("remove_tets: a tet to remove is on no rank (or removed before)");
  std::set<int64_t> affected;
  for (const GlobalTet& t : gone) affected.insert(t.v.begin(), t.v.end());
  // The local tets leave the piece (their tags, numbers and per-tet arrays with them).
  const int64_t nt = m.num_tets();
  int64_t kept = 0;
  for (int64_t e = 0; e < nt; ++e) {
    if (removed.count(piece.element_numbers[e])) continue;
    for (int j = 0; j < 4; ++j) m.tets[4 * kept + j] = m.tets[4 * e + j];
    if (!m.tet_tags.empty()) m.tet_tags[kept] = m.tet_tags[e];
    piece.element_numbers[kept] = piece.element_numbers[e];
    for (std::vector<int32_t>* a : tet_arrays)
      if (!a->empty()) (*a)[kept] = (*a)[e];
    ++kept;
  }
  m.tets.resize(4 * size_t(kept));
  if (!m.tet_tags.empty()) m.tet_tags.resize(kept);
  piece.element_numbers.erase(piece.element_numbers.begin() + kept, piece.element_numbers.begin() + nt);
  for (std::vector<int32_t>* a : tet_arrays)
    if (!a->empty()) a->resize(kept);
  return split_stars(comm, piece, affected, separated, id_offset, arrays, opening);  // the vertices are unchanged so far
}

}  // namespace hyperqn


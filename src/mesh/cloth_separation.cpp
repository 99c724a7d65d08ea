#include "mesh/cloth_separation.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>

#include "parallel/collectives.hpp"

namespace hyperqn {

namespace {

using Triple = std::array<int64_t, 3>;

// A triangle as every rank sees it: its number and its vertices' numbers; with an opening, its
// vertices' rest positions and positions (3 each, in the order of v).
struct GlobalTriangle {
  int64_t number;
  Triple v;
  std::array<double, 9> rest{}, x{};
};

Triple sorted(Triple t) {
  std::sort(t.begin(), t.end());
  return t;
}

// The local triangles whose vertex numbers `keep` selects, gathered from every rank, by number
// (with_rest: with their rest positions; positions: 3 per local vertex, theirs too).
template <typename Keep>
std::vector<GlobalTriangle> gather_triangles(MPI_Comm comm, const MeshPiece& piece, Keep&& keep, bool with_rest = false,
                                             const std::vector<double>* positions = nullptr) {
  const TetMesh& m = piece.mesh;
  const int64_t first = m.num_tets() + m.num_segments();
  std::vector<int64_t> mine;
  std::vector<double> mine_rest, mine_x;
  for (int64_t t = 0; t < m.num_triangles(); ++t) {
    Triple v;
    for (int j = 0; j < 3; ++j) v[j] = piece.vertex_numbers[m.triangles[3 * t + j]];
    const int64_t n = piece.element_numbers[first + t];
    if (!keep(n, v)) continue;
    mine.push_back(n);
    mine.insert(mine.end(), v.begin(), v.end());
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) {
        if (with_rest) mine_rest.push_back(m.coords[3 * size_t(m.triangles[3 * t + j]) + d]);
        if (positions) mine_x.push_back((*positions)[3 * size_t(m.triangles[3 * t + j]) + d]);
      }
  }
  const std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);
  const std::vector<double> all_rest = with_rest ? all_gathered(comm, mine_rest, MPI_DOUBLE) : std::vector<double>();
  const std::vector<double> all_x = positions ? all_gathered(comm, mine_x, MPI_DOUBLE) : std::vector<double>();
  std::vector<GlobalTriangle> triangles(all.size() / 4);
  for (size_t i = 0; i < triangles.size(); ++i) {
    triangles[i] = {all[4 * i], {all[4 * i + 1], all[4 * i + 2], all[4 * i + 3]}};
    if (with_rest) std::copy(all_rest.begin() + 9 * i, all_rest.begin() + 9 * (i + 1), triangles[i].rest.begin());
    if (positions) std::copy(all_x.begin() + 9 * i, all_x.begin() + 9 * (i + 1), triangles[i].x.begin());
  }
  std::sort(triangles.begin(), triangles.end(), [](const GlobalTriangle& a, const GlobalTriangle& b) { return a.number < b.number; });
  return triangles;
}

int shared_vertices(const Triple& a, const Triple& b) {
  int n = 0;
  for (int64_t x : a) n += std::count(b.begin(), b.end(), x) > 0;
  return n;
}

// The move of one side of a torn vertex (CrackOpening) at the positions `at` of the gathered
// triangles (GlobalTriangle::rest or ::x): `side` indexes fan_triangles. The side is a wedge of
// triangles at the vertex; it moves along the wedge's bisector (the sum of its triangles' angle
// bisectors at the vertex, each weighted by its angle), into its own triangles and away from both
// of its boundary edges there, so that it ends width / 2 from them (at most kOpeningHeightFraction
// of its triangles' least height above the vertex). A wedge narrower than a half turn leans its
// bisector toward its edges, so the move along it is longer by 1 / sin(wedge / 2): at a sheet's
// edge a cut splits a half disc into two quarter wedges, whose sides would else start width / √2
// apart, inside the barrier (docs/snapping.md#a-blade-through-a-cloth). The lean is capped at
// kMostLean (mesh/separation.hpp). A wedge without a direction (degenerate triangles) stays.
Eigen::Vector3d side_move(int64_t vertex, const std::vector<GlobalTriangle>& fan_triangles,
                          std::array<double, 9> GlobalTriangle::*at, const std::vector<int>& side, double width) {
  using Vec3 = Eigen::Vector3d;
  Vec3 u = Vec3::Zero();
  double reach = width / 2, wedge = 0;
  for (int i : side) {
    const GlobalTriangle& t = fan_triangles[i];
    const int j = int(std::find(t.v.begin(), t.v.end(), vertex) - t.v.begin());
    const double* x = (t.*at).data();
    const Vec3 p(&x[3 * j]), a(&x[3 * ((j + 1) % 3)]), b(&x[3 * ((j + 2) % 3)]);
    const double la = (a - p).norm(), lb = (b - p).norm(), lab = (b - a).norm();
    if (!(la > 0 && lb > 0 && lab > 0)) continue;
    const Vec3 ea = (a - p) / la, eb = (b - p) / lb;
    const double angle = std::acos(std::clamp(ea.dot(eb), -1.0, 1.0));
    const Vec3 bisector = ea + eb;
    if (bisector.norm() > 0) u += angle * bisector.normalized();
    reach = std::min(reach, kOpeningHeightFraction * (a - p).cross(b - p).norm() / lab);
    wedge += angle;
  }
  if (!(u.norm() > 0) || !(reach > 0)) return Vec3::Zero();
  const double lean = std::min(kMostLean, 1 / std::sin(std::min(wedge, M_PI) / 2));
  return lean * reach * u.normalized();
}

}  // namespace

SeparationResult tear_edges(MPI_Comm comm, MeshPiece& piece, const std::vector<std::array<int64_t, 2>>& batch,
                            const std::set<std::array<int64_t, 2>>& torn, int64_t id_offset,
                            const std::vector<VertexArray>& arrays, const CrackOpening& opening) {
  TetMesh& m = piece.mesh;
  const int64_t first = m.num_tets() + m.num_segments();
  auto number = [&](int32_t v) { return piece.vertex_numbers[v]; };
  SeparationResult result;

  // The batch's triangles, and the ends of its edges (the only fans that change).
  std::set<int64_t> in_batch;
  for (const auto& pair : batch) in_batch.insert(pair.begin(), pair.end());
  const std::vector<GlobalTriangle> faced = gather_triangles(comm, piece, [&](int64_t n, const Triple&) { return in_batch.count(n) > 0; });
  std::unordered_map<int64_t, Triple> by_number;
  for (const GlobalTriangle& t : faced) by_number[t.number] = t.v;
  std::set<int64_t> affected;
  std::set<std::array<Triple, 2>> torn_now;  // the batch's pairs as sorted vertex triples (a hinge's triangles)
  for (const auto& pair : batch) {
    const auto a = by_number.find(pair[0]), b = by_number.find(pair[1]);
    if (a == by_number.end() || b == by_number.end()) throw std::logic_error("tear_edges: an edge's triangle is on no rank");
    if (shared_vertices(a->second, b->second) != 2) throw std::logic_error("tear_edges: two triangles without a common edge");
    for (int64_t x : a->second)
      if (std::count(b->second.begin(), b->second.end(), x)) affected.insert(x);
    const Triple sa = sorted(a->second), sb = sorted(b->second);
    torn_now.insert({std::min(sa, sb), std::max(sa, sb)});
    // The edge's spring was carried by the first triangle (the lower number: connect_surface);
    // the second's new half carries on its history.
    const auto slot = [](const Triple& t, const Triple& other) {
      for (int e = 0; e < 3; ++e)
        if (std::count(other.begin(), other.end(), t[e]) && std::count(other.begin(), other.end(), t[(e + 1) % 3])) return e;
      return -1;
    };
    result.inherited.push_back({edge_spring_id(pair[1], slot(b->second, a->second)), edge_spring_id(pair[0], slot(a->second, b->second))});
  }

  // The hinges as they are before the batch (vertex numbers), then those across its edges go.
  std::vector<std::array<int64_t, 4>> hinge_numbers;
  {
    std::vector<int32_t> kept;
    for (int64_t h = 0; h < m.num_hinges(); ++h) {
      const int32_t* v = &m.hinges[4 * h];
      const std::array<int64_t, 4> g = {number(v[0]), number(v[1]), number(v[2]), number(v[3])};
      const Triple t1 = sorted({g[0], g[1], g[2]}), t2 = sorted({g[0], g[1], g[3]});
      if (torn_now.count({std::min(t1, t2), std::max(t1, t2)})) continue;
      kept.insert(kept.end(), v, v + 4);
      hinge_numbers.push_back(g);
    }
    m.hinges = std::move(kept);
  }
  // Each side of a torn edge carries its own spring, of half the edge's stiffness: the two then
  // store what the edge's spring stored, so a tear adds no energy (each triangle keeps its share).
  for (int64_t t = 0; t < m.num_triangles(); ++t) {
    const int64_t n = piece.element_numbers[first + t];
    if (!in_batch.count(n)) continue;
    for (const auto& pair : batch) {
      if (pair[0] != n && pair[1] != n) continue;
      const Triple& other = by_number.at(pair[0] == n ? pair[1] : pair[0]);
      for (int e = 0; e < 3; ++e) {
        const int64_t a = number(m.triangles[3 * t + e]), b = number(m.triangles[3 * t + (e + 1) % 3]);
        if (std::count(other.begin(), other.end(), a) && std::count(other.begin(), other.end(), b))
          m.triangle_edges[t] = uint8_t(m.triangle_edges[t] | (1u << e) | (1u << (kTornEdgeBit + e)));
      }
    }
  }

  // The fans of the affected vertices, from every rank; each fan's components through edges not torn.
  const std::vector<GlobalTriangle> fan_triangles = gather_triangles(comm, piece, [&](int64_t, const Triple& v) {
    for (int64_t x : v)
      if (affected.count(x)) return true;
    return false;
  }, opening.width > 0, opening.positions);
  std::map<Triple, int64_t> triangle_of;  // sorted vertex numbers -> triangle number
  for (const GlobalTriangle& t : fan_triangles) triangle_of[sorted(t.v)] = t.number;
  std::map<int64_t, std::vector<int>> fan;  // vertex -> indices into fan_triangles, ascending triangle number
  for (int i = 0; i < (int)fan_triangles.size(); ++i)
    for (int64_t x : fan_triangles[i].v)
      if (affected.count(x)) fan[x].push_back(i);
  std::vector<int64_t> copy_vertex;                // per copy of the global list: its original's number
  std::map<std::array<int64_t, 2>, int64_t> moved;  // (vertex, triangle number) -> the copy it moves to
  using Moves = std::array<Eigen::Vector3d, 2>;     // with an opening: at rest, at the positions
  std::vector<Moves> copy_shift;                    // per copy
  std::map<int64_t, Moves> original_shift;          // per vertex that splits, its original's
  for (const auto& [vertex, tris] : fan) {
    const int n = (int)tris.size();
    std::vector<int> parent(n);
    std::iota(parent.begin(), parent.end(), 0);
    const std::function<int(int)> root = [&](int i) { return parent[i] == i ? i : parent[i] = root(parent[i]); };
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const GlobalTriangle &a = fan_triangles[tris[i]], &b = fan_triangles[tris[j]];
        if (shared_vertices(a.v, b.v) == 2 && !torn.count({a.number, b.number})) parent[root(j)] = root(i);
      }
    // Components in the order of their smallest triangle (ascending): the first keeps the vertex.
    std::map<int, int64_t> copy_of_root;
    std::map<int, std::vector<int>> side_of_root;  // each component's fan_triangles indices
    for (int i = 0; i < n; ++i) {
      const int r = root(i);
      side_of_root[r].push_back(tris[i]);
      if (r == root(0)) continue;
      if (!copy_of_root.count(r)) {
        copy_of_root[r] = (int64_t)copy_vertex.size();
        copy_vertex.push_back(vertex);
      }
      moved[{vertex, fan_triangles[tris[i]].number}] = copy_of_root[r];
    }
    if (!(opening.width > 0) || side_of_root.size() < 2) continue;
    // Each side's move: in the rest shape (replayed on a restart from it alone) and at the positions.
    copy_shift.resize(copy_vertex.size(), Moves{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
    for (const auto& [r, side] : side_of_root) {
      Moves moves = {side_move(vertex, fan_triangles, &GlobalTriangle::rest, side, opening.width), Eigen::Vector3d::Zero()};
      if (opening.positions) moves[1] = side_move(vertex, fan_triangles, &GlobalTriangle::x, side, opening.width);
      if (r == root(0)) original_shift[vertex] = moves;
      else copy_shift[copy_of_root[r]] = moves;
    }
  }
  copy_shift.resize(copy_vertex.size(), Moves{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
  result.new_vertices = (int64_t)copy_vertex.size();

  // The local part: which triangle and hinge corners move to which copy.
  const int64_t nv0 = m.num_vertices();
  auto move_of = [&](int64_t vertex, int64_t triangle) {
    const auto it = moved.find({vertex, triangle});
    return it == moved.end() ? int64_t(-1) : it->second;
  };
  std::vector<int64_t> triangle_moves(m.triangles.size(), -1), hinge_moves(m.hinges.size(), -1);
  for (int64_t t = 0; t < m.num_triangles(); ++t)
    for (int j = 0; j < 3; ++j)
      triangle_moves[3 * t + j] = move_of(number(m.triangles[3 * t + j]), piece.element_numbers[first + t]);
  for (size_t h = 0; h < hinge_numbers.size(); ++h) {
    const std::array<int64_t, 4>& g = hinge_numbers[h];
    for (int j = 0; j < 4; ++j) {
      if (!affected.count(g[j])) continue;
      // the hinge's triangle holding this corner: (a, b, c) for a, b and c; (a, b, d) for d
      const auto t = triangle_of.find(sorted({g[0], g[1], g[j == 3 ? 3 : 2]}));
      if (t == triangle_of.end()) throw std::logic_error("tear_edges: a hinge's triangle is on no rank");
      hinge_moves[4 * h + j] = move_of(g[j], t->second);
    }
  }
  // The copies this piece holds, made in the global list's order (so vertex numbers stay ascending).
  std::vector<int32_t> local_copy(copy_vertex.size(), -1);
  for (const std::vector<int64_t>* moves : {&triangle_moves, &hinge_moves})
    for (int64_t k : *moves)
      if (k >= 0) local_copy[k] = 0;
  std::vector<int32_t> source(nv0);
  std::iota(source.begin(), source.end(), 0);
  for (size_t k = 0; k < copy_vertex.size(); ++k) {
    if (local_copy[k] < 0) continue;
    const auto where = std::lower_bound(piece.vertex_numbers.begin(), piece.vertex_numbers.begin() + nv0, copy_vertex[k]);
    const int32_t original = int32_t(where - piece.vertex_numbers.begin());
    local_copy[k] = append_vertex_copy(piece, original, piece.global_vertices + (int64_t)k, id_offset, arrays, source);
  }
  for (size_t i = 0; i < m.triangles.size(); ++i)
    if (triangle_moves[i] >= 0) m.triangles[i] = local_copy[triangle_moves[i]];
  for (size_t i = 0; i < m.hinges.size(); ++i)
    if (hinge_moves[i] >= 0) m.hinges[i] = local_copy[hinge_moves[i]];
  const int64_t first_copy = piece.global_vertices;
  piece.global_vertices += result.new_vertices;

  drop_unused_vertices(piece, source, arrays);
  result.source = std::move(source);
  if (opening.width > 0 && !copy_vertex.empty()) {
    // The rest positions before the first opening, kept for the masses (MeshPiece::unopened).
    if (piece.unopened.empty()) piece.unopened = m.coords;
    if (opening.positions) result.shift.assign(3 * piece.vertex_numbers.size(), 0.0);
    for (size_t i = 0; i < piece.vertex_numbers.size(); ++i) {
      const int64_t number = piece.vertex_numbers[i];
      const auto original = original_shift.find(number);
      const Moves* moves = number >= first_copy ? &copy_shift[size_t(number - first_copy)]
                           : original == original_shift.end() ? nullptr : &original->second;
      if (!moves) continue;
      for (int d = 0; d < 3; ++d) {
        m.coords[3 * i + d] += (*moves)[0][d];
        if (opening.positions) result.shift[3 * i + d] = (*moves)[1][d];
      }
    }
  }
  return result;
}

}  // namespace hyperqn

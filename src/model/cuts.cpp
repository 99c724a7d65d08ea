#include "model/cuts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <utility>

#include "parallel/collectives.hpp"

namespace hyperqn {

// The blades' sweeps over [t0, t1].
static std::vector<BladeSweep> blade_sweeps(const std::vector<CutSpec>& cuts, double t0, double t1) {
  std::vector<BladeSweep> sweeps;
  for (const CutSpec& c : cuts) sweeps.emplace_back(c, t0, t1);
  return sweeps;
}

// faces_crossed's work on the tets gathered within `reach_edges` longest edges (`longest`, over
// every rank) of the sweeps: the faces crossed, and with `find_crumbs` those of crumbs left out.
static std::vector<TetPair> faces_crossed_within(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                                 const std::vector<BladeSweep>& sweeps, double longest,
                                                 double reach_edges, const std::set<TetPair>& separated,
                                                 bool find_crumbs);

std::vector<TetPair> faces_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                   const std::vector<CutSpec>& cuts, double t0, double t1,
                                   const std::set<TetPair>& separated) {
  const TetMesh& m = piece.mesh;
  const std::vector<BladeSweep> sweeps = blade_sweeps(cuts, t0, t1);
  const auto at = [&](int32_t v) { return Eigen::Vector3d(&pos[3 * size_t(v)]); };
  // The centroids of two tets that share a face differ by a quarter of the difference of their
  // opposite vertices, so by at most half the longest edge: both centroids of a face that is
  // crossed lie within half the longest edge of the patch. Gathered: the tets within the longest
  // edge (twice that, for round-off).
  double longest2 = 0;  // squared (the root of the largest is the largest root)
  for (int64_t e = 0; e < m.num_tets(); ++e)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) longest2 = std::max(longest2, (at(m.tets[4 * e + i]) - at(m.tets[4 * e + j])).squaredNorm());
  double longest = std::sqrt(longest2);
  MPI_Allreduce(MPI_IN_PLACE, &longest, 1, MPI_DOUBLE, MPI_MAX, comm);
  // A crumb (below) of up to kCrumbTets tets from a crossed face lies within kCrumbTets / 2 longest
  // edges of the patch, its neighbours within half an edge more. So the wider gather only in a
  // step that cuts (the same answer on every rank).
  if (faces_crossed_within(comm, piece, pos, sweeps, longest, 1, separated, false).empty()) return {};
  return faces_crossed_within(comm, piece, pos, sweeps, longest, (kCrumbTets + 2) / 2.0, separated, true);
}

static std::vector<TetPair> faces_crossed_within(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                                 const std::vector<BladeSweep>& sweeps, double longest,
                                                 double reach_edges, const std::set<TetPair>& separated,
                                                 bool find_crumbs) {
  const TetMesh& m = piece.mesh;
  const auto at = [&](int32_t v) { return Eigen::Vector3d(&pos[3 * size_t(v)]); };
  // Every gathered tet within `deep` of the patch has its neighbours gathered too.
  const double reach = reach_edges * longest, deep = reach - longest;
  std::vector<int64_t> ints;
  std::vector<double> centroids;
  for (int64_t e = 0; e < m.num_tets(); ++e) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int j = 0; j < 4; ++j) c += at(m.tets[4 * e + j]);
    c *= 0.25;
    bool near = false;
    for (const BladeSweep& s : sweeps) near = near || s.near(c, reach);
    if (!near) continue;
    ints.push_back(piece.element_numbers[e]);
    for (int j = 0; j < 4; ++j) ints.push_back(piece.vertex_numbers[m.tets[4 * e + j]]);
    centroids.insert(centroids.end(), c.data(), c.data() + 3);
  }
  const std::vector<int64_t> all_ints = all_gathered(comm, ints, MPI_INT64_T);
  const std::vector<double> all_centroids = all_gathered(comm, centroids, MPI_DOUBLE);
  const size_t n = all_ints.size() / 5;
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return all_ints[5 * a] < all_ints[5 * b]; });
  // The faces between gathered tets: a triangle that two of them share. Each tet's four faces,
  // sorted by their vertices (then by the tet's place in `order`, so a pair's first tet is the
  // lower-numbered): a face two tets share is a run of two. (A sorted array, not a map: this runs
  // at every step of a deck with cuts.)
  struct Face {
    std::array<int64_t, 3> v;
    size_t at;  // the tet's place in order
  };
  std::vector<Face> faces;
  faces.reserve(4 * n);
  for (size_t at = 0; at < n; ++at)
    for (int skip = 0; skip < 4; ++skip) {
      Face f{{}, at};
      for (int j = 0, k = 0; j < 4; ++j)
        if (j != skip) f.v[k++] = all_ints[5 * order[at] + 1 + j];
      std::sort(f.v.begin(), f.v.end());
      faces.push_back(f);
    }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.v < b.v || (a.v == b.v && a.at < b.at); });
  std::vector<TetPair> crossed;
  struct Link {
    size_t other;  // the neighbour's place in order
    bool crossed;  // its face is in this batch
  };
  std::vector<std::vector<Link>> links(find_crumbs ? n : 0);  // per tet (by its place in order), its faces not separated before
  for (size_t p = 0; p < faces.size();) {
    size_t q = p + 1;
    while (q < faces.size() && faces[q].v == faces[p].v) ++q;
    const bool shared = q - p == 2;
    const size_t at_a = faces[p].at, at_b = faces[p + (shared ? 1 : 0)].at;
    const size_t a = order[at_a], b = order[at_b];
    p = q;
    if (!shared) continue;
    const TetPair pair{all_ints[5 * a], all_ints[5 * b]};
    if (separated.count(pair)) continue;
    const Eigen::Vector3d ca(&all_centroids[3 * a]), cb(&all_centroids[3 * b]);
    bool cut = false;
    for (const BladeSweep& s : sweeps) cut = cut || s.crosses(ca, cb);
    if (cut) crossed.push_back(pair);
    if (!find_crumbs) continue;
    links[at_a].push_back({at_b, cut});
    links[at_b].push_back({at_a, cut});
  }
  std::sort(crossed.begin(), crossed.end());
  if (!find_crumbs) return crossed;
  // A crumb: tets the batch would cut loose from the rest on their own, at most kCrumbTets of them
  // joined by faces it keeps (a jagged crack along the mesh's faces frees single tets where the
  // centroids of a tet's neighbours all lie across the blade from its own). Its faces in the batch
  // to tets of no crumb are not cut: it stays with those tets, and the crack goes around it (a body
  // of a few tets cut in two is two crumbs, and is cut). Decided on the gathered tets in their
  // numbers' order, the same on every rank.
  std::vector<char> in_crumb(n, 0);
  std::vector<size_t> flood(n, n);  // the start of the flood that reached a tet last (n: none)
  std::vector<std::vector<size_t>> crumbs;
  const auto is_deep = [&](size_t at) {
    const Eigen::Vector3d c(&all_centroids[3 * order[at]]);
    for (const BladeSweep& s : sweeps)
      if (s.near(c, deep)) return true;
    return false;
  };
  for (size_t start = 0; start < n; ++start) {
    if (in_crumb[start] || std::none_of(links[start].begin(), links[start].end(), [](const Link& l) { return l.crossed; }))
      continue;
    // Its piece through the faces kept, as far as kCrumbTets + 1 tets, or a tet whose neighbours
    // may not all have been gathered: then it is no crumb.
    std::vector<size_t> piece{start};
    flood[start] = start;
    bool closed = true;
    for (size_t i = 0; i < piece.size() && closed; ++i) {
      if (piece.size() > size_t(kCrumbTets) || !is_deep(piece[i])) closed = false;
      for (const Link& l : links[piece[i]])
        if (!l.crossed && flood[l.other] != start) {
          flood[l.other] = start;
          piece.push_back(l.other);
        }
    }
    if (!closed || piece.size() > size_t(kCrumbTets)) continue;
    for (size_t at : piece) in_crumb[at] = 1;
    crumbs.push_back(std::move(piece));
  }
  std::vector<TetPair> kept;  // crossed faces from crumbs to the rest
  for (const std::vector<size_t>& crumb : crumbs)
    for (size_t at : crumb)
      for (const Link& l : links[at])
        if (l.crossed && !in_crumb[l.other]) {
          const int64_t u = all_ints[5 * order[at]], w = all_ints[5 * order[l.other]];
          kept.push_back({std::min(u, w), std::max(u, w)});
        }
  std::sort(kept.begin(), kept.end());
  std::vector<TetPair> cut;
  std::set_difference(crossed.begin(), crossed.end(), kept.begin(), kept.end(), std::back_inserter(cut));
  return cut;
}

std::vector<int64_t> tets_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                  const std::vector<CutSpec>& cuts, double t0, double t1) {
  const TetMesh& m = piece.mesh;
  const std::vector<BladeSweep> sweeps = blade_sweeps(cuts, t0, t1);
  const auto at = [&](int32_t v) { return Eigen::Vector3d(&pos[3 * size_t(v)]); };
  // Each tet lies on one rank, which decides it; an edge is tested from its lower-numbered vertex,
  // so an edge that several tets share gets the same answer in each.
  std::vector<int64_t> mine;
  for (int64_t e = 0; e < m.num_tets(); ++e) {
    bool crossed = false;
    for (int i = 0; i < 4 && !crossed; ++i)
      for (int j = i + 1; j < 4 && !crossed; ++j) {
        int32_t a = m.tets[4 * e + i], b = m.tets[4 * e + j];
        if (piece.vertex_numbers[b] < piece.vertex_numbers[a]) std::swap(a, b);
        for (const BladeSweep& s : sweeps) crossed = crossed || s.crosses(at(a), at(b));
      }
    if (crossed) mine.push_back(piece.element_numbers[e]);
  }
  std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);
  std::sort(all.begin(), all.end());
  return all;
}

std::vector<TrianglePair> cloth_edges_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                              const std::vector<CutSpec>& cuts, double t0, double t1) {
  const TetMesh& m = piece.mesh;
  const std::vector<BladeSweep> sweeps = blade_sweeps(cuts, t0, t1);
  const auto at = [&](int32_t v) { return Eigen::Vector3d(&pos[3 * size_t(v)]); };
  auto number = [&](int32_t v) { return piece.vertex_numbers[v]; };
  // Two triangles that share an edge have centroids a third of their opposite vertices apart, so
  // within the longest edge of each other: a crossed dual edge's centroids are within it of the patch.
  double longest2 = 0;
  for (int64_t t = 0; t < m.num_triangles(); ++t)
    for (int j = 0; j < 3; ++j)
      longest2 = std::max(longest2, (at(m.triangles[3 * t + j]) - at(m.triangles[3 * t + (j + 1) % 3])).squaredNorm());
  double reach = std::sqrt(longest2);
  MPI_Allreduce(MPI_IN_PLACE, &reach, 1, MPI_DOUBLE, MPI_MAX, comm);
  // The crossed hinges as (lower end, higher end, lower opposite, higher opposite) vertex numbers.
  std::vector<int64_t> mine;
  for (int64_t h = 0; h < m.num_hinges(); ++h) {
    const int32_t* v = &m.hinges[4 * h];
    const bool c_first = number(v[2]) < number(v[3]);
    const Eigen::Vector3d ends = at(v[0]) + at(v[1]);
    const Eigen::Vector3d ca = (ends + at(v[c_first ? 2 : 3])) / 3, cb = (ends + at(v[c_first ? 3 : 2])) / 3;
    bool crossed = false;
    for (const BladeSweep& s : sweeps) crossed = crossed || (s.near(ca, reach) && s.crosses(ca, cb));
    if (!crossed) continue;
    const std::array<int64_t, 4> key = {std::min(number(v[0]), number(v[1])), std::max(number(v[0]), number(v[1])),
                                        std::min(number(v[2]), number(v[3])), std::max(number(v[2]), number(v[3]))};
    mine.insert(mine.end(), key.begin(), key.end());
  }
  const std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);
  std::vector<std::array<int64_t, 4>> hinges(all.size() / 4);
  for (size_t i = 0; i < hinges.size(); ++i) hinges[i] = {all[4 * i], all[4 * i + 1], all[4 * i + 2], all[4 * i + 3]};
  std::sort(hinges.begin(), hinges.end());
  hinges.erase(std::unique(hinges.begin(), hinges.end()), hinges.end());
  if (hinges.empty()) return {};
  // Their triangles (a, b, c) and (a, b, d), from the ranks that hold them: (hinge, triangle number).
  std::vector<std::pair<std::array<int64_t, 3>, int64_t>> wanted;  // sorted vertex numbers -> hinge
  for (size_t i = 0; i < hinges.size(); ++i)
    for (int o = 2; o < 4; ++o) {
      std::array<int64_t, 3> tri = {hinges[i][0], hinges[i][1], hinges[i][o]};
      std::sort(tri.begin(), tri.end());
      wanted.push_back({tri, (int64_t)i});
    }
  std::sort(wanted.begin(), wanted.end());
  std::vector<int64_t> found;
  const int64_t first = m.num_tets() + m.num_segments();
  for (int64_t t = 0; t < m.num_triangles(); ++t) {
    std::array<int64_t, 3> tri = {number(m.triangles[3 * t]), number(m.triangles[3 * t + 1]), number(m.triangles[3 * t + 2])};
    std::sort(tri.begin(), tri.end());
    auto it = std::lower_bound(wanted.begin(), wanted.end(), std::make_pair(tri, int64_t(-1)));
    for (; it != wanted.end() && it->first == tri; ++it) found.insert(found.end(), {it->second, piece.element_numbers[first + t]});
  }
  const std::vector<int64_t> all_found = all_gathered(comm, found, MPI_INT64_T);
  std::vector<std::vector<int64_t>> of(hinges.size());
  for (size_t k = 0; k + 1 < all_found.size(); k += 2) of[all_found[k]].push_back(all_found[k + 1]);
  std::vector<TrianglePair> pairs;
  for (std::vector<int64_t>& t : of) {
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    if (t.size() != 2) throw std::logic_error("cloth_edges_crossed: a hinge does not have two triangles");
    pairs.push_back({t[0], t[1]});
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

std::vector<int64_t> segments_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                      const std::vector<CutSpec>& cuts, double t0, double t1,
                                      const std::set<int64_t>& snapped) {
  const TetMesh& m = piece.mesh;
  const std::vector<BladeSweep> sweeps = blade_sweeps(cuts, t0, t1);
  const auto at = [&](int32_t v) { return Eigen::Vector3d(&pos[3 * size_t(v)]); };
  std::vector<int64_t> mine;
  for (int64_t s = 0; s < m.num_segments(); ++s) {
    const int64_t number = piece.element_numbers[m.num_tets() + s];
    if (snapped.count(number)) continue;
    int32_t a = m.segments[2 * s], b = m.segments[2 * s + 1];
    if (piece.vertex_numbers[b] < piece.vertex_numbers[a]) std::swap(a, b);
    bool crossed = false;
    for (const BladeSweep& sweep : sweeps) crossed = crossed || sweep.crosses(at(a), at(b));
    if (crossed) mine.push_back(number);
  }
  std::vector<int64_t> all = all_gathered(comm, mine, MPI_INT64_T);  // a segment on two ranks comes twice
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return all;
}

}  // namespace hyperqn

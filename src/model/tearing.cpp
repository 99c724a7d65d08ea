#include "model/tearing.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "mesh/input_error.hpp"
#include "mesh/separation.hpp"
#include "parallel/collectives.hpp"

namespace hyperqn {

std::vector<double> snap_strains(const SceneSpec& spec) {
  std::vector<double> strains;
  if (spec.bodies.empty()) {
    strains.push_back(spec.strand_material.snap_strain);
  } else {
    for (const BodySpec& b : spec.bodies) strains.push_back(b.strand_material.snap_strain);
  }
  if (std::all_of(strains.begin(), strains.end(), [](double s) { return s == 0; })) strains.clear();
  return strains;
}

std::vector<double> tear_strains(const SceneSpec& spec) {
  std::vector<double> strains;
  if (spec.bodies.empty()) {
    strains.push_back(spec.cloth.tear_strain);
  } else {
    for (const BodySpec& b : spec.bodies) strains.push_back(b.cloth.tear_strain);
  }
  if (std::all_of(strains.begin(), strains.end(), [](double s) { return s == 0; })) strains.clear();
  return strains;
}

bool blades_cut_cloth(const SceneSpec& spec) {
  bool cloth = spec.bodies.empty() && spec.mesh.has_cloth();
  for (const BodySpec& b : spec.bodies) cloth = cloth || b.mesh.has_cloth();
  return cloth && !spec.cuts.empty();
}

// The largest of `of` (a part's cloth and strand material) over the deck's parts: its own or its bodies'.
template <typename Of>
static int largest_of_parts(const SceneSpec& spec, Of of) {
  if (spec.bodies.empty()) return of(spec.cloth, spec.strand_material);
  int most = 0;
  for (const BodySpec& b : spec.bodies) most = std::max(most, of(b.cloth, b.strand_material));
  return most;
}

int tear_resolve(const SceneSpec& spec) {
  return largest_of_parts(spec, [](const ClothSpec& c, const StrandMaterial&) { return c.tear_strain > 0 ? c.tear_resolve : 0; });
}

int snap_resolve(const SceneSpec& spec) {
  return largest_of_parts(spec, [](const ClothSpec&, const StrandMaterial& s) { return s.snap_strain > 0 ? s.snap_resolve : 0; });
}

bool blades_cut_strands(const SceneSpec& spec) {
  bool strands = spec.bodies.empty() && spec.mesh.has_strands();
  for (const BodySpec& b : spec.bodies) strands = strands || b.mesh.has_strands();
  return strands && !spec.cuts.empty();
}

double tear_opening(MPI_Comm comm, const SceneSpec& spec, const MeshPiece& piece, double distance) {
  const TetMesh& m = piece.mesh;
  double least = HUGE_VAL;  // of the cloth triangles' heights
  for (int64_t t = 0; t < m.num_triangles(); ++t) {
    std::array<Eigen::Vector3d, 3> x;
    for (int j = 0; j < 3; ++j) x[j] = Eigen::Vector3d(&m.coords[3 * size_t(m.triangles[3 * t + j])]);
    const double area2 = (x[1] - x[0]).cross(x[2] - x[0]).norm();  // twice the area: height = area2 / base
    for (int j = 0; j < 3; ++j) least = std::min(least, area2 / (x[(j + 1) % 3] - x[j]).norm());
  }
  MPI_Allreduce(MPI_IN_PLACE, &least, 1, MPI_DOUBLE, MPI_MIN, comm);
  std::vector<std::pair<std::string, const ClothSpec*>> cloths;
  if (spec.bodies.empty() && spec.mesh.has_cloth()) cloths.push_back({"cloth", &spec.cloth});
  for (size_t k = 0; k < spec.bodies.size(); ++k)
    if (spec.bodies[k].mesh.has_cloth()) cloths.push_back({"bodies[" + std::to_string(k) + "].cloth", &spec.bodies[k].cloth});
  double thickest = 0;
  const bool cut = blades_cut_cloth(spec);
  for (const auto& [key, cloth] : cloths) {
    if (!(cloth->tear_strain > 0) && !cut) continue;
    thickest = std::max(thickest, cloth->thickness);
    const double most = kOpeningHeightFraction * least;
    if (cloth->thickness < most) continue;
    char what[400];
    std::snprintf(what, sizeof what,
                  "%g is too thick for tearing (or cutting) with self-contact: a torn edge opens by at most %g of its triangles' "
                  "least height on each side (here %.4g m), and its sides must start farther apart than the "
                  "thickness; use a thickness below %.2g (or a coarser cloth)",
                  cloth->thickness, kOpeningHeightFraction, least, most);
    throw InputError(spec.path, cloth->thickness_line, key + ".thickness", what);
  }
  return distance + thickest;
}

namespace {

// The stretch |F n| of the triangle (a, b, c) across its edge a-b: n the unit rest vector in its
// plane perpendicular to the edge (towards c), F the triangle's deformation gradient. From the
// rest (X) and current (x) positions, 3 per vertex.
double stretch_across(const double* X, const double* x, int32_t a, int32_t b, int32_t c) {
  double e[3], w[3], de[3], dw[3], ee = 0, we = 0;
  for (int k = 0; k < 3; ++k) {
    e[k] = X[3 * size_t(b) + k] - X[3 * size_t(a) + k];
    w[k] = X[3 * size_t(c) + k] - X[3 * size_t(a) + k];
    de[k] = x[3 * size_t(b) + k] - x[3 * size_t(a) + k];
    dw[k] = x[3 * size_t(c) + k] - x[3 * size_t(a) + k];
    ee += e[k] * e[k];
    we += w[k] * e[k];
  }
  // n = (w - s e) / h with s = w.e / e.e, h = |w - s e| (the height over the edge): F n = (dw - s de) / h
  const double s = we / ee;
  double h2 = 0, f2 = 0;
  for (int k = 0; k < 3; ++k) {
    h2 += (w[k] - s * e[k]) * (w[k] - s * e[k]);
    f2 += (dw[k] - s * de[k]) * (dw[k] - s * de[k]);
  }
  return std::sqrt(f2 / h2);
}

}  // namespace

double strain_across_edge(const double* rest, const double* pos, const int32_t* hinge) {
  return 0.5 * (stretch_across(rest, pos, hinge[0], hinge[1], hinge[2]) + stretch_across(rest, pos, hinge[0], hinge[1], hinge[3])) - 1;
}

std::vector<TrianglePair> edges_to_tear(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                        const std::vector<double>& strains, const std::vector<int32_t>& vertex_body) {
  const TetMesh& m = piece.mesh;
  auto number = [&](int32_t v) { return piece.vertex_numbers[v]; };
  // Each local hinge's ratio strain / limit (0: not over its limit).
  std::vector<double> ratio(m.num_hinges(), 0.0);
  double most = 0;
  for (int64_t h = 0; h < m.num_hinges(); ++h) {
    const int32_t* v = &m.hinges[4 * h];
    const double limit = strains[vertex_body.empty() ? 0 : vertex_body[v[0]]];
    if (limit <= 0) continue;
    const double strain = strain_across_edge(m.coords.data(), pos.data(), v);
    if (strain > limit) ratio[h] = strain / limit;
    most = std::max(most, ratio[h]);
  }
  MPI_Allreduce(MPI_IN_PLACE, &most, 1, MPI_DOUBLE, MPI_MAX, comm);
  if (most == 0) return {};
  // Of the hinges within kTie of the largest ratio (round-off apart: 1 and 2 ranks' positions differ
  // by it, and a sheet's symmetric edges tie), the one whose (ends' numbers lo, hi, then c, d) is lowest.
  constexpr double kTie = 1e-8;
  std::array<int64_t, 4> best_hinge = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
  for (int64_t h = 0; h < m.num_hinges(); ++h) {
    if (ratio[h] == 0 || ratio[h] < most * (1 - kTie)) continue;
    const int32_t* v = &m.hinges[4 * h];
    const std::array<int64_t, 4> key = {std::min(number(v[0]), number(v[1])), std::max(number(v[0]), number(v[1])),
                                        number(v[2]), number(v[3])};
    best_hinge = std::min(best_hinge, key);
  }
  const std::vector<int64_t> hinges = all_gathered(comm, std::vector<int64_t>(best_hinge.begin(), best_hinge.end()), MPI_INT64_T);
  for (size_t r = 0; r < hinges.size() / 4; ++r)
    best_hinge = std::min(best_hinge, std::array<int64_t, 4>{hinges[4 * r], hinges[4 * r + 1], hinges[4 * r + 2], hinges[4 * r + 3]});
  // Its two triangles (a, b, c) and (a, b, d), from the ranks that hold them.
  std::vector<int64_t> found;
  const int64_t first = m.num_tets() + m.num_segments();
  for (int64_t t = 0; t < m.num_triangles(); ++t) {
    std::array<int64_t, 3> tv;
    for (int j = 0; j < 3; ++j) tv[j] = number(m.triangles[3 * t + j]);
    auto has = [&](int64_t x) { return std::count(tv.begin(), tv.end(), x) > 0; };
    if (has(best_hinge[0]) && has(best_hinge[1]) && (has(best_hinge[2]) || has(best_hinge[3])))
      found.push_back(piece.element_numbers[first + t]);
  }
  std::vector<int64_t> pair = all_gathered(comm, found, MPI_INT64_T);
  if (pair.size() != 2) throw std::logic_error("edges_to_tear: a hinge does not have two triangles");
  std::sort(pair.begin(), pair.end());
  return {TrianglePair{pair[0], pair[1]}};
}

std::vector<int64_t> segments_to_snap(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                      const std::vector<double>& strains, const std::set<int64_t>& snapped) {
  const TetMesh& m = piece.mesh;
  const int64_t nt = m.num_tets();
  // The local segment most over its threshold (strain / limit largest; ties: the lower number).
  double best = 0;
  int64_t best_number = -1;
  for (int64_t s = 0; s < m.num_segments(); ++s) {
    const int32_t tag = m.segment_tags.empty() ? 0 : m.segment_tags[s];
    const double limit = strains.size() == 1 ? strains[0] : strains[tag];
    const int64_t n = piece.element_numbers[nt + s];
    if (limit <= 0 || snapped.count(n)) continue;
    const int32_t a = m.segments[2 * s], b = m.segments[2 * s + 1];
    double l2 = 0, rest2 = 0;
    for (int d = 0; d < 3; ++d) {
      const double dx = pos[3 * size_t(b) + d] - pos[3 * size_t(a) + d];
      const double dX = m.coords[3 * size_t(b) + d] - m.coords[3 * size_t(a) + d];
      l2 += dx * dx;
      rest2 += dX * dX;
    }
    const double strain = std::sqrt(l2) / std::sqrt(rest2) - 1;
    if (strain <= limit) continue;
    const double ratio = strain / limit;
    if (ratio > best || (ratio == best && n < best_number)) {
      best = ratio;
      best_number = n;
    }
  }
  // The same choice over all ranks: every rank's candidate, then the same comparison.
  const std::vector<double> ratios = all_gathered(comm, std::vector<double>{best}, MPI_DOUBLE);
  const std::vector<int64_t> numbers = all_gathered(comm, std::vector<int64_t>{best_number}, MPI_INT64_T);
  best = 0;
  best_number = -1;
  for (size_t r = 0; r < ratios.size(); ++r)
    if (numbers[r] >= 0 && (ratios[r] > best || (ratios[r] == best && numbers[r] < best_number))) {
      best = ratios[r];
      best_number = numbers[r];
    }
  return best_number < 0 ? std::vector<int64_t>() : std::vector<int64_t>{best_number};
}

}  // namespace hyperqn

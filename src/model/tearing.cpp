#include "model/tearing.hpp"

#include <algorithm>
#include <cmath>

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

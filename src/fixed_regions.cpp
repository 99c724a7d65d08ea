#include "fixed_regions.hpp"

#include <algorithm>
#include <cmath>

#include "input_error.hpp"

namespace hyperqn {

static double bbox_diagonal(const TetMesh& mesh) {
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int64_t v = 0; v < mesh.num_vertices(); ++v)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], mesh.coords[3 * v + d]);
      hi[d] = std::max(hi[d], mesh.coords[3 * v + d]);
    }
  double s = 0;
  for (int d = 0; d < 3; ++d) s += (hi[d] - lo[d]) * (hi[d] - lo[d]);
  return std::sqrt(s);
}

std::vector<char> select_fixed_vertices(const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                        const std::string& deck_path) {
  const double tol = 1e-9 * bbox_diagonal(mesh);
  std::vector<char> fixed(mesh.num_vertices(), 0);
  for (size_t b = 0; b < boxes.size(); ++b) {
    const BoxRegion& box = boxes[b];
    int64_t count = 0;
    for (int64_t v = 0; v < mesh.num_vertices(); ++v) {
      const double* p = &mesh.coords[3 * v];
      bool inside = true;
      for (int d = 0; d < 3; ++d) inside = inside && p[d] >= box.min[d] - tol && p[d] <= box.max[d] + tol;
      if (inside) {
        fixed[v] = 1;
        ++count;
      }
    }
    if (count == 0)
      throw InputError(deck_path, box.line, "fixed[" + std::to_string(b) + "].box",
                       "selects no vertex of the mesh (boxes are in coordinates after mesh.transform)");
  }
  return fixed;
}

}  // namespace hyperqn

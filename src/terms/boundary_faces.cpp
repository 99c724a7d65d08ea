#include "terms/boundary_faces.hpp"

#include <algorithm>
#include <map>
#include <utility>

namespace hyperqn {

std::vector<std::array<PetscInt, 3>> local_boundary_faces(const DistributedMesh& m) {
  using Key3 = std::array<int64_t, 3>;
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // outward, as intersections.py
  std::map<Key3, std::pair<int, std::array<PetscInt, 3>>> faces;  // sorted ids -> (tets holding it, the face)
  for (PetscInt c = 0; c < m.num_cells; ++c)
    for (const auto& f : kFaces) {
      const std::array<PetscInt, 3> face{m.cells[4 * c + f[0]], m.cells[4 * c + f[1]], m.cells[4 * c + f[2]]};
      Key3 key{m.vertex_ids[face[0]], m.vertex_ids[face[1]], m.vertex_ids[face[2]]};
      std::sort(key.begin(), key.end());
      auto& entry = faces[key];
      entry.first += 1;
      entry.second = face;
    }
  std::vector<std::array<PetscInt, 3>> out;
  for (const auto& [key, entry] : faces)
    if (entry.first == 1) out.push_back(entry.second);
  return out;
}

}  // namespace hyperqn

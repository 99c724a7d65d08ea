#include "terms/boundary_faces.hpp"

#include <algorithm>
#include <map>
#include <utility>

#include "parallel/collectives.hpp"

namespace hyperqn {

std::vector<std::array<PetscInt, 3>> local_boundary_faces(const DistributedMesh& m, std::vector<int64_t>* tet_faces) {
  using Key3 = std::array<int64_t, 3>;
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};  // outward, as intersections.py
  struct Entry {
    int tets = 0;  // holding it
    std::array<PetscInt, 3> face;
    int64_t tet_face = 0;
  };
  std::map<Key3, Entry> faces;  // by sorted ids
  for (PetscInt c = 0; c < m.num_cells; ++c)
    for (int k = 0; k < 4; ++k) {
      const int* f = kFaces[k];
      const std::array<PetscInt, 3> face{m.cells[4 * c + f[0]], m.cells[4 * c + f[1]], m.cells[4 * c + f[2]]};
      Key3 key{m.vertex_ids[face[0]], m.vertex_ids[face[1]], m.vertex_ids[face[2]]};
      std::sort(key.begin(), key.end());
      Entry& entry = faces[key];
      entry.tets += 1;
      entry.face = face;
      if (tet_faces) entry.tet_face = 4 * m.cell_ids[c] + k;
    }
  std::vector<std::array<PetscInt, 3>> out;
  if (tet_faces) tet_faces->clear();
  for (const auto& [key, entry] : faces)
    if (entry.tets == 1) {
      out.push_back(entry.face);
      if (tet_faces) tet_faces->push_back(entry.tet_face);
    }
  return out;
}

std::vector<char> held_by_one_rank(const DistributedMesh& m, const std::vector<std::array<PetscInt, 3>>& faces) {
  std::vector<int64_t> keys;
  for (const auto& f : faces) {
    std::array<int64_t, 3> key{m.vertex_ids[f[0]], m.vertex_ids[f[1]], m.vertex_ids[f[2]]};
    std::sort(key.begin(), key.end());
    keys.insert(keys.end(), key.begin(), key.end());
  }
  std::map<std::array<int64_t, 3>, int> holders;  // ranks holding each face
  const std::vector<int64_t> all = all_gathered(PetscObjectComm((PetscObject)m.dm), keys, MPI_INT64_T);
  for (size_t k = 0; k < all.size(); k += 3) ++holders[{all[k], all[k + 1], all[k + 2]}];
  std::vector<char> one(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) one[f] = holders[{keys[3 * f], keys[3 * f + 1], keys[3 * f + 2]}] == 1;
  return one;
}

std::vector<int64_t> boundary_tet_faces(const DistributedMesh& m) {
  std::vector<int64_t> tet_faces, out;
  const std::vector<std::array<PetscInt, 3>> faces = local_boundary_faces(m, &tet_faces);
  const std::vector<char> body = held_by_one_rank(m, faces);
  for (size_t f = 0; f < faces.size(); ++f)
    if (body[f]) out.push_back(tet_faces[f]);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace hyperqn

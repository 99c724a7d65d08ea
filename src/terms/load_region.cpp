// The region of a load (terms/load_kind.hpp) and what every load's term says of it.
#include <algorithm>
#include <cmath>
#include <map>

#include "parallel/collectives.hpp"
#include "terms/boundary_faces.hpp"
#include "terms/element_kernels.hpp"
#include "terms/load_kind.hpp"

namespace hyperqn {

namespace {

bool in_box(const LoadSpec& s, const double* p, double tol) {
  for (int d = 0; d < 3; ++d)
    if (p[d] < s.min[d] - tol || p[d] > s.max[d] + tol) return false;
  return true;
}

// A face_tag's region: the tag's triangles that are boundary faces of the tets (the free vertices
// of its triangles), in the box and the normal's cone if given. The boundary faces are found as
// for a box, in the same order, so a tag and a box that select the same faces give the same forces.
LoadRegion select_tagged_region(const DistributedMesh& mesh, const LoadSpec& spec, LoadTarget target) {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  const double tol = 1e-9 * rest_diagonal(mesh);
  const TaggedFaces& tagged = mesh.tagged_faces;
  LoadRegion region;
  region.target = target;
  if (target == LoadTarget::vertices) {
    const std::vector<int64_t> ids = tagged.vertex_ids_of(spec.face_tag);
    for (PetscInt v = 0; v < mesh.num_vertices; ++v)
      if (mesh.owned[v] && mesh.global_dof[v] >= 0 && std::binary_search(ids.begin(), ids.end(), mesh.vertex_ids[v]) &&
          (!spec.has_box || in_box(spec, &mesh.rest[3 * v], tol)))
        region.vertices.push_back(v);
    long long mine = (long long)region.vertices.size();
    MPI_Allreduce(&mine, &region.global_count, 1, MPI_LONG_LONG, MPI_SUM, comm);
    return region;
  }
  std::vector<std::array<int64_t, 3>> tag_keys;
  for (int64_t f = 0; f < tagged.size(); ++f)
    if (tagged.tags[f] == spec.face_tag) tag_keys.push_back({tagged.vertices[3 * f], tagged.vertices[3 * f + 1], tagged.vertices[3 * f + 2]});
  std::sort(tag_keys.begin(), tag_keys.end());
  const Vec3 n = Vec3(spec.normal.data());
  const double cos_angle = std::cos(spec.angle * M_PI / 180);
  // The rank's boundary faces of the tag, each with whether it is in the box and cone: 4 numbers.
  std::vector<std::array<PetscInt, 3>> candidates;
  std::vector<int64_t> keys;
  for (const auto& f : local_boundary_faces(mesh)) {
    std::array<int64_t, 3> key{mesh.vertex_ids[f[0]], mesh.vertex_ids[f[1]], mesh.vertex_ids[f[2]]};
    std::sort(key.begin(), key.end());
    if (!std::binary_search(tag_keys.begin(), tag_keys.end(), key)) continue;
    bool inside = !spec.has_box || (in_box(spec, &mesh.rest[3 * f[0]], tol) && in_box(spec, &mesh.rest[3 * f[1]], tol) &&
                                    in_box(spec, &mesh.rest[3 * f[2]], tol));
    if (inside && n.squaredNorm() > 0) {
      const Vec3 a(&mesh.rest[3 * f[0]]);
      const Vec3 normal = (Vec3(&mesh.rest[3 * f[1]]) - a).cross(Vec3(&mesh.rest[3 * f[2]]) - a);
      inside = normal.dot(n) >= cos_angle * normal.norm() * n.norm();
    }
    candidates.push_back(f);
    keys.insert(keys.end(), key.begin(), key.end());
    keys.push_back(inside);
  }
  // A face between two ranks' tets is a candidate on both: only those one rank alone holds are the body's.
  std::map<std::array<int64_t, 3>, std::pair<int, bool>> holders;
  const std::vector<int64_t> all = all_gathered(comm, keys, MPI_INT64_T);
  for (size_t k = 0; k < all.size(); k += 4) {
    auto& h = holders[{all[k], all[k + 1], all[k + 2]}];
    ++h.first;
    h.second = all[k + 3] != 0;
  }
  for (size_t f = 0; f < candidates.size(); ++f) {
    const auto& h = holders[{keys[4 * f], keys[4 * f + 1], keys[4 * f + 2]}];
    if (h.first == 1 && h.second) region.faces.push_back(candidates[f]);
  }
  long long boundary = 0;
  for (const auto& [key, h] : holders) {
    boundary += h.first == 1;
    region.global_count += h.first == 1 && h.second;
  }
  region.tag_not_boundary = tagged.count_in_file(spec.face_tag) - boundary;
  return region;
}

LoadRegion select_region_in_box(const DistributedMesh& mesh, const LoadSpec& spec, LoadTarget target) {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  const double tol = 1e-9 * rest_diagonal(mesh);
  LoadRegion region;
  region.target = target;
  if (target == LoadTarget::vertices) {
    for (PetscInt v = 0; v < mesh.num_vertices; ++v)
      // A fixed vertex takes no share: global_dof, not local_dof, which a mesh of every vertex
      // (the energy balance's, model/reactions.hpp) gives every vertex.
      if (mesh.owned[v] && mesh.global_dof[v] >= 0 && in_box(spec, &mesh.rest[3 * v], tol)) region.vertices.push_back(v);
    long long mine = (long long)region.vertices.size();
    MPI_Allreduce(&mine, &region.global_count, 1, MPI_LONG_LONG, MPI_SUM, comm);
    return region;
  }
  // The rank's boundary faces in the box; a face between two ranks' tets is a candidate on both,
  // so only the faces that one rank alone holds are the body's. The normal's cone after that: the
  // two ranks see such a face with opposite normals, and one of them alone in the cone would make
  // it the body's (a quarter cylinder's inner surface at 2 ranks took 33 faces for its 32).
  const Vec3 n = Vec3(spec.normal.data());
  const double cos_angle = std::cos(spec.angle * M_PI / 180);
  const auto in_cone = [&](const std::array<PetscInt, 3>& f) {
    if (n.squaredNorm() == 0) return true;
    const Vec3 a(&mesh.rest[3 * f[0]]);
    const Vec3 normal = (Vec3(&mesh.rest[3 * f[1]]) - a).cross(Vec3(&mesh.rest[3 * f[2]]) - a);
    return normal.dot(n) >= cos_angle * normal.norm() * n.norm();
  };
  // After cuts or fracture only the input's boundary faces (mesh.original_boundary): a crack's faces
  // take no load (a face_tag cannot select them either).
  const std::vector<int64_t>* original = mesh.original_boundary.get();
  std::vector<int64_t> tet_faces;
  const std::vector<std::array<PetscInt, 3>> boundary = local_boundary_faces(mesh, &tet_faces);
  std::vector<std::array<PetscInt, 3>> candidates;
  for (size_t b = 0; b < boundary.size(); ++b) {
    const auto& f = boundary[b];
    if (original && !std::binary_search(original->begin(), original->end(), tet_faces[b])) continue;
    if (!in_box(spec, &mesh.rest[3 * f[0]], tol) || !in_box(spec, &mesh.rest[3 * f[1]], tol) ||
        !in_box(spec, &mesh.rest[3 * f[2]], tol))
      continue;
    candidates.push_back(f);
  }
  const std::vector<char> body = held_by_one_rank(mesh, candidates);
  long long mine = 0;
  for (size_t f = 0; f < candidates.size(); ++f)
    if (body[f] && in_cone(candidates[f])) {
      region.faces.push_back(candidates[f]);
      ++mine;
    }
  MPI_Allreduce(&mine, &region.global_count, 1, MPI_LONG_LONG, MPI_SUM, comm);
  return region;
}

}  // namespace

LoadRegion select_load_region(const DistributedMesh& mesh, const LoadSpec& spec, LoadTarget target) {
  LoadRegion region = spec.has_face_tag ? select_tagged_region(mesh, spec, target) : select_region_in_box(mesh, spec, target);
  long long free = 0;
  for (const auto& f : region.faces)
    free += mesh.global_dof[f[0]] >= 0 || mesh.global_dof[f[1]] >= 0 || mesh.global_dof[f[2]] >= 0;
  MPI_Allreduce(&free, &region.global_free_faces, 1, MPI_LONG_LONG, MPI_SUM, PetscObjectComm((PetscObject)mesh.dm));
  return region;
}

PetscErrorCode LoadTerm::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  double e = *energy;
  for (size_t k = 0; k < dead_vertices_.size(); ++k) {
    const PetscInt v = dead_vertices_[k];
    const Vec3 f = factor_ * dead_forces_[k];
    e -= f.dot(Vec3(&pos[3 * v]) - Vec3(&mesh_.rest[3 * v]));
    if (gradient) add_vertex_vector(mesh_, v, -f, gradient);
  }
  *energy = e;
  return 0;
}

std::string LoadTerm::describe() const {
  const bool faces = region_.target == LoadTarget::faces;
  std::string text = "loads[" + std::to_string(index_) + "] " + spec_.type + " (deck line " + std::to_string(spec_.line) +
                     ") on " + std::to_string(region_.global_count) + (faces ? " boundary faces" : " free vertices");
  if (spec_.has_face_tag) text += " of face_tag " + std::to_string(spec_.face_tag);
  if (region_.tag_not_boundary > 0)
    text += " (" + std::to_string(region_.tag_not_boundary) + " of the tag's triangles are not boundary faces of the tets: left out)";
  return text;
}

PetscErrorCode LoadTerm::check_start(const std::vector<double>&, InputProblem& out) const {
  const bool faces = region_.target == LoadTarget::faces;
  if (faces && mesh_.global_cells == 0)
    out = {spec_.line, "loads[" + std::to_string(index_) + "].type",
           spec_.type + " acts on the boundary faces of tets, and the scene has none (a cloth's or strands': give "
                        "them a force or body_force)"};
  else if (region_.global_count == 0 && spec_.has_face_tag) {
    const bool narrowed = spec_.has_box || Vec3(spec_.normal.data()).squaredNorm() > 0;
    const std::string tag = "tag " + std::to_string(spec_.face_tag);
    out = {spec_.face_tag_line, "loads[" + std::to_string(index_) + "].face_tag",
           std::string("selects no ") + (faces ? "boundary face of the tets" : "free vertex") + " (loads[" +
               std::to_string(index_) + "], " + spec_.type + "): " +
               (!faces ? tag + "'s triangles have only fixed vertices" + (spec_.has_box ? " in the box" : std::string())
                : narrowed ? tag + " has no boundary face in the box and the cone of `normal`"
                           : tag + "'s triangles are interior faces of the tets or no faces of them")};
  }
  else if (region_.global_count == 0)
    out = {spec_.line, "loads[" + std::to_string(index_) + "].box",
           std::string("selects no ") + (faces ? "boundary face of the tets" : "free vertex") + " (loads[" +
               std::to_string(index_) + "], " + spec_.type + "): widen the box" + (faces ? " or `angle`" : "")};
  else if (faces && region_.global_free_faces == 0)
    out = {spec_.has_face_tag ? spec_.face_tag_line : spec_.line,
           "loads[" + std::to_string(index_) + "]." + (spec_.has_face_tag ? "face_tag" : "box"),
           "selects only boundary faces whose vertices are all fixed (loads[" + std::to_string(index_) + "], " +
               spec_.type + "): the load would act on nothing (a fixed region's reaction takes it)"};
  return 0;
}

}  // namespace hyperqn

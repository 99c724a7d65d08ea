#include "model/regions.hpp"

#include <algorithm>
#include <cmath>

#include <mpi.h>

#include "mesh/input_error.hpp"

namespace hyperqn {

bool in_box(const double* p, const BoxRegion& box, double tol) {
  for (int d = 0; d < 3; ++d)
    if (p[d] < box.min[d] - tol || p[d] > box.max[d] + tol) return false;
  return true;
}

double mesh_diagonal(MPI_Comm comm, const TetMesh& mesh) {
  double lo[3], hi[3];
  bounding_box(mesh.coords, lo, hi);
  MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
  MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
  if (lo[0] > hi[0]) return 0;  // no vertex anywhere
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

static int64_t global_count(MPI_Comm comm, int64_t count) {
  MPI_Allreduce(MPI_IN_PLACE, &count, 1, MPI_INT64_T, MPI_SUM, comm);
  return count;
}

std::vector<int32_t> vertex_bodies(const TetMesh& mesh) {
  std::vector<int32_t> body(mesh.num_vertices(), -1);
  for (int64_t t = 0; t < mesh.num_tets(); ++t)
    for (int k = 0; k < 4; ++k) body[mesh.tets[4 * t + k]] = mesh.tet_tags[t];
  return body;
}

std::vector<int32_t> select_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                     const std::string& deck_path, const std::string& section) {
  const double tol = 1e-9 * mesh_diagonal(comm, mesh);
  std::vector<int32_t> selected(mesh.num_vertices(), 0), body;
  for (const BoxRegion& b : boxes)
    if (b.body >= 0 && body.empty()) body = vertex_bodies(mesh);
  for (size_t b = 0; b < boxes.size(); ++b) {
    int64_t count = 0;
    for (int64_t v = 0; v < mesh.num_vertices(); ++v)
      if (in_box(&mesh.coords[3 * v], boxes[b], tol) && (boxes[b].body < 0 || body[v] == boxes[b].body)) {
        selected[v] = (int32_t)b + 1;
        ++count;
      }
    if (global_count(comm, count) == 0)
      throw InputError(deck_path, boxes[b].line, section + "[" + std::to_string(b) + "].box",
                       boxes[b].body >= 0 ? "selects no vertex of its body (boxes are in coordinates after the body's mesh.transform)"
                                          : "selects no vertex of the mesh (boxes are in coordinates after mesh.transform)");
  }
  return selected;
}

std::vector<int32_t> select_fixed_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                           const std::string& deck_path) {
  return select_vertices(comm, mesh, boxes, deck_path, "fixed");
}

void check_attachments(MPI_Comm comm, const TetMesh& mesh, const std::vector<AttachmentSpec>& attachments,
                       const std::vector<BoxRegion>& fixed, const std::vector<int32_t>& fixed_of_vertex,
                       const std::string& deck_path) {
  std::vector<BoxRegion> boxes;
  for (const AttachmentSpec& a : attachments) boxes.push_back(a.region);
  select_vertices(comm, mesh, boxes, deck_path, "attachments");
  const double tol = 1e-9 * mesh_diagonal(comm, mesh);
  for (size_t k = 0; k < boxes.size(); ++k) {
    bool acts = false;
    for (int64_t v = 0; v < mesh.num_vertices() && !acts; ++v) {
      const int32_t f = fixed_of_vertex[v];  // the vertex follows the last fixed region holding it
      acts = in_box(&mesh.coords[3 * v], boxes[k], tol) && (f == 0 || fixed[f - 1].release > 0);
    }
    if (global_count(comm, acts) == 0)
      throw InputError(deck_path, boxes[k].line, "attachments[" + std::to_string(k) + "].box",
                       "selects only vertices that are fixed (and never released): the attachment would do nothing");
  }
}

std::vector<int32_t> select_material_regions(MPI_Comm comm, const TetMesh& mesh, const std::vector<MaterialRegion>& regions,
                                             const std::string& deck_path) {
  const double tol = 1e-9 * mesh_diagonal(comm, mesh);
  std::vector<int32_t> material(mesh.num_tets(), 0);
  for (size_t k = 0; k < regions.size(); ++k) {
    const MaterialRegion& region = regions[k];
    int64_t count = 0;
    for (int64_t t = 0; t < mesh.num_tets(); ++t) {
      bool selected;
      if (region.by_box) {
        double c[3] = {0, 0, 0};
        for (int j = 0; j < 4; ++j)
          for (int d = 0; d < 3; ++d) c[d] += 0.25 * mesh.coords[3 * mesh.tets[4 * t + j] + d];
        selected = in_box(c, region.box, tol);
      } else {
        selected = std::find(region.tags.begin(), region.tags.end(), mesh.tet_tags[t]) != region.tags.end();
      }
      if (selected) {
        material[t] = (int32_t)k + 1;
        ++count;
      }
    }
    if (global_count(comm, count) == 0)
      throw InputError(deck_path, region.line, "regions[" + std::to_string(k) + "]",
                       region.by_box ? "selects no element (by centroid; boxes are in coordinates after mesh.transform)"
                                     : "selects no element: no element carries these tags");
  }
  return material;
}

}  // namespace hyperqn

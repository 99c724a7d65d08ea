#include "model/regions.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

std::vector<int32_t> vertex_bodies(MPI_Comm comm, const MeshPiece& piece, int bodies) {
  if (bodies == 0) return {};
  const TetMesh& m = piece.mesh;
  std::vector<long long> first(bodies, std::numeric_limits<long long>::max());
  const auto lowest = [&](const std::vector<int32_t>& vertices, const std::vector<int32_t>& tags, int size) {
    for (size_t e = 0; e < tags.size(); ++e)
      for (int j = 0; j < size; ++j)
        first[tags[e]] = std::min(first[tags[e]], (long long)piece.vertex_numbers[vertices[size * e + j]]);
  };
  lowest(m.tets, m.tet_tags, 4);
  lowest(m.segments, m.segment_tags, 2);
  lowest(m.triangles, m.triangle_tags, 3);
  MPI_Allreduce(MPI_IN_PLACE, first.data(), bodies, MPI_LONG_LONG, MPI_MIN, comm);
  std::vector<int32_t> body(m.num_vertices());
  for (int64_t v = 0; v < m.num_vertices(); ++v)
    body[v] = int32_t(std::upper_bound(first.begin(), first.end(), (long long)piece.vertex_numbers[v]) - first.begin()) - 1;
  return body;
}

bool selects(const BoxRegion& box, const double* p, int64_t v, const std::vector<int32_t>& vertex_body, double tol) {
  return in_box(p, box, tol) && (box.body < 0 || vertex_body.at(v) == box.body);
}

// Whether region selects each local vertex: those of its face tag's triangles (a rank has those
// touching its piece), in its box if it has one; or those in its box (of its body, if it names one).
static std::vector<char> region_members(const TetMesh& mesh, const BoxRegion& region, double tol,
                                        const std::vector<int32_t>& vertex_body) {
  std::vector<char> member(mesh.num_vertices(), 0);
  if (region.has_face_tag) {
    const std::vector<int64_t> ids = mesh.tagged_faces.vertex_ids_of(region.face_tag);
    for (int64_t v = 0; v < mesh.num_vertices(); ++v)
      member[v] = std::binary_search(ids.begin(), ids.end(), mesh.vertex_ids[v]) &&
                  (!region.has_box || in_box(&mesh.coords[3 * v], region, tol));
  } else {
    for (int64_t v = 0; v < mesh.num_vertices(); ++v) member[v] = selects(region, &mesh.coords[3 * v], v, vertex_body, tol);
  }
  return member;
}

std::vector<int32_t> select_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                     const std::string& deck_path, const std::string& section,
                                     const std::vector<int32_t>& vertex_body) {
  const double tol = 1e-9 * mesh_diagonal(comm, mesh);
  std::vector<int32_t> selected(mesh.num_vertices(), 0);
  for (size_t b = 0; b < boxes.size(); ++b) {
    const BoxRegion& region = boxes[b];
    const std::vector<char> member = region_members(mesh, region, tol, vertex_body);
    int64_t count = 0;
    for (int64_t v = 0; v < mesh.num_vertices(); ++v)
      if (member[v]) {
        selected[v] = (int32_t)b + 1;
        ++count;
      }
    if (global_count(comm, count) > 0) continue;
    if (region.has_face_tag)
      throw InputError(deck_path, region.face_tag_line, section + "[" + std::to_string(b) + "].face_tag",
                       "selects no vertex of the mesh: tag " + std::to_string(region.face_tag) + "'s triangles have " +
                           (region.has_box ? "no vertex in the box" : "no vertex of a tet"));
    throw InputError(deck_path, region.line, region_key(boxes, b, section) + ".box",
                     region.body >= 0 ? "selects no vertex of its body (boxes are in coordinates after the body's mesh.transform)"
                                      : "selects no vertex of the mesh (boxes are in coordinates after mesh.transform)");
  }
  return selected;
}

int held_components(const BoxRegion& region) {
  if (region.components.empty()) return 7;
  int bits = 0;
  for (const std::string& c : region.components) bits |= 1 << (c[0] - 'x');
  return bits;
}

void fixed_of_held(const std::vector<int32_t>& held, std::vector<int32_t>& fixed) {
  for (size_t v = 0; v < fixed.size(); ++v) {
    const int32_t* h = &held[3 * v];
    fixed[v] = h[0] == h[1] && h[1] == h[2] ? h[0] : 0;  // one region holds all three: a fixed vertex
  }
}

std::vector<int32_t> select_held_components(const TetMesh& mesh, const std::vector<BoxRegion>& boxes, double tol,
                                            std::vector<int32_t>& fixed, const std::vector<int32_t>& vertex_body) {
  if (std::none_of(boxes.begin(), boxes.end(), is_roller)) return {};
  std::vector<int32_t> held(3 * mesh.num_vertices(), 0);
  for (size_t b = 0; b < boxes.size(); ++b) {  // in deck order: a component follows the last region holding it
    const std::vector<char> member = region_members(mesh, boxes[b], tol, vertex_body);
    const int bits = held_components(boxes[b]);
    for (int64_t v = 0; v < mesh.num_vertices(); ++v)
      if (member[v] && fixed[v] != 0)
        for (int d = 0; d < 3; ++d)
          if (bits & (1 << d)) held[3 * v + d] = (int32_t)b + 1;
  }
  fixed_of_held(held, fixed);
  return held;
}

std::vector<int32_t> select_fixed_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                           const std::string& deck_path, const std::vector<int32_t>& vertex_body) {
  return select_vertices(comm, mesh, boxes, deck_path, "fixed", vertex_body);
}

void check_attachments(MPI_Comm comm, const TetMesh& mesh, const std::vector<AttachmentSpec>& attachments,
                       const std::vector<BoxRegion>& fixed, const std::vector<int32_t>& fixed_of_vertex,
                       const std::string& deck_path, const std::vector<int32_t>& vertex_body) {
  std::vector<BoxRegion> boxes;
  for (const AttachmentSpec& a : attachments) boxes.push_back(a.region);
  select_vertices(comm, mesh, boxes, deck_path, "attachments", vertex_body);
  const double tol = 1e-9 * mesh_diagonal(comm, mesh);
  for (size_t k = 0; k < boxes.size(); ++k) {
    bool acts = false;
    for (int64_t v = 0; v < mesh.num_vertices() && !acts; ++v) {
      const int32_t f = fixed_of_vertex[v];  // the vertex follows the last fixed region holding it
      acts = selects(boxes[k], &mesh.coords[3 * v], v, vertex_body, tol) && (f == 0 || fixed[f - 1].release > 0);
    }
    if (global_count(comm, acts) == 0)
      throw InputError(deck_path, boxes[k].line, region_key(boxes, k, "attachments") + ".box",
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

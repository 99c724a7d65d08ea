// Parts of the mesh selected by the deck's regions: fixed (Dirichlet) vertices, attached vertices
// and the elements of each material region, and how fixed regions and attachments move. Fixed
// vertices and material regions are decided once per rank on its piece of the mesh
// (mesh/mesh_piece.hpp) before the scene is built; attachments are checked there and selected
// again on each rank (in_box). The selections take the communicator of the ranks whose pieces
// make up the mesh: the tolerance and the "selects nothing" checks are about the whole mesh, so
// every rank throws the same InputError.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <mpi.h>

#include "geometry/motion.hpp"
#include "mesh/mesh.hpp"
#include "mesh/mesh_piece.hpp"
#include "model/material_spec.hpp"

namespace hyperqn {

struct BoxRegion {
  std::array<double, 3> min{0, 0, 0}, max{0, 0, 0};
  int line = 0;                      // deck line, for error messages
  Motion motion;                     // fixed regions and attachments only
  double release = -1;               // fixed regions: time from which its vertices are free (< 0: never);
                                     // attachments: the springs are gone (LiveScene::release_due)
  int body = -1;                     // fixed regions and attachments: only the vertices of this body
                                     // (bodies[body].fixed, bodies[body].attachments; -1: any)
  std::vector<std::string> components;  // fixed regions: the components held, "x", "y", "z" (empty: all three)
  int components_line = 0;              // its deck line
  // Fixed regions: the vertices of the mesh file's triangles of this tag (TetMesh::tagged_faces),
  // and in the box if it is given too (has_box).
  bool has_box = true;
  int face_tag = 0;
  bool has_face_tag = false;
  int face_tag_line = 0;
};

// The deck key of regions[k] of a section: "<section>[k]", or for a body's own region (listed
// after the scene's, body by body) "bodies[b].<section>[j]".
inline std::string region_key(const std::vector<BoxRegion>& regions, size_t k, const std::string& section) {
  const int body = regions[k].body;
  if (body < 0) return section + "[" + std::to_string(k) + "]";
  size_t first = k;
  while (first > 0 && regions[first - 1].body == body) --first;
  return "bodies[" + std::to_string(body) + "]." + section + "[" + std::to_string(k - first) + "]";
}

// The components a fixed region holds as bits (1: x, 2: y, 4: z); 7 for all three (no `components`).
int held_components(const BoxRegion& region);
// Whether a fixed region holds only some components (a roller, a symmetry plane).
inline bool is_roller(const BoxRegion& region) { return held_components(region) != 7; }

// The keys box, box.min and box.max of a deck section whose box is box(spec) (params/deck_keys.hpp).
// The section's reader checks min <= max.
template <typename Spec>
std::vector<DeckKey<Spec>> box_keys(BoxRegion& (*box)(Spec&), const char* doc, bool required) {
  return {map_key<Spec>("box", doc, required ? "" : "none", required),
          needed(DeckKey<Spec>{"box.min", Field<Spec, Array3>([box](Spec& s) -> Array3& { return box(s).min; }),
                               "the corner of least coordinates (after `mesh.transform`)"}),
          needed(DeckKey<Spec>{"box.max", Field<Spec, Array3>([box](Spec& s) -> Array3& { return box(s).max; }),
                               "the opposite corner: `min` ≤ `max` on every axis (equality gives a plane)"})};
}

// The keys of one of the deck's fixed: regions (params/deck_keys.hpp).
inline const std::vector<DeckKey<BoxRegion>>& fixed_keys() {
  using B = BoxRegion;
  static const std::vector<DeckKey<B>> keys = [] {
    std::vector<DeckKey<B>> k = box_keys<B>(
        +[](B& b) -> B& { return b; }, "the vertices fixed: those in this axis-aligned box, inclusive (or give `face_tag`)",
        false);
    k.push_back(custom_key<B>("face_tag", "integer",
                              "or the vertices of the mesh file's triangles of this tag (a Medit reference, a Gmsh "
                              "physical group; [loads.md](loads.md#face-tags)); with `box`, those in the box",
                              "none"));
    k.push_back(custom_key<B>("motion", "map: [`motion`](#motion)",
                              "how the region moves; the vertices follow it until `release`", "none (at rest)"));
    k.push_back({"components", &B::components,
                 "the components held, each once (e.g. `[z]`: a frictionless floor, `[x]`: a symmetry plane x = const): "
                 "they follow `motion`, the others are free; a vertex held in all three by one region is fixed "
                 "([loads.md](loads.md#rollers-components-of-fixed))",
                 {}, {"x", "y", "z"}, "", "[x, y, z]"});
    k.push_back({"release", &B::release,
                 "the region's vertices are free from the first step that starts at or after this time (below): they "
                 "start it with their prescribed position and velocity at its start and then move freely",
                 above(0, "a time"), {}, "", "never"});
    return k;
  }();
  return keys;
}

// A soft attachment (deck attachments[k]): a zero-rest-length spring of stiffness k (N/m, per
// vertex) from every free vertex in region's box to its rest position moved by region.motion, until
// region.release. A vertex in several attachment boxes gets a spring from each.
struct AttachmentSpec {
  BoxRegion region;
  double stiffness = 0;
};

// The keys of one of the deck's attachments: (params/deck_keys.hpp).
inline const std::vector<DeckKey<AttachmentSpec>>& attachment_keys() {
  using A = AttachmentSpec;
  static const std::vector<DeckKey<A>> keys = [] {
    std::vector<DeckKey<A>> k = box_keys<A>(
        +[](A& a) -> BoxRegion& { return a.region; },
        "the vertices attached, selected as for `fixed` (inclusive, tolerance 1e-9 × the mesh bounding-box size)", true);
    k.push_back(needed(DeckKey<A>{"stiffness", &A::stiffness,
                                  "k, **per vertex** (the total stiffness of an attachment grows with the number of "
                                  "vertices in its box)",
                                  above(0, "N/m per vertex")}));
    k.push_back(custom_key<A>("motion", "map: [`motion`](#motion)", "how the targets move", "none (targets at rest)"));
    k.push_back({"release", Field<A, double>([](A& a) -> double& { return a.region.release; }),
                 "the springs are gone from the first step that starts at or after this time, as for [`fixed`](#fixed)",
                 above(0, "a time"), {}, "", "never"});
    return k;
  }();
  return keys;
}

// Elements with a material other than the deck's default one: those whose centroid lies in a
// box, or whose mesh element tag is listed. Later regions override earlier ones.
struct MaterialRegion {
  bool by_box = true;
  BoxRegion box;
  std::vector<int> tags;
  MaterialSpec material;
  int line = 0;
};

// The keys of one of the deck's regions: (params/deck_keys.hpp). Its reader checks that it gives box
// or tags.
inline const std::vector<DeckKey<MaterialRegion>>& region_keys() {
  using R = MaterialRegion;
  static const std::vector<DeckKey<R>> keys = [] {
    std::vector<DeckKey<R>> k = box_keys<R>(
        +[](R& r) -> BoxRegion& { return r.box; },
        "the elements whose centroid lies in this box (or give `tags`)", false);
    k.push_back({"tags", &R::tags,
                 "or the elements of these tags: the mesh's element reference numbers (Medit's `ref` column, Gmsh's "
                 "physical groups)",
                 {}, {}, "", "none"});
    k.push_back(custom_key<R>("material", "map: as [`material`](#material-required-when-the-mesh-has-tetrahedra)",
                              "the elements' material", ""));
    k.back().required = true;
    return k;
  }();
  return keys;
}


// Whether the point p lies in the box, inclusive, widened by tol (1e-9 of the mesh's bounding-box
// diagonal against round-off, for every region).
bool in_box(const double* p, const BoxRegion& box, double tol);

// The diagonal of the bounding box of every rank's mesh (collective).
double mesh_diagonal(MPI_Comm comm, const TetMesh& mesh);

// Per local vertex of a piece of a scene of `bodies` bodies (deck bodies:), its body; empty for
// a scene of one body (bodies == 0). Collective. read_bodies_mesh appends the bodies one after the
// other and tags each body's elements with its index, so body k holds the vertex numbers from the
// lowest one of its tets, segments and triangles (over all ranks: a piece may hold a vertex only
// through a cloth hinge, which has no tag) up to the next body's.
std::vector<int32_t> vertex_bodies(MPI_Comm comm, const MeshPiece& piece, int bodies);
// Whether vertex v lies in the box (in_box) and, for a box of one body, in that body
// (vertex_body: vertex_bodies of the mesh).
bool selects(const BoxRegion& box, const double* p, int64_t v, const std::vector<int32_t>& vertex_body, double tol);

// Per vertex: 0 if in no box, k + 1 if in boxes[k] (the last box containing it wins); a box with
// BoxRegion::body >= 0 takes that body's vertices only (vertex_body: vertex_bodies of the mesh).
// A box that selects no vertex is an input error naming the deck line and the key
// "<section>[k].box".
std::vector<int32_t> select_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                     const std::string& deck_path, const std::string& section,
                                     const std::vector<int32_t>& vertex_body = {});
// select_vertices of the deck's fixed regions: 0 if free, k + 1 if fixed by fixed[k].
std::vector<int32_t> select_fixed_vertices(MPI_Comm comm, const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                           const std::string& deck_path, const std::vector<int32_t>& vertex_body = {});
// With rollers (is_roller), per vertex and component (3 per vertex): k + 1 if fixed[k] holds it (the
// last region holding that component wins, as select_vertices' last box does for whole vertices), 0
// if free; and *fixed as fixed_of_held says. Empty (and *fixed untouched) when no region is a
// roller. fixed: from select_fixed_vertices of the same boxes.
std::vector<int32_t> select_held_components(const TetMesh& mesh, const std::vector<BoxRegion>& boxes, double tol,
                                            std::vector<int32_t>& fixed, const std::vector<int32_t>& vertex_body = {});
// Per vertex from held (3 per vertex, as above): k + 1 if region k holds all three components (a
// fixed vertex, as without rollers), else 0 (free, its held components, if any, held by their slots).
void fixed_of_held(const std::vector<int32_t>& held, std::vector<int32_t>& fixed);

// Every attachment box selects a vertex (select_vertices' check) and at least one that is not
// fixed for good (free, or fixed by a region that is released): an attachment whose vertices all
// stay fixed adds nothing, a mistake. Input errors name the deck line and "attachments[k].box".
// fixed_of_vertex: select_fixed_vertices of `fixed`.
void check_attachments(MPI_Comm comm, const TetMesh& mesh, const std::vector<AttachmentSpec>& attachments,
                       const std::vector<BoxRegion>& fixed, const std::vector<int32_t>& fixed_of_vertex,
                       const std::string& deck_path, const std::vector<int32_t>& vertex_body = {});

// Per tet: 0 for the default material, k + 1 for regions[k] (by centroid in its box, or by
// element tag; later regions win). A region that selects no element is an input error.
std::vector<int32_t> select_material_regions(MPI_Comm comm, const TetMesh& mesh, const std::vector<MaterialRegion>& regions,
                                             const std::string& deck_path);

}  // namespace hyperqn

// The mesh distributed over MPI ranks: a DMPlex built from each rank's piece (mesh/mesh_piece.hpp),
// plus flat per-rank arrays that the element loops use directly.
//
// Unknowns: 3 position dofs per free vertex. Fixed vertices carry no dof at all (they are
// eliminated), so the global vectors hold exactly the free unknowns.
#pragma once
#include <petscdmplex.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "mesh/mesh_spec.hpp"
#include "mesh/mesh.hpp"
#include "mesh/mesh_piece.hpp"

namespace hyperqn {

struct DistributedMesh {
  DM dm = nullptr;                   // distributed, non-interpolated DMPlex with the dof section
  DM vertex_dm = nullptr;            // the same mesh with 1 dof per free vertex (for A1 of A = A1 (x) I3)
  PetscInt num_vertices = 0;         // local vertices (owned + ghost)
  PetscInt num_cells = 0;            // local tets (each cell lives on exactly one rank)
  PetscInt num_segments = 0;         // local strand segments (cells of 2 vertices; also on one rank each)
  PetscInt num_triangles = 0;        // local cloth triangles (cells of 3 vertices)
  PetscInt num_hinges = 0;           // local cloth hinges (cells of 4 vertices: an interior edge, the two opposite vertices)
  std::vector<double> rest;          // 3 per local vertex: rest positions
  // 3 per local vertex: the rest positions before any crack opened (MeshPiece::unopened), which
  // the tets' masses come from (mass_rest); empty: no crack opened, the same as rest.
  std::vector<double> unopened_rest;
  std::vector<PetscInt> cells;       // 4 local vertex indices per local tet, positively oriented
  std::vector<PetscInt> segments;    // 2 local vertex indices per local segment
  std::vector<int32_t> segment_tags; // per local segment: the input element tag
  std::vector<PetscInt> triangles;   // 3 local vertex indices per local triangle
  std::vector<int32_t> triangle_tags;   // per local triangle: the input element tag
  std::vector<uint8_t> triangle_edges;  // per local triangle: the edges it carries (TetMesh::triangle_edges)
  std::vector<PetscInt> hinges;      // 4 local vertex indices per local hinge (TetMesh::hinges)
  std::vector<int64_t> vertex_ids;   // per local vertex: index in the input mesh file
  TaggedFaces tagged_faces;          // the mesh file's triangles of the deck's face tags that touch the
                                     // rank's piece, by vertex id (empty without face tags)
  // Per local tet, segment, triangle: its index among the serial mesh's elements of its kind (the
  // same at every rank count: output in a global order, io/xdmf_writer.hpp).
  std::vector<int64_t> cell_ids, segment_ids, triangle_ids;
  // The input mesh's boundary faces on this rank's tets, each as 4 × cell_id + its index in the tet,
  // sorted: the faces a load's box may select once cuts or fracture changed the mesh (a crack's or
  // a kerf's faces are none of them: docs/loads.md). Null: the input's mesh, all of them.
  std::shared_ptr<const std::vector<int64_t>> original_boundary;
  std::vector<int32_t> cell_tags;    // per local tet: the input element tag (with bodies: its body, as the
                                     // segment and triangle tags)
  int num_bodies = 0;                // a scene of bodies (deck bodies:); 0: one body
  std::vector<int32_t> vertex_body;  // per local vertex: its body (model/regions.hpp vertex_bodies; empty: one body)
  std::vector<int32_t> fixed;        // per local vertex: 0 if free, k + 1 if fixed by region k
  // 3 per local vertex: k + 1 if region k holds that component of the free vertex (a roller,
  // model/regions.hpp select_held_components), else 0. Empty: no roller in the scene.
  std::vector<int32_t> held;
  bool rollers = false;              // held is not empty on some rank: every rank alike
  std::vector<int32_t> cell_material;  // per local tet: 0 default material, k + 1 region k
  std::vector<char> owned;           // per local vertex: 1 if this rank owns it (not a ghost)
  std::vector<PetscInt> local_dof;   // per local vertex: offset of its x dof in the local Vec, -1 if fixed
  std::vector<PetscInt> global_dof;  // per local vertex: global index of its x dof, -1 if fixed
  // Global counts (same on every rank).
  PetscInt global_vertices = 0, global_cells = 0, global_segments = 0, global_dofs = 0, global_fixed_vertices = 0;
  PetscInt global_triangles = 0, global_hinges = 0;

  ~DistributedMesh() {
    DMDestroy(&vertex_dm);
    DMDestroy(&dm);
  }
};

// The local elements (of `size` vertices each in `vertices`: m.triangles, m.hinges, ...) of one
// body: those whose first vertex is the body's (m.vertex_body); all of them if body < 0. In
// their local order.
std::vector<PetscInt> body_elements(const DistributedMesh& m, const std::vector<PetscInt>& vertices, int size, int body);

// Bounding box of the rest positions over all ranks, and its diagonal.
void rest_bounding_box(const DistributedMesh& m, double lo[3], double hi[3]);
double rest_diagonal(const DistributedMesh& m);

// The rest positions the tets' masses come from: before any crack opened (unopened_rest), so a
// kerf moves the elastic rest shape but not the mass.
inline const double* mass_rest(const DistributedMesh& m) {
  return m.unopened_rest.empty() ? m.rest.data() : m.unopened_rest.data();
}

// Builds the distributed mesh from this rank's piece (collective): a DMPlex of the piece's cells
// and vertices in the piece's order, shared vertices owned by the lowest rank holding them, and
// the dof layout with the vertices flagged in `fixed` (per local vertex: 0 free, k + 1 fixed by
// region k; empty: none) eliminated; cell_material (per local tet, may be empty) travels with the
// tets. Tets, strand segments, cloth triangles and hinges are all cells of the DMPlex (of 4, 2, 3
// and 4 vertices), so every element has its vertices on its rank. The pieces are the partition:
// nothing is moved. (PETSc 3.18 cannot repartition a distributed mesh without faces and edges,
// "Parallel partitioning of uninterpolated meshes not supported"; pieces are cut before.)
PetscErrorCode distribute_mesh(MPI_Comm comm, const MeshPiece& piece, const std::vector<int32_t>& fixed,
                               const std::vector<int32_t>& cell_material, DistributedMesh& out);

// Rank 0's serial mesh (other ranks pass an empty one) cut into one piece per rank by METIS
// (pieces_of_serial_mesh) and sent piece by piece, so that rank 0 holds at most one other piece
// beside the mesh. Collective; a failure on rank 0 throws std::runtime_error on every rank
// (rank 0's with the reason).
MeshPiece scatter_serial_mesh(MPI_Comm comm, const TetMesh& serial);

// Rank root's piece cut by METIS (split_piece) for the ranks root .. root + count - 1, each sent
// its own (a part of a partition file read by more ranks than it has parts). Only the ranks of
// the group call it, root with its piece (null if it could not get it: the others are told), the
// others with null. If root fails they throw std::runtime_error, except those already served, so
// callers agree on failure afterwards (collectively).
MeshPiece share_piece(MPI_Comm comm, int root, int count, const MeshPiece* piece);

}  // namespace hyperqn

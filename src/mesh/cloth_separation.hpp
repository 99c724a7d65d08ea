// Tearing cloth on the distributed pieces (docs/snapping.md#tearing-cloth): a torn interior edge
// separates its two triangles.
//  - The hinge across it goes (no bending joins the two sides), and each side carries its own
//    edge spring (triangle_edges: the triangle that did not carry the edge now does too) of half
//    the edge's stiffness (kTornEdgeBit), so the two store what the one did: a tear adds no energy.
//  - A vertex whose fan of triangles (joined through edges not torn) falls apart into several
//    components gets a copy for each component but the one holding the smallest triangle number.
//  - Numbering follows mesh/separation.hpp: the global list of copies is ordered by (original
//    vertex number, smallest triangle number of the component), copy k of a batch is vertex
//    (vertices before) + k with id number + id_offset; a copy takes the original's rest position,
//    flags and (through `source`) position and velocity, so momentum is unchanged. Cloth mass is a
//    third of each triangle's at each vertex, so each copy gets exactly its own triangles' thirds.
//  - A hinge at a copied vertex moves to the copy of the component of its triangle holding that
//    vertex (both of its triangles, for an end of its edge: they are joined through it). A piece
//    holds a copy where it holds one of its triangles or a hinge that moves to it.
#pragma once
#include <mpi.h>

#include <array>
#include <cstdint>
#include <set>
#include <vector>

#include "mesh/mesh_piece.hpp"
#include "mesh/separation.hpp"

namespace hyperqn {

// Tears the edges of `batch` (pairs of global triangle numbers, first < second, sorted, the same
// on every rank; each triangle anywhere) in `piece`; `torn` holds every pair torn so far, the
// batch's included. Collective. Vertices that no local element uses any more leave the piece.
// With an opening (self-contact: the two sides of a torn edge start coincident, where the barrier
// is infinite), each side of a vertex that splits (the original's fan and each copy's) moves along
// its wedge's bisector, into its own triangles, until it is width / 2 from the wedge's edges (at
// most kOpeningHeightFraction of their least height above the vertex, twice that for a narrow
// wedge), in the rest shape and at the positions
// (SeparationResult::shift), as mesh/separation.hpp's CrackOpening moves a tet crack's sides; from
// the gathered fans in their triangles' order, so every rank computes the same bits.
SeparationResult tear_edges(MPI_Comm comm, MeshPiece& piece, const std::vector<std::array<int64_t, 2>>& batch,
                            const std::set<std::array<int64_t, 2>>& torn, int64_t id_offset,
                            const std::vector<VertexArray>& arrays, const CrackOpening& opening = {});

}  // namespace hyperqn

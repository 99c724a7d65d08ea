// Snapping strand segments on the distributed pieces (docs/snapping.md): a
// snapped segment lets go of everything else at both its ends. At each end vertex v of a segment
// of the batch:
//  - if an element that has not snapped (a segment, or a tet the strand is tied to) uses v, it keeps
//    v, and every snapped segment at v gets a copy of its own;
//  - otherwise the snapped segment with the smallest number keeps v and the others get copies.
// Numbering follows mesh/separation.hpp: the global list of copies is ordered by (original vertex
// number, segment number), copy k of a batch is vertex (vertices before) + k with id number +
// id_offset, a piece holds a copy where it holds the segment, and a copy takes the original's
// rest position, flags and (through `source`) position and velocity. A strand's mass is lumped
// from its segments, so each copy gets exactly half of its segment's mass.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <set>
#include <vector>

#include "mesh/mesh_piece.hpp"
#include "mesh/separation.hpp"

namespace hyperqn {

// Snaps the segments of `batch` (global segment numbers, sorted, the same on every rank; each
// segment anywhere) in `piece`; `snapped` holds every segment snapped so far, the batch's
// included. Collective. Vertices that no local element uses any more leave the piece.
SeparationResult snap_segments(MPI_Comm comm, MeshPiece& piece, const std::vector<int64_t>& batch,
                               const std::set<int64_t>& snapped, int64_t id_offset,
                               const std::vector<VertexArray>& arrays);

}  // namespace hyperqn

// Separating tets along their shared faces on the distributed pieces (docs/topology.md): a vertex
// whose star of tets falls apart into several components (tets joined through faces that are not
// separated) gets a copy for each component but the one holding the smallest tet number. Every
// rank computes the same global list of copies from the stars it gathers, so numbering does not
// depend on the rank count:
//  - the list is ordered by (original vertex number, smallest tet number of the component);
//  - copy k of a batch gets vertex number (vertices before the batch) + k, and vertex id
//    number + id_offset (ids stay unique and ordered after those of the input);
//  - a copy sits where its tets are: a piece holds it if it holds one of its tets, and its owner is
//    the lowest rank holding it (distribute_mesh's rule for every vertex);
//  - a copy has the original's rest position, flags (fixed, held, body) and, through `source`,
//    its position and velocity: momentum is unchanged (with a CrackOpening, both sides' positions
//    then move a little apart). Lumped mass is assembled from the tets, so
//    each copy gets exactly its own tets' quarters.
// Only tets are separated; a piece with other elements on a changed vertex keeps them on the
// original (decks with cuts are refused for meshes with strands or cloth).
#pragma once
#include <mpi.h>

#include <array>
#include <cstdint>
#include <set>
#include <vector>

#include "mesh/mesh_piece.hpp"

namespace hyperqn {

// A face between two tets, by their global tet numbers (element_numbers), first < second.
using TetPair = std::array<int64_t, 2>;

// Per-vertex arrays that travel with a piece (e.g. the fixed flags): `width` values per vertex;
// an empty array stays empty.
struct VertexArray {
  std::vector<int32_t>* values;
  int width;
};

struct SeparationResult {
  int64_t new_vertices = 0;     // copies made by this batch (global)
  std::vector<int32_t> source;  // per local vertex after the batch: the local vertex before it whose state it takes
  std::vector<double> shift;    // with an opening's positions: 3 per local vertex after the batch, its move
  // Elements the batch made that carry on an old one's history, the same list on every rank:
  // (the new element's history id, the old one's). A torn edge's spring on the triangle that did
  // not carry it takes the carrier's (mesh/cloth_separation.hpp).
  std::vector<std::array<int64_t, 2>> inherited;
};

// How a fresh crack opens, for self-contact (docs/records/2026-12-03-cut-contact.md): both sides
// of a crack start coincident, where the barrier is infinite. Each side of a vertex that splits
// (the original's component and each copy's) moves away from the crack into its own tets, along
// the direction all its boundary faces at the vertex (the new crack, earlier cracks, the body's
// surface) recede from most, by width / 2 (at most a tenth of the height of each of its tets above
// the vertex): in the rest shape (a kerf of the blade's width, recomputed from the rest shape
// alone when a restart replays the cuts) and, with positions, at the positions
// (SeparationResult::shift). A side whose boundary faces cannot all recede in the rest shape (it
// wraps around the vertex: a saddle of a jagged crack) falls apart into groups that can, grown
// greedily through its faces from its smallest tet (a single tet always can), each with its own
// copy and its own move (docs/records/2026-12-04-bunny-saddle.md); the faces between the groups
// are not in `separated` (their tets no longer share the vertex). Only a degenerate side stays
// where it is; where two stay, their vertices keep one rest position, which self-contact treats
// as one vertex (ContactSpec::joined_twins).
// Computed from the gathered stars in their tets' order: the same bits on every rank holding a
// vertex, at any rank count.
struct CrackOpening {
  const std::vector<double>* positions = nullptr;  // 3 per local vertex before the batch (or null)
  double width = 0;                                // 0: no opening
};
// A side moves by at most this fraction of the least height above the vertex of its elements (tets
// or, for a torn cloth, triangles), times kMostLean where it leans (below): none of them inverts,
// and none loses more than kMostLean times this share of its rest volume or area (its mass comes
// from the rest shape before any opening).
constexpr double kOpeningHeightFraction = 0.1;
// A side whose boundary faces (edges, for a cloth) at the vertex do not all face one way (where a
// crack meets the body's surface or the sheet's edge: a wedge) recedes from them by less than its
// move: 1/√2 of it for a quarter space. So it moves farther, by 1 / (how much they recede per unit
// of move), at most kMostLean times, so that its crack faces still end width / 2 from their old
// place and the two sides start out of the barrier's layer.
constexpr double kMostLean = 2;

// Separates the faces of `batch` (sorted, the same on every rank; each face's tets anywhere) in
// `piece`; `separated` holds every face separated so far, the batch's included (the same on every
// rank). Collective. Vertices that no local element uses any more leave the piece.
SeparationResult separate_faces(MPI_Comm comm, MeshPiece& piece, const std::vector<TetPair>& batch,
                                const std::set<TetPair>& separated, int64_t id_offset,
                                const std::vector<VertexArray>& arrays, const CrackOpening& opening = {});

// Removes the tets `tets` (global numbers, sorted, the same on every rank; each anywhere) from
// `piece` (docs/removal.md): the local ones leave it with their tags, numbers and `tet_arrays`
// (per local tet, e.g. the cell materials); then each vertex of a removed tet whose star of the
// tets left falls apart (through faces not in `separated`) is split as separate_faces splits it,
// and the vertices no local element uses any more (a removed tet's orphans among them) leave the
// piece. With an opening (self-contact), each side of a vertex that splits moves as
// separate_faces moves it, away from its boundary faces there (the removed tets' among them).
// Collective.
SeparationResult remove_tets(MPI_Comm comm, MeshPiece& piece, const std::vector<int64_t>& tets,
                             const std::set<TetPair>& separated, int64_t id_offset,
                             const std::vector<VertexArray>& arrays, const std::vector<std::vector<int32_t>*>& tet_arrays,
                             const CrackOpening& opening = {});

// Appends to `piece` a copy of its local vertex `original`, with global number `number` (id
// number + id_offset), the original's rest position and `arrays` values; `source` gets `original`.
// Returns the copy's local index.
int32_t append_vertex_copy(MeshPiece& piece, int32_t original, int64_t number, int64_t id_offset,
                           const std::vector<VertexArray>& arrays, std::vector<int32_t>& source);

// The vertices that no local element uses any more leave `piece` (the order, by number, is kept);
// `source` and `arrays` (per local vertex) follow.
void drop_unused_vertices(MeshPiece& piece, std::vector<int32_t>& source, const std::vector<VertexArray>& arrays);

}  // namespace hyperqn

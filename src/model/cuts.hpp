// Scripted cuts (deck cuts:, docs/topology.md): which interior faces the blades crossed in a step.
#pragma once
#include <mpi.h>

#include <set>
#include <vector>

#include "geometry/blade.hpp"
#include "mesh/mesh_piece.hpp"
#include "mesh/separation.hpp"
#include "model/tearing.hpp"

namespace hyperqn {

// The interior faces (not in `separated`) whose dual edge, the segment between the centroids of
// its two tets at the positions `pos` (3 per local vertex of `piece`, ghosts included), one of the
// blades crossed while it swept over [t0, t1] (BladeSweep::crosses, from the lower tet's centroid).
// Sorted, the same on every rank: the tets near a blade are gathered to every rank, which all
// decide every face alike. Faces that would cut a crumb loose (at most kCrumbTets tets that the
// other faces of the batch and `separated` leave with no face to the rest) are left out: the crumb
// stays with the tets across them. Collective.
constexpr int kCrumbTets = 4;
std::vector<TetPair> faces_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                   const std::vector<CutSpec>& cuts, double t0, double t1,
                                   const std::set<TetPair>& separated);

// The local tets of `piece` that have an edge one of the blades (those with remove) crossed while
// it swept over [t0, t1] (BladeSweep::crosses, each edge from its lower-numbered vertex), at the
// positions `pos` (3 per local vertex); their numbers from every rank, sorted: the same list on
// every rank. Collective.
std::vector<int64_t> tets_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                  const std::vector<CutSpec>& cuts, double t0, double t1);

// The interior cloth edges (the piece's hinges: a torn or cut edge has none) whose dual edge, the
// segment between the centroids of its two triangles at the positions `pos`, one of the blades
// crossed while it swept over [t0, t1] (BladeSweep::crosses, from the centroid of the triangle
// whose opposite vertex has the lower number), as pairs of their triangles' numbers; sorted, the
// same on every rank. A blade cuts a cloth as it cuts tets, and the edge then separates as a torn
// one does (mesh/cloth_separation.hpp). Collective.
std::vector<TrianglePair> cloth_edges_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                              const std::vector<CutSpec>& cuts, double t0, double t1);

// The strand segments (not in `snapped`) that one of the blades crossed while it swept over
// [t0, t1] (BladeSweep::crosses, each segment from its lower-numbered end) at the positions `pos`
// (3 per local vertex of `piece`), as their global numbers; sorted, the same on every rank. A
// blade cuts a strand as it cuts a cloth, and the segment then snaps as an overstretched one does
// (mesh/strand_separation.hpp). Collective.
std::vector<int64_t> segments_crossed(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                      const std::vector<CutSpec>& cuts, double t0, double t1,
                                      const std::set<int64_t>& snapped);

}  // namespace hyperqn

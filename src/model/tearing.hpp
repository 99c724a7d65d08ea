// Breaks that follow from the strain (docs/snapping.md): which strand segments
// snap after an accepted step.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <set>
#include <vector>

#include "mesh/mesh_piece.hpp"
#include "model/scene_spec.hpp"

namespace hyperqn {

// The snapping strain of each segment tag (the body's index in a scene of bodies, else any tag):
// 0 where its strand material does not snap. Empty if no strand of the deck snaps.
std::vector<double> snap_strains(const SceneSpec& spec);

// The segment that snaps after a step: of those (not in `snapped`) whose strain l/L - 1 at the
// positions `pos` (3 per local vertex of `piece`) exceeds their tag's snapping strain (L the rest
// length of the piece's coordinates), the one most over it (the largest strain / snapping strain;
// ties: the lowest segment number), as a list of its global number, or empty. One per step: a
// snap takes away the tension the others carried, so they are judged again after the next step.
// The same on every rank. Collective.
std::vector<int64_t> segments_to_snap(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                      const std::vector<double>& strains, const std::set<int64_t>& snapped);

}  // namespace hyperqn

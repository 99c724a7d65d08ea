// Breaks that follow from the strain (docs/snapping.md): which strand segments
// snap and which cloth edges tear after an accepted step.
#pragma once
#include <mpi.h>

#include <array>
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

// The tearing strain of each body's cloth (one entry without bodies): 0 where it does not tear.
// Empty if no cloth of the deck tears.
std::vector<double> tear_strains(const SceneSpec& spec);

// The largest cloth.tear.resolve of the deck's tearing cloths (0 without).
int tear_resolve(const SceneSpec& spec);
// The largest strand_material.snap.resolve of the deck's snapping strands (0 without).
int snap_resolve(const SceneSpec& spec);

// Whether the deck's blades (cuts) cut a cloth: its edges they cross separate as torn ones do.
bool blades_cut_cloth(const SceneSpec& spec);
// Whether the deck's blades cut strands: the segments they cross snap as overstretched ones do.
bool blades_cut_strands(const SceneSpec& spec);

// With self-contact a torn edge opens (mesh/cloth_separation.hpp) by d + the thickest tearing
// (or cut: blades_cut_cloth) cloth's thickness, each side by at most kOpeningHeightFraction of its triangles' least height
// above the vertex; the two sides must then start farther apart than the cloth's thickness, where
// the barrier is finite. So a tearing cloth's thickness must stay below kOpeningHeightFraction of
// the least height of the scene's cloth triangles (half the smallest full opening, for wedges not
// straight across): else an InputError names its cloth.thickness. Returns the opening's width.
// Collective (the least height over every rank's piece).
double tear_opening(MPI_Comm comm, const SceneSpec& spec, const MeshPiece& piece, double distance);

// An interior cloth edge, by its two triangles' global numbers (element_numbers), first < second.
using TrianglePair = std::array<int64_t, 2>;

// The strain across an interior edge: of its two triangles (a, b, c) and (a, b, d) (hinge: a, b, c,
// d, local indices), the mean of their stretches |F n| across it, less 1 (n the unit rest vector
// in the triangle's plane perpendicular to the edge, F the triangle's deformation gradient), at
// the positions `pos` with rest positions `rest` (3 per vertex). A tear along the edge relieves
// this stretch: separating the two triangles frees them in the direction n.
double strain_across_edge(const double* rest, const double* pos, const int32_t* hinge);

// The edge that tears after a step: of the interior edges not torn (the piece's hinges: a torn
// edge has none) whose strain across (strain_across_edge) at the positions `pos` exceeds their body's tearing strain
// (vertex_body: the body of each local vertex, empty for one), the one most over it (the largest
// strain / tearing strain; ratios within 1e-8 of the largest count as ties, so that round-off does
// not make 1 and 2 ranks choose differently: of those, the lowest pair of end vertex numbers, then
// of opposite vertices), as a list of its pair of triangles, or empty. One per step, for the reason segments_to_snap gives. The same on every
// rank. Collective.
std::vector<TrianglePair> edges_to_tear(MPI_Comm comm, const MeshPiece& piece, const std::vector<double>& pos,
                                        const std::vector<double>& strains, const std::vector<int32_t>& vertex_body);

}  // namespace hyperqn

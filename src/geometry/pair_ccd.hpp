// Continuous collision tests of the pair kernels (geometry/pair_distance.hpp): a vertex against a
// triangle, an edge against an edge, every point moving on a straight line
//   x(t) = start + t (end - start),  t in [0, 1],
// 12-vectors in the kernels' order ((p, t0, t1, t2) or (a0, a1, b0, b1)). What a barrier's step
// bound for self-contact needs (docs/self-contact.md#pair-kernels-for-self-contact); no PETSc.
//
// Additive CCD (Li, Kaufman, Jiang 2021, "Codimensional Incremental Potential Contact", as in the
// IPC toolkit's additive_ccd): the pair's distance changes at most l_p per unit of t, l_p the
// largest relative speed of a point of one primitive against the other (the common mean motion
// removed). From a distance d, a step of 0.9 (d - xi) / l_p therefore keeps the pair farther
// apart than xi (the minimum separation); the steps add up until the clearance d - xi falls below
// clearance_fraction times its value at t = 0. No root of a polynomial: coplanar and parallel
// motion (grazing) need no special case.
//
// The result t is conservative: the pair is farther apart than min_separation at every time in
// [0, t] (up to the round-off of the distance), so t lies before the first time they reach
// min_separation, and before they touch. At t the clearance is still at least
// min(clearance_fraction, 0.1) of the starting one: a smaller fraction gives a t closer to the
// impact in more steps (IPC's 0.1 by default; at most 10^6 steps, after which the t reached is
// returned). A pair that never comes that close before t = 1 gives +infinity, so a pair passing
// within 0.1 of its starting clearance without touching gets a conservative t at the default;
// one that starts at or within min_separation gives 0.
#pragma once
#include "geometry/pair_distance.hpp"

namespace hyperqn {

double vertex_triangle_impact(const Vector12d& start, const Vector12d& end, double min_separation,
                              double clearance_fraction = 0.1);
double edge_edge_impact(const Vector12d& start, const Vector12d& end, double min_separation,
                        double clearance_fraction = 0.1);

}  // namespace hyperqn

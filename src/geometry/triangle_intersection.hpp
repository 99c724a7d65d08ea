// Whether two triangles cross: what a start with self-contact checks (terms/self_contact.hpp),
// with the convention of the output checker hyperqn_tools.intersections (docs/outputs.md#intersecting-triangles),
// so the two count the same pairs. No PETSc.
//
// Two triangles cross when each has vertices strictly on both sides of the other's plane and the
// segments where they cut the line common to both planes overlap (Moeller's interval test), or,
// when one lies in the other's plane, their interiors overlap (no edge normal of either separates
// them). "Strictly" means by more than the tolerance tol: a vertex within tol of a plane counts as
// on it, and overlaps of tol or less do not count, so triangles that touch at a point or along an
// edge do not cross. The signed distances are taken with unit normals; their rounding error (about
// 1e-16 of the triangles' size) is far below the tolerances used (1e-8 of the scene's diagonal),
// so every decision is exact except within tol of touching, which counts as not crossing.
#pragma once
#include <Eigen/Dense>
#include <array>

namespace hyperqn {

using Triangle3 = std::array<Eigen::Vector3d, 3>;

// The tolerance relative to the diagonal of the scene's bounding box (the checker's RTOL).
constexpr double kIntersectionRtol = 1e-8;

// Whether the triangle's height over its longest edge is at most tol (such a triangle takes no
// part in the test, as in the checker).
bool degenerate_triangle(const Triangle3& t, double tol);

// Whether a and b (neither degenerate) cross; if so and point is not null, a point of their
// crossing (the middle of the common segment; coplanar: a's centroid).
bool triangles_cross(const Triangle3& a, const Triangle3& b, double tol, Eigen::Vector3d* point = nullptr);

}  // namespace hyperqn

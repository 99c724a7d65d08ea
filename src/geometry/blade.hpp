// A scripted cut (deck cuts:, docs/topology.md): a rectangular blade that moves in its own plane, or
// a triangle-mesh blade (surface) that moves along its triangles.
// Which interior faces of a tet mesh it separates in a step is decided here, geometrically; the
// mesh operation that follows is mesh/separation.hpp's. No PETSc.
#pragma once
#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "geometry/box_tree.hpp"
#include "geometry/motion.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

// Which positions the blade is tested against (the faces' dual edges): the body's as it is now, in
// the world, or its rest shape (a cut scripted in the material: a turning or falling body is cut
// where the rest shape says, and the faces do not depend on the solve, so not on the rank count).
enum class CutFrame { world, rest };
inline const std::vector<std::string> kCutFrameNames = {"world", "rest"};  // in the enum's order

struct CutSpec {
  std::array<double, 3> center{0, 0, 0};  // the rectangle's centre at t = 0
  std::array<double, 3> normal{1, 0, 0};  // its plane's normal (nonzero, any length)
  std::array<double, 3> axis{0, 1, 0};    // its first side's direction (projected into the plane)
  std::array<double, 2> size{1, 1};       // its side lengths along axis and normal x axis
  Motion motion;                          // a translation in the plane (the reader refuses others)
  CutFrame frame = CutFrame::world;       // positions the blade meets
  bool remove = false;                    // removes the tets it crosses an edge of, instead of separating faces
  int line = 0;                           // deck line, for messages
  // A triangle-mesh blade instead of the rectangle (surface given: center, normal, axis, size are not).
  std::string surface;                    // the file, resolved (empty: the rectangle)
  double surface_scale = 1;               // x -> scale x + offset, applied to the file's vertices
  std::array<double, 3> surface_offset{0, 0, 0};
  std::vector<Eigen::Vector3d> mesh_vertices;       // transformed, at t = 0 (the reader fills these)
  std::vector<std::array<int, 3>> mesh_triangles;   // those of positive area only
  std::shared_ptr<const BoxTree> mesh_tree;         // over their boxes at t = 0 (index_blade_surface)
};

// Builds c.mesh_tree once (the reader calls it after filling the triangles): a step's sweep moves
// the blade by a translation, so its queries go to this tree moved back, not to a tree per step.
void index_blade_surface(CutSpec& c);

// The deck's keys of one cut (params/deck_keys.hpp); the reader asks for either the rectangle
// (center, normal, axis, size) or surface, checks axis against normal and that the motion keeps
// the blade in its plane (each triangle's plane, for a surface).
inline const std::vector<DeckKey<CutSpec>>& cut_keys() {
  using C = CutSpec;
  static const std::vector<DeckKey<C>> keys = {
      DeckKey<C>{"center", &C::center, "the blade's centre at t = 0 (a rectangle)", {}, std::vector<std::string>(0), "", "required without `surface`"},
      DeckKey<C>{"normal", &C::normal, "the normal of the blade's plane, any length", nonzero_vector(), std::vector<std::string>(0), "", "required without `surface`"},
      DeckKey<C>{"axis", &C::axis,
                 "the direction of the rectangle's first side (its part in the plane; not along `normal`)",
                 nonzero_vector(), std::vector<std::string>(0), "", "required without `surface`"},
      DeckKey<C>{"size", &C::size, "the rectangle's side lengths along `axis` and along normal × axis",
                 above(0, "a length"), std::vector<std::string>(0), "", "required without `surface`"},
      DeckKey<C>{"surface", &C::surface,
                 "a triangle-mesh blade instead of the rectangle: `.obj` or `.mesh` (Medit `Triangles`), relative to "
                 "the deck's directory, as for [colliders](deck-scene.md#colliders); each triangle is a patch of "
                 "the blade (its normal by its winding); zero-area triangles are ignored",
                 {}, std::vector<std::string>(0), "", "none (the rectangle)"},
      DeckKey<C>{"surface_scale", &C::surface_scale, "the surface's vertices x become scale x + offset (with `surface`)",
                 above(0, "a scale")},
      DeckKey<C>{"surface_offset", &C::surface_offset, "the offset added after the scale (with `surface`)"},
      enum_key<C>("frame", &C::frame, kCutFrameNames,
                   "which positions the blade meets: `world`, the body's now (where it is); `rest`, its rest shape "
                   "(a cut scripted in the material: the same faces whatever the body does, at any rank count)",
                   "world"),
      DeckKey<C>{"remove", &C::remove,
                 "`true`: the blade removes the tets that have an edge its swept patch crossed in a step (a kerf), "
                 "instead of separating faces ([removal.md](removal.md)); with self-contact the vertices it splits open as "
                 "a crack does; not in a deck with a cloth or strands"},
      custom_key<C>("motion", "map: [`motion`](deck-scene.md#motion), a translation in the blade's plane and, for the rectangle, "
                    "a turn in it",
                    "how the blade moves: `translate.velocity` (in its plane) and, for the rectangle, `rotate` about an "
                    "axis along `normal` (it turns in its plane, about `rotate.center`), between `start` and `end`, or "
                    "along a `curve`; a triangle-mesh blade does not turn",
                    "none (it cuts where it stands, after the first step)"),
  };
  return keys;
}

// The blade's frame: the plane through the centre at t = 0 with unit normal n and in-plane unit
// axes u (axis's part in the plane) and w = n x u; half side lengths.
struct BladeFrame {
  Eigen::Vector3d origin, n, u, w;
  double half[2];
  explicit BladeFrame(const CutSpec& c);
};

// The blade's sweep over one step [t0, t1]: its rectangle moved along the segment from its
// position at t0 to that at t1 (the blade stays in its plane, so the swept patch is a planar
// hexagon: the rectangle's Minkowski sum with that segment). A rectangle that also turns (rotate
// about an axis along its normal: it stays in its plane) turns at a constant rate over the step
// while its centre moves along that segment; a point's path in the blade's own frame is then
// sampled every kBladeTurnSample radians of the turn (and at t0 and t1) and joined by chords, and
// the point is swept when that path meets the rectangle.
inline constexpr double kBladeTurnSample = M_PI / 180;  // 1 degree: a chord strays 3.8e-5 of its radius
class BladeSweep {
 public:
  BladeSweep(const CutSpec& c, double t0, double t1);
  // Whether the segment from a to b crosses the swept patch: a and b on opposite sides of the
  // plane (a point on it counts as on the normal's side) and the crossing point inside the patch.
  bool crosses(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  // Whether p is within `reach` of the swept patch (a box around it: a cheap prefilter).
  bool near(const Eigen::Vector3d& p, double reach) const;
  // Whether the swept patch meets the axis-aligned box [lo, hi] (an overestimate: the patch's
  // bounding box against the box).
  bool may_meet_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const;

 private:
  bool inside(double s, double r, double grow) const;  // in-plane coordinates relative to the t0 centre
  // A turning rectangle: whether world point p's path in the blade's frame meets the rectangle
  // grown by `grow` (and by the chords' largest stray from the path, with grow > 0: near's prefilter
  // covers what crosses finds).
  bool turning_inside(const Eigen::Vector3d& p, double grow) const;
  // A triangle-mesh blade: each triangle at t0 (corner p, unit normal n by its winding, in-plane
  // unit axes u, w = n x u), its other corners and the step's displacement in (u, w) coordinates;
  // the bounding box of its sweep.
  struct Tri {
    Eigen::Vector3d p, n, u, w, lo, hi;
    double q[2][2], d[2];
  };
  bool mesh_crosses(const Tri& t, const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  BladeFrame f_;
  Eigen::Vector3d c0_;   // the centre at t0
  double d_[2];          // the centre's in-plane displacement over the step
  // A turning rectangle (turns_): per sample k = 0..K of the step, the turn since t = 0 as the
  // cosine and sine of -theta_k, and the centre's in-plane offset from its t = 0 place; the whole
  // step's turn. Empty for a blade that only moves.
  bool turns_ = false;
  std::vector<std::array<double, 2>> unturn_, offset_;
  double turn_ = 0;
  bool mesh_ = false;
  // The triangles a box query meets: those whose sweep box overlaps [lo, hi] (and a few beside it).
  template <class Test>
  bool any_triangle(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Test&& test) const;
  const Tri& triangle(int k) const;
  const CutSpec* spec_ = nullptr;  // a surface blade's (the sweep lives within one step's search)
  double t0_ = 0, t1_ = 0;
  mutable std::vector<Tri> tris_;   // made on demand (made_)
  mutable std::vector<char> made_;
  std::shared_ptr<const BoxTree> tree_;  // CutSpec::mesh_tree: the triangles' boxes at t = 0
  Eigen::Vector3d shift_, step_;         // the blade's translation from t = 0 to t0, and over the step
  double hair_ = 0;                      // round-off allowance of the moved-back queries
  Eigen::Vector3d lo_, hi_;              // the mesh sweep's bounding box (a prefilter)
};

// A motion that keeps the blade in its plane (every triangle's, for a surface), or why not ("").
std::string blade_motion_problem(const CutSpec& c);

}  // namespace hyperqn

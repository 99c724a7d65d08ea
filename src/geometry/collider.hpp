// Obstacles a body can touch: analytic shapes (plane, sphere, solid box, capsule) and static or
// moving triangle surfaces, each with a rigid prescribed motion. Contact is vertex against
// obstacle: what the contact term (terms/contact.hpp) needs of an obstacle is its signed distance
// with first and second derivatives, and for the barrier a continuous collision test along a
// straight vertex path. No PETSc here; every rank holds every collider.
#pragma once
#include <Eigen/Dense>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "geometry/motion.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

enum class ColliderType { plane, sphere, box, capsule, mesh };
inline const std::vector<std::string> kColliderTypeNames = {"plane", "sphere", "box", "capsule", "mesh"};  // in the enum's order

// What the deck says of one collider (its keys: collider_keys(); make_collider reads the file).
struct ColliderSpec {
  ColliderType type = ColliderType::plane;
  std::array<double, 3> point{0, 0, 0}, normal{0, 1, 0};   // plane (normal: nonzero, any length)
  std::array<double, 3> center{0, 0, 0};                    // sphere
  double radius = 0;                                        // sphere, capsule (> 0)
  std::array<double, 3> min{0, 0, 0}, max{0, 0, 0};         // box (solid), min < max
  std::array<double, 3> a{0, 0, 0}, b{0, 0, 0};             // capsule axis end points
  std::string file;                            // mesh: OBJ (.obj) or Medit (.mesh, its Triangles)
  double friction = 0;                         // Coulomb coefficient mu >= 0
  Motion motion;                               // rigid motion of the whole obstacle
  int line = 0;                                // deck line, for error messages
};

// The deck's keys of one of its colliders: (params/deck_keys.hpp): each type's own keys, friction and
// motion. Its reader resolves `file` and checks min < max.
inline const std::vector<DeckKey<ColliderSpec>>& collider_keys() {
  using C = ColliderSpec;
  const auto of = [](DeckKey<C> k, std::vector<std::string> types) { return only_with(k, "type", types, true); };
  static const std::vector<DeckKey<C>> keys = {
      needed(enum_key<C>("type", &C::type, kColliderTypeNames, "the obstacle's shape; the other keys are its own")),
      of({"point", &C::point, "a point of the plane"}, {"plane"}),
      of({"normal", &C::normal, "the plane's normal, any length; the side it points to is outside", nonzero_vector()},
         {"plane"}),
      of({"center", &C::center, "the centre of a solid ball"}, {"sphere"}),
      of({"radius", &C::radius, "the ball's radius; a capsule is every point within `radius` of the segment a–b",
          above(0, "a length")},
         {"sphere", "capsule"}),
      of({"min", &C::min, "a corner of a solid axis-aligned box"}, {"box"}),
      of({"max", &C::max, "the opposite corner: min < max along every axis"}, {"box"}),
      of({"a", &C::a, "one end point of the capsule's axis"}, {"capsule"}),
      of({"b", &C::b, "the other end point"}, {"capsule"}),
      of({"file", &C::file,
          "a triangle surface: `.obj` (Wavefront `v`, `f`; polygons are fanned into triangles) or `.mesh` (Medit "
          "`Vertices` and `Triangles`); relative to the deck's directory. Outside is where its counter-clockwise "
          "faces point (an open surface works like the boundary of a half-space near it); read on every rank, with "
          "errors naming the file and line (numbers, `MeshVersionFormatted` and vertex indices as in mesh files, "
          "[above](#mesh-required))"},
         {"mesh"}),
      {"friction", &C::friction, "Coulomb coefficient μ", between(0, 100, "a Coulomb coefficient")},
      custom_key<C>("motion", "map: [`motion`](#motion)",
                    "a rigid motion of the whole obstacle (rotation about an axis through `center` at `rate` "
                    "degrees per unit time, and/or a translation at `velocity`, between `start` and `end`)",
                    "none (at rest)"),
  };
  return keys;
}

class Collider {
 public:
  virtual ~Collider() = default;

  // Moves the obstacle to its pose at time t (the motion of its spec; static ones stay).
  void set_time(double t) { pose_ = pose_at(motion_, t); }
  const RigidPose& pose() const { return pose_; }

  // Signed distance phi(p) from the point p to the obstacle at its current pose: > 0 outside,
  // < 0 inside (plane: the side the normal points to is outside; a triangle surface: the side its
  // counter-clockwise faces point to, by angle-weighted pseudo-normals). If gradient is not null,
  // d phi/dp (a unit vector where phi is differentiable: the outward normal at the closest
  // point); if hessian is not null, d2 phi/dp2 (0 for a plane or at a face's interior).
  double distance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient = nullptr,
                  Eigen::Matrix3d* hessian = nullptr) const;

  // Continuous collision test along the straight path p(s) = p0 + s (p1 - p0), s in [0, 1], with
  // the obstacle at its current pose and phi(p0) > 0: the smallest s at which phi(p(s)) = 0, or a
  // value >= 1 (+infinity) if the path stays outside. Exact for the analytic shapes (which return
  // 0 for a start with phi(p0) <= 0); for triangle surfaces the first crossing of a triangle,
  // either way (a start inside a closed surface gives where the path leaves it).
  double first_contact(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1) const;

  double friction() const { return friction_; }
  ColliderType type() const { return type_; }
  const std::string& type_name() const { return kColliderTypeNames[(int)type_]; }  // as the deck writes it
  bool moves() const { return motion_.active; }  // the deck gave it a motion (it may start later)
  int line() const { return line_; }             // its deck line (ColliderSpec::line)

 protected:
  Collider(const ColliderSpec& spec)
      : motion_(spec.motion), friction_(spec.friction), type_(spec.type), line_(spec.line) {}
  // The same in the obstacle's own frame (its pose at t = 0); q = pose().inverse(p).
  virtual double local_distance(const Eigen::Vector3d& q, Eigen::Vector3d* gradient, Eigen::Matrix3d* hessian) const = 0;
  virtual double local_first_contact(const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) const = 0;

 private:
  Motion motion_;
  RigidPose pose_;
  double friction_;
  ColliderType type_;
  int line_;
};

// Builds the collider of a spec (index: its place in the deck's colliders list). A mesh collider
// reads spec.file (the deck reader resolved it against the deck's directory and checked that it
// exists) and throws InputError naming the file and line of bad content, or deck_path, spec.line
// and the key colliders[index].file if the file holds no triangle.
std::unique_ptr<Collider> make_collider(const ColliderSpec& spec, const std::string& deck_path, int index);

}  // namespace hyperqn

// Obstacles: every collider shape (plane, sphere, box, capsule, triangle mesh from OBJ and Medit)
// against known distances, its gradient and Hessian against finite differences, first contact
// against a bisection on phi along the path (hits and misses), moving colliders against the static
// shape in the obstacle's frame, bad surface files, and the BVH against brute force.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "check.hpp"
#include "input_error_check.hpp"
#include "geometry/bvh.hpp"
#include "geometry/collider.hpp"
#include "geometry/motion.hpp"
#include "geometry/surface_file.hpp"
#include "geometry/triangle_queries.hpp"
#include "mesh/input_error.hpp"

using namespace hyperqn;
namespace fs = std::filesystem;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

namespace {

std::mt19937 rng(20240917);  // fixed seed: the same points on every run

Vec3 random_point(double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  return Vec3(u(rng), u(rng), u(rng));
}

std::array<double, 3> arr(const Vec3& v) { return {v[0], v[1], v[2]}; }


void write_file(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// ---------------------------------------------------------------------------------------------
// Specs

ColliderSpec plane_spec() {
  ColliderSpec s;
  s.type = ColliderType::plane;
  s.point = {0.2, 1.0, -0.3};
  s.normal = {0.3, 2.0, -0.5};
  return s;
}
ColliderSpec sphere_spec() {
  ColliderSpec s;
  s.type = ColliderType::sphere;
  s.center = {0.1, -0.2, 0.3};
  s.radius = 0.8;
  return s;
}
ColliderSpec box_spec() {
  ColliderSpec s;
  s.type = ColliderType::box;
  s.min = {-0.5, -1.0, -0.75};
  s.max = {0.5, 1.0, 0.75};
  return s;
}
ColliderSpec capsule_spec() {
  ColliderSpec s;
  s.type = ColliderType::capsule;
  s.a = {-0.6, 0.1, -0.2};
  s.b = {0.7, 0.4, 0.5};
  s.radius = 0.45;
  return s;
}
ColliderSpec mesh_spec(const fs::path& file) {
  ColliderSpec s;
  s.type = ColliderType::mesh;
  s.file = file.string();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Surfaces written by the test

// Corner k of the box has x from bit 0, y from bit 1, z from bit 2. Quads counter-clockwise
// seen from outside.
const int kCubeQuads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};

Vec3 cube_corner(const ColliderSpec& box, int k) {
  return Vec3(k & 1 ? box.max[0] : box.min[0], k & 2 ? box.max[1] : box.min[1], k & 4 ? box.max[2] : box.min[2]);
}

// OBJ with quads in the i/t/n forms, one face with negative indices, and lines to ignore.
std::string cube_obj(const ColliderSpec& box) {
  std::string s = "# cube\no cube\nmtllib none.mtl\n";
  for (int k = 0; k < 8; ++k) {
    const Vec3 x = cube_corner(box, k);
    char line[128];
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", x[0], x[1], x[2]);
    s += line;
  }
  s += "vt 0 0\nvn 0 0 1\ns off\n";
  for (int f = 0; f < 6; ++f) {
    const int* q = kCubeQuads[f];
    auto id = [&](int k) { return std::to_string(q[k] + 1); };
    if (f == 0) s += "f " + id(0) + " " + id(1) + " " + id(2) + " " + id(3) + "\n";
    else if (f == 1) s += "f " + id(0) + "/1 " + id(1) + "/1 " + id(2) + "/1 " + id(3) + "/1\n";
    else if (f == 2) s += "f " + id(0) + "//1 " + id(1) + "//1 " + id(2) + "//1 " + id(3) + "//1\n";
    else if (f == 3) s += "f " + id(0) + "/1/1 " + id(1) + "/1/1 " + id(2) + "/1/1 " + id(3) + "/1/1\n";
    else {
      s += "f";
      for (int k = 0; k < 4; ++k) s += " " + std::to_string(q[k] - 8);  // counted back from the 8th
      s += "\n";
    }
  }
  return s;
}

// Medit with 12 triangles, and sections the collider skips.
std::string cube_medit(const ColliderSpec& box) {
  std::string s = "MeshVersionFormatted 2\nDimension 3\n# a comment\nVertices\n8\n";
  for (int k = 0; k < 8; ++k) {
    const Vec3 x = cube_corner(box, k);
    char line[128];
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g 0\n", x[0], x[1], x[2]);
    s += line;
  }
  s += "Edges\n1\n1 2 0\nTriangles\n12\n";
  for (const auto& q : kCubeQuads) {
    s += std::to_string(q[0] + 1) + " " + std::to_string(q[1] + 1) + " " + std::to_string(q[2] + 1) + " 1\n";
    s += std::to_string(q[0] + 1) + " " + std::to_string(q[2] + 1) + " " + std::to_string(q[3] + 1) + " 1\n";
  }
  s += "Tetrahedra\n1\n1 2 3 5 0\nEnd\n";
  return s;
}

// Icosahedron subdivided n times and projected on the sphere |x - c| = r; outward faces.
TriangleSurface icosphere(int n, const Vec3& c, double r) {
  TriangleSurface s;
  const double t = (1 + std::sqrt(5.0)) / 2;
  const double v[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                           {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& x : v) s.vertices.push_back(Vec3(x[0], x[1], x[2]).normalized());
  s.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},   {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < n; ++level) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      s.vertices.push_back((s.vertices[a] + s.vertices[b]).normalized());
      return mid[key] = int(s.vertices.size()) - 1;
    };
    std::vector<std::array<int, 3>> finer;
    for (const auto& f : s.triangles) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    s.triangles = finer;
  }
  for (Vec3& x : s.vertices) x = c + r * x;
  return s;
}

std::string to_obj(const TriangleSurface& s) {
  std::string out;
  char line[128];
  for (const Vec3& x : s.vertices) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", x[0], x[1], x[2]);
    out += line;
  }
  for (const auto& f : s.triangles)
    out += "f " + std::to_string(f[0] + 1) + " " + std::to_string(f[1] + 1) + " " + std::to_string(f[2] + 1) + "\n";
  return out;
}

// ---------------------------------------------------------------------------------------------
// Generic checks

// Gradient against central differences of phi, Hessian against central differences of the
// gradient, at p. `same_piece` false: the Hessian changes within the stencil (p is within h of a
// boundary between smooth pieces), and the point is skipped. Returns whether it was checked.
bool check_derivatives(const Collider& c, const Vec3& p, const std::string& what, bool filter_pieces = false) {
  constexpr double h = 1e-5;
  Vec3 g;
  Mat3 H;
  c.distance(p, &g, &H);
  Vec3 g_fd;
  Mat3 H_fd;
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = h * Vec3::Unit(k);
    Vec3 gp, gm;
    Mat3 Hp, Hm;
    const double fp = c.distance(p + e, &gp, &Hp), fm = c.distance(p - e, &gm, &Hm);
    if (filter_pieces && ((Hp - H).norm() > 1e-3 * (1 + H.norm()) || (Hm - H).norm() > 1e-3 * (1 + H.norm())))
      return false;
    g_fd[k] = (fp - fm) / (2 * h);
    H_fd.col(k) = (gp - gm) / (2 * h);
  }
  const double eg = (g - g_fd).norm() / std::max(1.0, g.norm());
  const double eh = (H - H_fd).norm() / std::max(1.0, H.norm());
  CHECK_MSG(eg < 1e-6, what + ": gradient error " + std::to_string(eg));
  CHECK_MSG(eh < 1e-6, what + ": Hessian error " + std::to_string(eh));
  CHECK_MSG(std::fabs(g.norm() - 1) < 1e-12, what + ": gradient not unit");
  CHECK_MSG((H - H.transpose()).norm() < 1e-12, what + ": Hessian not symmetric");
  return true;
}

struct ContactTally {
  int hits = 0, misses = 0, grazes = 0;
};

// first_contact along p0 -> p1 (phi(p0) > 0) against sampling phi along the path and bisecting
// the first sign change.
void check_first_contact(const Collider& c, const Vec3& p0, const Vec3& p1, ContactTally& tally, const std::string& what) {
  const int n = 2000;
  auto phi = [&](double s) { return c.distance(p0 + s * (p1 - p0)); };
  const double s = c.first_contact(p0, p1);
  double prev = 0, min_phi = phi(0);
  for (int k = 1; k <= n; ++k) {
    const double sk = double(k) / n, fk = phi(sk);
    min_phi = std::min(min_phi, fk);
    if (fk <= 0) {
      double lo = prev, hi = sk;
      for (int it = 0; it < 200 && hi - lo > 1e-15; ++it) {
        const double mid = 0.5 * (lo + hi);
        (phi(mid) > 0 ? lo : hi) = mid;
      }
      CHECK_MSG(std::fabs(s - hi) < 1e-9, what + ": first contact " + std::to_string(s) + " vs bisection " +
                                              std::to_string(hi));
      ++tally.hits;
      return;
    }
    prev = sk;
  }
  // No sign change seen: a miss, unless the path grazes the surface between samples.
  if (min_phi < 1e-3) {
    ++tally.grazes;
    if (s < 1) CHECK_MSG(std::fabs(phi(s)) < 1e-9, what + ": grazing contact off the surface");
    return;
  }
  CHECK_MSG(s >= 1, what + ": contact " + std::to_string(s) + " on a path that misses");
  ++tally.misses;
}

// Random paths from outside points: half aimed at `target` (mostly hits), half random.
void check_paths(const Collider& c, const Vec3& target, double extent, const std::string& what) {
  ContactTally tally;
  for (int i = 0; i < 300; ++i) {
    Vec3 p0;
    do p0 = random_point(-extent, extent);
    while (c.distance(p0) < 0.05);
    Vec3 p1 = i % 2 ? random_point(-extent, extent) : Vec3(2 * target - p0 + random_point(-0.3, 0.3));
    if (i % 5 == 0) p1 = p0 + 0.3 * (p1 - p0);  // short steps: many end outside
    check_first_contact(c, p0, p1, tally, what);
  }
  std::printf("  %-28s first contact: %d hits, %d misses, %d grazing\n", what.c_str(), tally.hits, tally.misses,
              tally.grazes);
  CHECK_MSG(tally.hits > 50 && tally.misses > 20, what + ": paths should both hit and miss");
}

// The moving collider at a time t equals the static one evaluated in the obstacle's frame.
void check_moving(ColliderSpec spec, const std::string& what) {
  spec.motion.active = false;
  const auto fixed = make_collider(spec, "deck.yaml", 0);
  spec.motion.active = true;
  spec.motion.axis = {1, 2, 3};
  spec.motion.center = {0.5, 0, -0.2};
  spec.motion.rate_deg = 40;
  spec.motion.velocity = {0.1, -0.2, 0.3};
  const auto moving = make_collider(spec, "deck.yaml", 0);
  moving->set_time(0.7);
  const Mat3 R = moving->pose().rotation;
  CHECK_MSG((R - Mat3::Identity()).norm() > 0.1, what + ": the pose should rotate");
  double worst = 0, worst_contact = 0;
  int hits = 0;
  for (int i = 0; i < 200; ++i) {
    const Vec3 p = random_point(-2, 2);
    Vec3 g, gs;
    Mat3 H, Hs;
    const Vec3 q = moving->pose().inverse(p);
    const double phi = moving->distance(p, &g, &H), phis = fixed->distance(q, &gs, &Hs);
    worst = std::max({worst, std::fabs(phi - phis), (g - R * gs).norm(), (H - R * Hs * R.transpose()).norm()});
    // Independently of pose(): a body point X moved by the motion keeps its distance.
    const Vec3 X = random_point(-2, 2);
    worst = std::max(worst, std::fabs(moving->distance(moved(spec.motion, X, 0.7)) - fixed->distance(X)));
    // A path from an outside point.
    if (phi > 0.01) {
      const Vec3 p1 = random_point(-2, 2);
      const double s = moving->first_contact(p, p1), ss = fixed->first_contact(q, moving->pose().inverse(p1));
      if (s < 1) ++hits;
      worst_contact = std::max(worst_contact, (s >= 1 && ss >= 1) ? 0.0 : std::fabs(s - ss));
    }
  }
  CHECK_MSG(worst < 1e-11, what + ": moving vs static " + std::to_string(worst));
  CHECK_MSG(worst_contact < 1e-9, what + ": moving first contact vs static " + std::to_string(worst_contact));
  CHECK_MSG(hits > 10, what + ": moving paths should hit");
}

// ---------------------------------------------------------------------------------------------
// Shapes

void test_plane() {
  const auto c = make_collider(plane_spec(), "deck.yaml", 0);
  const Vec3 n = Vec3(0.3, 2.0, -0.5).normalized();
  for (int i = 0; i < 50; ++i) {
    const Vec3 p = random_point(-3, 3);
    Vec3 g;
    Mat3 H;
    CHECK_NEAR(c->distance(p, &g, &H), n.dot(p - Vec3(0.2, 1.0, -0.3)), 1e-14);
    CHECK((g - n).norm() < 1e-15 && H.norm() == 0);
    check_derivatives(*c, p, "plane");
  }
  check_paths(*c, Vec3(0.2, 1.0, -0.3), 3, "plane");
  check_moving(plane_spec(), "plane");
  // A zero normal (the deck forbids it) must not give NaN.
  ColliderSpec zero = plane_spec();
  zero.normal = {0, 0, 0};
  const auto z = make_collider(zero, "deck.yaml", 0);
  Vec3 g;
  CHECK(std::isfinite(z->distance(Vec3(1, 2, 3), &g)) && g.allFinite());
}

void test_sphere() {
  const auto c = make_collider(sphere_spec(), "deck.yaml", 0);
  const Vec3 ctr(0.1, -0.2, 0.3);
  CHECK_NEAR(c->distance(ctr + Vec3(0, 2, 0)), 1.2, 1e-15);
  CHECK_NEAR(c->distance(ctr), -0.8, 1e-15);
  Vec3 g;
  Mat3 H;
  c->distance(ctr, &g, &H);  // the centre: any unit gradient, no NaN
  CHECK(std::fabs(g.norm() - 1) < 1e-15 && H.allFinite());
  for (int i = 0; i < 100; ++i) {
    const Vec3 p = random_point(-2, 2);
    if ((p - ctr).norm() < 0.1) continue;
    CHECK_NEAR(c->distance(p), (p - ctr).norm() - 0.8, 1e-14);
    check_derivatives(*c, p, "sphere");
  }
  check_paths(*c, ctr, 2.5, "sphere");
  check_moving(sphere_spec(), "sphere");
}

// Distance of the box by cases, for the known answers.
void test_box() {
  const auto c = make_collider(box_spec(), "deck.yaml", 0);
  CHECK_NEAR(c->distance(Vec3(1.5, 0, 0)), 1.0, 1e-15);                     // face region
  CHECK_NEAR(c->distance(Vec3(1.5, 2.0, 0)), std::sqrt(2.0), 1e-15);        // edge region
  CHECK_NEAR(c->distance(Vec3(-1.5, -2.0, 1.75)), std::sqrt(3.0), 1e-15);   // corner region
  CHECK_NEAR(c->distance(Vec3(0, 0, 0)), -0.5, 1e-15);                      // inside: nearest face x
  CHECK_NEAR(c->distance(Vec3(0.1, 0.8, 0)), -0.2, 1e-15);                  // nearest face +y
  Vec3 g;
  Mat3 H;
  c->distance(Vec3(0.1, -0.8, 0), &g, &H);
  CHECK((g - Vec3(0, -1, 0)).norm() < 1e-15 && H.norm() == 0);
  c->distance(Vec3(1.5, 2.0, 0), &g, &H);  // edge along z: curvature across it only
  CHECK((H * Vec3::UnitZ()).norm() < 1e-15 && std::fabs(H(0, 0) - 0.5 / std::sqrt(2.0)) < 1e-15);
  int checked = 0;
  const Vec3 h(0.5, 1.0, 0.75);
  for (int i = 0; i < 400; ++i) {
    const Vec3 p = random_point(-2, 2);
    // Away from the non-smooth sets: region boundaries (|x_k| = h_k) and, inside, the ties
    // between nearest faces.
    const Vec3 e = p.cwiseAbs() - h;
    bool near_kink = (e.cwiseAbs().array() < 1e-3).any();
    if ((e.array() < 0).all()) {
      std::array<double, 3> s{e[0], e[1], e[2]};
      std::sort(s.begin(), s.end());
      near_kink |= s[2] - s[1] < 1e-3;
    }
    if (near_kink) continue;
    check_derivatives(*c, p, "box");
    ++checked;
  }
  CHECK(checked > 300);
  check_paths(*c, Vec3(0, 0, 0), 2.5, "box");
  check_moving(box_spec(), "box");
}

void test_capsule() {
  const auto c = make_collider(capsule_spec(), "deck.yaml", 0);
  const Vec3 a(-0.6, 0.1, -0.2), b(0.7, 0.4, 0.5);
  const Vec3 t = (b - a).normalized(), across = t.unitOrthogonal();
  CHECK_NEAR(c->distance(0.5 * (a + b) + 1.0 * across), 0.55, 1e-15);  // side
  CHECK_NEAR(c->distance(b + 1.0 * t), 0.55, 1e-15);                    // cap at b
  CHECK_NEAR(c->distance(a - 2.0 * t + 0.5 * across), std::sqrt(4.25) - 0.45, 1e-15);
  CHECK_NEAR(c->distance(0.3 * a + 0.7 * b), -0.45, 1e-15);             // on the axis
  Vec3 g;
  Mat3 H;
  c->distance(0.3 * a + 0.7 * b, &g, &H);
  CHECK(std::fabs(g.norm() - 1) < 1e-15 && H.allFinite());
  const double L = (b - a).norm();
  int checked = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 p = random_point(-2, 2);
    const double s = (p - a).dot(t);
    const double axis_dist = (p - a - std::min(std::max(s, 0.0), L) * t).norm();
    if (std::fabs(s) < 1e-3 || std::fabs(s - L) < 1e-3 || axis_dist < 0.05) continue;
    CHECK_NEAR(c->distance(p), axis_dist - 0.45, 1e-14);
    check_derivatives(*c, p, "capsule");
    ++checked;
  }
  CHECK(checked > 250);
  check_paths(*c, 0.5 * (a + b), 2.5, "capsule");
  check_moving(capsule_spec(), "capsule");
  // Paths along the axis hit the caps; paths parallel to the axis hit the side.
  CHECK_NEAR(c->first_contact(b + 2 * t, a), 1.55 / (2 + L), 1e-14);
  CHECK_NEAR(c->first_contact(0.5 * (a + b) + 2 * across, 0.5 * (a + b) - 2 * across), 1.55 / 4, 1e-15);
  CHECK(c->first_contact(0.5 * (a + b) + across - 3 * t, 0.5 * (a + b) + across + 3 * t) >= 1);
  // A degenerate capsule (a == b) is a ball, without NaN.
  ColliderSpec point = capsule_spec();
  point.b = point.a;
  const auto ball = make_collider(point, "deck.yaml", 0);
  CHECK_NEAR(ball->distance(a + Vec3(0, 0, 1)), 0.55, 1e-15);
  CHECK_NEAR(ball->first_contact(a + Vec3(0, 0, 1), a - Vec3(0, 0, 1)), 0.55 / 2, 1e-15);
}

void test_mesh_cube(const fs::path& dir) {
  const ColliderSpec box = box_spec();
  write_file(dir / "cube.obj", cube_obj(box));
  write_file(dir / "cube.mesh", cube_medit(box));
  const auto analytic = make_collider(box, "deck.yaml", 0);
  for (const char* name : {"cube.obj", "cube.mesh"}) {
    const auto c = make_collider(mesh_spec(dir / name), "deck.yaml", 0);
    const std::string what = std::string("mesh ") + name;
    double worst = 0, worst_g = 0;
    for (int i = 0; i < 2000; ++i) {
      const Vec3 p = random_point(-2, 2);
      Vec3 g, ga;
      worst = std::max(worst, std::fabs(c->distance(p, &g) - analytic->distance(p, &ga)));
      const Vec3 e = p.cwiseAbs() - Vec3(0.5, 1.0, 0.75);
      if ((e.array() > 0).any()) worst_g = std::max(worst_g, (g - ga).norm());  // outside: one answer
    }
    CHECK_MSG(worst < 1e-12, what + ": phi vs analytic box " + std::to_string(worst));
    CHECK_MSG(worst_g < 1e-9, what + ": gradient vs analytic box " + std::to_string(worst_g));
    // Outside, away from region boundaries: derivatives by differences (edges and corners curve).
    int checked = 0;
    for (int i = 0; i < 300; ++i) {
      const Vec3 p = random_point(-2, 2);
      const Vec3 e = p.cwiseAbs() - Vec3(0.5, 1.0, 0.75);
      if (!(e.array() > 0).any() || (e.cwiseAbs().array() < 1e-3).any()) continue;
      checked += check_derivatives(*c, p, what);
    }
    CHECK(checked > 100);
    check_paths(*c, Vec3(0, 0, 0), 2.5, what);
    check_moving(mesh_spec(dir / name), what);
  }
}

void test_mesh_icosphere(const fs::path& dir) {
  const Vec3 ctr(0.1, -0.2, 0.3);
  const double r = 0.8;
  write_file(dir / "ico.obj", to_obj(icosphere(3, ctr, r)));
  const auto c = make_collider(mesh_spec(dir / "ico.obj"), "deck.yaml", 0);
  const auto ball = make_collider(sphere_spec(), "deck.yaml", 0);
  double worst = 0;
  for (int i = 0; i < 500; ++i) {
    const Vec3 p = random_point(-2, 2);
    worst = std::max(worst, std::fabs(c->distance(p) - ball->distance(p)));
  }
  CHECK_MSG(worst < 0.01 * r, "icosphere vs sphere " + std::to_string(worst));
  CHECK(c->distance(ctr) < -0.95 * r);
  int checked = 0, tried = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 p = random_point(-2, 2);
    if (std::fabs((p - ctr).norm() - r) < 0.1 || (p - ctr).norm() < 0.3) continue;
    ++tried;
    checked += check_derivatives(*c, p, "mesh icosphere", true);
  }
  CHECK_MSG(checked > 0.95 * tried, "icosphere: too many points skipped near piece boundaries: " +
                                        std::to_string(tried - checked) + " of " + std::to_string(tried));
  check_paths(*c, ctr, 2.5, "mesh icosphere");
}

// A flat tetrahedron (sharp edges and corners): there the sign needs the pseudo-normals, since
// p - closest can point against one of the faces along an edge. Convex, so the truth is simple:
// inside iff below every face plane, and |phi| the distance to the nearest triangle.
void test_mesh_sliver(const fs::path& dir) {
  write_file(dir / "sliver.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.3 0.3 0.04\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n");
  const auto c = make_collider(mesh_spec(dir / "sliver.obj"), "deck.yaml", 0);
  const std::vector<Vec3> x{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 0.04}};
  const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  int wrong = 0, inside = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3 p = random_point(-0.2, 1.2).cwiseProduct(Vec3(1, 1, 0.15));
    double d2 = std::numeric_limits<double>::infinity(), plane = -std::numeric_limits<double>::infinity();
    for (const auto& t : f) {
      d2 = std::min(d2, (p - closest_on_triangle(p, x[t[0]], x[t[1]], x[t[2]]).point).squaredNorm());
      const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]).normalized();
      plane = std::max(plane, n.dot(p - x[t[0]]));
    }
    const double truth = plane <= 0 ? -std::sqrt(d2) : std::sqrt(d2);
    inside += plane <= 0;
    if (std::fabs(c->distance(p) - truth) > 1e-12) ++wrong;
  }
  CHECK_MSG(wrong == 0, "sliver: " + std::to_string(wrong) + " wrong signed distances");
  CHECK(inside > 20);
}

// An open quad z = 0 over [0, 1]^2, normal +z: phi = z over it; paths cross it or pass by.
void test_mesh_quad(const fs::path& dir) {
  write_file(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  const auto c = make_collider(mesh_spec(dir / "quad.obj"), "deck.yaml", 0);
  for (int i = 0; i < 100; ++i) {
    Vec3 p = random_point(0.01, 0.99);
    p.z() = (i % 2 ? 1 : -1) * p.z();
    Vec3 g;
    Mat3 H;
    CHECK_NEAR(c->distance(p, &g, &H), p.z(), 1e-15);
    CHECK_MSG((g - Vec3::UnitZ()).norm() < 1e-15 && H.norm() == 0,
              "quad: 1e15 |g - e_z| = " + std::to_string(1e15 * (g - Vec3::UnitZ()).norm()) + ", 1e15 |H| = " + std::to_string(1e15 * H.norm()));
  }
  CHECK_NEAR(c->distance(Vec3(2, 0.5, 1)), std::sqrt(2.0), 1e-15);
  CHECK_NEAR(c->first_contact(Vec3(0.3, 0.4, 1), Vec3(0.5, 0.6, -1)), 0.5, 1e-15);
  CHECK_NEAR(c->first_contact(Vec3(0.3, 0.4, -1), Vec3(0.5, 0.5, 3)), 0.25, 1e-15);  // from either side
  CHECK(c->first_contact(Vec3(1.3, 0.4, 1), Vec3(1.5, 0.6, -1)) >= 1);                // past the edge
  CHECK(c->first_contact(Vec3(0.3, 0.4, 1), Vec3(0.5, 0.6, 0.1)) >= 1);               // stops short
  // Through the shared diagonal of the two triangles: not lost between them.
  CHECK_NEAR(c->first_contact(Vec3(0.5, 0.5, 1), Vec3(0.5, 0.5, -1)), 0.5, 1e-15);
}

// ---------------------------------------------------------------------------------------------
// BVH against brute force on a few thousand irregular triangles

void test_bvh() {
  TriangleSurface s = icosphere(4, Vec3(0, 0, 0), 1.0);
  for (Vec3& x : s.vertices) x *= 1 + 0.05 * std::sin(7 * x.x()) * std::cos(5 * x.y());  // bumpy
  const int n = int(s.triangles.size());
  const TriangleBVH bvh(s.vertices, s.triangles);
  double worst = 0, worst_s = 0;
  long long tested = 0;
  const int queries = 300;
  for (int i = 0; i < queries; ++i) {
    const Vec3 p = i % 3 ? random_point(-1.5, 1.5) : Vec3(random_point(-1, 1).normalized() * 1.01);
    double brute = std::numeric_limits<double>::infinity();
    for (const auto& f : s.triangles)
      brute = std::min(brute, (p - closest_on_triangle(p, s.vertices[f[0]], s.vertices[f[1]], s.vertices[f[2]]).point)
                                  .squaredNorm());
    const SurfaceHit hit = bvh.closest(p);
    worst = std::max(worst, std::fabs(hit.distance2 - brute));
    CHECK(std::fabs((p - hit.point).squaredNorm() - hit.distance2) < 1e-15);
    tested += hit.triangles_tested;
    // Segments: the first crossing against every triangle.
    const Vec3 q1 = random_point(-1.5, 1.5);
    double first = std::numeric_limits<double>::infinity();
    for (const auto& f : s.triangles) {
      const double sc = segment_triangle(p, q1, s.vertices[f[0]], s.vertices[f[1]], s.vertices[f[2]]);
      if (sc >= 0) first = std::min(first, sc);
    }
    const double got = bvh.first_crossing(p, q1);
    worst_s = std::max(worst_s, first <= 1 ? std::fabs(got - first) : (got < 0 ? 0.0 : 1.0));
  }
  CHECK_MSG(worst < 1e-14, "BVH closest vs brute force " + std::to_string(worst));
  CHECK_MSG(worst_s < 1e-15, "BVH first crossing vs brute force " + std::to_string(worst_s));
  const double mean = double(tested) / queries;
  std::printf("  BVH: %d triangles, %.1f tested per closest-point query\n", n, mean);
  CHECK_MSG(mean < 0.05 * n, "BVH prunes too little: " + std::to_string(mean));
}

// ---------------------------------------------------------------------------------------------
// Errors

void test_errors(const fs::path& dir) {
  auto bad = [&](const std::string& name, const std::string& text, const std::vector<std::string>& parts) {
    const fs::path p = dir / name;
    write_file(p, text);
    std::vector<std::string> with_file = parts;
    with_file.push_back(p.string());
    expect_input_error(name, [&] { make_collider(mesh_spec(p), "deck.yaml", 2); }, with_file);
  };
  const std::string v3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  bad("index.obj", v3 + "f 1 2 4\n", {":4:", "out of range"});
  bad("zero.obj", v3 + "f 1 0 2\n", {":4:", "'0'"});
  bad("relative.obj", v3 + "f -1 -2 -4\n", {":4:", "before the first vertex"});
  bad("number.obj", "v 0 0 0\nv 1 x 0\n", {":2:", "'x'"});
  bad("short_v.obj", "v 0 0\n", {":1:"});
  bad("short_f.obj", v3 + "\n# gap\nf 1 2\n", {":6:", "at least 3"});
  bad("word.obj", v3 + "f 1 2 a/1\n", {":4:", "'a/1'"});
  bad("index.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\nTriangles\n1\n1 2 7 0\nEnd\n",
      {":10:", "out of range"});
  bad("number.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n1 0 zz 0\n", {":6:", "'zz'"});
  bad("keyword.mesh", "MeshVersionFormatted 2\nDimension 3\nBogus 3\n", {":3:", "Bogus"});
  bad("short.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n", {":5:", "Vertices"});
  bad("dim.mesh", "MeshVersionFormatted 2\nDimension 2\n", {":2:", "3D"});
  // Numbers are plain decimals; Medit versions 1 to 4; the indices of skipped sections in range.
  bad("hex.obj", "v 0 0 0\nv 0x1 0 0\nv 0 1 0\nf 1 2 3\n", {":2:", "'0x1'", "hexadecimal"});
  bad("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n", {":3:", "'-inf'", "not finite"});
  const std::string tri = "Vertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\nTriangles\n1\n1 2 3 0\n";  // lines 3-10
  bad("nan.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\nNaN 0 0 0\n0 1 0 0\n", {":6:", "'NaN'", "not finite"});
  bad("version.mesh", "MeshVersionFormatted 99\nDimension 3\n" + tri, {":1:", "MeshVersionFormatted", "99"});
  bad("edges.mesh", "MeshVersionFormatted 2\nDimension 3\n" + tri + "Edges\n1\n1 4 0\n", {":13:", "'Edges'", "index 4", "1..3"});
  bad("corners.mesh", "MeshVersionFormatted 2\nDimension 3\nCorners 1 5\n" + tri, {":3:", "'Corners'", "index 5", "1..3"});
  bad("surface.stl", "solid x\n", {".stl"});
  // No triangle: the deck entry is named, with the file.
  bad("empty.obj", v3 + "l 1 2\n", {"deck.yaml", "colliders[2].file", "no triangle"});
  bad("empty.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nEnd\n", {"colliders[2].file"});
  expect_input_error("missing file", [&] { make_collider(mesh_spec(dir / "none.obj"), "deck.yaml", 0); },
                     {(dir / "none.obj").string()});
}

// velocity_at: the motion's velocity as it reaches t (what a released fixed vertex keeps), against
// finite differences of moved(): central inside (start, end), backward at end, 0 from the left
// of start and after end.
void test_motion_velocity() {
  Motion m;
  m.active = true;
  m.axis = {1, 2, 3};
  m.center = {0.5, 0, -0.2};
  m.rate_deg = 360;
  m.velocity = {0.1, -0.2, 0.3};
  m.start = 0.2;
  m.end = 0.9;
  const Vec3 X(0.3, -0.7, 1.1);
  const double e = 1e-6;
  double worst = 0;
  for (double t : {0.25, 0.5, 0.8999})
    worst = std::max(worst, (velocity_at(m, X, t) - (moved(m, X, t + e) - moved(m, X, t - e)) / (2 * e)).norm());
  const Vec3 backward = (3 * moved(m, X, m.end) - 4 * moved(m, X, m.end - e) + moved(m, X, m.end - 2 * e)) / (2 * e);
  worst = std::max(worst, (velocity_at(m, X, m.end) - backward).norm());
  CHECK_MSG(worst < 1e-6, "velocity_at against finite differences of moved: " + std::to_string(worst));
  CHECK_MSG(velocity_at(m, X, 0.9).norm() > 1, "at end the motion is still the one that reached it");
  for (double t : {0.0, 0.2, 0.95})
    CHECK_MSG(velocity_at(m, X, t).norm() == 0, "no velocity at t = " + std::to_string(t) + " (not yet moving, or held)");
  m.active = false;
  CHECK_MSG(velocity_at(m, X, 0.5).norm() == 0, "an inactive motion has no velocity");
}

}  // namespace

int main() {
  test_motion_velocity();
  test_plane();
  test_sphere();
  test_box();
  test_capsule();
  test_bvh();
  const fs::path dir = fs::temp_directory_path() / ("hyperqn_test_colliders_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  try {
    test_mesh_cube(dir);
    test_mesh_icosphere(dir);
    test_mesh_quad(dir);
    test_mesh_sliver(dir);
    test_errors(dir);
  } catch (const std::exception& e) {
    CHECK_MSG(false, std::string("unexpected exception: ") + e.what());
  }
  fs::remove_all(dir);
  return check::summary("test_colliders");
}

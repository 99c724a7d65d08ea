// The pair kernels for self-contact (geometry/pair_distance, geometry/pair_ccd): vertex-triangle
// and edge-edge squared distances in every sub-case against independent closest points, their
// gradients and Hessians against central differences (nearly touching and nearly parallel pairs
// included), the edge-edge mollifier and a mollified barrier by central differences (parallel
// edges included), and the additive CCD on known impact times, grazing motion, starts at contact
// and random trajectories sampled densely.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "check.hpp"
#include "geometry/pair_ccd.hpp"
#include "geometry/pair_distance.hpp"
#include "geometry/triangle_queries.hpp"

using namespace hyperqn;
using Vec3 = Eigen::Vector3d;

namespace {

std::mt19937 rng(26);  // fixed seed: the same pairs on every run
double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
Vec3 random_point(double lo, double hi) { return Vec3(uniform(lo, hi), uniform(lo, hi), uniform(lo, hi)); }

Vector12d stack(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  Vector12d x;
  x << x0, x1, x2, x3;
  return x;
}
Vec3 point(const Vector12d& x, int k) { return x.segment<3>(3 * k); }

// A function of the 12 coordinates with its gradient and Hessian.
using Function12 = std::function<double(const Vector12d&, Vector12d*, Matrix12d*)>;

double vertex_triangle(const Vector12d& x, Vector12d* g, Matrix12d* H) {
  return point_triangle_squared_distance(point(x, 0), point(x, 1), point(x, 2), point(x, 3), g, H);
}
double edge_edge(const Vector12d& x, Vector12d* g, Matrix12d* H) {
  return edge_edge_squared_distance(point(x, 0), point(x, 1), point(x, 2), point(x, 3), g, H);
}

// Largest relative FD errors seen, printed at the end.
double worst_gradient = 0, worst_hessian = 0;

// Relative error max|fd - exact| / max|exact|.
template <class M>
double relative_error(const M& fd, const M& exact) {
  return (fd - exact).cwiseAbs().maxCoeff() / std::max(exact.cwiseAbs().maxCoeff(), 1e-300);
}

// The gradient against central differences of the value, the Hessian against central differences
// of the gradient, with step h (relative errors; the tolerances are stated by the callers).
// gradient_floor: where the gradient vanishes (parallel edges under the mollifier), its error is
// relative to this instead. hessian_tol < 0: the Hessian is not checked (where it jumps).
void check_derivatives(const std::string& what, const Function12& f, const Vector12d& x, double h,
                       double gradient_tol = 1e-7, double hessian_tol = 1e-6, double gradient_floor = 0) {
  Vector12d g;
  Matrix12d H;
  f(x, &g, &H);
  Vector12d g_fd;
  Matrix12d H_fd;
  for (int i = 0; i < 12; ++i) {
    Vector12d xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    Vector12d gp, gm;
    g_fd[i] = (f(xp, &gp, nullptr) - f(xm, &gm, nullptr)) / (2 * h);
    H_fd.col(i) = (gp - gm) / (2 * h);
  }
  const double eg = (g_fd - g).cwiseAbs().maxCoeff() / std::max(g.cwiseAbs().maxCoeff(), gradient_floor);
  const double eh = relative_error(H_fd, H);
  worst_gradient = std::max(worst_gradient, eg);
  if (hessian_tol >= 0) worst_hessian = std::max(worst_hessian, eh);
  CHECK_MSG(eg <= gradient_tol, what + ": gradient error " + std::to_string(eg));
  if (hessian_tol >= 0) CHECK_MSG(eh <= hessian_tol, what + ": Hessian error " + std::to_string(eh));
  CHECK_MSG((H - H.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * std::max(1.0, H.cwiseAbs().maxCoeff()),
            what + ": Hessian symmetric");
}

bool same_case(const PairCase& a, PairCase::Kind kind, const std::vector<int>& points) {
  if (a.kind != kind) return false;
  int k = 0;
  for (int p : points)
    if (a.points[k++] != p) return false;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Vertex against triangle

const Vec3 kT0(0, 0, 0), kT1(1, 0.1, 0.05), kT2(0.2, 0.9, -0.1);

void test_vertex_triangle_cases() {
  const Vec3 n = (kT1 - kT0).cross(kT2 - kT0).normalized();
  const Vec3 centroid = (kT0 + kT1 + kT2) / 3;
  const Vec3 corners[3] = {kT0, kT1, kT2};
  struct Probe {
    std::string name;
    Vec3 p;
    PairCase::Kind kind;
    std::vector<int> points;
  };
  std::vector<Probe> probes;
  const Vec3 inside = 0.3 * kT0 + 0.3 * kT1 + 0.4 * kT2;
  probes.push_back({"face", inside + 0.4 * n, PairCase::PointPlane, {0, 1, 2, 3}});
  probes.push_back({"face below", inside - 0.3 * n, PairCase::PointPlane, {0, 1, 2, 3}});
  probes.push_back({"face, nearly touching (1e-6)", inside + 1e-6 * n, PairCase::PointPlane, {0, 1, 2, 3}});
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = corners[k], b = corners[(k + 1) % 3];
    const Vec3 mid = 0.4 * a + 0.6 * b;
    const Vec3 out = (b - a).cross(n).normalized();  // in the plane, away from the triangle
    const std::string e = "edge " + std::to_string(k);
    probes.push_back({e, mid + 0.3 * out + 0.2 * n, PairCase::PointEdge, {0, 1 + k, 1 + (k + 1) % 3}});
    probes.push_back({e + ", nearly touching (1e-6)", mid + 1e-6 * out, PairCase::PointEdge, {0, 1 + k, 1 + (k + 1) % 3}});
    const Vec3 away = (corners[k] - centroid).normalized();
    const std::string v = "vertex " + std::to_string(k);
    probes.push_back({v, corners[k] + 0.5 * away - 0.2 * n, PairCase::PointPoint, {0, 1 + k}});
    probes.push_back({v + ", nearly touching (1e-6)", corners[k] + 1e-6 * away, PairCase::PointPoint, {0, 1 + k}});
  }
  for (const Probe& probe : probes) {
    const std::string what = "vertex-triangle " + probe.name;
    const PairCase c = point_triangle_case(probe.p, kT0, kT1, kT2);
    CHECK_MSG(same_case(c, probe.kind, probe.points), what + ": sub-case");
    // The value against the closest point of geometry/triangle_queries.
    const double d = point_triangle_squared_distance(probe.p, kT0, kT1, kT2);
    const double reference = (probe.p - closest_on_triangle(probe.p, kT0, kT1, kT2).point).squaredNorm();
    // (Both round p - closest to about 1e-16 of the triangle's size: relative 1e-10 at 1e-6 away.)
    CHECK_MSG(std::fabs(d - reference) <= 1e-12 * reference + 1e-15 * std::sqrt(reference),
              what + ": distance " + std::to_string(d));
    // Relative errors <= 1e-7 (gradient), 1e-6 (Hessian), step 1e-6 (1e-8 when nearly touching,
    // so that the step stays inside the sub-case).
    const double h = reference < 1e-10 ? 1e-8 : 1e-6;
    check_derivatives(what, vertex_triangle, stack(probe.p, kT0, kT1, kT2), h);
  }
}

// Many random pairs: the distance against the closest point of geometry/triangle_queries.
void test_vertex_triangle_random() {
  double worst = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 p = random_point(-1, 2), a = random_point(0, 1), b = random_point(0, 1), c = random_point(0, 1);
    const double d = point_triangle_squared_distance(p, a, b, c);
    const double reference = (p - closest_on_triangle(p, a, b, c).point).squaredNorm();
    worst = std::max(worst, std::fabs(d - reference) / reference);
  }
  CHECK_MSG(worst <= 1e-10, "vertex-triangle, random: relative distance error " + std::to_string(worst));
}

// ---------------------------------------------------------------------------------------------
// Edge against edge

// Independent reference: the squared distance of a point to a segment (clamped projection),
// minimized over the point's parameter on the other segment by golden-section search (the
// function is convex in it).
double point_segment_reference(const Vec3& p, const Vec3& b0, const Vec3& b1) {
  const Vec3 v = b1 - b0;
  const double t = std::clamp(v.dot(p - b0) / v.squaredNorm(), 0.0, 1.0);
  return (p - b0 - t * v).squaredNorm();
}
double edge_edge_reference(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  auto f = [&](double s) { return point_segment_reference(a0 + s * (a1 - a0), b0, b1); };
  const double ratio = (std::sqrt(5.0) - 1) / 2;
  double lo = 0, hi = 1;
  for (int i = 0; i < 200; ++i) {
    const double m1 = hi - ratio * (hi - lo), m2 = lo + ratio * (hi - lo);
    (f(m1) < f(m2) ? hi : lo) = (f(m1) < f(m2) ? m2 : m1);
  }
  return std::min({f(0), f(1), f(0.5 * (lo + hi))});
}

struct EdgePair {
  std::string name;
  Vec3 a0, a1, b0, b1;
  PairCase::Kind kind;
  std::vector<int> points;
};

// Edge b crossing above edge a = (0,0,0)-(1,0,0) at height h, at angle theta in the xy plane,
// their closest points in the middle of both.
EdgePair crossing(const std::string& name, double theta, double h) {
  const Vec3 c(0.5, 0, h), d(std::cos(theta), std::sin(theta), 0);
  return {name, Vec3(0, 0, 0), Vec3(1, 0, 0), c - 0.4 * d, c + 0.4 * d, PairCase::EdgeEdge, {0, 1, 2, 3}};
}

void test_edge_edge_cases() {
  const Vec3 b0(-1, 0, 0), b1(1, 0.1, 0);  // for the end-point cases
  const Vec3 p(0.2, 0.1, 0.3), away(0.3, 0.5, 0.8);
  const Vec3 q(-1.3, 0.1, 0.2), out(-0.5, 0.3, 0.4);
  std::vector<EdgePair> pairs = {
      {"interior, skew", Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, -0.5, 0.3), Vec3(0.4, 0.6, 0.35), PairCase::EdgeEdge, {0, 1, 2, 3}},
      crossing("interior, nearly touching (1e-6)", 1.0, 1e-6),
      crossing("interior, nearly parallel (1e-3 rad)", 1e-3, 0.1),
      crossing("interior, nearly parallel (1e-4 rad)", 1e-4, 0.1),
      {"a0 against edge b", p, p + away, b0, b1, PairCase::PointEdge, {0, 2, 3}},
      {"a1 against edge b", p + away, p, b0, b1, PairCase::PointEdge, {1, 2, 3}},
      {"b0 against edge a", b0, b1, p, p + away, PairCase::PointEdge, {2, 0, 1}},
      {"b1 against edge a", b0, b1, p + away, p, PairCase::PointEdge, {3, 0, 1}},
      {"a0 against edge b, nearly touching (1e-6)", Vec3(0.1, 0.055, 1e-6), Vec3(0.1, 0.055, 1e-6) + away, b0, b1, PairCase::PointEdge, {0, 2, 3}},
      {"a0 against b0", q, q + out, b0, b1, PairCase::PointPoint, {0, 2}},
      {"a1 against b1", Vec3(2.2, 0, 0) - out, Vec3(2.2, 0, 0), b0, b1, PairCase::PointPoint, {1, 3}},
      {"a1 against b0", b0, b1, Vec3(1.2, 0.2, -0.1), Vec3(1.2, 0.2, -0.1) + away, PairCase::PointPoint, {1, 2}},
      {"a0 against b0, nearly touching (1e-6)", b0 - Vec3(1e-6, 0, 0), b0 - Vec3(0.6, -0.3, 0.5), b0, b1, PairCase::PointPoint, {0, 2}},
      {"parallel, apart along their line", Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1.5, 0.2, 0), Vec3(2.5, 0.2, 0), PairCase::PointPoint, {1, 2}},
  };
  for (const EdgePair& e : pairs) {
    const std::string what = "edge-edge " + e.name;
    const PairCase c = edge_edge_case(e.a0, e.a1, e.b0, e.b1);
    CHECK_MSG(same_case(c, e.kind, e.points), what + ": sub-case");
    const double d = edge_edge_squared_distance(e.a0, e.a1, e.b0, e.b1);
    const double reference = edge_edge_reference(e.a0, e.a1, e.b0, e.b1);
    CHECK_MSG(std::fabs(d - reference) <= 1e-9 * reference, what + ": distance " + std::to_string(d));
    // Relative errors <= 1e-7 (gradient), 1e-6 (Hessian); step 1e-6, 1e-8 when nearly touching.
    // Nearly parallel lines: the k-th derivative grows like theta^(1-k), so the step is 1e-4 theta
    // (below the tilt of about 10 theta^2 that moves the closest points off the edges) and the
    // errors <= 1e-6, 1e-5.
    const bool parallel = e.name.find("parallel") != std::string::npos;
    const double theta = e.name.find("1e-4 rad") != std::string::npos ? 1e-4 : 1e-3;
    const double h = parallel ? 1e-4 * theta : reference < 1e-10 ? 1e-8 : 1e-6;
    check_derivatives(what, edge_edge, stack(e.a0, e.a1, e.b0, e.b1), h, parallel ? 1e-6 : 1e-7, parallel ? 1e-5 : 1e-6);
  }
  // Exactly parallel and overlapping: an end point against the other edge (no line-line case).
  const Vec3 a0(0, 0, 0), a1(1, 0, 0), c0(0.3, 0.2, 0), c1(1.3, 0.2, 0);
  const PairCase c = edge_edge_case(a0, a1, c0, c1);
  CHECK(c.kind == PairCase::PointEdge);
  CHECK_NEAR(edge_edge_squared_distance(a0, a1, c0, c1), 0.04, 1e-15);
}

// Many random pairs, general and nearly parallel: the distance against the golden-section search.
void test_edge_edge_random() {
  double worst = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 a0 = random_point(0, 1), a1 = random_point(0, 1), b0 = random_point(0, 1);
    Vec3 b1 = random_point(0, 1);
    if (trial % 2) b1 = b0 + (a1 - a0) * uniform(0.3, 2) + random_point(-1, 1) * std::pow(10.0, -uniform(3, 9));
    const double d = edge_edge_squared_distance(a0, a1, b0, b1);
    const double reference = edge_edge_reference(a0, a1, b0, b1);
    worst = std::max(worst, std::fabs(d - reference) / std::max(reference, 1e-12));
  }
  CHECK_MSG(worst <= 1e-8, "edge-edge, random and nearly parallel: relative distance error " + std::to_string(worst));
}

// ---------------------------------------------------------------------------------------------
// The mollifier, and a mollified barrier as the term will use it

// IPC's log barrier on squared distances, b(D) = -(D - Dh)^2 ln(D / Dh) for D < Dh, with its first
// and second derivatives (a stand-in for the contact model of the future term).
void barrier(double D, double Dh, double* b, double* db, double* d2b) {
  if (D >= Dh) {
    *b = *db = *d2b = 0;
    return;
  }
  const double l = std::log(D / Dh), e = D - Dh;
  *b = -e * e * l;
  *db = -2 * e * l - e * e / D;
  *d2b = -2 * l - 4 * e / D + e * e / (D * D);
}

// E = m(x) b(D(x)) for an edge pair with eps_x of its rest pose.
Function12 mollified_barrier(double eps_x, double Dh) {
  return [eps_x, Dh](const Vector12d& x, Vector12d* g, Matrix12d* H) {
    Vector12d gm, gD;
    Matrix12d Hm, HD;
    const double m = edge_edge_mollifier(point(x, 0), point(x, 1), point(x, 2), point(x, 3), eps_x, &gm, &Hm);
    const double D = edge_edge(x, &gD, &HD);
    double b, db, d2b;
    barrier(D, Dh, &b, &db, &d2b);
    if (g) *g = b * gm + m * db * gD;
    if (H) *H = b * Hm + db * (gm * gD.transpose() + gD * gm.transpose()) + m * (d2b * gD * gD.transpose() + db * HD);
    return m * b;
  };
}

void test_mollifier() {
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  const double eps_x = edge_edge_mollifier_threshold(a0, a1, Vec3(0, 0.2, 0), Vec3(1.0, 0.2, 0));
  CHECK_NEAR(eps_x, 1e-3, 1e-18);
  auto mollifier = [eps_x](const Vector12d& x, Vector12d* g, Matrix12d* H) {
    return edge_edge_mollifier(point(x, 0), point(x, 1), point(x, 2), point(x, 3), eps_x, g, H);
  };
  // Value: c = sin^2(theta) |ea|^2 |eb|^2 for the crossing pairs (|ea| = 1, |eb| = 0.8).
  for (double theta : {0.0, 1e-4, 1e-2, 0.03, 0.2}) {
    const EdgePair e = crossing("", theta, 0.1);
    const double c = std::pow(std::sin(theta) * 0.8, 2), q = c / eps_x;
    const double expected = q < 1 ? (2 - q) * q : 1;
    CHECK_NEAR(edge_edge_mollifier(e.a0, e.a1, e.b0, e.b1, eps_x), expected, 1e-12);
  }
  // Derivatives inside the mollified range (theta = 1e-2: c / eps_x = 0.064; 0.03: 0.58) and
  // beyond it (0 there). Relative errors <= 1e-7, 1e-6; step 1e-6.
  for (double theta : {1e-2, 0.03}) {
    const EdgePair e = crossing("", theta, 0.1);
    check_derivatives("mollifier at theta " + std::to_string(theta), mollifier, stack(e.a0, e.a1, e.b0, e.b1), 1e-6);
  }
  {
    const EdgePair e = crossing("", 0.2, 0.1);
    Vector12d g;
    Matrix12d H;
    edge_edge_mollifier(e.a0, e.a1, e.b0, e.b1, eps_x, &g, &H);
    CHECK(g.isZero(0) && H.isZero(0));
  }
  // The mollified barrier (activation Dh = 0.05^2, the pairs 0.03 apart) through parallel, where
  // the distance's own sub-case changes. Nearly parallel: relative errors <= 1e-6, 1e-5, step
  // min(1e-7, 0.1 theta^2) (tilting one edge by about 10 theta^2 here moves the lines' closest
  // points off the edges, a change of sub-case; below 1e-6 rad no step in double precision stays
  // inside it, so 1e-6 is the smallest angle checked). Exactly parallel
  // and overlapping, the distance has no derivative but m b has one, 0 (its error relative to
  // |H| x 1e-2, the change over 1 % of the edges' length; step 1e-9): the mollified energy is C1
  // there. Its Hessian jumps there (as the distance's does between sub-cases), so it is not checked.
  const double Dh = 0.05 * 0.05;
  const Function12 E = mollified_barrier(eps_x, Dh);
  for (double theta : {0.03, 1e-3, 1e-5, 1e-6}) {
    const EdgePair e = crossing("", theta, 0.03);
    char name[64];
    std::snprintf(name, sizeof name, "mollified barrier at theta %g", theta);
    check_derivatives(name, E, stack(e.a0, e.a1, e.b0, e.b1), std::min(1e-7, 0.1 * theta * theta), 1e-6, 1e-5);
  }
  for (const Vector12d& x : {stack(a0, a1, Vec3(0.1, 0, 0.03), Vec3(0.9, 0, 0.03)),
                             stack(a0, a1, Vec3(0.3, 0.03, 0), Vec3(1.3, 0.03, 0))}) {
    Vector12d g;
    Matrix12d H;
    E(x, &g, &H);
    CHECK(g.isZero(0));
    check_derivatives("mollified barrier, parallel", E, x, 1e-9, 1e-6, -1, 1e-2 * H.cwiseAbs().maxCoeff());
  }
}

// ---------------------------------------------------------------------------------------------
// Continuous collision detection

const double kInf = std::numeric_limits<double>::infinity();

// The triangle (0,0,0), (1,0,0), (0,1,0) at rest, p moving from p0 to p1.
double vertex_path(const Vec3& p0, const Vec3& p1, double xi, double fraction = 0.1) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0);
  return vertex_triangle_impact(stack(p0, t0, t1, t2), stack(p1, t0, t1, t2), xi, fraction);
}

// t <= exact and within the relative tolerance below it.
void check_impact(const std::string& what, double t, double exact, double tol) {
  CHECK_MSG(t <= exact && t >= exact * (1 - tol),
            what + ": t = " + std::to_string(t) + " against " + std::to_string(exact));
}

void test_ccd_known_times() {
  // A vertex falling onto the face, head on: t* = 0.5. IPC's default stop (0.1 of the clearance
  // left) returns 0.9 t* here; a stop at 1e-6 of it returns t* to 1e-5.
  check_impact("vertex onto face, default stop", vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, -1), 0), 0.5, 0.1 + 1e-12);
  check_impact("vertex onto face", vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, -1), 0, 1e-6), 0.5, 1e-5);
  // With a minimum separation 0.1: the pair reaches it at t = 0.45.
  check_impact("vertex onto face, separation 0.1", vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, -1), 0.1, 1e-6), 0.45, 1e-5);
  // Obliquely: from (0.1, 0.1, 1) to (0.5, 0.3, -1) it crosses the face at t = 0.5.
  check_impact("vertex onto face, oblique", vertex_path(Vec3(0.1, 0.1, 1), Vec3(0.5, 0.3, -1), 0, 1e-6), 0.5, 1e-5);
  // Both moving: the triangle rises by 0.5 while the vertex falls by 2 from 1 above: t* = 0.4.
  {
    const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), up(0, 0, 0.5);
    const double t = vertex_triangle_impact(stack(Vec3(0.2, 0.3, 1), t0, t1, t2),
                                            stack(Vec3(0.2, 0.3, -1), t0 + up, t1 + up, t2 + up), 0, 1e-6);
    check_impact("vertex onto a rising face", t, 0.4, 1e-5);
  }
  // Moving away or passing beside: no contact.
  CHECK(vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, 3), 0) == kInf);
  CHECK(vertex_path(Vec3(2, 2, 1), Vec3(2, 2, -1), 0) == kInf);
  // Stopping short of the face, 0.2 above it: no contact. Stopping 0.01 above it, within 0.1 of
  // the starting clearance: a conservative t with the default stop, none with a stop at 1e-6.
  CHECK(vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, 0.2), 0) == kInf);
  CHECK(vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, 0.01), 0, 1e-6) == kInf);
  CHECK(vertex_path(Vec3(0.2, 0.3, 1), Vec3(0.2, 0.3, 0.01), 0) <= 1);

  // An edge crossing an edge: a along x at z = 1 moving to z = -1 through b along y at z = 0: t* = 0.5.
  const Vec3 a0(-1, 0, 1), a1(1, 0, 1), b0(0, -1, 0), b1(0, 1, 0), down(0, 0, -2);
  check_impact("edge through edge", edge_edge_impact(stack(a0, a1, b0, b1), stack(a0 + down, a1 + down, b0, b1), 0, 1e-6),
               0.5, 1e-5);
  check_impact("edge through edge, default stop",
               edge_edge_impact(stack(a0, a1, b0, b1), stack(a0 + down, a1 + down, b0, b1), 0), 0.5, 0.1 + 1e-12);
  // Obliquely, and b moving up by 0.5 (t* = 0.4); a's sideways motion keeps the crossing inside both.
  {
    const Vec3 side(0.3, 0.2, -2), up(0, 0, 0.5);
    const double t = edge_edge_impact(stack(a0, a1, b0, b1), stack(a0 + side, a1 + side, b0 + up, b1 + up), 0, 1e-6);
    check_impact("edge through a rising edge, oblique", t, 0.4, 1e-5);
  }
  // Passing beside the other edge's end: no contact.
  {
    const Vec3 shift(0, 2, 0);
    CHECK(edge_edge_impact(stack(a0 + shift, a1 + shift, b0, b1), stack(a0 + shift + down, a1 + shift + down, b0, b1), 0) ==
          kInf);
  }
}

// Grazing motion: no contact where the pair stays apart (asserted with a stop at 1e-6 of the
// starting clearance; the default stop at 0.1 may give a conservative t instead, checked by
// sampling), the exact time where it touches in passing.
void check_grazing_miss(const std::string& what, const Vector12d& start, const Vector12d& end, double xi,
                        double (*impact)(const Vector12d&, const Vector12d&, double, double),
                        double (*squared_distance)(const Vector12d&, Vector12d*, Matrix12d*)) {
  CHECK_MSG(impact(start, end, xi, 1e-6) == kInf, what + ": no contact");
  const double t = impact(start, end, xi, 0.1);
  double closest = kInf;
  for (int k = 0; k <= 4000 && t < kInf; ++k)
    closest = std::min(closest, squared_distance(start + (t * k / 4000) * (end - start), nullptr, nullptr));
  CHECK_MSG(t == kInf || (t <= 1 && closest >= xi * xi), what + ": default stop conservative");
}

void test_ccd_grazing() {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0);
  auto vertex = [&](const Vec3& p) { return stack(p, t0, t1, t2); };
  // Sliding 1e-3 above the face, across all of it, with separation 0 and 5e-4.
  for (double xi : {0.0, 5e-4})
    check_grazing_miss("vertex sliding over the face", vertex(Vec3(-0.5, 0.2, 1e-3)), vertex(Vec3(1.5, 0.2, 1e-3)), xi,
                       vertex_triangle_impact, vertex_triangle);
  // Moving in the triangle's plane onto its edge x = 0 (coplanar: no root of a cubic to find): t* = 0.5.
  check_impact("vertex in the plane onto an edge", vertex_path(Vec3(-1, 0.25, 0), Vec3(1, 0.25, 0), 0, 1e-6), 0.5, 1e-5);
  // Along x + y = 0 in the plane, touching the corner (0,0,0) in passing at t = 0.5.
  check_impact("vertex touching a corner in passing", vertex_path(Vec3(-1, 1, 0), Vec3(1, -1, 0), 0, 1e-6), 0.5, 1e-5);
  // Along x + y = -1e-3: 1e-3 from the edge x = 0 at t = 0.5, 7.07e-4 from the corner at its
  // closest. No contact at separation 0 or 5e-4; at separation 1e-3 contact at t = 0.5.
  const Vec3 p0(-1.001, 1, 0), p1(0.999, -1, 0);
  for (double xi : {0.0, 5e-4})
    check_grazing_miss("vertex passing a corner", vertex(p0), vertex(p1), xi, vertex_triangle_impact, vertex_triangle);
  check_impact("vertex passing a corner within the separation", vertex_path(p0, p1, 1e-3, 1e-6), 0.5, 1e-5);

  // Edges: a sliding along above b, parallel to it and 1e-3 away: no contact.
  const Vec3 a0(0, 0, 1e-3), a1(1, 0, 1e-3), b0(0.5, 0, 0), b1(1.5, 0, 0), along(1, 0, 0);
  check_grazing_miss("edge sliding along a parallel edge", stack(a0, a1, b0, b1), stack(a0 + along, a1 + along, b0, b1),
                     0, edge_edge_impact, edge_edge);
  // Crossing edges 1e-3 apart sliding past each other, and one turning until parallel to the other.
  const Vec3 f0(-1, 0, 1e-3), f1(1, 0, 1e-3), g0(0, -1, 0), g1(0, 1, 0), slide(0.5, 0.5, 0);
  check_grazing_miss("crossing edges sliding", stack(f0, f1, g0, g1), stack(f0 + slide, f1 + slide, g0, g1), 0,
                     edge_edge_impact, edge_edge);
  check_grazing_miss("crossing edge turning parallel", stack(f0, f1, g0, g1),
                     stack(Vec3(0, -1, 1e-3), Vec3(0, 1, 1e-3), g0, g1), 5e-4, edge_edge_impact, edge_edge);
  // Parallel edges closing sideways in their common plane: t* = 0.5 (they meet along a segment).
  const Vec3 c0(0, 1, 0), c1(1, 1, 0), e0(0.5, 0, 0), e1(1.5, 0, 0), sideways(0, -2, 0);
  check_impact("parallel edges closing in their plane",
               edge_edge_impact(stack(c0, c1, e0, e1), stack(c0 + sideways, c1 + sideways, e0, e1), 0, 1e-6), 0.5, 1e-5);
}

void test_ccd_start_at_contact() {
  // On the face, at a corner, within the separation: t = 0 whichever way the vertex goes.
  CHECK(vertex_path(Vec3(0.2, 0.3, 0), Vec3(0.2, 0.3, 1), 0) == 0);
  CHECK(vertex_path(Vec3(0.2, 0.3, 0), Vec3(0.2, 0.3, -1), 0) == 0);
  CHECK(vertex_path(Vec3(0, 0, 0), Vec3(1, 1, 1), 0) == 0);
  CHECK(vertex_path(Vec3(0.2, 0.3, 0.05), Vec3(0.2, 0.3, 1), 0.1) == 0);
  CHECK(vertex_path(Vec3(0.2, 0.3, 0.1), Vec3(0.2, 0.3, -1), 0.1) == 0);
  // Just outside the separation: moving away, no contact; moving in, a t before the pair reaches
  // it (t* = 1e-9 / 1.1), where it is still outside.
  CHECK(vertex_path(Vec3(0.2, 0.3, 0.1 + 1e-9), Vec3(0.2, 0.3, 1), 0.1) == kInf);
  {
    const Vec3 p0(0.2, 0.3, 0.1 + 1e-9), p1(0.2, 0.3, -1);
    const double t = vertex_path(p0, p1, 0.1);
    CHECK(t >= 0 && t <= 1e-9 / 1.1);
    const Vec3 p = p0 + t * (p1 - p0);
    CHECK(point_triangle_squared_distance(p, Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)) >= 0.1 * 0.1);
  }
  // Crossing edges, and edges touching end to end, and edges within the separation.
  const Vec3 a0(-1, 0, 0), a1(1, 0, 0), b0(0, -1, 0), b1(0, 1, 0), up(0, 0, 1);
  CHECK(edge_edge_impact(stack(a0, a1, b0, b1), stack(a0 + up, a1 + up, b0, b1), 0) == 0);
  CHECK(edge_edge_impact(stack(a0, a1, a1, Vec3(2, 1, 0)), stack(a0, a1, a1 + up, Vec3(2, 1, 1)), 0) == 0);
  CHECK(edge_edge_impact(stack(a0, a1, b0 + 0.5 * up, b1 + 0.5 * up), stack(a0, a1, b0 + up, b1 + up), 0.6) == 0);
}

// Random trajectories of four points in the unit box, moving up to 1 in each coordinate: the pair
// never comes closer than the separation before the returned t (4000 samples), and a trajectory
// whose samples come closer before t = 1 has a finite t before that sample. Every second
// trajectory is made to touch at a random time tau (point 0, or edge a's point at a random
// parameter, meets a random point of the other primitive there): t <= tau.
enum class PairKind { VertexTriangle, EdgeEdge };

void test_ccd_random(PairKind kind) {
  const bool vt = kind == PairKind::VertexTriangle;
  auto impact = vt ? vertex_triangle_impact : edge_edge_impact;
  auto squared_distance = vt ? vertex_triangle : edge_edge;
  constexpr int kSamples = 4000;
  int trials = 0, close = 0, touching = 0, violations = 0, misses = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Vector12d start, end;
    for (int i = 0; i < 12; ++i) start[i] = uniform(0, 1);
    for (int i = 0; i < 12; ++i) end[i] = start[i] + uniform(-1, 1);
    double tau = kInf;
    if (trial % 2) {
      tau = uniform(0.2, 0.9);
      const Vector12d at = start + tau * (end - start);
      // The other primitive's point that is met, at tau.
      const Vec3 target = vt ? Vec3(0.2 * point(at, 1) + 0.3 * point(at, 2) + 0.5 * point(at, 3))
                             : Vec3(0.6 * point(at, 2) + 0.4 * point(at, 3));
      // Point 0 at tau such that it (vertex) or a's point at s = 0.3 (edge) is the target.
      const Vec3 p0_at = vt ? target : Vec3((target - 0.3 * point(at, 1)) / 0.7);
      end.segment<3>(0) = point(start, 0) + (p0_at - point(start, 0)) / tau;
    }
    const double xi = trial % 3 == 0 ? 0 : trial % 3 == 1 ? 1e-3 : 0.05;
    const double fraction = trial % 4 < 2 ? 0.1 : 1e-3;
    if (squared_distance(start, nullptr, nullptr) <= xi * xi) continue;
    ++trials;
    const double t = impact(start, end, xi, fraction);
    double first_close = kInf;  // the first sample closer than xi
    for (int k = 0; k <= kSamples; ++k) {
      const double s = double(k) / kSamples;
      if (squared_distance(start + s * (end - start), nullptr, nullptr) < xi * xi) {
        first_close = s;
        break;
      }
    }
    for (int k = 0; k <= kSamples && t < kInf; ++k) {
      const double s = std::min(t, 1.0) * k / kSamples;
      if (std::sqrt(squared_distance(start + s * (end - start), nullptr, nullptr)) < xi * (1 - 1e-12)) ++violations;
    }
    if (first_close < kInf) {
      ++close;
      if (!(t < first_close)) ++misses;
    }
    if (tau < kInf) {
      ++touching;
      if (!(t <= tau)) ++misses;
    }
  }
  const std::string what = std::string("CCD random ") + (vt ? "vertex-triangle" : "edge-edge");
  std::printf("%s: %d trajectories, %d touching at a known time, %d seen within the separation\n", what.c_str(),
              trials, touching, close);
  CHECK_MSG(trials >= 300 && touching >= 150 && close >= 100, what + ": enough trajectories and contacts");
  CHECK_MSG(violations == 0, what + ": " + std::to_string(violations) + " samples before t closer than the separation");
  CHECK_MSG(misses == 0, what + ": " + std::to_string(misses) + " contacts missed or t after them");
}

}  // namespace

int main() {
  test_vertex_triangle_cases();
  test_vertex_triangle_random();
  test_edge_edge_cases();
  test_edge_edge_random();
  test_mollifier();
  test_ccd_known_times();
  test_ccd_grazing();
  test_ccd_start_at_contact();
  test_ccd_random(PairKind::VertexTriangle);
  test_ccd_random(PairKind::EdgeEdge);
  std::printf("worst relative FD error: gradient %.2e, Hessian %.2e\n", worst_gradient, worst_hessian);
  return check::summary("test_pair_contact");
}

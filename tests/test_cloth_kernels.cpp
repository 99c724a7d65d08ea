// Cloth kernels: the triangle membrane (materials/membrane) and the hinge bending energies
// (materials/hinge_bending). Energies vs analytic gradients vs analytic Hessians by central
// differences at many poses, zero energy at rest, rigid invariance, the PSD fix, the rest Hessian's
// null space, the cotangent Gram matrix, the closed forms against SVD/matrix formulas, and the
// dihedral angle's sign convention.
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>

#include "check.hpp"
#include "materials/hinge_bending.hpp"
#include "materials/membrane.hpp"

using namespace hyperqn;
namespace mb = hyperqn::membrane;
namespace hg = hyperqn::hinge;
using mb::Vec9;
using hg::Mat12;
using hg::Vec12;

static const double kPi = 3.14159265358979323846;
static std::mt19937 gen(7);
static double uniform() { return std::uniform_real_distribution<double>(-1, 1)(gen); }
static Mat3 random_matrix() {
  Mat3 A;
  for (int i = 0; i < 9; ++i) A(i % 3, i / 3) = uniform();
  return A;
}
static Mat3 rotation(double angle, const Vec3& axis) { return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(); }

// Largest FD errors seen, printed at the end (for the report).
static double worst_grad = 0, worst_hess = 0;

// ||fd - exact||_inf / max(1, ||exact||_inf): relative for large values, absolute below 1.
template <class V>
static double rel_err(const V& fd, const V& exact) {
  return (fd - exact).cwiseAbs().maxCoeff() / std::max(1.0, exact.cwiseAbs().maxCoeff());
}

// Central differences of E against g, and of g against H, at x with step h; plus symmetry and the
// PSD fix. The callbacks are the kernels with their parameters bound.
template <int N>
static void check_derivatives(const std::string& name, const Eigen::Matrix<double, N, 1>& x, double h,
                              const std::function<double(const Eigen::Matrix<double, N, 1>&)>& E,
                              const std::function<double(const Eigen::Matrix<double, N, 1>&, Eigen::Matrix<double, N, 1>&)>& EG,
                              const std::function<Eigen::Matrix<double, N, N>(const Eigen::Matrix<double, N, 1>&, bool)>& H) {
  using V = Eigen::Matrix<double, N, 1>;
  using M = Eigen::Matrix<double, N, N>;
  V g;
  const double e = EG(x, g);
  CHECK_MSG(std::fabs(e - E(x)) <= 1e-14 * std::max(1.0, std::fabs(e)), name + ": energy_gradient's energy = energy");
  const M K = H(x, false);
  V fd_g;
  M fd_K;
  for (int i = 0; i < N; ++i) {
    V xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    fd_g[i] = (E(xp) - E(xm)) / (2 * h);
    V gp, gm;
    EG(xp, gp);
    EG(xm, gm);
    fd_K.col(i) = (gp - gm) / (2 * h);
  }
  const double eg = rel_err(fd_g, g), eK = rel_err(fd_K, K);
  worst_grad = std::max(worst_grad, eg);
  worst_hess = std::max(worst_hess, eK);
  std::printf("  %-40s |g| %9.3e grad err %8.2e  |H| %9.3e hess err %8.2e\n", name.c_str(), g.cwiseAbs().maxCoeff(),
              eg, K.cwiseAbs().maxCoeff(), eK);
  CHECK_MSG(g.allFinite() && K.allFinite(), name + ": finite");
  CHECK_MSG(eg < 1e-6, name + ": gradient vs FD " + std::to_string(eg));
  CHECK_MSG(eK < 1e-5, name + ": Hessian vs FD " + std::to_string(eK));
  CHECK_MSG((K - K.transpose()).norm() <= 1e-12 * std::max(1.0, K.norm()), name + ": Hessian symmetric");
  const M Kpsd = H(x, true);
  const double min_eig = Eigen::SelfAdjointEigenSolver<M>(Kpsd).eigenvalues().minCoeff();
  CHECK_MSG(min_eig >= -1e-10 * std::max(1.0, Kpsd.norm()), name + ": PSD-fixed Hessian has eigenvalue " + std::to_string(min_eig));
  // The fix only acts on negative eigenvalues: an already PSD Hessian is unchanged.
  if (Eigen::SelfAdjointEigenSolver<M>(K).eigenvalues().minCoeff() >= 0)
    CHECK_MSG((Kpsd - K).norm() <= 1e-10 * std::max(1.0, K.norm()), name + ": PSD fix leaves a PSD Hessian alone");
}

// ---------------------------------------------------------------- membrane

static const char* model_name(mb::Model m) {
  return m == mb::Model::stvk ? "stvk" : m == mb::Model::corotated ? "corotated" : "neohookean";
}

static const double mu = 1.3, lambda = 2.1;

struct Triangle {
  Vec3 X[3];
  mb::TriangleRest r;
  Vec9 rest_x() const {
    Vec9 x;
    x << X[0], X[1], X[2];
    return x;
  }
  // The pose x_i = A X_i + t.
  Vec9 affine(const Mat3& A, const Vec3& t) const {
    Vec9 x;
    for (int i = 0; i < 3; ++i) x.segment<3>(3 * i) = A * X[i] + t;
    return x;
  }
  // A pose with the given 3x2 deformation gradient (x0 = 0).
  Vec9 with_F(const mb::Mat3x2& F) const {
    const Eigen::Matrix2d Dm = r.Dm_inv.inverse();
    Vec9 x;
    x << Vec3::Zero(), F * Dm.col(0), F * Dm.col(1);
    return x;
  }
};

static Triangle make_triangle() {
  Triangle t;
  t.X[0] = Vec3(0.1, -0.2, 0.3);
  t.X[1] = t.X[0] + Vec3(1.1, 0.2, 0.1);
  t.X[2] = t.X[0] + Vec3(0.3, 0.9, -0.2);
  t.r = mb::rest(t.X[0], t.X[1], t.X[2]);
  return t;
}

static void check_membrane_pose(mb::Model m, const Triangle& t, const std::string& pose, const Vec9& x, double h) {
  check_derivatives<9>(
      std::string(model_name(m)) + " " + pose, x, h, [&](const Vec9& y) { return mb::energy(m, mu, lambda, t.r, y); },
      [&](const Vec9& y, Vec9& g) { return mb::energy_gradient(m, mu, lambda, t.r, y, g); },
      [&](const Vec9& y, bool psd) { return mb::hessian(m, mu, lambda, t.r, y, psd); });
}

static void test_membrane_rest_data(const Triangle& t) {
  const Vec3 E1 = t.X[1] - t.X[0], E2 = t.X[2] - t.X[0];
  CHECK_NEAR(t.r.area, 0.5 * E1.cross(E2).norm(), 1e-15);
  // Rest F has orthonormal columns.
  const mb::Mat3x2 F = mb::deformation_gradient(t.r, t.rest_x());
  CHECK_NEAR((F.transpose() * F - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-14);
  CHECK_NEAR(mb::max_stretch(t.r, t.rest_x()), 1.0, 1e-14);
  bool threw = false;
  try {
    mb::rest(t.X[0], t.X[1], t.X[0] + 2.0 * E1);  // collinear
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK_MSG(threw, "a collinear rest triangle throws");
  CHECK_NEAR(mb::laplacian_weight(mb::Model::corotated, mu, lambda), 2 * mu + lambda, 0.0);
}

static void test_basis_gram(const Triangle& t) {
  const std::array<double, 9> a = mb::basis_gram(t.r);
  Mat3 K;
  for (int i = 0; i < 9; ++i) K(i / 3, i % 3) = a[i];
  CHECK_NEAR(K.rowwise().sum().cwiseAbs().maxCoeff(), 0.0, 1e-14);
  CHECK_NEAR((K - K.transpose()).norm(), 0.0, 1e-14);
  const Vec3 ev = Eigen::SelfAdjointEigenSolver<Mat3>(K).eigenvalues();
  CHECK_MSG(ev.minCoeff() >= -1e-14 && ev(1) > 1e-3, "basis_gram is PSD with rank 2");
  // f^T K f = A |grad f|^2 for a linear field f = c . X (here |grad f| = |c projected on the plane|).
  const Vec3 c(0.3, -1.2, 0.7);
  const Vec3 nhat = (t.X[1] - t.X[0]).cross(t.X[2] - t.X[0]).normalized();
  const Vec3 f(c.dot(t.X[0]), c.dot(t.X[1]), c.dot(t.X[2]));
  const double grad2 = (c - c.dot(nhat) * nhat).squaredNorm();
  CHECK_NEAR(f.dot(K * f), t.r.area * grad2, 1e-13);
  // Cotangent form: K_01 = -cot(angle at x2)/2.
  const Vec3 u = t.X[0] - t.X[2], v = t.X[1] - t.X[2];
  CHECK_NEAR(K(0, 1), -0.5 * u.dot(v) / u.cross(v).norm(), 1e-14);
}

static void test_membrane_closed_forms(const Triangle& t) {
  double err_corot = 0, err_stvk = 0, err_neo = 0, err_stretch = 0;
  for (int trial = 0; trial < 50; ++trial) {
    mb::Mat3x2 F;
    for (int i = 0; i < 6; ++i) F(i % 3, i / 3) = 1.5 * uniform();
    const Vec9 x = t.with_F(F);
    Eigen::JacobiSVD<mb::Mat3x2> svd(F);
    const Eigen::Vector2d s = svd.singularValues();
    const double corot = mu * ((s(0) - 1) * (s(0) - 1) + (s(1) - 1) * (s(1) - 1)) + 0.5 * lambda * std::pow(s.sum() - 2, 2);
    const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
    const double stvk = mu * (E * E).trace() + 0.5 * lambda * E.trace() * E.trace();
    const double J = std::sqrt((F.transpose() * F).determinant());
    const double neo = 0.5 * mu * (F.squaredNorm() - 2) - mu * std::log(J) + 0.5 * lambda * std::log(J) * std::log(J);
    auto rel = [](double a, double b) { return std::fabs(a - b) / std::max(1.0, std::fabs(b)); };
    err_corot = std::max(err_corot, rel(mb::energy(mb::Model::corotated, mu, lambda, t.r, x) / t.r.area, corot));
    err_stvk = std::max(err_stvk, rel(mb::energy(mb::Model::stvk, mu, lambda, t.r, x) / t.r.area, stvk));
    err_neo = std::max(err_neo, rel(mb::energy(mb::Model::neohookean, mu, lambda, t.r, x) / t.r.area, neo));
    err_stretch = std::max(err_stretch, rel(mb::max_stretch(t.r, x), s(0)));
  }
  CHECK_MSG(err_corot < 1e-12, "corotated psi vs SVD formula " + std::to_string(err_corot));
  CHECK_MSG(err_stvk < 1e-12, "stvk psi vs matrix formula " + std::to_string(err_stvk));
  CHECK_MSG(err_neo < 1e-12, "neohookean psi vs det C formula " + std::to_string(err_neo));
  CHECK_MSG(err_stretch < 1e-12, "max_stretch vs SVD " + std::to_string(err_stretch));
}

static void test_membrane_model(mb::Model m, const Triangle& t) {
  const std::string name = model_name(m);
  const Vec9 X = t.rest_x();
  // Zero energy and gradient at rest, and under a rigid motion of the rest pose.
  const Mat3 R = rotation(2.0, Vec3(1, -2, 0.5));
  const Vec3 trans(0.4, -1.1, 2.0);
  Vec9 g;
  for (const Vec9& x : {X, t.affine(R, trans)}) {
    CHECK_NEAR(mb::energy_gradient(m, mu, lambda, t.r, x, g), 0.0, 1e-13);
    CHECK_MSG(g.norm() < 1e-13, name + ": zero gradient at rest, |g| = " + std::to_string(g.norm()));
  }
  // Rest Hessian: rank 3 (9 dofs - 3 translations - 3 rotations; out-of-plane motions of a single
  // triangle are rigid to first order).
  {
    const Mat9 H = mb::hessian(m, mu, lambda, t.r, X, false);
    const Eigen::Matrix<double, 9, 1> ev = Eigen::SelfAdjointEigenSolver<Mat9>(H).eigenvalues();
    int zero = 0, positive = 0;
    for (int i = 0; i < 9; ++i) {
      if (std::fabs(ev(i)) < 1e-10 * ev.maxCoeff()) ++zero;
      if (ev(i) > 1e-3 * ev.maxCoeff()) ++positive;
    }
    CHECK_MSG(zero == 6 && positive == 3, name + ": rest Hessian has 6 zero and 3 positive eigenvalues");
    // All three models linearize to the same plane-stress elasticity.
    const Mat9 H_stvk = mb::hessian(mb::Model::stvk, mu, lambda, t.r, X, false);
    CHECK_MSG((H - H_stvk).norm() < 1e-12 * H.norm(), name + ": rest Hessian = StVK's");
  }
  // Rigid invariance at a general pose: same energy, rotated gradient.
  {
    const Vec9 x = t.affine(Mat3::Identity() + 0.3 * random_matrix(), Vec3(0.1, 0.2, 0.3));
    Vec9 y, gx, gy;
    for (int i = 0; i < 3; ++i) y.segment<3>(3 * i) = R * x.segment<3>(3 * i) + trans;
    const double ex = mb::energy_gradient(m, mu, lambda, t.r, x, gx);
    const double ey = mb::energy_gradient(m, mu, lambda, t.r, y, gy);
    CHECK_MSG(std::fabs(ex - ey) <= 1e-13 * std::max(1.0, ex), name + ": energy rigid-invariant");
    double err = 0;
    for (int i = 0; i < 3; ++i) err = std::max(err, (R * gx.segment<3>(3 * i) - gy.segment<3>(3 * i)).norm());
    CHECK_MSG(err <= 1e-12 * std::max(1.0, gx.norm()), name + ": gradient rotates with the pose");
  }
  // Poses for the finite differences.
  const Vec3 t1 = (t.X[1] - t.X[0]).normalized();
  const Vec3 nhat = (t.X[1] - t.X[0]).cross(t.X[2] - t.X[0]).normalized();
  const Vec3 t2 = nhat.cross(t1);
  const Vec3 d = (0.6 * t1 + 0.8 * t2).normalized();  // an in-plane direction
  const double h = 1e-6;
  check_membrane_pose(m, t, "rest", X, h);
  check_membrane_pose(m, t, "stretched 1.5x", t.affine(Mat3::Identity() + 0.5 * d * d.transpose(), trans), h);
  check_membrane_pose(m, t, "sheared", t.affine(Mat3::Identity() + 0.4 * t1 * t2.transpose(), trans), h);
  check_membrane_pose(m, t, "compressed", t.affine(0.6 * Mat3::Identity() + 0.05 * random_matrix(), trans), h);
  check_membrane_pose(m, t, "general", t.affine(Mat3::Identity() + 0.4 * random_matrix(), trans), h);
  check_membrane_pose(m, t, "rotated 110deg + stretched",
                      t.affine(rotation(1.9, Vec3(0.2, 1, 0.3)) * (Mat3::Identity() + 0.3 * t1 * t1.transpose()), trans), h);
  {
    // x2 squashed onto the edge x0 x1 to 1e-3 of its height (J = 1e-3).
    Vec9 x = X;
    const Vec3 E2 = t.X[2] - t.X[0];
    const Vec3 foot = t.X[0] + E2.dot(t1) * t1;
    x.segment<3>(6) = foot + 1e-3 * (t.X[2] - foot);
    check_membrane_pose(m, t, "squashed to 1e-3 height", x, 1e-8);
  }
  // A collapsed triangle (x2 on the edge line, J = 0).
  {
    Vec9 x = X;
    x.segment<3>(6) = t.X[0] + 0.4 * (t.X[1] - t.X[0]);
    const double e = mb::energy_gradient(m, mu, lambda, t.r, x, g);
    const Mat9 H = mb::hessian(m, mu, lambda, t.r, x, true);
    CHECK_MSG(!std::isnan(e) && g.allFinite() && H.allFinite(), name + ": collapsed triangle: no NaN, finite gradient and Hessian");
    if (m == mb::Model::neohookean)
      CHECK_MSG(e == std::numeric_limits<double>::infinity() &&
                    mb::energy(m, mu, lambda, t.r, x) == std::numeric_limits<double>::infinity(),
                "neohookean: energy +inf at J = 0");
    else
      CHECK_MSG(std::isfinite(e), name + ": finite energy at J = 0");
    // StVK depends on J^2 = |n|^2/(4A^2) only, smooth through the collapse: exact derivatives there.
    if (m == mb::Model::stvk) check_membrane_pose(m, t, "collapsed (J = 0)", x, 1e-6);
  }
}

// ---------------------------------------------------------------- hinges

static Vec12 stack(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Vec12 x;
  x << a, b, c, d;
  return x;
}
static Vec3 vtx(const Vec12& x, int i) { return x.segment<3>(3 * i); }
static Vec12 transform(const Vec12& x, const Mat3& A, const Vec3& t) {
  Vec12 y;
  for (int i = 0; i < 4; ++i) y.segment<3>(3 * i) = A * vtx(x, i) + t;
  return y;
}

// A hinge with edge x0 x1 along the x axis, x2 in the (x, +y) half plane, and x3 the flat
// position (p3, -h3, 0) rotated about the edge by phi (towards +z = n1 for phi > 0): theta = -phi.
static Vec12 folded_hinge(double phi) {
  return stack(Vec3(0, 0, 0), Vec3(1.2, 0, 0), Vec3(0.4, 0.9, 0), Vec3(0.7, -0.8 * std::cos(phi), 0.8 * std::sin(phi)));
}

static const Mat3 kPlace = rotation(0.8, Vec3(1, 1, -0.3));  // a generic placement in space
static const Vec3 kShift(0.3, -0.5, 1.2);

static void check_hinge_pose(const hg::HingeRest& r, double k, const std::string& pose, const Vec12& x, double h) {
  check_derivatives<12>(
      "dihedral " + pose, x, h, [&](const Vec12& y) { return hg::dihedral_energy(k, r, y); },
      [&](const Vec12& y, Vec12& g) { return hg::dihedral_energy_gradient(k, r, y, g); },
      [&](const Vec12& y, bool psd) { return hg::dihedral_hessian(k, r, y, psd); });
  // The angle's own gradient (also where theta = theta0, where the energy's gradient vanishes).
  Vec12 dtheta, fd;
  hg::dihedral_angle_gradient(x, dtheta);
  for (int i = 0; i < 12; ++i) {
    Vec12 xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    fd[i] = (hg::dihedral_angle(xp) - hg::dihedral_angle(xm)) / (2 * h);
  }
  const double err = rel_err(fd, dtheta);
  worst_grad = std::max(worst_grad, err);
  CHECK_MSG(err < 1e-6, "dihedral " + pose + ": angle gradient vs FD " + std::to_string(err));
}

static void test_dihedral() {
  const double k = 0.7;
  // Sign convention (hinge_bending.hpp): lifting x3 towards n1 by 90 degrees gives -pi/2.
  {
    const Vec12 x = stack(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(0.5, 0, 1));
    CHECK_NEAR(hg::dihedral_angle(x), -kPi / 2, 1e-15);
    const Vec12 y = stack(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 1, 0), Vec3(0.5, 0, -1));
    CHECK_NEAR(hg::dihedral_angle(y), kPi / 2, 1e-15);
    CHECK_NEAR(hg::dihedral_angle(transform(x, kPlace, kShift)), -kPi / 2, 1e-14);
    for (double phi : {0.0, 0.3, -1.0, 2.2, 3.0, -3.1})
      CHECK_NEAR(hg::dihedral_angle(transform(folded_hinge(phi), kPlace, kShift)), -phi, 1e-13);
  }
  // Flat rest hinge: theta0 = 0; the weight 3 |e|^2 / (A1 + A2).
  const Vec12 flat = transform(folded_hinge(0), kPlace, kShift);
  const hg::HingeRest r = hg::hinge_rest(vtx(flat, 0), vtx(flat, 1), vtx(flat, 2), vtx(flat, 3));
  CHECK_NEAR(r.theta0, 0.0, 1e-14);
  CHECK_NEAR(r.weight, 3 * 1.44 / (0.5 * 1.2 * 0.9 + 0.5 * 1.2 * 0.8), 1e-13);
  // Curved rest hinge: theta0 from the rest pose; zero energy and gradient there and after a rigid motion.
  const Vec12 curved = transform(folded_hinge(0.6), kPlace, kShift);
  const hg::HingeRest rc = hg::hinge_rest(vtx(curved, 0), vtx(curved, 1), vtx(curved, 2), vtx(curved, 3));
  CHECK_NEAR(rc.theta0, -0.6, 1e-13);
  const Mat3 R = rotation(2.5, Vec3(-0.3, 1, 2));
  const Vec3 t(1, 2, -3);
  Vec12 g;
  for (const auto& [rest, x] : {std::make_pair(r, flat), std::make_pair(r, transform(flat, R, t)),
                               std::make_pair(rc, curved), std::make_pair(rc, transform(curved, R, t))}) {
    CHECK_NEAR(hg::dihedral_energy_gradient(k, rest, x, g), 0.0, 1e-24);
    CHECK_MSG(g.norm() < 1e-12, "dihedral: zero gradient at rest, |g| = " + std::to_string(g.norm()));
  }
  // Rigid invariance at a general pose.
  {
    Vec12 x = transform(folded_hinge(1.3), kPlace, kShift);
    for (int i = 0; i < 12; ++i) x[i] += 0.1 * uniform();
    const Vec12 y = transform(x, R, t);
    Vec12 gx, gy;
    const double ex = hg::dihedral_energy_gradient(k, rc, x, gx), ey = hg::dihedral_energy_gradient(k, rc, y, gy);
    CHECK_MSG(std::fabs(ex - ey) <= 1e-13 * std::max(1.0, ex), "dihedral: energy rigid-invariant");
    double err = 0;
    for (int i = 0; i < 4; ++i) err = std::max(err, (R * gx.segment<3>(3 * i) - gy.segment<3>(3 * i)).norm());
    CHECK_MSG(err <= 1e-12 * std::max(1.0, gx.norm()), "dihedral: gradient rotates with the pose");
  }
  // Wrapping: theta0 = 3.0 and theta = -3.0 are 2 pi - 6 apart, not 6.
  {
    const hg::HingeRest rw{3.0, 1.0};
    const Vec12 x = folded_hinge(3.0);  // theta = -3
    CHECK_NEAR(hg::dihedral_energy(1.0, rw, x), std::pow(2 * kPi - 6.0, 2), 1e-12);
  }
  // Poses (each with a small generic perturbation so no coordinate is special).
  auto perturbed = [](Vec12 x, double eps) {
    for (int i = 0; i < 12; ++i) x[i] += eps * uniform();
    return x;
  };
  const Vec3 ex = kPlace * Vec3(1, 0, 0), ey = kPlace * Vec3(0, 1, 0);
  const double h = 1e-6;
  check_hinge_pose(r, k, "flat rest", flat, h);
  check_hinge_pose(rc, k, "curved rest", curved, h);
  check_hinge_pose(r, k, "stretched 1.5x, folded 0.5",
                   perturbed(transform(folded_hinge(0.5), kPlace * (Mat3::Identity() + 0.5 * Vec3(1, 0, 0) * Vec3(1, 0, 0).transpose()), kShift), 0.02), h);
  check_hinge_pose(r, k, "sheared, folded -0.8",
                   perturbed(transform(folded_hinge(-0.8), (Mat3::Identity() + 0.4 * ex * ey.transpose()) * kPlace, kShift), 0.02), h);
  check_hinge_pose(rc, k, "compressed, folded 1.0",
                   perturbed(transform(folded_hinge(1.0), 0.6 * kPlace, kShift), 0.02), h);
  check_hinge_pose(r, k, "general", perturbed(transform(folded_hinge(0.4), kPlace, kShift), 0.2), h);
  check_hinge_pose(r, k, "folded past 90 (theta ~ 2.2)", perturbed(transform(folded_hinge(-2.2), kPlace, kShift), 0.01), h);
  check_hinge_pose(rc, k, "folded -2.2, curved rest", perturbed(transform(folded_hinge(2.2), kPlace, kShift), 0.01), h);
  check_hinge_pose(r, k, "almost flat-folded (theta ~ 3.0)", perturbed(transform(folded_hinge(-3.0), kPlace, kShift), 0.01), h);
  {
    // Wing 1 squashed to 1e-3 of its height (x2 almost on the edge line), folded 0.7.
    Vec12 x = folded_hinge(0.7);
    x.segment<3>(6) = Vec3(0.4, 0.9e-3, 0.0);
    check_hinge_pose(r, k, "squashed wing (1e-3 height)", transform(x, kPlace, kShift), 1e-9);
  }
  // Degenerate wing (x2 on the edge line) and collapsed edge: finite.
  {
    Vec12 x = folded_hinge(0.7);
    x.segment<3>(6) = Vec3(0.4, 0, 0);
    const double e = hg::dihedral_energy_gradient(k, r, x, g);
    const Mat12 H = hg::dihedral_hessian(k, r, x, true);
    CHECK_MSG(std::isfinite(e) && g.allFinite() && H.allFinite(), "dihedral: degenerate wing stays finite");
    Vec12 y = folded_hinge(0.7);
    y.segment<3>(3) = y.segment<3>(0);
    const double ey2 = hg::dihedral_energy_gradient(k, r, y, g);
    CHECK_MSG(std::isfinite(ey2) && g.allFinite() && hg::dihedral_hessian(k, r, y, true).allFinite(),
              "dihedral: collapsed edge stays finite");
  }
  bool threw = false;
  try {
    hg::hinge_rest(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(0.5, -1, 0));
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK_MSG(threw, "dihedral: a degenerate rest triangle throws");
}

static void test_quadratic() {
  const double k = 0.9;
  const Vec12 flat = transform(folded_hinge(0), kPlace, kShift);
  const std::array<double, 4> w = hg::quadratic_weights(vtx(flat, 0), vtx(flat, 1), vtx(flat, 2), vtx(flat, 3));
  const double c = hg::quadratic_coefficient(vtx(flat, 0), vtx(flat, 1), vtx(flat, 2), vtx(flat, 3));
  CHECK_NEAR(c, 3.0 / (0.5 * 1.2 * 0.9 + 0.5 * 1.2 * 0.8), 1e-13);
  CHECK_NEAR(w[0] + w[1] + w[2] + w[3], 0.0, 1e-14);
  // Q annihilates every affine map of the flat rest hinge (rigid motions included).
  Vec12 g;
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Mat3 A = trial == 0 ? rotation(1.0, Vec3(1, 2, 3)) : Mat3(2.0 * random_matrix());
    const Vec12 x = transform(flat, A, Vec3(uniform(), uniform(), uniform()));
    const double e = hg::quadratic_energy_gradient(k, w, c, x, g);
    worst = std::max({worst, e, g.norm()});
  }
  CHECK_MSG(worst < 1e-12, "quadratic: zero energy and gradient under affine maps of a flat hinge, worst " + std::to_string(worst));
  // Scale of w (the cotangent normalization): rotating only x3 by phi about the edge moves it by
  // 2 h3 sin(phi/2) and w3 = -|e|/h3, so E = 1/2 k 3 |e|^2/(A1 + A2) (2 sin(phi/2))^2 -- half the
  // dihedral energy k weight phi^2 for small phi (same k).
  const hg::HingeRest r = hg::hinge_rest(vtx(flat, 0), vtx(flat, 1), vtx(flat, 2), vtx(flat, 3));
  for (double phi : {1e-3, 0.5, 2.0}) {
    const Vec12 x = transform(folded_hinge(phi), kPlace, kShift);
    CHECK_NEAR(hg::quadratic_energy(k, w, c, x), 0.5 * k * r.weight * std::pow(2 * std::sin(0.5 * phi), 2), 1e-13);
  }
  // A curved rest hinge is not at zero energy in this model (it assumes a flat rest state).
  {
    const Vec12 curved = folded_hinge(0.6);
    const std::array<double, 4> wc = hg::quadratic_weights(vtx(curved, 0), vtx(curved, 1), vtx(curved, 2), vtx(curved, 3));
    const double cc = hg::quadratic_coefficient(vtx(curved, 0), vtx(curved, 1), vtx(curved, 2), vtx(curved, 3));
    CHECK_MSG(hg::quadratic_energy(k, wc, cc, curved) > 1e-3, "quadratic: a curved rest hinge has energy at rest");
  }
  // Derivatives (E is quadratic: FD is exact up to roundoff) and rigid invariance.
  const Mat3 R = rotation(2.5, Vec3(-0.3, 1, 2));
  auto check = [&](const std::string& pose, const Vec12& x) {
    check_derivatives<12>(
        "quadratic " + pose, x, 1e-5, [&](const Vec12& y) { return hg::quadratic_energy(k, w, c, y); },
        [&](const Vec12& y, Vec12& gy) { return hg::quadratic_energy_gradient(k, w, c, y, gy); },
        [&](const Vec12&, bool) { return hg::quadratic_hessian(k, w, c); });
    Vec12 gx, gy;
    const double ex = hg::quadratic_energy_gradient(k, w, c, x, gx);
    const double ey = hg::quadratic_energy_gradient(k, w, c, transform(x, R, Vec3(1, 2, 3)), gy);
    CHECK_MSG(std::fabs(ex - ey) <= 1e-12 * std::max(1.0, ex), "quadratic " + pose + ": energy rigid-invariant");
    double err = 0;
    for (int i = 0; i < 4; ++i) err = std::max(err, (R * gx.segment<3>(3 * i) - gy.segment<3>(3 * i)).norm());
    CHECK_MSG(err <= 1e-12 * std::max(1.0, gx.norm()), "quadratic " + pose + ": gradient rotates with the pose");
  };
  check("flat rest", flat);
  check("folded past 90 (theta ~ 2.2)", transform(folded_hinge(-2.2), kPlace, kShift));
  check("almost flat-folded (theta ~ 3.0)", transform(folded_hinge(3.0), kPlace, kShift));
  Vec12 x = transform(folded_hinge(0.9), kPlace * (Mat3::Identity() + 0.5 * random_matrix()), kShift);
  check("general", x);
  const Eigen::Matrix<double, 12, 1> ev = Eigen::SelfAdjointEigenSolver<Mat12>(hg::quadratic_hessian(k, w, c)).eigenvalues();
  CHECK_MSG(ev.minCoeff() >= -1e-12 && std::fabs(ev(8)) < 1e-12 && ev(9) > 1e-3, "quadratic: Hessian PSD with rank 3");
  // The weights are Bergou's cotangent formula: at a symmetric rest hinge (a square split along its
  // diagonal) all four angles at x0, x1 are 45 degrees: w = (2, 2, -2, -2).
  const std::array<double, 4> ws = hg::quadratic_weights(Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0), Vec3(1, 0, 0));
  CHECK_NEAR(ws[0], 2.0, 1e-14);
  CHECK_NEAR(ws[1], 2.0, 1e-14);
  CHECK_NEAR(ws[2], -2.0, 1e-14);
  CHECK_NEAR(ws[3], -2.0, 1e-14);
}

int main() {
  const Triangle t = make_triangle();
  test_membrane_rest_data(t);
  test_basis_gram(t);
  test_membrane_closed_forms(t);
  for (mb::Model m : {mb::Model::stvk, mb::Model::corotated, mb::Model::neohookean}) test_membrane_model(m, t);
  test_dihedral();
  test_quadratic();
  std::printf("worst FD error: gradient %.2e, Hessian %.2e\n", worst_grad, worst_hess);
  return check::summary("test_cloth_kernels");
}

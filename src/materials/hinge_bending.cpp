#include "materials/hinge_bending.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "materials/triangle_geometry.hpp"

namespace hyperqn {
namespace hinge {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Below this fraction of the edge length a wing's height (|n_i| / |e|) is floored, so the angle's
// derivatives (~ 1/height) stay finite for a degenerate triangle, as spring.hpp's kTinyLength.
constexpr double kTinyHeight = 1e-12;
// The edge length is floored at kTinyHeight times the hinge's size too (a collapsed edge: the angle
// is meaningless there, kept finite); a hinge collapsed to a point has theta = 0 and no derivatives.

Vec3 vertex(const Vec12& x, int i) { return x.segment<3>(3 * i); }

void check_triangle(const Vec3& a, const Vec3& b, const Vec3& c, const char* which) {
  double area;
  if (!proper_rest_triangle(a, b, c, &area))
    throw std::invalid_argument(std::string("degenerate rest hinge: triangle ") + which + " has area " +
                                std::to_string(area));
}

// Interior angle's cotangent at a, in the triangle (a, b, c).
double cot_at(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = b - a, v = c - a;
  return u.dot(v) / u.cross(v).norm();
}

void rest_areas(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3, double& A1, double& A2) {
  check_triangle(X0, X1, X2, "1 (x0, x1, x2)");
  check_triangle(X1, X0, X3, "2 (x1, x0, x3)");
  A1 = 0.5 * (X1 - X0).cross(X2 - X0).norm();
  A2 = 0.5 * (X0 - X1).cross(X3 - X1).norm();
}

// theta - theta0 wrapped into (-pi, pi] (both are in (-pi, pi], so one turn suffices).
double wrapped(double d) {
  if (d > kPi) return d - 2 * kPi;
  if (d <= -kPi) return d + 2 * kPi;
  return d;
}

// The angle, its gradient, and (if H) its Hessian. With e = x1 - x0 and t_i the parameter of
// x_i's projection on the edge line (0 at x0, 1 at x1), the gradient (Bridson, Marino, Fedkiw 2003)
// is: dtheta/dx2 = -|e| n1/|n1|^2 (a unit move of x2 along n1/|n1| turns its wing by -1/h2 radians,
// h2 = |n1|/|e| its height over the edge),
// dtheta/dx3 = -|e| n2/|n2|^2, and x0, x1 take minus the lever-rule shares of those:
// dtheta/dx0 = -(1 - t2) G2 - (1 - t3) G3, dtheta/dx1 = -t2 G2 - t3 G3. The Hessian is the exact
// Jacobian of these expressions (product and chain rule on e, n_i, |n_i|^2, t_i).
double angle(const Vec12& x, Vec12* g, Mat12* H) {
  const Vec3 x0 = vertex(x, 0), x1 = vertex(x, 1), x2 = vertex(x, 2), x3 = vertex(x, 3);
  const Vec3 e = x1 - x0, a = x2 - x0, c = x3 - x0, b = x3 - x1;
  const Vec3 n1 = e.cross(a), n2 = b.cross(e);
  const double size2 = std::max({e.squaredNorm(), a.squaredNorm(), c.squaredNorm()});
  if (!(size2 > 0)) {  // all four vertices at one point
    if (g) g->setZero();
    if (H) H->setZero();
    return 0.0;
  }
  const double ee_raw = e.squaredNorm();
  const double ee_floor = kTinyHeight * kTinyHeight * size2;
  const bool e_floored = !(ee_raw > ee_floor);
  const double ee = e_floored ? ee_floor : ee_raw;
  const double el = std::sqrt(ee);
  const double theta = std::atan2(n1.cross(n2).dot(e) / el, n1.dot(n2));
  if (!g) return theta;

  const double q_floor = std::pow(kTinyHeight * ee, 2);
  const bool q1_floored = !(n1.squaredNorm() > q_floor), q2_floored = !(n2.squaredNorm() > q_floor);
  const double q1 = q1_floored ? q_floor : n1.squaredNorm();
  const double q2 = q2_floored ? q_floor : n2.squaredNorm();
  const double t2 = a.dot(e) / ee, t3 = c.dot(e) / ee;
  const Vec3 G2 = -el / q1 * n1, G3 = -el / q2 * n2;
  g->segment<3>(0) = -(1 - t2) * G2 - (1 - t3) * G3;
  g->segment<3>(3) = -t2 * G2 - t3 * G3;
  g->segment<3>(6) = G2;
  g->segment<3>(9) = G3;
  if (!H) return theta;

  using Jac = Eigen::Matrix<double, 3, 12>;
  using Row = Eigen::Matrix<double, 1, 12>;
  const Mat3 I = Mat3::Identity();
  Jac de = Jac::Zero(), da = Jac::Zero(), dc = Jac::Zero(), db = Jac::Zero();
  de.block<3, 3>(0, 0) = -I, de.block<3, 3>(0, 3) = I;
  da.block<3, 3>(0, 0) = -I, da.block<3, 3>(0, 6) = I;
  dc.block<3, 3>(0, 0) = -I, dc.block<3, 3>(0, 9) = I;
  db.block<3, 3>(0, 3) = -I, db.block<3, 3>(0, 9) = I;
  const Jac dn1 = -cross_matrix(a) * de + cross_matrix(e) * da;  // n1 = e x a
  const Jac dn2 = -cross_matrix(e) * db + cross_matrix(b) * de;  // n2 = b x e
  const Row eT_de = e.transpose() * de;
  const Row del = e_floored ? Row::Zero() : Row(eT_de / el);
  const Row dee = e_floored ? Row::Zero() : Row(2 * eT_de);
  const Row dq1 = q1_floored ? Row::Zero() : Row(2 * n1.transpose() * dn1);
  const Row dq2 = q2_floored ? Row::Zero() : Row(2 * n2.transpose() * dn2);
  const Row dt2 = (e.transpose() * da + a.transpose() * de) / ee - (a.dot(e) / (ee * ee)) * dee;
  const Row dt3 = (e.transpose() * dc + c.transpose() * de) / ee - (c.dot(e) / (ee * ee)) * dee;
  const Jac dG2 = -(n1 / q1) * del - (el / q1) * dn1 + (el / (q1 * q1)) * n1 * dq1;
  const Jac dG3 = -(n2 / q2) * del - (el / q2) * dn2 + (el / (q2 * q2)) * n2 * dq2;
  H->block<3, 12>(0, 0) = -(1 - t2) * dG2 + G2 * dt2 - (1 - t3) * dG3 + G3 * dt3;
  H->block<3, 12>(3, 0) = -t2 * dG2 - G2 * dt2 - t3 * dG3 - G3 * dt3;
  H->block<3, 12>(6, 0) = dG2;
  H->block<3, 12>(9, 0) = dG3;
  *H = 0.5 * (*H + H->transpose()).eval();  // symmetric up to roundoff
  return theta;
}

}  // namespace

// ---- Quadratic bending ----

std::array<double, 4> quadratic_weights(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3) {
  double A1, A2;
  rest_areas(X0, X1, X2, X3, A1, A2);
  const double a1 = cot_at(X0, X1, X2), a2 = cot_at(X0, X1, X3);  // at x0
  const double b1 = cot_at(X1, X0, X2), b2 = cot_at(X1, X0, X3);  // at x1
  return {b1 + b2, a1 + a2, -a1 - b1, -a2 - b2};
}

double quadratic_coefficient(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3) {
  double A1, A2;
  rest_areas(X0, X1, X2, X3, A1, A2);
  return 3.0 / (A1 + A2);
}

namespace {
Vec3 weighted_sum(const std::array<double, 4>& w, const Vec12& x) {
  return w[0] * vertex(x, 0) + w[1] * vertex(x, 1) + w[2] * vertex(x, 2) + w[3] * vertex(x, 3);
}
}  // namespace

double quadratic_energy(double k, const std::array<double, 4>& w, double coefficient, const Vec12& x) {
  return 0.5 * k * coefficient * weighted_sum(w, x).squaredNorm();
}

double quadratic_energy_gradient(double k, const std::array<double, 4>& w, double coefficient, const Vec12& x,
                                 Vec12& g) {
  const Vec3 s = weighted_sum(w, x);
  for (int i = 0; i < 4; ++i) g.segment<3>(3 * i) = (k * coefficient * w[i]) * s;
  return 0.5 * k * coefficient * s.squaredNorm();
}

Mat12 quadratic_hessian(double k, const std::array<double, 4>& w, double coefficient) {
  Mat12 H;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) H.block<3, 3>(3 * i, 3 * j) = (k * coefficient * w[i] * w[j]) * Mat3::Identity();
  return H;
}

// ---- Dihedral bending ----

HingeRest hinge_rest(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3) {
  double A1, A2;
  rest_areas(X0, X1, X2, X3, A1, A2);
  Vec12 X;
  X << X0, X1, X2, X3;
  return {dihedral_angle(X), 3.0 * (X1 - X0).squaredNorm() / (A1 + A2)};
}

double dihedral_angle(const Vec12& x) { return angle(x, nullptr, nullptr); }

double dihedral_angle_gradient(const Vec12& x, Vec12& dtheta) { return angle(x, &dtheta, nullptr); }

double dihedral_energy(double k, const HingeRest& r, const Vec12& x) {
  const double d = wrapped(dihedral_angle(x) - r.theta0);
  return k * r.weight * d * d;
}

double dihedral_energy_gradient(double k, const HingeRest& r, const Vec12& x, Vec12& g) {
  const double d = wrapped(angle(x, &g, nullptr) - r.theta0);
  g *= 2 * k * r.weight * d;
  return k * r.weight * d * d;
}

Mat12 dihedral_hessian(double k, const HingeRest& r, const Vec12& x, bool psd) {
  Vec12 g;
  Mat12 H;
  const double d = wrapped(angle(x, &g, &H) - r.theta0);
  Mat12 K = 2 * k * r.weight * (g * g.transpose() + d * H);
  if (psd) {
    Eigen::SelfAdjointEigenSolver<Mat12> eig(K);
    K = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  }
  return K;
}

}  // namespace hinge
}  // namespace hyperqn

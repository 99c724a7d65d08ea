// Materials against finite differences: P vs d psi/dF, dP/dF vs dP/dF by differences, symmetry,
// invariance and the rest-pose null space, at rest, uniform scaling, general, near-degenerate,
// small-J, J = 0 and inverted poses, for every material (corotated, Neo-Hookean, StVK, principal-
// stretch with polynomial and spline functions, fibre-reinforced). Also the signed SVD, the scalar
// functions, closed-form comparisons, the rest stiffness against the Laplacian weight, and the
// material factory.
// GCC 12 reports a false -Wmaybe-uninitialized inside Eigen 3.4's eigen solver; not our code.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Eigenvalues>
#pragma GCC diagnostic pop
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "materials/cofactor.hpp"
#include "materials/material.hpp"
#include "materials/material_factory.hpp"
#include "materials/scalar_function.hpp"
#include "materials/svd3.hpp"

using namespace hyperqn;

namespace {

// True if make() throws std::invalid_argument (the materials' way to reject parameters).
template <typename F>
bool throws(F make) {
  try {
    make();
  } catch (const std::invalid_argument&) {
    return true;
  }
  return false;
}

constexpr double kStep = 1e-6;  // central-difference step on entries of F

struct Pose {
  std::string name;
  Mat3 F;
};

struct Worst {
  double stress = 0.0, hessian = 0.0;
};

std::mt19937 rng(20240611);  // fixed seed: the poses are the same on every run

Mat3 random_rotation() {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

Mat3 random_matrix(double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat3 A;
  for (int k = 0; k < 9; ++k) A(k) = scale * u(rng);
  return A;
}

// Q1 diag(s) Q2^T with random rotations: a pose with prescribed signed singular values.
Mat3 with_singular_values(double s1, double s2, double s3) {
  return random_rotation() * Vec3(s1, s2, s3).asDiagonal() * random_rotation().transpose();
}

Mat3 unit(int k) {
  Mat3 E = Mat3::Zero();
  E(k) = 1.0;  // column-major, so entry k of vec(F)
  return E;
}

Mat3 stress(const Material& m, const Mat3& F) {
  Mat3 P;
  m.energy_and_stress(F, P);
  return P;
}

bool finite(const Mat9& H) { return H.allFinite(); }

std::vector<Pose> make_poses() {
  std::vector<Pose> p;
  p.push_back({"rest F=I", Mat3::Identity()});
  p.push_back({"uniform 0.7*R", 0.7 * random_rotation()});
  p.push_back({"uniform 1.3*I", 1.3 * Mat3::Identity()});
  p.push_back({"general (random)", Mat3::Identity() + random_matrix(0.35)});
  p.push_back({"near-degenerate sigma3=1e-3", with_singular_values(1.1, 0.8, 1e-3)});
  p.push_back({"small J (0 < J < J0)", with_singular_values(0.9, 0.5, 0.15)});  // J = 0.0675
  // Third column zero: every term of det F has a factor from it, so J is exactly 0.
  Mat3 Z = Mat3::Identity() + random_matrix(0.35);
  Z.col(2).setZero();
  p.push_back({"J = 0 exactly", Z});
  // Reflection times a pose with det 0.3: det = -0.3, signed sigma = (1.2, 0.8, -0.3125).
  const Mat3 reflect = Vec3(1.0, 1.0, -1.0).asDiagonal();
  p.push_back({"inverted det=-0.3", reflect * with_singular_values(1.2, 0.8, 0.3125)});
  // Two singular values 3e-7 apart: the pair quotients (Psi_i - Psi_j)/(sigma_i - sigma_j) take their limit.
  p.push_back({"near-equal sigma1~sigma2", with_singular_values(1.2, 1.2 - 3e-7, 0.9)});
  // Strongly inverted: sigma3 = -0.7, so sigma2 + sigma3 = 0.2 and J = -0.6.
  p.push_back({"inverted sigma=(1.2,0.9,-0.7)", reflect * with_singular_values(1.2, 0.9, 0.7)});
  return p;
}

void check_signed_svd(const Pose& pose) {
  const SignedSVD s = signed_svd(pose.F);
  const std::string where = "signed SVD at " + pose.name;
  const double tol = 1e-12 * std::max(1.0, pose.F.norm());
  CHECK_MSG((s.U * s.sigma.asDiagonal() * s.V.transpose() - pose.F).norm() <= tol, where + ": reconstruction");
  CHECK_MSG(std::abs(s.U.determinant() - 1.0) <= 1e-12 && std::abs(s.V.determinant() - 1.0) <= 1e-12,
            where + ": det U, det V != 1");
  CHECK_MSG((s.U.transpose() * s.U - Mat3::Identity()).norm() <= 1e-12 &&
                (s.V.transpose() * s.V - Mat3::Identity()).norm() <= 1e-12,
            where + ": U or V not orthogonal");
  CHECK_MSG(std::abs(s.sigma(0)) >= std::abs(s.sigma(1)) && std::abs(s.sigma(1)) >= std::abs(s.sigma(2)),
            where + ": |sigma| not descending");
  CHECK_MSG(s.sigma(0) >= 0.0 && s.sigma(1) >= 0.0, where + ": sigma1 or sigma2 negative");
  const double J = pose.F.determinant();
  if (J != 0.0) CHECK_MSG((s.sigma(2) < 0.0) == (J < 0.0), where + ": sign of sigma3 != sign of det F");
}

// isotropic: also check psi(FQ) = psi(F) (false for the fibre term, which has a rest direction).
void check_pose(const Material& m, const std::string& label, const Pose& pose, Worst& worst, bool isotropic) {
  const Mat3& F = pose.F;
  const std::string where = label + " at " + pose.name;

  Mat3 P;
  const double psi = m.energy_and_stress(F, P);
  const Mat9 H = m.stress_derivative(F);

  // (e) everything finite
  CHECK_MSG(std::isfinite(psi) && P.allFinite() && finite(H), where + ": non-finite energy/P/dPdF");
  // (d) both energy entry points agree (same formula; tolerance only for FMA contraction)
  CHECK_MSG(std::abs(m.energy(F) - psi) <= 1e-15 * std::max(1.0, std::abs(psi)),
            where + ": energy_and_stress energy != energy(F)");

  // (a) P against central differences of the energy
  Mat3 P_fd;
  for (int k = 0; k < 9; ++k)
    P_fd(k) = (m.energy(F + kStep * unit(k)) - m.energy(F - kStep * unit(k))) / (2.0 * kStep);
  const double err_P = (P_fd - P).norm() / std::max(1.0, P.norm());
  worst.stress = std::max(worst.stress, err_P);
  CHECK_MSG(err_P <= 1e-6, where + ": P vs FD of energy, rel err " + std::to_string(err_P));

  // (b) dP/dF against central differences of P
  Mat9 H_fd;
  for (int k = 0; k < 9; ++k) {
    const Mat3 dP = (stress(m, F + kStep * unit(k)) - stress(m, F - kStep * unit(k))) / (2.0 * kStep);
    H_fd.col(k) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  const double err_H = (H_fd - H).norm() / H.norm();
  worst.hessian = std::max(worst.hessian, err_H);
  CHECK_MSG(err_H <= 1e-5, where + ": dPdF vs FD of P, rel Frobenius err " + std::to_string(err_H));

  // (c) symmetric
  const double asym = (H - H.transpose()).norm() / H.norm();
  CHECK_MSG(asym <= 1e-10, where + ": dPdF asymmetric, rel " + std::to_string(asym));

  // Rotation invariance psi(QF) = psi(F), and isotropy psi(FQ) = psi(F).
  const Mat3 Q = random_rotation();
  const double scale = std::max(1.0, std::abs(psi));
  CHECK_MSG(std::abs(m.energy(Q * F) - psi) <= 1e-12 * scale, where + ": psi(QF) != psi(F)");
  if (isotropic) CHECK_MSG(std::abs(m.energy(F * Q) - psi) <= 1e-12 * scale, where + ": psi(FQ) != psi(F)");
}

void check_rest(const Material& m, const std::string& label) {
  Mat3 P;
  const double psi = m.energy_and_stress(Mat3::Identity(), P);
  CHECK_MSG(std::abs(psi) <= 1e-14, label + ": psi(I) != 0");
  CHECK_MSG(P.norm() <= 1e-14, label + ": P(I) != 0");
}

// At F = I the corotated dP/dF is known exactly: 0 on the 3 rotations (skew dF), 2 mu on the 5
// deviatoric stretches, 2 mu + 3 lambda on dilation. The reference code got 6 zeros here.
void check_corotated_rest_spectrum(double mu, double lambda, const std::string& label) {
  const Mat9 H = make_corotated(mu, lambda)->stress_derivative(Mat3::Identity());
  const Eigen::SelfAdjointEigenSolver<Mat9> es(H);
  const auto& ev = es.eigenvalues();  // ascending
  int zeros = 0;
  for (int k = 0; k < 9; ++k) zeros += std::abs(ev(k)) <= 1e-9;
  CHECK_MSG(zeros == 3, label + " at rest: expected 3 zero eigenvalues of dPdF, got " + std::to_string(zeros));
  for (int k = 3; k < 8; ++k)
    CHECK_MSG(std::abs(ev(k) - 2.0 * mu) <= 1e-9, label + " at rest: deviatoric eigenvalue != 2 mu");
  if (lambda > 0.0)
    CHECK_MSG(std::abs(ev(8) - (2.0 * mu + 3.0 * lambda)) <= 1e-9, label + " at rest: dilation eigenvalue");
  // The zero modes are the infinitesimal rotations: skew(dF) = dF.
  for (int k = 0; k < 3; ++k) {
    Mat3 v = Eigen::Map<const Mat3>(es.eigenvectors().col(k).data());
    CHECK_MSG((v + v.transpose()).norm() <= 1e-9, label + " at rest: zero mode is not a rotation");
  }
}

// sigma_2 + sigma_3 = 0 (the SVD rotation jumps): the clamped dP/dF of an SVD-based material must stay
// finite. No FD here: psi is not C2 there.
void check_pair_sum_clamp(const std::string& label, const Material& m) {
  const Mat3 F = random_rotation() * Vec3(1.0, 0.5, -0.5).asDiagonal() * random_rotation().transpose();
  Mat3 P;
  const double psi = m.energy_and_stress(F, P);
  CHECK_MSG(std::isfinite(psi) && P.allFinite() && m.stress_derivative(F).allFinite(),
            label + " at sigma2 + sigma3 = 0: non-finite");
}

using Vec9 = Eigen::Matrix<double, 9, 1>;

Vec9 vec(const Mat3& A) { return Eigen::Map<const Vec9>(A.data()); }

// ---- scalar functions ----

// value' = first and first' = second by central differences at the given points.
void check_scalar_derivatives(const ScalarFunction& phi, const std::string& label, const std::vector<double>& xs) {
  const double h = 1e-6;
  for (double x : xs) {
    const std::string where = label + " at x = " + std::to_string(x);
    const double d1 = (phi.value(x + h) - phi.value(x - h)) / (2.0 * h);
    const double d2 = (phi.first(x + h) - phi.first(x - h)) / (2.0 * h);
    const double s1 = std::max({1.0, std::abs(phi.value(x)), std::abs(phi.first(x))});
    const double s2 = std::max({1.0, std::abs(phi.first(x)), std::abs(phi.second(x))});
    CHECK_MSG(std::abs(d1 - phi.first(x)) <= 1e-7 * s1, where + ": first vs FD of value");
    CHECK_MSG(std::abs(d2 - phi.second(x)) <= 1e-7 * s2, where + ": second vs FD of first");
  }
}

void check_polynomial() {
  const std::vector<double> c{0.5, -1.0, 2.0, 3.0};
  const PolynomialFunction p(c);
  const double x = 1.7, t = x - 1.0;
  CHECK_NEAR(p.value(x), 0.5 - t + 2.0 * t * t + 3.0 * t * t * t, 1e-14);
  CHECK_NEAR(p.first(x), -1.0 + 4.0 * t + 9.0 * t * t, 1e-14);
  CHECK_NEAR(p.second(x), 4.0 + 18.0 * t, 1e-14);
  // Rest values are read off the coefficients.
  CHECK(p.value(1.0) == 0.5 && p.first(1.0) == -1.0 && p.second(1.0) == 4.0);
  check_scalar_derivatives(p, "polynomial", {-1.3, 0.0, 0.4, 1.0, 2.5});
  const PolynomialFunction zero({});
  CHECK(zero.value(3.0) == 0.0 && zero.first(3.0) == 0.0 && zero.second(3.0) == 0.0);
}

void check_spline() {
  const std::vector<double> xs{0.3, 0.7, 1.0, 1.4, 2.0}, ys{-2.5, -0.9, 0.0, 1.1, 4.0};
  const MonotoneSplineFunction s(xs, ys);
  // The stress curve interpolates the control points; the energy is anchored at phi(1) = 0.
  for (std::size_t i = 0; i < xs.size(); ++i)
    CHECK_MSG(std::abs(s.first(xs[i]) - ys[i]) <= 1e-14, "spline: phi'(x_i) != y_i at i = " + std::to_string(i));
  CHECK(s.value(1.0) == 0.0);
  CHECK_NEAR(MonotoneSplineFunction(xs, ys, 0.75).value(1.0), 0.75, 1e-15);
  // Derivatives consistent inside each piece and on both linear extensions. At a control point
  // phi'' has a kink (phi is C2, not C3), so a central difference of phi' across it is only first-order
  // accurate (error ~ h |jump of the third derivative| / 4, ~1e-6 here); there we check instead that
  // phi' and phi'' are continuous, and differentiate just beside it.
  check_scalar_derivatives(s, "spline", {-0.8, 0.0, 0.5, 0.85, 1.2, 1.75, 3.5});
  for (double x : xs) {
    const double scale = std::max(1.0, std::abs(s.second(x)));
    CHECK_MSG(std::abs(s.second(x - 1e-12) - s.second(x)) <= 1e-9 * scale &&
                  std::abs(s.second(x + 1e-12) - s.second(x)) <= 1e-9 * scale &&
                  std::abs(s.first(x - 1e-12) - s.first(x + 1e-12)) <= 1e-9 * scale,
              "spline: phi' or phi'' discontinuous at x = " + std::to_string(x));
    check_scalar_derivatives(s, "spline beside a knot", {x - 1e-4, x + 1e-4});
  }
  // The energy is the exact integral: Simpson's rule is exact for the cubic pieces and for the
  // linear extensions, so it must reproduce phi(b) - phi(a) to round-off on each.
  std::vector<double> breaks{-1.0};
  breaks.insert(breaks.end(), xs.begin(), xs.end());
  breaks.push_back(3.0);
  for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
    const double a = breaks[i], b = breaks[i + 1];
    const double simpson = (b - a) / 6.0 * (s.first(a) + 4.0 * s.first(0.5 * (a + b)) + s.first(b));
    CHECK_MSG(std::abs(simpson - (s.value(b) - s.value(a))) <= 1e-13 * std::max(1.0, std::abs(simpson)),
              "spline: value is not the exact integral on [" + std::to_string(a) + ", " + std::to_string(b) + "]");
  }
  // Monotone data give a monotone stress curve, also across the extensions.
  double prev = s.first(-1.0);
  bool monotone = true;
  for (double x = -1.0; x <= 3.0; x += 1e-3) {
    const double v = s.first(x);
    monotone = monotone && v >= prev - 1e-14;
    prev = v;
  }
  CHECK_MSG(monotone, "spline: stress curve of increasing data is not increasing");
  // No overshoot on step-like data (a plain cubic spline overshoots here); flat parts stay flat.
  const MonotoneSplineFunction step({0, 1, 2, 3, 4, 5}, {0, 0, 0, 1, 1, 1});
  bool bounded = true;
  for (double x = 0.0; x <= 5.0; x += 1e-3) bounded = bounded && step.first(x) >= 0.0 && step.first(x) <= 1.0;
  CHECK_MSG(bounded, "spline: overshoot on step data");
  CHECK(step.first(0.5) == 0.0 && step.first(4.5) == 1.0 && step.first(-3.0) == 0.0 && step.first(9.0) == 1.0);
  // Non-monotone data: the extremum stays at the data point (slope 0 there).
  const MonotoneSplineFunction bump({0, 1, 2}, {0, 1, 0});
  CHECK(bump.slopes()[1] == 0.0);
  CHECK_MSG(bump.first(0.5) <= 1.0 && bump.first(1.5) <= 1.0, "spline: overshoot at a local maximum");
  check_scalar_derivatives(bump, "spline bump", {-0.5, 0.5, 1.5, 2.5});
  // Collinear data reproduce the line (and the linear extension continues it): phi' = 2x - 1.
  const MonotoneSplineFunction line({0.0, 0.5, 1.0, 2.0}, {-1.0, 0.0, 1.0, 3.0});
  for (double x : {-2.0, 0.2, 0.9, 1.5, 4.0}) {
    CHECK_NEAR(line.first(x), 2.0 * x - 1.0, 1e-14);
    CHECK_NEAR(line.value(x), x * x - x, 1e-13);  // integral_1^x (2t - 1) dt
  }
  // Invalid input.
  CHECK(throws([] { MonotoneSplineFunction({1.0}, {0.0}); }));
  CHECK(throws([] { MonotoneSplineFunction({0.0, 1.0}, {0.0}); }));
  CHECK(throws([] { MonotoneSplineFunction({0.0, 1.0, 1.0}, {0.0, 1.0, 2.0}); }));
  CHECK(throws([] { MonotoneSplineFunction({0.0, 1.0}, {0.0, std::nan("")}); }));
  CHECK(throws([] { PolynomialFunction({1.0, INFINITY}); }));
}

// ---- materials used below ----

std::shared_ptr<const ScalarFunction> poly(std::vector<double> c) {
  return std::make_shared<PolynomialFunction>(std::move(c));
}
std::shared_ptr<const ScalarFunction> spline(std::vector<double> x, std::vector<double> y) {
  return std::make_shared<MonotoneSplineFunction>(std::move(x), std::move(y));
}

// A general polynomial principal-stretch material. psi(I) = 0 (all c_0 = 0) and P(I) = 0:
// f'(1) + 2 g'(1) + h'(1) = 0.75 - 0.5 - 0.25 = 0 (dyadic, so exactly 0 in floating point too).
// Rest stiffness f''(1) + 2 g''(1) + h''(1) = 2.2 + 2.0 + 3.4 = 7.6.
std::unique_ptr<Material> make_test_polynomial() {
  return make_principal_stretch(poly({0.0, 0.75, 1.1, -0.4, 0.15}), poly({0.0, -0.25, 0.5, 0.2}),
                                poly({0.0, -0.25, 1.7, -0.6}));
}
// Spline principal-stretch material: every stress curve passes through (1, 0), so P(I) = 0, and
// each energy is anchored at 0 at x = 1, so psi(I) = 0. The poses reach both linear extensions
// (sigma3 < 0.3, J < 0.1 and J < 0).
std::unique_ptr<Material> make_test_spline() {
  return make_principal_stretch(spline({0.3, 0.7, 1.0, 1.4, 2.0}, {-2.5, -0.9, 0.0, 1.1, 4.0}),
                                spline({0.2, 0.6, 1.0, 1.8}, {-0.6, -0.3, 0.0, 0.5}),
                                spline({0.1, 0.5, 1.0, 1.5, 3.0}, {-6.0, -1.5, 0.0, 0.8, 2.0}));
}
// Mixed: spline f, no g (null = zero), polynomial h.
std::unique_ptr<Material> make_test_mixed() {
  return make_principal_stretch(spline({0.5, 1.0, 1.5}, {-1.0, 0.0, 1.6}), nullptr, poly({0.0, 0.0, 2.0, 0.5}));
}
// Corotated written with splines: f' = (2 mu + lambda)(x - 1) - 2 lambda and g' = lambda are lines, which
// the monotone spline and its linear extensions reproduce, so this is corotated again.
std::unique_ptr<Material> make_spline_corotated(double mu, double lambda) {
  std::vector<double> x{-0.5, 0.25, 1.0, 1.6, 2.5}, y;
  for (double xi : x) y.push_back((2.0 * mu + lambda) * (xi - 1.0) - 2.0 * lambda);
  return make_principal_stretch(spline(x, y), spline({0.0, 1.0, 2.0}, {lambda, lambda, lambda}), nullptr);
}

// Closed form (no SVD) of the polynomial Neo-Hookean that make_principal_stretch_neohookean_like builds:
// psi = mu/2 (|F|^2 - 3) - mu (J - 1) + (mu + lambda)/2 (J - 1)^2.
class PolyNeoHookeanClosedForm final : public Material {
 public:
  PolyNeoHookeanClosedForm(double mu, double lambda) : mu_(mu), k_(mu + lambda) {}
  std::string name() const override { return "closed form"; }
  double energy(const Mat3& F) const override {
    const double J = F.determinant();
    return 0.5 * mu_ * (F.squaredNorm() - 3.0) - mu_ * (J - 1.0) + 0.5 * k_ * (J - 1.0) * (J - 1.0);
  }
  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    P = mu_ * F + (k_ * (F.determinant() - 1.0) - mu_) * cofactor(F);
    return energy(F);
  }
  Mat9 stress_derivative(const Mat3& F) const override {
    const Vec9 c = vec(cofactor(F));
    return mu_ * Mat9::Identity() + k_ * c * c.transpose() + (k_ * (F.determinant() - 1.0) - mu_) * cofactor_derivative(F);
  }
  double laplacian_weight() const override { return 0.0; }
  bool projective_dynamics_exact() const override { return false; }

 private:
  double mu_, k_;
};

// a and b agree in energy, P and dP/dF at every pose (relative to max(1, size)).
void check_same_material(const Material& a, const Material& b, const std::string& label,
                         const std::vector<Pose>& poses, double tol) {
  double worst = 0.0;
  for (const Pose& p : poses) {
    Mat3 Pa, Pb;
    const double ea = a.energy_and_stress(p.F, Pa), eb = b.energy_and_stress(p.F, Pb);
    const Mat9 Ha = a.stress_derivative(p.F), Hb = b.stress_derivative(p.F);
    const double de = std::abs(ea - eb) / std::max(1.0, std::abs(eb));
    const double dP = (Pa - Pb).norm() / std::max(1.0, Pb.norm());
    const double dH = (Ha - Hb).norm() / std::max(1.0, Hb.norm());
    worst = std::max({worst, de, dP, dH});
    CHECK_MSG(de <= tol && dP <= tol && dH <= tol,
              label + " at " + p.name + ": energy/P/dPdF differ by " + std::to_string(de) + "/" + std::to_string(dP) +
                  "/" + std::to_string(dH));
  }
  std::printf("%-52s max rel diff %.1e\n", label.c_str(), worst);
}

// ---- rest stiffness vs Laplacian weight ----

// At F = I: dilation = Rayleigh quotient of dP/dF on vec(I)/sqrt3 (2 mu + 3 lambda for isotropic
// linear elasticity), shear = on (e1 e2^T + e2 e1^T)/sqrt2 (2 mu), and the uniaxial stiffness along n,
// vec(n n^T)^T dPdF vec(n n^T) = d^2 psi / d(stretch along n)^2 (2 mu + lambda = (dilation + 2 shear)/3
// for every n if isotropic). The weight must be within a factor 1.5 of the largest uniaxial stiffness.
void check_rest_stiffness(const Material& m, const std::string& label, bool isotropic, const Vec3& fiber_dir) {
  const Mat9 H = m.stress_derivative(Mat3::Identity());
  const Vec9 vI = vec(Mat3::Identity()) / std::sqrt(3.0);
  Mat3 S = Mat3::Zero();
  S(0, 1) = S(1, 0) = 1.0 / std::sqrt(2.0);
  const Vec9 vS = vec(S);
  const double dil = vI.dot(H * vI), shear = vS.dot(H * vS), equiv = (dil + 2.0 * shear) / 3.0;
  std::vector<Vec3> dirs{Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ(), Vec3(1, 1, 1), Vec3(1, -2, 0.5)};
  for (int k = 0; k < 3; ++k) dirs.push_back(random_rotation().col(0));
  if (fiber_dir.norm() > 0.0) dirs.push_back(fiber_dir);
  double umin = INFINITY, umax = -INFINITY;
  for (Vec3 n : dirs) {
    n.normalize();
    const Vec9 v = vec(n * n.transpose());
    const double u = v.dot(H * v);
    umin = std::min(umin, u);
    umax = std::max(umax, u);
  }
  const double w = m.laplacian_weight();
  std::printf("%-40s w %8.4f  uniaxial [%8.4f, %8.4f]  (dil+2shear)/3 %8.4f  dil %8.4f  shear %8.4f  w/max %.4f\n",
              label.c_str(), w, umin, umax, equiv, dil, shear, w / umax);
  CHECK_MSG(w >= umax / 1.5 && w <= 1.5 * umax, label + ": Laplacian weight not within 1.5x of the rest stiffness");
  if (isotropic) {
    const double tol = 1e-10 * H.norm();
    CHECK_MSG(umax - umin <= tol, label + ": uniaxial rest stiffness depends on direction");
    CHECK_MSG(std::abs(equiv - umax) <= tol, label + ": uniaxial stiffness != (dilation + 2 shear)/3");
    CHECK_MSG((H * vI - dil * vI).norm() <= tol && (H * vS - shear * vS).norm() <= tol,
              label + ": dilation/shear are not eigenvectors of dPdF at rest");
  }
}

// ---- fibre-specific checks ----

// dP/dF(I) of the fibre material = base + k vec(d d^T) vec(d d^T)^T, and the fibre term is
// anisotropic: a stretch along d costs k/2 e^2 more than the same stretch across d.
void check_fiber(const Material& fiber, const Material& base, Vec3 d, double k, const std::string& label) {
  d.normalize();
  const Vec9 v = vec(d * d.transpose());
  const Mat9 diff = fiber.stress_derivative(Mat3::Identity()) - base.stress_derivative(Mat3::Identity());
  CHECK_MSG((diff - k * v * v.transpose()).norm() <= 1e-12 * std::max(1.0, k), label + ": rest dPdF != base + k d d^T");
  const Vec3 n = d.unitOrthogonal();
  const double e = 0.1;
  const Mat3 along = Mat3::Identity() + e * d * d.transpose(), across = Mat3::Identity() + e * n * n.transpose();
  CHECK_NEAR(fiber.energy(along) - base.energy(along), 0.5 * k * e * e, 1e-14);
  CHECK_NEAR(fiber.energy(across) - base.energy(across), 0.0, 1e-14);
  // Inside the regularization ball (||Fd|| < eps) the energy stays within 3 k eps / 8 of the exact one.
  for (double len : {0.0, 0.5 * kFiberEpsilon, 0.9 * kFiberEpsilon}) {
    const Mat3 F = Mat3::Identity() - (1.0 - len) * d * d.transpose();
    const double exact = base.energy(F) + 0.5 * k * (len - 1.0) * (len - 1.0);
    CHECK_MSG(std::abs(fiber.energy(F) - exact) <= 3.0 * k * kFiberEpsilon / 8.0 + 1e-14,
              label + ": regularized fibre energy too far from exact at ||Fd|| = " + std::to_string(len));
  }
}

// A pose with ||F d|| = len: F d = len Q d, the rest of F random.
Mat3 fiber_pose(const Vec3& d, double len, const Mat3& Q, const Mat3& noise) {
  return Q * (Mat3::Identity() - (1.0 - len) * d * d.transpose() + noise * (Mat3::Identity() - d * d.transpose()));
}

// Poses that put ||F d|| at 0, inside and just outside the regularization ball (eps = kFiberEpsilon),
// and one ordinary compressed pose. Not exactly on the ball's surface: psi is C2 but not C3 there, so
// a central difference of P across it is only first-order accurate (with eps = 1e-3 it was 5e-4
// relative at step 1e-6, shrinking 10x per 10x smaller step); check_fiber_junction checks continuity
// there instead.
std::vector<Pose> fiber_poses(Vec3 d) {
  d.normalize();
  std::vector<Pose> p;
  for (double len : {0.0, 0.5, 0.99, 1.01, 1.1}) {
    len *= kFiberEpsilon;
    p.push_back({"||Fd|| = " + std::to_string(len), fiber_pose(d, len, random_rotation(), random_matrix(0.05))});
  }
  p.push_back({"||Fd|| = 0.5", fiber_pose(d, 0.5, random_rotation(), random_matrix(0.05))});
  return p;
}

// psi, P and dP/dF are continuous across the surface ||F d|| = eps of the regularization ball.
void check_fiber_junction(const Material& m, Vec3 d, const std::string& label) {
  d.normalize();
  const Mat3 Q = random_rotation(), noise = random_matrix(0.05);
  const Mat3 Fin = fiber_pose(d, kFiberEpsilon * (1.0 - 1e-9), Q, noise);
  const Mat3 Fout = fiber_pose(d, kFiberEpsilon * (1.0 + 1e-9), Q, noise);
  Mat3 Pin, Pout;
  const double ein = m.energy_and_stress(Fin, Pin), eout = m.energy_and_stress(Fout, Pout);
  const Mat9 Hin = m.stress_derivative(Fin), Hout = m.stress_derivative(Fout);
  CHECK_MSG(std::abs(ein - eout) <= 1e-9 * std::max(1.0, std::abs(eout)) &&
                (Pin - Pout).norm() <= 1e-9 * std::max(1.0, Pout.norm()) && (Hin - Hout).norm() <= 1e-6 * Hout.norm(),
            label + ": psi, P or dPdF jumps at ||Fd|| = eps");
}

void check_factory() {
  CHECK(make_material("corotated", 1.3, 2.1, 0.1)->name() == "corotated");
  CHECK(make_material("neohookean", 1.3, 2.1, 0.1)->name() == "neohookean");
  CHECK(make_material("stvk", 1.3, 2.1, 0.1)->name() == "stvk");
  CHECK_MSG(throws([] { make_material("mooney-rivlin", 1.0, 1.0, 0.1); }), "unknown model should throw");
  CHECK_MSG(throws([] { make_material("neohookean", 1.0, 1.0, 0.0); }), "neohookean, J0 = 0 should throw");
  CHECK_MSG(throws([] { make_material("principal-stretch", 1.0, 1.0, 0.1); }), "principal-stretch without f, g, h");

  MaterialParams p;
  p.model = "stvk";
  p.mu = 1.3;
  p.lambda = 2.1;
  p.kappa = 100.0;
  const auto stvk = make_material(p);
  CHECK(stvk->name() == "stvk");
  // The kappa term is there: at J = 0.5 psi exceeds plain StVK by kappa (0.5)^3 / 2592.
  const Mat3 F = Vec3(1.0, 1.0, 0.5).asDiagonal();
  CHECK_NEAR(stvk->energy(F) - make_stvk(1.3, 2.1, 0.0)->energy(F), 100.0 * 0.125 / 2592.0, 1e-14);
  p.kappa = -1.0;
  CHECK_MSG(throws([&] { make_material(p); }), "stvk, kappa < 0 should throw");

  p = MaterialParams{};
  p.model = "principal-stretch";
  p.f = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, 0.0, 1.0});
  p.h = std::make_shared<MonotoneSplineFunction>(std::vector<double>{0.5, 1.0, 1.5}, std::vector<double>{-1.0, 0.0, 1.0});
  const auto ps = make_material(p);
  CHECK(ps->name() == "principal-stretch");
  CHECK_NEAR(ps->laplacian_weight(), 2.0 + 2.0, 1e-14);  // f''(1) = 2, h''(1) = slope of h' = 2
  p.f = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, 0.0, -3.0});
  CHECK_MSG(throws([&] { make_material(p); }), "principal-stretch with negative rest stiffness should throw");

  p = MaterialParams{};
  p.model = "neohookean";
  p.mu = 1.3;
  p.lambda = 2.1;
  p.has_fiber = true;
  p.fiber_direction = Vec3(0.0, 2.0, 0.0);
  p.fiber_stiffness = 5.0;
  const auto fib = make_material(p);
  CHECK(fib->name() == "neohookean+fiber");
  CHECK_NEAR(fib->laplacian_weight(), 2.0066 * 1.3 + 1.0122 * 2.1 + 5.0, 1e-14);
  CHECK(!fib->projective_dynamics_exact());
  p.fiber_direction = Vec3::Zero();
  CHECK_MSG(throws([&] { make_material(p); }), "fibre with zero direction should throw");
  p.fiber_direction = Vec3::UnitX();
  p.fiber_stiffness = -1.0;
  CHECK_MSG(throws([&] { make_material(p); }), "fibre with k < 0 should throw");
  CHECK_MSG(throws([] { make_fiber(nullptr, Vec3::UnitX(), 1.0); }), "fibre without base should throw");

  CHECK_NEAR(make_corotated(1.3, 2.1)->laplacian_weight(), 2.0 * 1.3 + 2.1, 1e-15);
  CHECK_NEAR(make_neohookean(1.3, 2.1, 0.1)->laplacian_weight(), 2.0066 * 1.3 + 1.0122 * 2.1, 1e-15);
  CHECK_NEAR(make_stvk(1.3, 2.1, 100.0)->laplacian_weight(), 2.0 * 1.3 + 1.0033 * 2.1, 1e-15);
  CHECK_NEAR(make_principal_stretch_corotated(1.3, 2.1)->laplacian_weight(), 2.0 * 1.3 + 2.1, 1e-14);
  CHECK_NEAR(make_principal_stretch_neohookean_like(1.3, 2.1)->laplacian_weight(), 2.0 * 1.3 + 2.1, 1e-14);
  // PD is exact for ARAP (corotated, lambda = 0) only.
  CHECK(make_corotated(1.3, 0.0)->projective_dynamics_exact());
  CHECK(!make_corotated(1.3, 2.1)->projective_dynamics_exact());
  CHECK(!make_neohookean(1.3, 0.0, 0.1)->projective_dynamics_exact());
  CHECK(!make_stvk(1.3, 0.0, 0.0)->projective_dynamics_exact());
  CHECK(!make_principal_stretch_corotated(1.3, 0.0)->projective_dynamics_exact());
  CHECK(!make_fiber(make_corotated(1.3, 0.0), Vec3::UnitX(), 1.0)->projective_dynamics_exact());
}

// The fast signed SVD (eigen-decomposition of F^T F) against the Jacobi one on random
// well-conditioned poses: the same singular values and the same polar rotation U V^T.
void check_fast_svd() {
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  double worst = 0;
  for (int n = 0; n < 1000; ++n) {
    Mat3 F = Mat3::Identity();
    for (int i = 0; i < 9; ++i) F(i % 3, i / 3) += u(gen);
    if (n % 3 == 0) F = Eigen::AngleAxisd(3.0 * u(gen), Vec3(u(gen), u(gen), 1).normalized()) * F;
    if (F.determinant() <= 0) continue;
    const SignedSVD a = signed_svd(F), b = signed_svd_jacobi(F);
    worst = std::max({worst, (a.sigma - b.sigma).cwiseAbs().maxCoeff(), (a.rotation() - b.rotation()).cwiseAbs().maxCoeff(),
                      (a.U * a.sigma.asDiagonal() * a.V.transpose() - F).cwiseAbs().maxCoeff()});
  }
  CHECK_MSG(worst < 1e-12, "fast signed SVD differs from Jacobi by " + std::to_string(worst));
  // Exactly at rest (a triple singular value) and under uniform scaling.
  for (double c : {1.0, 0.5, 2.0}) {
    const SignedSVD a = signed_svd(c * Mat3::Identity());
    CHECK((a.rotation() - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-14 && std::fabs(a.sigma(2) - c) < 1e-14);
  }
}

// signed_polar_rotation (Newton's polar iteration, the Jacobi SVD where it does not apply) against
// the exact rotation: F = Q1 diag(sigma) Q2^T with signed sigma, |sigma_1| >= |sigma_2| >= |sigma_3|,
// has R = Q1 Q2^T (unique while sigma_2 + sigma_3 != 0, also for repeated sigma). Thousands of random
// F: general, inverted, nearly and exactly flat, repeated and nearly repeated singular values, at
// scales 1e-3 to 1e3, where Newton needs many steps or runs out of them; and the Jacobi SVD's rotation
// on random F near rotations, inverted ones included.
void check_polar_rotation() {
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto rotation = [&] {
    std::normal_distribution<double> n(0.0, 1.0);
    return Eigen::Quaterniond(n(gen), n(gen), n(gen), n(gen)).normalized().toRotationMatrix();
  };
  const std::vector<Vec3> special{
      {1, 1, 1},         {1.3, 1.3, 1.3},    {1.2, 1.2, 0.7},     {1.2, 0.7, 0.7},   {1.2, 0.7, -0.5},
      {1, 1, 1 - 1e-9},  {1.1, 0.8, 1e-3},   {1.1, 0.8, 1e-5},    {1.1, 0.8, 1e-9},  {1.1, 0.8, 0.0},
      {1.1, 0.8, -1e-9}, {1.1, 0.8, -1e-3},  {1.1, 1.1, -1e-9},   {1.2, 0.9, -0.7},  {1.5, 1.5, -1.0},
      {1.0, 0.3, -0.25}, {4.0, 1e-2, 1e-2},  {3.0, 2.0, 2.0 - 1e-9},
      {1.1, 0.018, 0.018}, {1.1, 0.012, 0.012}, {1.1, 1.1, 0.018}, {1.1, 1.1, 0.012}, {1.1, 1.1, 1.8e-3}};  // the
  // last five: cond(F) = ||F|| ||F^-1|| of 86, 130, 86, 130, 860 around the Newton bound of 100
  double worst = 0.0, worst_svd = 0.0;
  std::string worst_at;
  for (int n = 0; n < 6000; ++n) {
    Vec3 s;
    if (n < 3 * static_cast<int>(special.size())) {
      s = special[n % special.size()];
    } else {  // random signed singular values, sorted by magnitude, third one negative half the time
      for (int i = 0; i < 3; ++i) s(i) = 0.05 + 2.0 * u(gen);
      std::sort(s.data(), s.data() + 3, std::greater<double>());
      if (n % 2) s(2) = -s(2);
      if (n % 7 == 0) s(2) *= 1e-6;  // nearly flat
    }
    const double scale = std::pow(10.0, std::round(6.0 * u(gen)) - 3.0);  // 1e-3 .. 1e3
    const Mat3 Q1 = rotation(), Q2 = rotation();
    const Mat3 F = scale * (Q1 * s.asDiagonal() * Q2.transpose());
    const Mat3 R = signed_polar_rotation(F);
    // R's condition number is sigma_1 / (sigma_2 + sigma_3), so the error is weighted by its inverse.
    const double err = (R - Q1 * Q2.transpose()).cwiseAbs().maxCoeff() * (s(1) + s(2)) / s(0);
    char where[120];
    std::snprintf(where, sizeof where, "sigma = (%g, %g, %g) * %g", s(0), s(1), s(2), scale);
    if (err > worst) {
      worst = err;
      worst_at = where;
    }
    CHECK_MSG(std::abs(R.determinant() - 1.0) <= 1e-13 && (R.transpose() * R - Mat3::Identity()).norm() <= 1e-13,
              std::string("signed_polar_rotation: not a rotation at ") + where);
    // Against the Jacobi SVD on F near rotations (I + noise, some reflected).
    Mat3 G = Mat3::Identity();
    for (int k = 0; k < 9; ++k) G(k) += 0.8 * (u(gen) - 0.5);
    G = (n % 3 == 0 ? Mat3(Vec3(1.0, 1.0, -1.0).asDiagonal()) : Mat3::Identity()) * Q1 * G;
    const SignedSVD j = signed_svd_jacobi(G);
    const double gap = std::min(j.sigma(1) + j.sigma(2), 1.0) / j.sigma(0);
    worst_svd = std::max(worst_svd, (signed_polar_rotation(G) - j.rotation()).cwiseAbs().maxCoeff() * gap);
  }
  std::printf("signed_polar_rotation: largest |R - R_exact| (sigma_2 + sigma_3)/sigma_1 = %.1e (%s), vs Jacobi %.1e\n",
              worst, worst_at.c_str(), worst_svd);
  char msg[200];
  std::snprintf(msg, sizeof msg, "signed_polar_rotation differs from the exact rotation by %.1e at %s", worst,
                worst_at.c_str());
  CHECK_MSG(worst <= 1e-14, msg);
  std::snprintf(msg, sizeof msg, "signed_polar_rotation differs from the Jacobi SVD by %.1e", worst_svd);
  CHECK_MSG(worst_svd <= 1e-14, msg);
  // Exactly the identity at rest; a rotation stays itself.
  CHECK(signed_polar_rotation(Mat3::Identity()) == Mat3::Identity());
  const Mat3 Q = rotation();
  CHECK((signed_polar_rotation(Q) - Q).cwiseAbs().maxCoeff() <= 1e-15);
}

}  // namespace

// energy_and_stress_batch gives each element what energy_and_stress gives it alone: the poses in
// batches of every size from 1 to kBatch, each pose once in each lane position.
void check_batch(const Material& m, const std::string& label, const std::vector<Pose>& poses) {
  double worst = 0.0;
  for (int n = 1; n <= kBatch; ++n)
    for (size_t first = 0; first < poses.size(); ++first) {
      StressBatch b;
      for (int e = 0; e < n; ++e)
        for (int c = 0; c < 9; ++c) b.F[c][e] = poses[(first + e) % poses.size()].F(c);
      m.energy_and_stress_batch(b, n);
      for (int e = 0; e < n; ++e) {
        Mat3 P;
        const double psi = m.energy_and_stress(poses[(first + e) % poses.size()].F, P);
        double scale = std::abs(psi) + 1.0, err = std::abs(b.psi[e] - psi);
        for (int c = 0; c < 9; ++c) {
          scale = std::max(scale, std::abs(P(c)));
          err = std::max(err, std::abs(b.P[c][e] - P(c)));
        }
        worst = std::max(worst, err / scale);
      }
    }
  CHECK_MSG(worst <= 1e-13, label + ": a batch differs from one element alone by " + std::to_string(worst));
}

int main() {
  check_fast_svd();
  check_polar_rotation();
  const std::vector<Pose> poses = make_poses();
  for (const Pose& p : poses) check_signed_svd(p);
  check_polynomial();
  check_spline();

  struct Case {
    std::string label;
    std::unique_ptr<Material> m;
    bool isotropic = true;
    bool svd_based = false;     // gets the sigma2 + sigma3 = 0 finiteness check
    Vec3 fiber_dir = Vec3::Zero();  // nonzero for fibre materials (extra poses and rest checks)
  };
  const Vec3 d1 = Vec3(1.0, 2.0, 2.0) / 3.0, d2 = Vec3::UnitZ(), d3 = Vec3(-0.3, 0.4, 1.2);
  std::vector<Case> cases;
  cases.push_back({"corotated(mu=1.3, lambda=2.1)", make_corotated(1.3, 2.1), true, true});
  cases.push_back({"corotated(mu=1.3, lambda=0)", make_corotated(1.3, 0.0), true, true});
  cases.push_back({"neohookean(mu=1.3, lambda=2.1, J0=0.1)", make_neohookean(1.3, 2.1, 0.1)});
  cases.push_back({"neohookean(mu=1.3, lambda=0, J0=0.1)", make_neohookean(1.3, 0.0, 0.1)});
  cases.push_back({"stvk(mu=1.3, lambda=2.1, kappa=0)", make_stvk(1.3, 2.1, 0.0)});
  cases.push_back({"stvk(mu=1.3, lambda=2.1, kappa=100)", make_stvk(1.3, 2.1, 100.0)});
  cases.push_back({"principal-stretch polynomial", make_test_polynomial(), true, true});
  cases.push_back({"principal-stretch spline", make_test_spline(), true, true});
  cases.push_back({"principal-stretch spline f + poly h", make_test_mixed(), true, true});
  cases.push_back({"principal-stretch corotated(1.3, 2.1)", make_principal_stretch_corotated(1.3, 2.1), true, true});
  cases.push_back({"principal-stretch spline corotated", make_spline_corotated(1.3, 2.1), true, true});
  cases.push_back({"principal-stretch NH-like(1.3, 2.1)", make_principal_stretch_neohookean_like(1.3, 2.1), true, true});
  cases.push_back({"fiber(neohookean, d=(1,2,2)/3, k=2.5)", make_fiber(make_neohookean(1.3, 2.1, 0.1), d1, 2.5), false,
                   false, d1});
  cases.push_back({"fiber(stvk kappa=100, d=e3, k=4)", make_fiber(make_stvk(1.3, 2.1, 100.0), d2, 4.0), false, false, d2});
  cases.push_back({"fiber(PS spline, d=(-.3,.4,1.2), k=1)", make_fiber(make_test_spline(), d3, 1.0), false, true, d3});

  for (const Case& c : cases) {
    Worst worst;
    check_rest(*c.m, c.label);
    for (const Pose& p : poses) check_pose(*c.m, c.label, p, worst, c.isotropic);
    if (c.fiber_dir.norm() > 0.0)
      for (const Pose& p : fiber_poses(c.fiber_dir)) check_pose(*c.m, c.label, p, worst, c.isotropic);
    if (c.svd_based) check_pair_sum_clamp(c.label, *c.m);
    check_batch(*c.m, c.label, poses);
    std::printf("%-40s worst FD rel err: P %.1e, dPdF %.1e\n", c.label.c_str(), worst.stress, worst.hessian);
  }
  check_corotated_rest_spectrum(1.3, 2.1, cases[0].label);
  check_corotated_rest_spectrum(1.3, 0.0, cases[1].label);

  // Closed forms: the principal-stretch machinery reproduces corotated (polynomial and spline f, g)
  // and the polynomial Neo-Hookean; the latter has Neo-Hookean's Hessian at rest.
  const std::vector<Pose> rest_only{poses[0]};
  check_same_material(*make_principal_stretch_corotated(1.3, 2.1), *make_corotated(1.3, 2.1),
                      "principal-stretch corotated vs corotated", poses, 1e-10);
  check_same_material(*make_spline_corotated(1.3, 2.1), *make_corotated(1.3, 2.1),
                      "principal-stretch spline corotated vs corotated", poses, 1e-10);
  check_same_material(*make_principal_stretch_neohookean_like(1.3, 2.1), PolyNeoHookeanClosedForm(1.3, 2.1),
                      "principal-stretch NH-like vs closed form", poses, 1e-10);
  check_same_material(*make_principal_stretch_neohookean_like(1.3, 2.1), *make_neohookean(1.3, 2.1, 0.1),
                      "principal-stretch NH-like vs neohookean at rest", rest_only, 1e-12);
  // StVK linearizes like corotated at rest (E ~ sym(dF); the kappa term has zero curvature at J = 1).
  check_same_material(*make_stvk(1.3, 2.1, 100.0), *make_corotated(1.3, 2.1), "stvk vs corotated at rest", rest_only,
                      1e-12);

  check_fiber(*cases[12].m, *make_neohookean(1.3, 2.1, 0.1), d1, 2.5, cases[12].label);
  check_fiber(*cases[13].m, *make_stvk(1.3, 2.1, 100.0), d2, 4.0, cases[13].label);
  check_fiber(*cases[14].m, *make_test_spline(), d3, 1.0, cases[14].label);
  for (int k = 12; k <= 14; ++k) check_fiber_junction(*cases[k].m, cases[k].fiber_dir, cases[k].label);

  std::printf("rest stiffness at F = I (w = laplacian_weight):\n");
  for (const Case& c : cases) check_rest_stiffness(*c.m, c.label, c.isotropic, c.fiber_dir);

  check_factory();
  return check::summary("test_materials");
}

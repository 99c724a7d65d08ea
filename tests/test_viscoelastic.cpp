// The generalized Maxwell branches (materials/maxwell_branches.hpp), alone:
//  - the condensed energy's P against central differences of W, and dP/dF against central
//    differences of P, symmetric, at rest history and at a history left by large-strain steps
//    (stretches to 2 and 0.5, shear, an inverted F, equal eigenvalues), for dt = 0, tau/20, 10 tau;
//  - the closed forms of W, P and the update (no eigenvectors; materials/spectral3.hpp) against
//    Eigen's iterative eigensolver (the kernel before them, kept here as a reference) at those
//    poses and at two or three eigenvalues of b apart by 1e-4 and 1e-8, within 1e-12; and at
//    compressions to 1e-2 and 1e-3 against long double, within 1e-13;
//  - objectivity: W(QF) = W(F) and the update from QF is the update from F;
//  - the update keeps det C_v = 1 (isochoric flow) and is the minimizer it claims: the history it
//    gives makes the branch stress 2 mu eps_e equal to the condensed P (the stationarity of the
//    local potential);
//  - the standard linear solid in simple shear gamma0 = 1e-3 held from t = 0 (the equilibrium part
//    a linear shear modulus mu_inf, the branch mu_1 = g mu_inf / (1 - g)): the shear stress after
//    n steps of dt = tau/20 against gamma0 (mu_inf + mu_1 e^{-t/tau}), within 0.5% for t <= 5 tau,
//    and the observed order in dt (backward Euler: 1);
//  - the same solid's loss per cycle under gamma0 sin(omega t) against pi gamma0^2 E_1 omega tau /
//    (1 + omega^2 tau^2) within 1% for omega tau = 0.1, 1, 10 (400 steps over the shorter of tau
//    and the period), and its creep under a held shear stress against the closed form within 0.5%
//    at dt = tau/20. These are material points under prescribed simple-shear kinematics (the normal
//    stresses of order gamma^2 left unbalanced); tests/python/test_viscoelastic.py runs relaxation
//    through the whole solver.
#include "materials/maxwell_branches.hpp"

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>

#include "check.hpp"

using namespace hyperqn;

namespace {

constexpr double kStep = 1e-6;

Mat3 unit(int k) {
  Mat3 E = Mat3::Zero();
  E(k) = 1.0;
  return E;
}

Mat3 rotation(double a, const Vec3& axis) { return Eigen::AngleAxisd(a, axis.normalized()).toRotationMatrix(); }

Mat3 stress(const MaxwellBranches& m, const Mat3& F, const double* h, double dt) {
  Mat3 P = Mat3::Zero();
  m.energy(F, h, dt, &P);
  return P;
}

void check_derivatives(const MaxwellBranches& m, const Mat3& F, const double* h, double dt, const std::string& where) {
  const Mat3 P = stress(m, F, h, dt);
  Mat3 P_fd;
  for (int k = 0; k < 9; ++k)
    P_fd(k) = (m.energy(F + kStep * unit(k), h, dt, nullptr) - m.energy(F - kStep * unit(k), h, dt, nullptr)) / (2 * kStep);
  const double err_P = (P_fd - P).norm() / std::max(1.0, P.norm());
  CHECK_MSG(err_P <= 1e-6, where + ": P vs FD of W, rel err " + std::to_string(err_P));
  const Mat9 H = m.stress_derivative(F, h, dt);
  Mat9 H_fd;
  for (int k = 0; k < 9; ++k) {
    const Mat3 dP = (stress(m, F + kStep * unit(k), h, dt) - stress(m, F - kStep * unit(k), h, dt)) / (2 * kStep);
    H_fd.col(k) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  const double err_H = (H_fd - H).norm() / std::max(1e-12, H.norm());
  CHECK_MSG(err_H <= 1e-5, where + ": dP/dF vs FD of P, rel err " + std::to_string(err_H));
  const double asym = (H - H.transpose()).norm() / std::max(1e-12, H.norm());
  CHECK_MSG(asym <= 1e-10, where + ": dP/dF asymmetric, rel " + std::to_string(asym));
  std::printf("  %-44s P %.1e  dP/dF %.1e\n", where.c_str(), err_P, err_H);
}

double det_Cv_inverse(const double* h) {
  Mat3 A;
  A << h[0], h[3], h[5], h[3], h[1], h[4], h[5], h[4], h[2];
  return A.determinant();
}

void check_fd_and_update() {
  const MaxwellBranches m({{0.7, 0.1}, {0.4, 2.0}, {1.3, 0.01}, {0.2, 30.0}});
  const int width = kViscousValues * m.size();
  std::vector<double> rest(width), h(width), h2(width);
  m.rest(rest.data());
  // A history left by two large steps: a stretch to 2 along x, then a shear with rotation.
  const Mat3 F1 = Vec3(2.0, 1 / std::sqrt(2.0), 1 / std::sqrt(2.0)).asDiagonal();
  m.update(F1, rest.data(), 0.05, h.data());
  Mat3 F2 = F1;
  F2(0, 1) = 0.8;
  F2 = rotation(0.7, Vec3(1, 2, 3)) * F2;
  m.update(F2, h.data(), 0.05, h2.data());
  for (int i = 0; i < m.size(); ++i) {
    CHECK_MSG(std::fabs(det_Cv_inverse(&h[kViscousValues * i]) - 1) < 1e-12, "isochoric flow: det C_v = 1 (step 1)");
    CHECK_MSG(std::fabs(det_Cv_inverse(&h2[kViscousValues * i]) - 1) < 1e-12, "isochoric flow: det C_v = 1 (step 2)");
  }
  struct Pose {
    std::string name;
    Mat3 F;
  };
  Mat3 shear = Mat3::Identity();
  shear(0, 1) = 1.5;
  Mat3 general;
  general << 1.3, 0.2, -0.1, 0.05, 0.8, 0.3, -0.2, 0.1, 1.1;
  const std::vector<Pose> poses = {
      {"rest", Mat3::Identity()},
      {"uniform 1.2 (equal eigenvalues)", 1.2 * Mat3::Identity()},
      {"stretch 2", Vec3(2.0, 0.75, 0.75).asDiagonal()},
      {"compression 0.5", Vec3(0.5, 1.3, 1.3).asDiagonal()},
      {"shear 1.5", shear},
      {"general", general},
      {"inverted", Vec3(1.1, 0.9, -0.8).asDiagonal()},
      {"two equal eigenvalues, rotated", rotation(0.3, Vec3(0, 1, 1)) * Vec3(1.4, 0.9, 0.9).asDiagonal()},
  };
  for (double dt : {0.0, 0.005, 1.0})
    for (const Pose& p : poses)
      for (const std::vector<double>* hist : {&rest, &h2}) {
        char where[120];
        std::snprintf(where, sizeof where, "%s, dt %g, %s", p.name.c_str(), dt, hist == &rest ? "rest C_v" : "flowed C_v");
        check_derivatives(m, p.F, hist->data(), dt, where);
      }

  // Objectivity: W(QF) = W(F), the same history from QF.
  const Mat3 Q = rotation(1.1, Vec3(-1, 0.5, 2));
  std::vector<double> hq(width);
  m.update(Q * F2, h.data(), 0.05, hq.data());
  double diff = 0;
  for (int k = 0; k < width; ++k) diff = std::max(diff, std::fabs(hq[k] - h2[k]));
  CHECK_MSG(diff < 1e-12, "the update from QF is the update from F: " + std::to_string(diff));
  const double W = m.energy(general, h2.data(), 0.05, nullptr);
  CHECK_MSG(std::fabs(m.energy(Q * general, h2.data(), 0.05, nullptr) - W) < 1e-13 * std::max(1.0, W), "W(QF) = W(F)");

  // The update is the local minimizer: the stress stored at the step's end (dt = 0 from the new
  // history) equals the condensed P of the step (the stationarity condition).
  for (const Pose& p : poses) {
    if (p.name == "inverted") continue;
    std::vector<double> end(width);
    m.update(p.F, h2.data(), 0.05, end.data());
    const Mat3 Pc = stress(m, p.F, h2.data(), 0.05), Ps = stress(m, p.F, end.data(), 0.0);
    CHECK_MSG((Pc - Ps).norm() <= 1e-12 * std::max(1.0, Pc.norm()), "stored stress = condensed stress at " + p.name);
  }
  CHECK(std::isinf(m.energy(Vec3(1.0, 1.0, 0.0).asDiagonal(), rest.data(), 0.1, nullptr)));
  bool refused = false;
  try {
    MaxwellBranches({{1, 1}, {1, 1}, {1, 1}, {1, 1}, {1, 1}});
  } catch (const std::invalid_argument&) {
    refused = true;
  }
  CHECK_MSG(refused, "more than 4 branches refused");
  refused = false;
  try {
    MaxwellBranches({{1, 0}});
  } catch (const std::invalid_argument&) {
    refused = true;
  }
  CHECK_MSG(refused, "tau = 0 refused");
}

// The branches' energy, P and update by Eigen's iterative eigensolver of the trial b (the kernel
// before the closed forms of materials/spectral3.hpp), as a reference for them.
struct Reference {
  const MaxwellBranches& m;
  // The trial b of branch i in its eigenbasis: eigenvalues beta, vectors N; the log strains' deviator d.
  bool trial(const Mat3& F, const double* h, Mat3& A, Mat3& N, Vec3& beta, Vec3& d, double& mean) const {
    A << h[0], h[3], h[5], h[3], h[1], h[4], h[5], h[4], h[2];
    const Mat3 b = F * A * F.transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(0.5 * (b + b.transpose()));
    N = eig.eigenvectors();
    beta = eig.eigenvalues();
    if (!(beta.minCoeff() > 0)) return false;
    const Vec3 e = 0.5 * beta.array().log().matrix();
    mean = e.sum() / 3.0;
    d = e.array() - mean;
    return true;
  }
  double energy(const Mat3& F, const double* h, double dt, Mat3& P) const {
    double W = 0;
    P.setZero();
    for (int i = 0; i < m.size(); ++i) {
      Mat3 A, N;
      Vec3 beta, d;
      double mean;
      if (!trial(F, h + kViscousValues * i, A, N, beta, d, mean)) return INFINITY;
      const double mi = m.branches()[i].mu * m.branches()[i].tau / (m.branches()[i].tau + dt);
      W += mi * d.squaredNorm();
      const Vec3 phi = mi * d.cwiseQuotient(beta);
      P += 2.0 * (N * phi.asDiagonal() * N.transpose()) * F * A;
    }
    return W;
  }
  void update(const Mat3& F, const double* start, double dt, double* end) const {
    const Mat3 Finv = F.inverse();
    for (int i = 0; i < m.size(); ++i) {
      Mat3 A, N;
      Vec3 beta, d;
      double mean;
      if (!trial(F, start + kViscousValues * i, A, N, beta, d, mean)) continue;
      const double keep = m.branches()[i].tau / (m.branches()[i].tau + dt);
      const Vec3 be = (2.0 * (keep * d.array() + mean)).exp().matrix();
      const Mat3 An = Finv * (N * be.asDiagonal() * N.transpose()) * Finv.transpose();
      const double packed[6] = {An(0, 0), An(1, 1), An(2, 2), An(0, 1), An(1, 2), An(0, 2)};
      for (int k = 0; k < kViscousValues; ++k) end[kViscousValues * i + k] = packed[k];
    }
  }
};

// The closed forms against the reference at the poses of check_fd_and_update and at poses whose
// trial b has two or three eigenvalues apart by 1e-4 and 1e-8 (relative), for a rest history and a
// flowed one (F = T^{1/2} A^{-1/2} puts b = F A F^T at T): W, P and the update agree to 1e-12 of
// their size, plus 1e-15 of sum mu |F| for W and P. That floor is b's own rounding (eps |b|, in
// both paths): at three nearly equal eigenvalues W ~ m |d|^2 and P ~ m |d| are tiny, and against a
// long double computation both paths err by a few 1e-16 of mu |F| there (the closed forms no more
// than the eigensolver).
void check_against_reference() {
  const MaxwellBranches m({{0.7, 0.1}, {0.4, 2.0}, {1.3, 0.01}, {0.2, 30.0}});
  const Reference ref{m};
  const int width = kViscousValues * m.size();
  std::vector<double> rest(width), h(width), flowed(width);
  m.rest(rest.data());
  const Mat3 F1 = Vec3(2.0, 1 / std::sqrt(2.0), 1 / std::sqrt(2.0)).asDiagonal();
  m.update(F1, rest.data(), 0.05, h.data());
  Mat3 F2 = F1;
  F2(0, 1) = 0.8;
  F2 = rotation(0.7, Vec3(1, 2, 3)) * F2;
  m.update(F2, h.data(), 0.05, flowed.data());
  Mat3 shear = Mat3::Identity();
  shear(0, 1) = 1.5;
  Mat3 general;
  general << 1.3, 0.2, -0.1, 0.05, 0.8, 0.3, -0.2, 0.1, 1.1;
  const Mat3 R = rotation(0.9, Vec3(1, -2, 0.5));
  std::vector<std::pair<std::string, Mat3>> targets;  // T = b's wanted value, or F itself (flag below)
  for (double gap : {1e-4, 1e-8}) {
    char name[80];
    std::snprintf(name, sizeof name, "pair apart by %g, third below", gap);
    targets.push_back({name, R * Vec3(1.69, 1.69 * (1 + gap), 0.64).asDiagonal() * R.transpose()});
    std::snprintf(name, sizeof name, "pair apart by %g, third above", gap);
    targets.push_back({name, R * Vec3(0.7, 0.7 * (1 + gap), 2.5).asDiagonal() * R.transpose()});
    std::snprintf(name, sizeof name, "three apart by %g", gap);
    targets.push_back({name, 1.44 * R * Vec3(1 - gap, 1, 1 + gap).asDiagonal() * R.transpose()});
    std::snprintf(name, sizeof name, "three apart by %g near rest", gap);
    targets.push_back({name, R * Vec3(1 - gap, 1, 1 + 0.5 * gap).asDiagonal() * R.transpose()});
  }
  std::vector<std::pair<std::string, Mat3>> poses = {
      {"rest", Mat3::Identity()},
      {"uniform 1.2", 1.2 * Mat3::Identity()},
      {"stretch 2", Vec3(2.0, 0.75, 0.75).asDiagonal()},
      {"compression 0.5", Vec3(0.5, 1.3, 1.3).asDiagonal()},
      {"shear 1.5", shear},
      {"general", general},
      {"inverted", Vec3(1.1, 0.9, -0.8).asDiagonal()},
      {"two equal, rotated", rotation(0.3, Vec3(0, 1, 1)) * Vec3(1.4, 0.9, 0.9).asDiagonal()},
  };
  double worst[3] = {0, 0, 0};
  for (const std::vector<double>* hist : {&rest, &flowed}) {
    Mat3 A;
    const double* hv = hist->data();
    A << hv[0], hv[3], hv[5], hv[3], hv[1], hv[4], hv[5], hv[4], hv[2];  // branch 0's; every branch differs
    Eigen::SelfAdjointEigenSolver<Mat3> ea(A);
    const Mat3 A_minus_half = ea.operatorInverseSqrt();
    std::vector<std::pair<std::string, Mat3>> all = poses;
    for (const auto& [name, T] : targets) {
      Eigen::SelfAdjointEigenSolver<Mat3> et(T);
      all.push_back({name, et.operatorSqrt() * A_minus_half});
    }
    for (const auto& [name, F] : all)
      for (double dt : {0.0, 0.005, 1.0}) {
        Mat3 P_ref, P = Mat3::Zero();
        const double W_ref = ref.energy(F, hv, dt, P_ref), W = m.energy(F, hv, dt, &P);
        double floor = 0;  // 1e-15 sum mu |F| over 1e-12
        for (const MaxwellBranch& b : m.branches()) floor += 1e-3 * b.mu * F.norm();
        const double eW = std::fabs(W - W_ref) / (W_ref + floor), eP = (P - P_ref).norm() / (P_ref.norm() + floor);
        std::vector<double> end(width), end_ref(width);
        m.update(F, hv, dt, end.data());
        ref.update(F, hv, dt, end_ref.data());
        double eA = 0;
        for (int k = 0; k < width; ++k) eA = std::max(eA, std::fabs(end[k] - end_ref[k]));
        const std::string where = name + ", dt " + std::to_string(dt) + (hist == &rest ? ", rest C_v" : ", flowed C_v");
        CHECK_MSG(eW <= 1e-12, where + ": W against the eigensolver's, rel " + std::to_string(eW));
        CHECK_MSG(eP <= 1e-12, where + ": P against the eigensolver's, rel " + std::to_string(eP));
        CHECK_MSG(eA <= 1e-12, where + ": the update against the eigensolver's: " + std::to_string(eA));
        worst[0] = std::max(worst[0], eW);
        worst[1] = std::max(worst[1], eP);
        worst[2] = std::max(worst[2], eA);
        std::printf("  %-52s W %.1e  P %.1e  update %.1e\n", where.c_str(), eW, eP, eA);
      }
  }
  std::printf("  closed forms against the eigensolver: worst W %.1e, P %.1e, update %.1e\n", worst[0], worst[1], worst[2]);
}

// Strong compression: b's smallest eigenvalue far below the others, where q + shift would have an
// absolute error of eps |b| (so would the eigensolver's) and spectral3 takes it from det b. W and P
// of one branch at rest history against the same formulas in long double (b = F F^T and its
// eigensolve; long double's eps 1e-19 keeps l1 = 1e-6 to 1e-13): within 1e-13 at stretches 1e-2
// and 1e-3 (measured about 1e-15 and 7e-14 for P; the double eigensolver: 1.2e-12, 5.4e-12).
void check_strong_compression() {
  typedef Eigen::Matrix<long double, 3, 3> Mat3L;
  typedef Eigen::Matrix<long double, 3, 1> Vec3L;
  const MaxwellBranches m({{1.0, 1.0}});
  std::vector<double> rest(kViscousValues);
  m.rest(rest.data());
  const Mat3 R = rotation(0.9, Vec3(1, -2, 0.5)), R2 = rotation(2.1, Vec3(0.3, 1, -0.7));
  for (double stretch : {1e-2, 1e-3, -1e-3}) {
    const Mat3 F = R * Vec3(stretch, 1.0, 1.0).asDiagonal() * R2;
    const Mat3L FL = F.cast<long double>();
    Eigen::SelfAdjointEigenSolver<Mat3L> eig(FL * FL.transpose());
    const Vec3L beta = eig.eigenvalues();
    const Vec3L e = 0.5L * beta.array().log().matrix();
    const Vec3L d = e.array() - e.sum() / 3;
    const long double W_ref = d.squaredNorm();
    const Mat3L P_ref = 2.0L * (eig.eigenvectors() * d.cwiseQuotient(beta).asDiagonal() * eig.eigenvectors().transpose()) * FL;
    Mat3 P = Mat3::Zero();
    const double W = m.energy(F, rest.data(), 0.0, &P);
    const double eW = (double)(std::fabs(W - W_ref) / W_ref), eP = (double)((P.cast<long double>() - P_ref).norm() / P_ref.norm());
    std::printf("  compression to %g: W %.1e, P %.1e against long double\n", stretch, eW, eP);
    CHECK_MSG(eW <= 1e-13 && eP <= 1e-13, "strong compression " + std::to_string(stretch) + ": W " + std::to_string(eW) + ", P " + std::to_string(eP));
  }
}

// Simple shear gamma0 held from t = 0 (reached in the first step): the largest relative error of
// the shear stress against the closed form over t in (0, 5 tau], in steps of dt.
double relaxation_error(double dt, bool print) {
  const double mu_inf = 1.0, g = 0.3, tau = 0.1, gamma0 = 1e-3;
  const double mu1 = g * mu_inf / (1 - g);
  const MaxwellBranches m({{mu1, tau}});
  std::vector<double> h(kViscousValues), next(kViscousValues);
  m.rest(h.data());
  Mat3 F = Mat3::Identity();
  F(0, 1) = gamma0;
  const int steps = (int)std::lround(5 * tau / dt);
  double worst = 0;
  for (int n = 1; n <= steps; ++n) {
    // The equilibrium part: a linear shear modulus (Neo-Hookean's sigma_xy = mu gamma in simple
    // shear, exactly); the branch's Cauchy stress from its P (J = 1).
    const Mat3 sigma = stress(m, F, h.data(), dt) * F.transpose();
    const double s = mu_inf * gamma0 + sigma(0, 1);
    const double t = n * dt, exact = gamma0 * (mu_inf + mu1 * std::exp(-t / tau));
    worst = std::max(worst, std::fabs(s - exact) / exact);
    if (print && n % (steps / 5) == 0) std::printf("  t = %.2f tau: sigma_xy %.8e, closed form %.8e, rel %.2e\n", t / tau, s, exact, std::fabs(s - exact) / exact);
    m.update(F, h.data(), dt, next.data());
    h = next;
  }
  return worst;
}

void check_relaxation() {
  const double tau = 0.1;
  const double e20 = relaxation_error(tau / 20, true);
  const double e40 = relaxation_error(tau / 40, false), e80 = relaxation_error(tau / 80, false);
  const double order = std::log2(e40 / e80);
  std::printf("  standard linear solid, relaxation: worst rel error %.3e (dt = tau/20), %.3e (tau/40), %.3e (tau/80); order %.2f\n",
              e20, e40, e80, order);
  CHECK_MSG(e20 <= 5e-3, "relaxation within 0.5% at dt = tau/20: " + std::to_string(e20));
  CHECK_MSG(std::fabs(order - 1) < 0.1, "first order in dt: " + std::to_string(order));
}

// The shear stress of the standard linear solid at shear gamma after a step of dt from the branch's
// history h: mu_inf gamma (the equilibrium part, linear in shear) + the branch's sigma_xy.
double shear_stress(const MaxwellBranches& m, double mu_inf, double gamma, const double* h, double dt) {
  Mat3 F = Mat3::Identity();
  F(0, 1) = gamma;
  return mu_inf * gamma + (stress(m, F, h, dt) * F.transpose())(0, 1);
}

// Loss per cycle under gamma = gamma0 sin(omega t): the area of the stress-strain loop over one cycle
// after 8 tau (or 2 cycles) of transient, by the trapezoid rule in gamma (exact for the elastic part),
// against pi gamma0^2 mu1 omega tau / (1 + omega^2 tau^2).
void check_loss_per_cycle() {
  const double mu_inf = 1.0, g = 0.3, tau = 0.1, gamma0 = 1e-3, mu1 = g * mu_inf / (1 - g);
  const MaxwellBranches m({{mu1, tau}});
  for (double wt : {0.1, 1.0, 10.0}) {
    const double omega = wt / tau, period = 2 * M_PI / omega;
    const int per_cycle = (int)std::ceil(period / std::min(tau, period) * 400);
    const double dt = period / per_cycle;
    const int transient = per_cycle * (int)std::ceil(std::max(8 * tau, 2 * period) / period);
    std::vector<double> h(kViscousValues), next(kViscousValues);
    m.rest(h.data());
    double gamma_prev = 0, sigma_prev = 0, loss = 0;
    for (int n = 1; n <= transient + per_cycle; ++n) {
      const double gamma = gamma0 * std::sin(omega * n * dt);
      const double sigma = shear_stress(m, mu_inf, gamma, h.data(), dt);
      if (n > transient) loss += 0.5 * (sigma + sigma_prev) * (gamma - gamma_prev);
      Mat3 F = Mat3::Identity();
      F(0, 1) = gamma;
      m.update(F, h.data(), dt, next.data());
      h = next;
      gamma_prev = gamma;
      sigma_prev = sigma;
    }
    const double exact = M_PI * gamma0 * gamma0 * mu1 * wt / (1 + wt * wt);
    const double rel = std::fabs(loss - exact) / exact;
    std::printf("  loss per cycle, omega tau = %g: %.6e against %.6e, rel %.2e (%d steps per cycle)\n", wt, loss, exact,
                rel, per_cycle);
    CHECK_MSG(rel <= 1e-2, "loss per cycle within 1% at omega tau = " + std::to_string(wt) + ": " + std::to_string(rel));
  }
}

// Creep under a shear stress s0 held from t = 0: each step's gamma solves mu_inf gamma + sigma_branch
// = s0 (Newton on the scalar, with the exact tangent), against gamma(t) = s0/E_inf - s0 E_1 /
// (E_inf (E_inf + E_1)) e^{-t/tau_c}, tau_c = tau (E_inf + E_1) / E_inf (E_inf = mu_inf, E_1 = mu1).
void check_creep() {
  const double mu_inf = 1.0, g = 0.3, tau = 0.1, mu1 = g * mu_inf / (1 - g), s0 = 1e-3;
  const double tau_c = tau * (mu_inf + mu1) / mu_inf;
  const MaxwellBranches m({{mu1, tau}});
  double worst[2] = {0, 0};
  const double dts[2] = {tau / 20, tau / 40};
  for (int r = 0; r < 2; ++r) {
    const double dt = dts[r];
    std::vector<double> h(kViscousValues), next(kViscousValues);
    m.rest(h.data());
    double gamma = 0;
    for (int n = 1; n <= (int)std::lround(5 * tau_c / dt); ++n) {
      for (int it = 0; it < 20; ++it) {
        Mat3 F = Mat3::Identity();
        F(0, 1) = gamma;
        // d sigma_xy / d gamma at small strain: mu_inf + dP_xy/dF_xy of the branch (J = 1, sigma ~ P F^T).
        const double slope = mu_inf + m.stress_derivative(F, h.data(), dt)(3, 3);
        const double residual = shear_stress(m, mu_inf, gamma, h.data(), dt) - s0;
        gamma -= residual / slope;
        if (std::fabs(residual) < 1e-15) break;
      }
      Mat3 F = Mat3::Identity();
      F(0, 1) = gamma;
      m.update(F, h.data(), dt, next.data());
      h = next;
      const double t = n * dt;
      const double exact = s0 / mu_inf - s0 * mu1 / (mu_inf * (mu_inf + mu1)) * std::exp(-t / tau_c);
      worst[r] = std::max(worst[r], std::fabs(gamma - exact) / exact);
    }
  }
  std::printf("  creep: worst rel error %.3e (dt = tau/20), %.3e (tau/40), order %.2f\n", worst[0], worst[1],
              std::log2(worst[0] / worst[1]));
  CHECK_MSG(worst[0] <= 5e-3, "creep within 0.5% at dt = tau/20: " + std::to_string(worst[0]));
}

}  // namespace

int main() {
  check_fd_and_update();
  check_against_reference();
  check_strong_compression();
  check_relaxation();
  check_loss_per_cycle();
  check_creep();
  return check::summary("test_viscoelastic");
}

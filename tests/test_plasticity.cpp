// J2 plasticity in logarithmic strain (materials/log_strain_plasticity.cpp), alone, through the
// registry (material.plastic on model hencky):
//  - P against central differences of the condensed W, and dP/dF against central differences of P
//    (symmetric): at rest history and after plastic history (a stretch to 1.6 then a rotated shear),
//    with isotropic, kinematic, both and no hardening, at poses inside the elastic range, beyond
//    yield (stretch 2, shear 1.5, compression 0.5, equal eigenvalues), and within 1e-3 of the yield
//    surface on either side; the elastic model hencky likewise;
//    P against W also exactly on the yield surface (from a rest and a flowed history), and at
//    eigenvalues of C 1e-4 and 1e-8 apart (a pair, all three) after flow;
//  - the closed-form eigensystem (spectral3::eigensystem, the flowed tets' path): N orthonormal and
//    N diag(l) N^T = C to a few eps |C|, the eigenvalues those of Eigen's iterative solver, at
//    distinct, equal and nearly equal eigenvalues and strong compression; W and P from a flowed
//    history against the same formulas on Eigen's iterative eigensolver (the path before it);
//  - objectivity: W(QF) = W(F) and the update from QF is the update from F;
//  - the update is the local minimizer: the stored stress from the new history equals the
//    condensed P; the flow is isochoric (tr E_p = 0); dissipation >= 0 at every step here;
//  - uniaxial stress (the lateral stresses solved to zero by Newton with the model's tangent): in
//    the log strain E_11 and its conjugate stress T_11 the response is small-strain J2's, at any
//    strain: yield at sigma_y (within 0.1%), the hardening slope E H / (E + H) with H = H_iso +
//    H_kin (within 1%), the residual strain after unloading to zero stress against the closed form
//    ((sigma_max - sigma_y) / H; sigma_y / H_kin after the reverse yield of kinematic hardening), and
//    the elastic-perfectly plastic loop of a strain cycle +-eps_a: its area (trapezoids of T_11 dE_11)
//    and the sum of the steps' dissipation against 4 sigma_y (eps_a - sigma_y / E), within 1%.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "materials/material_factory.hpp"
#include "materials/spectral3.hpp"
#include "materials/symmetric6.hpp"

using namespace hyperqn;

namespace {

constexpr double kMu = 80.0, kLambda = 120.0, kSigmaY = 0.4;  // E = mu (3 lambda + 2 mu) / (lambda + mu) = 208
const double kYoung = kMu * (3 * kLambda + 2 * kMu) / (kLambda + kMu);

std::unique_ptr<InelasticModel> plastic(double sigma_y, double h_iso, double h_kin) {
  MaterialSpec spec;
  spec.model = "hencky";
  spec.mu = kMu;
  spec.lambda = kLambda;
  spec.inelastic.kind = "plastic";
  spec.inelastic.values = {{"yield_stress", sigma_y}, {"isotropic_hardening", h_iso}, {"kinematic_hardening", h_kin}};
  return make_inelastic(spec);
}

Mat3 unit(int k) {
  Mat3 E = Mat3::Zero();
  E(k) = 1.0;
  return E;
}

Mat3 rotation(double a, const Vec3& axis) { return Eigen::AngleAxisd(a, axis.normalized()).toRotationMatrix(); }

Mat3 stress(const InelasticModel& m, const Mat3& F, const double* h) {
  Mat3 P = Mat3::Zero();
  m.energy(F, h, 0.1, &P);
  return P;
}

// FD of W vs P (step 1e-6) and of P vs dP/dF (step ds; ds = 0: P only, where dP/dF jumps: on the
// yield surface).
void check_derivatives(const InelasticModel& m, const Mat3& F, const double* h, const std::string& where,
                       double ds = 1e-6) {
  const Mat3 P = stress(m, F, h);
  Mat3 P_fd;
  // On the surface W'' jumps: central differences err by about the step times the jump, so a step
  // of 1e-9 there (W's rounding over it is still below 1e-7 of P).
  const double dw = ds == 0 ? 1e-9 : 1e-6;
  for (int k = 0; k < 9; ++k)
    P_fd(k) = (m.energy(F + dw * unit(k), h, 0.1, nullptr) - m.energy(F - dw * unit(k), h, 0.1, nullptr)) / (2 * dw);
  const double err_P = (P_fd - P).norm() / std::max(1e-3, P.norm());
  CHECK_MSG(err_P <= 1e-6, where + ": P vs FD of W, rel err " + std::to_string(err_P));
  if (ds == 0) {
    std::printf("  %-58s P %.1e\n", where.c_str(), err_P);
    return;
  }
  const Mat9 H = m.stress_derivative(F, h, 0.1);
  Mat9 H_fd;
  for (int k = 0; k < 9; ++k) {
    const Mat3 dP = (stress(m, F + ds * unit(k), h) - stress(m, F - ds * unit(k), h)) / (2 * ds);
    H_fd.col(k) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  const double err_H = (H_fd - H).norm() / std::max(1e-12, H.norm());
  CHECK_MSG(err_H <= 1e-5, where + ": dP/dF vs FD of P, rel err " + std::to_string(err_H));
  const double asym = (H - H.transpose()).norm() / std::max(1e-12, H.norm());
  CHECK_MSG(asym <= 1e-10, where + ": dP/dF asymmetric, rel " + std::to_string(asym));
  std::printf("  %-58s P %.1e  dP/dF %.1e\n", where.c_str(), err_P, err_H);
}

// The trial yield function's value relative to the yield radius at F from history h, by bisection
// on the scale s of the log strain: F(s) = exp(s log V) for a diagonal pose (the pose's scale that
// puts it at the yield surface).
double elastic_scale(const InelasticModel& m, const Vec3& log_stretch, const double* h) {
  // The flow begins where the update first moves E_p along the ray.
  double lo = 0, hi = 1;
  for (int it = 0; it < 200; ++it) {
    const double s = 0.5 * (lo + hi);
    const Mat3 F = (s * log_stretch).array().exp().matrix().asDiagonal();
    std::vector<double> end(m.history_width());
    m.update(F, h, 0.1, end.data());
    bool flowed = false;
    for (int k = 0; k < m.history_width(); ++k) flowed = flowed || end[k] != h[k];
    (flowed ? hi : lo) = s;
  }
  return 0.5 * (lo + hi);
}

void check_fd() {
  struct Hardening {
    const char* name;
    double iso, kin;
  };
  const Mat3 F1 = Vec3(1.6, 1 / std::sqrt(1.6), 1 / std::sqrt(1.6)).asDiagonal();
  Mat3 F2 = F1;
  F2(0, 1) = 0.7;
  F2 = rotation(0.7, Vec3(1, 2, 3)) * F2;
  Mat3 shear = Mat3::Identity();
  shear(0, 1) = 1.5;
  Mat3 general;
  general << 1.3, 0.2, -0.1, 0.05, 0.8, 0.3, -0.2, 0.1, 1.1;
  const std::vector<std::pair<std::string, Mat3>> poses = {
      {"rest", Mat3::Identity()},
      {"elastic 1e-3 stretch", Vec3(1.001, 0.9996, 0.9997).asDiagonal()},
      {"uniform 1.2 (equal eigenvalues, elastic)", 1.2 * Mat3::Identity()},
      {"stretch 2", Vec3(2.0, 0.75, 0.75).asDiagonal()},
      {"compression 0.5", Vec3(0.5, 1.3, 1.3).asDiagonal()},
      {"shear 1.5", shear},
      {"general", general},
      {"inverted", Vec3(1.1, 0.9, -0.8).asDiagonal()},
      {"two equal eigenvalues, rotated", rotation(0.3, Vec3(0, 1, 1)) * Vec3(1.4, 0.9, 0.9).asDiagonal()},
  };
  // Nearly equal eigenvalues of C (checked after flow: the closed-form eigenvectors' hard case).
  std::vector<std::pair<std::string, Mat3>> close;
  for (double gap : {1e-4, 1e-8}) {
    const Mat3 R = rotation(0.9, Vec3(1, -2, 0.5));
    close.push_back({"pair apart by " + std::to_string(gap), R * Vec3(1.3, 1.3 * std::sqrt(1 + gap), 0.8).asDiagonal()});
    close.push_back(
        {"three apart by " + std::to_string(gap), 1.2 * R * Vec3(std::sqrt(1 - gap), 1, std::sqrt(1 + gap)).asDiagonal()});
  }
  for (const Hardening& hard : {Hardening{"iso", 5.0, 0.0}, Hardening{"kin", 0.0, 7.0}, Hardening{"both", 5.0, 7.0},
                                Hardening{"none", 0.0, 0.0}}) {
    const auto m = plastic(kSigmaY, hard.iso, hard.kin);
    std::vector<double> rest(m->history_width()), h1(m->history_width()), h2(m->history_width());
    m->rest(rest.data());
    m->update(F1, rest.data(), 0.1, h1.data());
    m->update(F2, h1.data(), 0.1, h2.data());
    CHECK_MSG(h2[6] > h1[6] && h1[6] > 0, std::string(hard.name) + ": the history flowed twice");
    CHECK_MSG(std::fabs(h2[0] + h2[1] + h2[2]) < 1e-14, "isochoric flow: tr E_p = 0");
    for (const auto& [name, F] : poses)
      for (const std::vector<double>* hist : {&rest, &h2})
        check_derivatives(*m, F, hist->data(), name + ", " + hard.name + (hist == &rest ? ", rest" : ", flowed"));
    for (const auto& [name, F] : close) check_derivatives(*m, F, h2.data(), name + ", " + hard.name + ", flowed");
    // Near the yield surface, on either side (1e-3 of the yield scale; FD steps well inside).
    const Vec3 ray(std::log(1.3), -0.5 * std::log(1.3), -0.5 * std::log(1.3));
    for (const std::vector<double>* hist : {&rest, &h2}) {
      const double s = elastic_scale(*m, ray, hist->data());
      for (double side : {-1e-3, 1e-3}) {
        const Mat3 F = rotation(0.4, Vec3(1, 1, 0)) * Mat3(((1 + side) * s * ray).array().exp().matrix().asDiagonal());
        check_derivatives(*m, F, hist->data(),
                          std::string(side < 0 ? "inside" : "beyond") + " the yield surface by 1e-3, " + hard.name +
                              (hist == &rest ? ", rest" : ", flowed"),
                          1e-8);
      }
      const Mat3 F = rotation(0.4, Vec3(1, 1, 0)) * Mat3((s * ray).array().exp().matrix().asDiagonal());
      check_derivatives(*m, F, hist->data(),
                        std::string("on the yield surface, ") + hard.name + (hist == &rest ? ", rest" : ", flowed"), 0);
    }
    // Objectivity.
    const Mat3 Q = rotation(1.1, Vec3(-1, 0.5, 2));
    std::vector<double> hq(m->history_width()), h3(m->history_width());
    m->update(Q * general, h2.data(), 0.1, hq.data());
    m->update(general, h2.data(), 0.1, h3.data());
    double diff = 0;
    for (int k = 0; k < m->history_width(); ++k) diff = std::max(diff, std::fabs(hq[k] - h3[k]));
    CHECK_MSG(diff < 1e-13, std::string(hard.name) + ": the update from QF is the update from F: " + std::to_string(diff));
    const double W = m->energy(general, h2.data(), 0.1, nullptr);
    CHECK_MSG(std::fabs(m->energy(Q * general, h2.data(), 0.1, nullptr) - W) < 1e-13 * std::max(1.0, W), "W(QF) = W(F)");
    // The update is the minimizer: the stored stress from the end's history is the condensed P.
    for (const auto& [name, F] : poses) {
      std::vector<double> end(m->history_width());
      m->update(F, h2.data(), 0.1, end.data());
      Mat3 Ps = Mat3::Zero();
      m->stored_energy(F, end.data(), &Ps);
      const Mat3 Pc = stress(*m, F, h2.data());
      CHECK_MSG((Pc - Ps).norm() <= 1e-10 * std::max(1.0, Pc.norm()), "stored stress = condensed stress at " + name);
      CHECK_MSG(m->dissipation(F, h2.data(), 0.1, end.data()) >= 0, "dissipation >= 0 at " + name);
    }
    CHECK(std::isinf(m->energy(Vec3(1.0, 1.0, 0.0).asDiagonal(), rest.data(), 0.1, nullptr)));
  }
  // The elastic model hencky: the plastic energy at rest history within the elastic range.
  const auto hencky = make_material("hencky", kMu, kLambda, 0.1);
  const auto m = plastic(kSigmaY, 0, 0);
  std::vector<double> rest(m->history_width());
  m->rest(rest.data());
  for (const auto& [name, F] : poses) {
    const double h = 1e-6;
    Mat3 P, P_fd, Pp;
    const double psi = hencky->energy_and_stress(F, P);
    if (name == "elastic 1e-3 stretch" || name == "rest" || name.rfind("uniform", 0) == 0)
      CHECK_MSG(std::fabs(psi - m->energy(F, rest.data(), 0.1, nullptr)) <= 1e-14 * std::max(1.0, psi),
                "hencky = plastic at rest history in the elastic range");
    for (int k = 0; k < 9; ++k) {
      P_fd(k) = (hencky->energy(F + h * unit(k)) - hencky->energy(F - h * unit(k))) / (2 * h);
      Mat3 Pa, Pb;
      hencky->energy_and_stress(F + h * unit(k), Pa);
      hencky->energy_and_stress(F - h * unit(k), Pb);
      Pp = (Pa - Pb) / (2 * h);
      const Mat9 H = hencky->stress_derivative(F);
      CHECK_MSG((Eigen::Map<const Eigen::Matrix<double, 9, 1>>(Pp.data()) - H.col(k)).norm() <= 1e-5 * H.norm(),
                "hencky dP/dF vs FD at " + name);
    }
    CHECK_MSG((P_fd - P).norm() <= 1e-6 * std::max(1.0, P.norm()), "hencky P vs FD at " + name);
  }
}

// Deformation gradients F whose C = F^T F has eigenvalues distinct, equal, nearly equal (1e-4 to
// 1e-12 apart: the low pair, the high pair, all three) and far apart (strong compression), rotated.
std::vector<std::pair<std::string, Mat3>> spectra() {
  const Mat3 R = rotation(0.9, Vec3(1, -2, 0.5)), R2 = rotation(2.1, Vec3(0.3, 1, -0.7));
  std::vector<std::pair<std::string, Vec3>> stretches = {
      {"distinct", Vec3(0.8, 1.1, 1.4)}, {"uniform", Vec3(1.2, 1.2, 1.2)}, {"low pair equal", Vec3(0.9, 0.9, 1.3)},
      {"high pair equal", Vec3(0.9, 1.3, 1.3)}, {"compression 1e-2", Vec3(1e-2, 1.0, 1.1)},
      {"compression 1e-3", Vec3(1e-3, 1.2, 0.9)}, {"two compressed", Vec3(1e-2, 2e-2, 1.0)}};
  for (double gap : {1e-4, 1e-8, 1e-12}) {
    char g[16];
    std::snprintf(g, sizeof g, "%.0e", gap);
    stretches.push_back({std::string("low pair ") + g, Vec3(0.9, 0.9 * std::sqrt(1 + gap), 1.3)});
    stretches.push_back({std::string("high pair ") + g, Vec3(0.9, 1.3, 1.3 * std::sqrt(1 + gap))});
    stretches.push_back({std::string("three ") + g, Vec3(std::sqrt(1 - gap), 1, std::sqrt(1 + gap))});
  }
  std::vector<std::pair<std::string, Mat3>> F;
  for (const auto& [name, l] : stretches) F.push_back({name, R * l.asDiagonal() * R2});
  return F;
}

// spectral3::eigensystem of C = F^T F (det C = (det F)^2, as the model passes it): N orthonormal to
// 1e-15, N diag(l) N^T = C within 4 eps |C|, the eigenvalues those of the long-double solver within
// 4 eps |C| and, where the smallest is far below the others (taken from det C), within 1e-13 of it.
void check_eigensystem() {
  double worst[4] = {};
  for (const auto& [name, F] : spectra()) {
    const Mat3 b = F.transpose() * F;
    const double J = F.determinant();
    const spectral3::Eigensystem e = spectral3::eigensystem(b, J * J);
    const Vec3 l(e.lambda[0], e.lambda[1], e.lambda[2]);
    const double orth = (e.N.transpose() * e.N - Mat3::Identity()).norm();
    const double res = (e.N * l.asDiagonal() * e.N.transpose() - b).norm() / b.norm();
    Vec3 sorted = l;
    std::sort(sorted.data(), sorted.data() + 3);
    const Eigen::Matrix<long double, 3, 3> FL = F.cast<long double>();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<long double, 3, 3>> ref(FL.transpose() * FL);
    const double err = (sorted - ref.eigenvalues().cast<double>()).norm() / b.norm();
    const double small = std::fabs(sorted(0) / (double)ref.eigenvalues()(0) - 1);
    std::printf("  eigensystem, %-18s orthogonality %.1e  residual %.1e  eigenvalues %.1e (smallest rel %.1e)\n",
                name.c_str(), orth, res, err, small);
    CHECK_MSG(orth <= 1e-15 && res <= 4 * 2.2e-16 && err <= 4 * 2.2e-16, "eigensystem of " + name);
    CHECK_MSG(sorted(0) > 0.25 * sorted(1) || small <= 1e-13, "the smallest eigenvalue from det C: " + name);
    for (int a = 0; a < 3; ++a)
      CHECK_MSG(std::fabs(e.lambda[a] - b.trace() / 3 - e.shift[a]) <= 4e-16 * b.norm(), "shift = l - q: " + name);
    const double got[3] = {orth, res, err};
    for (int k = 0; k < 3; ++k) worst[k] = std::max(worst[k], got[k]);
    if (sorted(0) <= 0.25 * sorted(1)) worst[3] = std::max(worst[3], small);
  }
  std::printf("  eigensystem: worst orthogonality %.1e, residual %.1e, eigenvalues %.1e, a small one rel %.1e\n",
              worst[0], worst[1], worst[2], worst[3]);
}

// W and P of the plastic model from a flowed history by the same formulas on Eigen's iterative
// eigensolver (the path before the closed-form eigensystem: log[x, y] by atanh), in Scalar.
template <class Scalar>
Scalar reference_energy(const Mat3& F_in, const double* h, double sigma_y, double H_iso, double H_kin,
                        Eigen::Matrix<Scalar, 3, 3>* P) {
  typedef Eigen::Matrix<Scalar, 3, 3> M3;
  typedef Eigen::Matrix<Scalar, 3, 1> V3;
  const Scalar mu = kMu, kappa = kLambda + 2 * Scalar(kMu) / 3, two3 = Scalar(2) / 3, r23 = std::sqrt(two3);
  const M3 F = F_in.cast<Scalar>();
  const Eigen::SelfAdjointEigenSolver<M3> eig(F.transpose() * F);
  const M3 N = eig.eigenvectors();
  const V3 l = eig.eigenvalues();
  V3 E;
  for (int a = 0; a < 3; ++a) E(a) = std::log(l(a)) / 2;
  const Scalar theta = E.sum();
  M3 e = M3::Zero();
  for (int a = 0; a < 3; ++a) e(a, a) = E(a) - theta / 3;
  const M3 Epn = N.transpose() * unpack_symmetric(h).cast<Scalar>() * N;
  const M3 xi = 2 * mu * (e - Epn) - two3 * Scalar(H_kin) * Epn;
  const Scalar f = xi.norm() - r23 * (Scalar(sigma_y) + Scalar(H_iso) * Scalar(h[6]));
  const Scalar gamma = f > 0 ? f / (2 * mu + two3 * Scalar(H_kin + H_iso)) : Scalar(0);
  const M3 Ep = gamma > 0 ? M3(Epn + gamma * xi / xi.norm()) : Epn;
  const Scalar alpha = Scalar(h[6]) + r23 * gamma;
  const M3 T = 2 * mu * (e - Ep) + kappa * theta * M3::Identity();
  M3 Sp;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const Scalar x = l(a), y = l(b), s = (x - y) / (x + y);
      const Scalar d = std::fabs(s) < Scalar(1e-6) ? 2 / (x + y) * (1 + s * s / 3) : 2 * std::atanh(s) / (s * (x + y));
      Sp(a, b) = d * T(a, b);
    }
  *P = F * (N * Sp * N.transpose());
  return mu * (e - Ep).squaredNorm() + kappa * theta * theta / 2 + Scalar(H_iso) * alpha * alpha / 2 +
         Scalar(H_kin) / 3 * Ep.squaredNorm() + r23 * Scalar(sigma_y) * gamma;
}

// The flowed tets' path (closed-form eigensystem) against the same formulas in long double: W
// within 1e-13 and P within 1e-12 of their size at every spectrum above; the iterative eigensolver
// in double (the path before) beside it, within the same bounds but at strong compression, where
// its smallest eigenvalue has an absolute error of eps |C|.
void check_against_eigensolver() {
  const double iso = 5.0, kin = 7.0;
  const auto m = plastic(kSigmaY, iso, kin);
  std::vector<double> rest(m->history_width()), h1(m->history_width()), h2(m->history_width());
  m->rest(rest.data());
  const Mat3 F1 = Vec3(1.6, 1 / std::sqrt(1.6), 1 / std::sqrt(1.6)).asDiagonal();
  Mat3 F2 = F1;
  F2(0, 1) = 0.7;
  m->update(F1, rest.data(), 0.1, h1.data());
  m->update(rotation(0.7, Vec3(1, 2, 3)) * F2, h1.data(), 0.1, h2.data());
  double worst[4] = {};
  for (const auto& [name, F0] : spectra()) {
    for (double scale : {1.0, 1.15}) {  // elastic from the flowed history, and flowing further
      const Mat3 F = scale * F0;
      Mat3 P = Mat3::Zero(), P_old;
      Eigen::Matrix<long double, 3, 3> P_ref;
      const double W = m->energy(F, h2.data(), 0.1, &P);
      const long double W_ref = reference_energy<long double>(F, h2.data(), kSigmaY, iso, kin, &P_ref);
      const double W_old = reference_energy<double>(F, h2.data(), kSigmaY, iso, kin, &P_old);
      const Mat3 Pr = P_ref.cast<double>();
      const double eW = std::fabs(W - (double)W_ref) / std::fabs((double)W_ref), eP = (P - Pr).norm() / Pr.norm();
      const double oW = std::fabs(W_old - (double)W_ref) / std::fabs((double)W_ref), oP = (P_old - Pr).norm() / Pr.norm();
      std::printf("  flowed history, %-18s x %.2f  W %.1e  P %.1e against long double (iterative solver: %.1e, %.1e)\n",
                  name.c_str(), scale, eW, eP, oW, oP);
      CHECK_MSG(eW <= 1e-13 && eP <= 1e-12, "closed form at " + name + ": W " + std::to_string(eW) + ", P " +
                                                std::to_string(eP));
      if (name.rfind("compression", 0) != 0 && name != "two compressed")
        CHECK_MSG(oW <= 1e-13 && oP <= 1e-12, "the iterative solver's at " + name);
      const double got[4] = {eW, eP, oW, oP};
      for (int k = 0; k < 4; ++k) worst[k] = std::max(worst[k], got[k]);
    }
  }
  std::printf("  flowed history against long double: worst W %.1e, P %.1e (the iterative solver's %.1e, %.1e)\n",
              worst[0], worst[1], worst[2], worst[3]);
}

// A uniaxial-stress material point: F = diag(exp(e), l, l), l solved so that P_22 = P_33 = 0.
struct Uniaxial {
  const InelasticModel& m;
  std::vector<double> h, next;
  double lateral = 1.0;
  double dissipated = 0;
  bool negative = false;
  explicit Uniaxial(const InelasticModel& model) : m(model), h(model.history_width()), next(model.history_width()) {
    m.rest(h.data());
  }
  Mat3 F(double e) const { return Vec3(std::exp(e), lateral, lateral).asDiagonal(); }
  // The step to log strain e: T_11 at its end (T = S C for a diagonal pose: T_11 = P_11 F_11).
  double step(double e) {
    for (int it = 0; it < 50; ++it) {
      const Mat3 P = stress(m, F(e), h.data());
      if (std::fabs(P(1, 1)) < 1e-13 * kYoung) break;
      const Mat9 H = m.stress_derivative(F(e), h.data(), 0.1);
      lateral -= P(1, 1) / (H(4, 4) + H(4, 8));  // F_22 and F_33 move together
    }
    const Mat3 P = stress(m, F(e), h.data());
    m.update(F(e), h.data(), 0.1, next.data());
    const double D = m.dissipation(F(e), h.data(), 0.1, next.data());
    negative = negative || D < 0;
    dissipated += D;
    h = next;
    return P(0, 0) * std::exp(e);
  }
};

void check_uniaxial() {
  struct Case {
    const char* name;
    double iso, kin;
  };
  for (const Case& c : {Case{"isotropic", 20.0, 0.0}, Case{"kinematic", 0.0, 20.0}, Case{"both", 12.0, 8.0}}) {
    const auto m = plastic(kSigmaY, c.iso, c.kin);
    Uniaxial u(*m);
    const double H = c.iso + c.kin, slope = kYoung * H / (kYoung + H);
    // 200 steps to log strain 0.2 (about 100 times the yield strain).
    std::vector<double> e, s;
    for (int n = 1; n <= 200; ++n) {
      e.push_back(0.2 * n / 200);
      s.push_back(u.step(e.back()));
    }
    // Yield: the intersection of the elastic line through the first step and the plastic line
    // through the last two.
    const double E_fit = s[0] / e[0];
    const double H_fit = (s[199] - s[198]) / (e[199] - e[198]);
    const double e_y = (s[199] - H_fit * e[199]) / (E_fit - H_fit);
    const double sigma_y = E_fit * e_y;
    std::printf("  uniaxial %-10s E %.6f (exact %.6f)  yield %.6f (sigma_y %.3f, rel %.1e)  slope %.6f (E H/(E+H) "
                "%.6f, rel %.1e)\n",
                c.name, E_fit, kYoung, sigma_y, kSigmaY, sigma_y / kSigmaY - 1, H_fit, slope, H_fit / slope - 1);
    CHECK_MSG(std::fabs(sigma_y / kSigmaY - 1) <= 1e-3, std::string(c.name) + ": yield at sigma_y within 0.1%");
    CHECK_MSG(std::fabs(H_fit / slope - 1) <= 1e-2, std::string(c.name) + ": hardening slope within 1%");
    // Unloading: elastic down to the reverse yield stress beta - R (back stress beta = H_kin eps_p,
    // radius R = sigma_y + H_iso eps_p). Where that is below zero (isotropic, both) zero stress is
    // reached elastically and the residual log strain is the plastic one, (sigma_max - sigma_y) / H;
    // where not (kinematic alone: Bauschinger), the reverse flow (slope E H / (E + H) again) reaches
    // zero stress at eps_p = sigma_y / H_kin, the residual strain.
    const double s_max = s.back(), e_max = e.back();
    const double eps_p = (s_max - kSigmaY) / H;
    const double s_rev = c.kin * eps_p - (kSigmaY + c.iso * eps_p);
    double e_zero = e_max - s_max / kYoung, residual = eps_p;
    if (s_rev > 0) {
      const double e_rev = e_max - (s_max - s_rev) / kYoung;
      const double at_rev = u.step(e_rev);
      CHECK_MSG(std::fabs(at_rev / s_rev - 1) <= 1e-9, "reverse yield at beta - R");
      e_zero = e_rev - s_rev / slope;
      residual = kSigmaY / c.kin;
    }
    const double s_at = u.step(e_zero);
    std::printf("  unloaded to T_11 %.2e at E_11 %.8f, the closed form's residual strain %.8f (rel %.1e)%s\n", s_at,
                e_zero, residual, e_zero / residual - 1, s_rev > 0 ? " after reverse yield" : "");
    CHECK_MSG(std::fabs(s_at) <= 1e-9 * s_max, "unloading reaches zero stress where the closed form says");
    CHECK_MSG(std::fabs(e_zero / residual - 1) <= 1e-6, "residual strain as the closed form");
    CHECK_MSG(!u.negative, "dissipation never negative");
  }
  // Elastic-perfectly plastic: the loop of a strain cycle eps_a -> -eps_a -> eps_a.
  const auto m = plastic(kSigmaY, 0, 0);
  Uniaxial u(*m);
  const double eps_a = 0.01;  // 5.2 yield strains
  const int n = 1000;
  double s_prev = 0, e_prev = 0;
  for (int k = 1; k <= n / 4; ++k) s_prev = u.step(e_prev = eps_a * k / (n / 4));
  u.dissipated = 0;
  double area = 0;
  for (int k = 1; k <= n; ++k) {
    const double e = k <= n / 2 ? eps_a - 2 * eps_a * k / (n / 2) : -eps_a + 2 * eps_a * (k - n / 2) / (n / 2);
    const double s = u.step(e);
    area += 0.5 * (s + s_prev) * (e - e_prev);
    s_prev = s;
    e_prev = e;
  }
  area = std::fabs(area);
  const double exact = 4 * kSigmaY * (eps_a - kSigmaY / kYoung);
  std::printf("  perfectly plastic loop +-%.3g: area %.6e, dissipated %.6e, 4 sigma_y (eps_a - sigma_y/E) %.6e "
              "(rel %.1e, %.1e)\n",
              eps_a, area, u.dissipated, exact, area / exact - 1, u.dissipated / exact - 1);
  CHECK_MSG(std::fabs(area / exact - 1) <= 1e-2, "loop area within 1%");
  CHECK_MSG(std::fabs(u.dissipated / exact - 1) <= 1e-2, "dissipation per cycle within 1%");
  CHECK_MSG(!u.negative, "dissipation never negative");
}

void check_refusals() {
  for (const auto& [sy, hi, hk] : {std::tuple{0.0, 0.0, 0.0}, std::tuple{-1.0, 0.0, 0.0}, std::tuple{1.0, -1.0, 0.0},
                                   std::tuple{1.0, 0.0, -1.0}}) {
    bool refused = false;
    try {
      plastic(sy, hi, hk);
    } catch (const std::invalid_argument&) {
      refused = true;
    }
    CHECK_MSG(refused, "a yield stress <= 0 or a negative hardening modulus is refused");
  }
}

}  // namespace

int main() {
  check_fd();
  check_eigensystem();
  check_against_eigensolver();
  check_uniaxial();
  check_refusals();
  return check::summary("test_plasticity");
}

// Materials against finite differences: P vs d psi/dF, dP/dF vs dP/dF by differences, symmetry,
// invariance and the rest-pose null space, at rest, uniform scaling, general, near-degenerate,
// small-J, J = 0 and inverted poses. Also the signed SVD and the material factory.
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
#include "materials/material.hpp"
#include "materials/material_factory.hpp"
#include "materials/svd3.hpp"

using namespace hyperqn;

namespace {

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

void check_pose(const Material& m, const std::string& label, const Pose& pose, Worst& worst) {
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
  CHECK_MSG(std::abs(m.energy(F * Q) - psi) <= 1e-12 * scale, where + ": psi(FQ) != psi(F)");
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

// sigma_2 + sigma_3 = 0 (R jumps): the clamped dP/dF must stay finite. No FD here: psi is not C2.
void check_corotated_clamp(const std::string& label, const Material& m) {
  const Mat3 F = random_rotation() * Vec3(1.0, 0.5, -0.5).asDiagonal() * random_rotation().transpose();
  Mat3 P;
  const double psi = m.energy_and_stress(F, P);
  CHECK_MSG(std::isfinite(psi) && P.allFinite() && m.stress_derivative(F).allFinite(),
            label + " at sigma2 + sigma3 = 0: non-finite");
}

void check_factory() {
  CHECK(make_material("corotated", 1.3, 2.1, 0.1)->name() == "corotated");
  CHECK(make_material("neohookean", 1.3, 2.1, 0.1)->name() == "neohookean");
  bool threw = false;
  try {
    make_material("stvk", 1.0, 1.0, 0.1);
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK_MSG(threw, "make_material(\"stvk\") should throw std::invalid_argument");
  threw = false;
  try {
    make_material("neohookean", 1.0, 1.0, 0.0);
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK_MSG(threw, "make_material(neohookean, J0 = 0) should throw std::invalid_argument");
  CHECK_NEAR(make_corotated(1.3, 2.1)->laplacian_weight(), 2.0 * 1.3 + 2.1, 1e-15);
  CHECK_NEAR(make_neohookean(1.3, 2.1, 0.1)->laplacian_weight(), 2.0066 * 1.3 + 1.0122 * 2.1, 1e-15);
  // PD is exact for ARAP (corotated, lambda = 0) only.
  CHECK(make_corotated(1.3, 0.0)->projective_dynamics_exact());
  CHECK(!make_corotated(1.3, 2.1)->projective_dynamics_exact());
  CHECK(!make_neohookean(1.3, 0.0, 0.1)->projective_dynamics_exact());
}

}  // namespace

int main() {
  const std::vector<Pose> poses = make_poses();
  for (const Pose& p : poses) check_signed_svd(p);

  struct Case {
    std::string label;
    std::unique_ptr<Material> m;
  };
  std::vector<Case> cases;
  cases.push_back({"corotated(mu=1.3, lambda=2.1)", make_corotated(1.3, 2.1)});
  cases.push_back({"corotated(mu=1.3, lambda=0)", make_corotated(1.3, 0.0)});
  cases.push_back({"neohookean(mu=1.3, lambda=2.1, J0=0.1)", make_neohookean(1.3, 2.1, 0.1)});
  cases.push_back({"neohookean(mu=1.3, lambda=0, J0=0.1)", make_neohookean(1.3, 0.0, 0.1)});

  for (const Case& c : cases) {
    Worst worst;
    check_rest(*c.m, c.label);
    for (const Pose& p : poses) check_pose(*c.m, c.label, p, worst);
    std::printf("%-40s worst FD rel err: P %.1e, dPdF %.1e\n", c.label.c_str(), worst.stress, worst.hessian);
  }
  check_corotated_rest_spectrum(1.3, 2.1, cases[0].label);
  check_corotated_rest_spectrum(1.3, 0.0, cases[1].label);
  check_corotated_clamp(cases[0].label, *cases[0].m);
  check_corotated_clamp(cases[1].label, *cases[1].m);
  check_factory();
  return check::summary("test_materials");
}

// Springs: one spring (materials/spring, also the strand segment) and the mass-spring tets
// (materials/tet_springs): gradients and Hessians against finite differences, the PSD fix, and
// the spring Laplacian.
#include <random>

#include "check.hpp"
#include "materials/spring.hpp"
#include "materials/tet_springs.hpp"

using namespace hyperqn;
namespace ts = hyperqn::tet_springs;

static double rel(double a, double b) { return std::fabs(a - b) / std::max(1.0, std::fabs(b)); }

static void check_pose(const std::string& name, const Mat3& F, const Mat3& Dm, double k) {
  Mat3 P;
  const double e = ts::energy_and_stress(F, Dm, k, P);
  CHECK_NEAR(e, ts::energy(F, Dm, k), 1e-15 * std::max(1.0, e));
  const double h = 1e-6;
  double errP = 0, errC = 0;
  const Mat9 C = ts::stress_derivative(F, Dm, k, false);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      Mat3 Fp = F, Fm = F;
      Fp(i, j) += h;
      Fm(i, j) -= h;
      errP = std::max(errP, rel((ts::energy(Fp, Dm, k) - ts::energy(Fm, Dm, k)) / (2 * h), P(i, j)));
      Mat3 Pp, Pm;
      ts::energy_and_stress(Fp, Dm, k, Pp);
      ts::energy_and_stress(Fm, Dm, k, Pm);
      const Mat3 dP = (Pp - Pm) / (2 * h);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) errC = std::max(errC, rel(dP(a, b), C(a + 3 * b, i + 3 * j)));
    }
  CHECK_MSG(errP < 1e-6, name + ": P vs FD " + std::to_string(errP));
  CHECK_MSG(errC < 1e-5, name + ": dP/dF vs FD " + std::to_string(errC));
  CHECK_MSG((C - C.transpose()).norm() <= 1e-12 * C.norm(), name + ": dP/dF symmetric");
  const Mat9 Cpsd = ts::stress_derivative(F, Dm, k, true);
  const double min_eig = Eigen::SelfAdjointEigenSolver<Mat9>(Cpsd).eigenvalues().minCoeff();
  CHECK_MSG(min_eig >= -1e-10 * Cpsd.norm(), name + ": PSD-fixed dP/dF has eigenvalue " + std::to_string(min_eig));
}

// One spring k/2 (|u| - L)^2 at edge u: dE/du and d2E/du2 against central differences.
static void check_spring(const std::string& name, const Vec3& u, double L, double k) {
  const double h = 1e-6 * std::max(1.0, u.norm());
  const Vec3 g = spring::gradient(u, L, k);
  const Mat3 K = spring::stiffness(u, L, k, false);
  double errg = 0, errK = 0;
  for (int i = 0; i < 3; ++i) {
    Vec3 up = u, um = u;
    up[i] += h;
    um[i] -= h;
    errg = std::max(errg, rel((spring::energy(up, L, k) - spring::energy(um, L, k)) / (2 * h), g[i]));
    const Vec3 dg = (spring::gradient(up, L, k) - spring::gradient(um, L, k)) / (2 * h);
    for (int a = 0; a < 3; ++a) errK = std::max(errK, rel(dg[a], K(a, i)));
  }
  CHECK_MSG(errg < 1e-6, name + ": spring gradient vs FD " + std::to_string(errg));
  CHECK_MSG(errK < 1e-5, name + ": spring stiffness vs FD " + std::to_string(errK));
  CHECK_MSG((K - K.transpose()).norm() <= 1e-14 * K.norm(), name + ": spring stiffness symmetric");
  const double min_eig = Eigen::SelfAdjointEigenSolver<Mat3>(spring::stiffness(u, L, k, true)).eigenvalues().minCoeff();
  CHECK_MSG(min_eig >= -1e-12 * k, name + ": PSD-fixed spring stiffness has eigenvalue " + std::to_string(min_eig));
}

static void test_single_spring() {
  const double k = 7.0, L = 0.8;
  CHECK_NEAR(spring::energy(Vec3(0, L, 0), L, k), 0.0, 0.0);
  CHECK_NEAR(spring::gradient(Vec3(0, 0, L), L, k).norm(), 0.0, 1e-15);
  check_spring("stretched", Vec3(0.3, 1.1, -0.2), L, k);
  check_spring("compressed", Vec3(0.1, -0.3, 0.2), L, k);  // transverse k (1 - L/l) < 0: the PSD fix acts
  const double negative = Eigen::SelfAdjointEigenSolver<Mat3>(spring::stiffness(Vec3(0.1, -0.3, 0.2), L, k, false))
                              .eigenvalues()
                              .minCoeff();
  CHECK_MSG(negative < 0, "a compressed spring's exact stiffness is indefinite");
  // A collapsed edge: energy k L^2 / 2, force and stiffness finite.
  const Vec3 zero = Vec3::Zero();
  CHECK_NEAR(spring::energy(zero, L, k), 0.5 * k * L * L, 1e-10);  // the length is floored at 1e-12 L
  CHECK(spring::gradient(zero, L, k).allFinite() && spring::stiffness(zero, L, k, true).allFinite());
}

int main() {
  test_single_spring();
  std::mt19937 gen(3);
  std::uniform_real_distribution<double> u(-1, 1);
  Mat3 Dm;
  Dm << 1.0, 0.2, 0.1, 0.0, 0.9, 0.3, 0.1, 0.0, 1.1;
  const double k = 3.5;
  Mat3 P;
  CHECK_NEAR(ts::energy_and_stress(Mat3::Identity(), Dm, k, P), 0.0, 0.0);
  CHECK_NEAR(P.norm(), 0.0, 1e-14);
  // Rigid rotation: no energy.
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  CHECK_NEAR(ts::energy(R, Dm, k), 0.0, 1e-13);
  Mat3 G;
  for (int i = 0; i < 9; ++i) G(i % 3, i / 3) = u(gen);
  check_pose("general", Mat3::Identity() + 0.3 * G, Dm, k);
  check_pose("stretched", 1.5 * R, Dm, k);
  check_pose("compressed", 0.6 * R + 0.05 * G, Dm, k);  // compressed springs: transverse k (1 - L/l) < 0
  Mat3 inverted = Mat3::Identity() + 0.2 * G;
  inverted.col(0) *= -1;
  check_pose("inverted", inverted, Dm, k);
  // The Laplacian: rows sum to zero, 3k on the diagonal (each vertex is on 3 edges).
  const Eigen::Matrix4d L = ts::laplacian(k);
  CHECK_NEAR(L.rowwise().sum().norm(), 0.0, 1e-14);
  CHECK_NEAR(L(2, 2), 3 * k, 1e-14);
  return check::summary("test_springs");
}

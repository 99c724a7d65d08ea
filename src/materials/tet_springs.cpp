#include "materials/tet_springs.hpp"

#include "materials/spring.hpp"

namespace hyperqn {
namespace tet_springs {

namespace {
constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
}  // namespace

void rest_edges(const Mat3& Dm, Vec3 D[6]) {
  auto X = [&](int a) { return a == 0 ? Vec3::Zero().eval() : Vec3(Dm.col(a - 1)); };
  for (int j = 0; j < 6; ++j) D[j] = X(kEdges[j][1]) - X(kEdges[j][0]);
}

double energy_and_stress(const Mat3& F, const Mat3& Dm, double k, Mat3& P) {
  Vec3 D[6];
  rest_edges(Dm, D);
  double e = 0;
  P.setZero();
  for (const Vec3& Dj : D) {
    const double L = Dj.norm();
    const Vec3 u = F * Dj;
    e += spring::energy(u, L, k);
    P += spring::gradient(u, L, k) * Dj.transpose();  // d/dF of k/2 (|F D| - L)^2, u = F D
  }
  return e;
}

double energy(const Mat3& F, const Mat3& Dm, double k) {
  Mat3 P;
  return energy_and_stress(F, Dm, k, P);
}

Mat9 stress_derivative(const Mat3& F, const Mat3& Dm, double k, bool psd) {
  Vec3 D[6];
  rest_edges(Dm, D);
  Mat9 C = Mat9::Zero();
  for (const Vec3& Dj : D) {
    const Mat3 K = spring::stiffness(F * Dj, Dj.norm(), k, psd);
    // d vec(P) = (D D^T (x) K) d vec(F) for P = k (l - L) u D^T / l.
    const Mat3 DDt = Dj * Dj.transpose();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) C.block<3, 3>(3 * a, 3 * b) += DDt(a, b) * K;
  }
  return C;
}

Eigen::Matrix4d laplacian(double k) {
  Eigen::Matrix4d L = Eigen::Matrix4d::Zero();
  for (const auto& e : kEdges) {
    L(e[0], e[0]) += k;
    L(e[1], e[1]) += k;
    L(e[0], e[1]) -= k;
    L(e[1], e[0]) -= k;
  }
  return L;
}

}  // namespace tet_springs
}  // namespace hyperqn

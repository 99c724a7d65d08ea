#include "materials/membrane.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "materials/stress_measures.hpp"
#include "materials/triangle_geometry.hpp"

namespace hyperqn {
namespace membrane {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// Below this J the normal's direction is undefined: |n| is floored at kTinyJ * 2A so the
// derivatives of J stay finite (as spring.hpp's kTinyLength). StVK and corotated stay finite
// through a collapse; for neohookean it is where the energy is +inf.
constexpr double kTinyJ = 1e-12;
// Corotated: s = sigma1 + sigma2 is 0 only at F = 0; floored so 1/s stays finite there.
constexpr double kTinyStretchSum = 1e-12;

// The invariants as functions of the two edges e = (e1, e2) = (x1 - x0, x2 - x0), with their
// gradients in e (6-vectors); everything is mapped back to x only at the end.
struct Invariants {
  double I1, J;
  bool collapsed;  // |n| <= kTinyJ * 2A (J was floored)
  Vec3 e1, e2, nhat;  // nhat = n / max(|n|, floor)
  double n_len;       // max(|n|, floor)
  Eigen::Matrix2d M;  // Dm^-1 Dm^-T: I1 = sum_ab M_ab e_a . e_b
  Vec6 dI1, dJ;
};

Invariants invariants(const TriangleRest& r, const Vec9& x, bool gradients) {
  Invariants v;
  v.e1 = x.segment<3>(3) - x.segment<3>(0);
  v.e2 = x.segment<3>(6) - x.segment<3>(0);
  v.M = r.Dm_inv * r.Dm_inv.transpose();
  v.I1 = v.M(0, 0) * v.e1.squaredNorm() + 2 * v.M(0, 1) * v.e1.dot(v.e2) + v.M(1, 1) * v.e2.squaredNorm();
  const Vec3 n = v.e1.cross(v.e2);
  const double floor = kTinyJ * 2 * r.area;
  const double len = n.norm();
  v.collapsed = !(len > floor);
  v.n_len = std::max(len, floor);
  v.nhat = n / v.n_len;
  v.J = v.n_len / (2 * r.area);
  if (gradients) {
    v.dI1.head<3>() = 2 * (v.M(0, 0) * v.e1 + v.M(0, 1) * v.e2);
    v.dI1.tail<3>() = 2 * (v.M(0, 1) * v.e1 + v.M(1, 1) * v.e2);
    // d|n| = nhat . dn, dn = de1 x e2 + e1 x de2.
    v.dJ.head<3>() = v.e2.cross(v.nhat) / (2 * r.area);
    v.dJ.tail<3>() = v.nhat.cross(v.e1) / (2 * r.area);
  }
  return v;
}

// psi and its first and second partial derivatives in (I1, J).
struct Psi {
  double psi, I, J, II, IJ, JJ;
};

Psi psi_of(Model m, double mu, double lambda, double I1, double J) {
  Psi p{};
  switch (m) {
    case Model::stvk:
      // tr(E^2) = (tr C^2 - 2 tr C + 2)/4 with tr C^2 = I1^2 - 2 det C, tr E = (I1 - 2)/2.
      p.psi = 0.25 * mu * (I1 * I1 - 2 * J * J - 2 * I1 + 2) + 0.125 * lambda * (I1 - 2) * (I1 - 2);
      p.I = 0.5 * mu * (I1 - 1) + 0.25 * lambda * (I1 - 2);
      p.J = -mu * J;
      p.II = 0.5 * mu + 0.25 * lambda;
      p.IJ = 0;
      p.JJ = -mu;
      break;
    case Model::corotated: {
      // psi = mu (I1 + 2) + f(s), f(s) = -2 mu s + lambda/2 (s - 2)^2, s = sqrt(q), q = I1 + 2J.
      const double s = std::max(std::sqrt(std::max(I1 + 2 * J, 0.0)), kTinyStretchSum);
      const double f1 = -2 * mu + lambda * (s - 2);
      const double a = f1 / (2 * s);                                  // df/dq
      const double b = lambda / (4 * s * s) - f1 / (4 * s * s * s);    // d2f/dq2
      p.psi = mu * (I1 - 2 * s + 2) + 0.5 * lambda * (s - 2) * (s - 2);
      p.I = mu + a;
      p.J = 2 * a;
      p.II = b;
      p.IJ = 2 * b;
      p.JJ = 4 * b;
      break;
    }
    case Model::neohookean: {
      const double L = std::log(J);
      p.psi = 0.5 * mu * (I1 - 2) - mu * L + 0.5 * lambda * L * L;
      p.I = 0.5 * mu;
      p.J = (lambda * L - mu) / J;
      p.II = 0;
      p.IJ = 0;
      p.JJ = (lambda + mu - lambda * L) / (J * J);
      break;
    }
  }
  return p;
}

bool infinite_energy(Model m, const Invariants& v) { return m == Model::neohookean && v.collapsed; }

}  // namespace

TriangleRest rest(const Vec3& X0, const Vec3& X1, const Vec3& X2) {
  const Vec3 E1 = X1 - X0, E2 = X2 - X0;
  const Vec3 n = E1.cross(E2);
  TriangleRest r;
  if (!proper_rest_triangle(X0, X1, X2, &r.area))
    throw std::invalid_argument("degenerate rest triangle (area " + std::to_string(r.area) + ")");
  // Orthonormal frame of the rest plane: t1 along E1, t2 = nhat x t1.
  const Vec3 t1 = E1.normalized();
  const Vec3 t2 = n.normalized().cross(t1);
  Eigen::Matrix2d Dm;
  Dm << E1.norm(), E2.dot(t1), 0.0, E2.dot(t2);  // det Dm = 2A > 0
  r.Dm_inv = Dm.inverse();
  return r;
}

Mat3x2 deformation_gradient(const TriangleRest& r, const Vec9& x) {
  Mat3x2 Ds;
  Ds.col(0) = x.segment<3>(3) - x.segment<3>(0);
  Ds.col(1) = x.segment<3>(6) - x.segment<3>(0);
  return Ds * r.Dm_inv;
}

double energy(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x) {
  const Invariants v = invariants(r, x, false);
  if (infinite_energy(m, v)) return std::numeric_limits<double>::infinity();
  return r.area * psi_of(m, mu, lambda, v.I1, v.J).psi;
}

double energy_gradient(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x, Vec9& g) {
  const Invariants v = invariants(r, x, true);
  const Psi p = psi_of(m, mu, lambda, v.I1, v.J);
  const Vec6 ge = r.area * (p.I * v.dI1 + p.J * v.dJ);
  g.segment<3>(0) = -ge.head<3>() - ge.tail<3>();  // e1 = x1 - x0, e2 = x2 - x0
  g.segment<3>(3) = ge.head<3>();
  g.segment<3>(6) = ge.tail<3>();
  if (infinite_energy(m, v)) return std::numeric_limits<double>::infinity();
  return r.area * p.psi;
}

Mat9 hessian(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x, bool psd) {
  const Invariants v = invariants(r, x, true);
  const Psi p = psi_of(m, mu, lambda, v.I1, v.J);
  // d2I1/de2 = 2 M (x) I3 (constant).
  Mat6 HI;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) HI.block<3, 3>(3 * a, 3 * b) = 2 * v.M(a, b) * Mat3::Identity();
  // d2|n| = Jn^T (I - nhat nhat^T) Jn / |n| + nhat . d2n, Jn = dn/de = [-[e2]x, [e1]x]; d2n is the
  // bilinear de1 x de2' + de1' x de2, and nhat . (a x b) = -a^T [nhat]x b.
  Eigen::Matrix<double, 3, 6> Jn;
  Jn << -cross_matrix(v.e2), cross_matrix(v.e1);
  Mat6 Hn = Jn.transpose() * (Mat3::Identity() - v.nhat * v.nhat.transpose()) * Jn / v.n_len;
  const Mat3 S = -cross_matrix(v.nhat);
  Hn.block<3, 3>(0, 3) += S;
  Hn.block<3, 3>(3, 0) += S.transpose();
  const Mat6 HJ = Hn / (2 * r.area);
  Mat6 He = p.I * HI + p.J * HJ + p.II * v.dI1 * v.dI1.transpose() +
            p.IJ * (v.dI1 * v.dJ.transpose() + v.dJ * v.dI1.transpose()) + p.JJ * v.dJ * v.dJ.transpose();
  He *= r.area;
  Eigen::Matrix<double, 6, 9> T = Eigen::Matrix<double, 6, 9>::Zero();
  T.block<3, 3>(0, 0) = -Mat3::Identity();
  T.block<3, 3>(0, 3) = Mat3::Identity();
  T.block<3, 3>(3, 0) = -Mat3::Identity();
  T.block<3, 3>(3, 6) = Mat3::Identity();
  Mat9 H = T.transpose() * He * T;
  H = 0.5 * (H + H.transpose());
  if (psd) {
    Eigen::SelfAdjointEigenSolver<Mat9> eig(H);
    const auto lam = eig.eigenvalues().cwiseMax(0.0);
    H = eig.eigenvectors() * lam.asDiagonal() * eig.eigenvectors().transpose();
  }
  return H;
}

Mat3 cauchy_stress(Model m, double mu, double lambda, const TriangleRest& r, const Vec9& x) {
  // dE/d(e1, e2) = A P Dm^-T, so P F^T = (g1 e1^T + g2 e2^T) / A with F = [e1 e2] Dm^-1.
  Vec9 g;
  energy_gradient(m, mu, lambda, r, x, g);
  Mat3x2 G, Ds;
  G << g.segment<3>(3), g.segment<3>(6);
  Ds << x.segment<3>(3) - x.segment<3>(0), x.segment<3>(6) - x.segment<3>(0);
  const double J = std::max(Ds.col(0).cross(Ds.col(1)).norm(), kTinyJ * 2 * r.area) / (2 * r.area);  // as invariants'
  return stress_measures::cauchy<2>(Ds, G / r.area, J);
}

double max_stretch(const TriangleRest& r, const Vec9& x) {
  const Mat3x2 F = deformation_gradient(r, x);
  const Eigen::Matrix2d C = F.transpose() * F;
  const double half_diff = 0.5 * (C(0, 0) - C(1, 1));
  const double lam = 0.5 * (C(0, 0) + C(1, 1)) + std::sqrt(half_diff * half_diff + C(0, 1) * C(0, 1));
  return std::sqrt(lam);
}

double laplacian_weight(Model, double mu, double lambda) { return 2 * mu + lambda; }

std::array<double, 9> basis_gram(const TriangleRest& r) {
  // G^T = [[-1, -1], [1, 0], [0, 1]] Dm^-1 (rows: the gradients of the three basis functions).
  Eigen::Matrix<double, 3, 2> D;
  D << -1, -1, 1, 0, 0, 1;
  const Eigen::Matrix<double, 3, 2> Gt = D * r.Dm_inv;
  const Mat3 K = r.area * Gt * Gt.transpose();
  std::array<double, 9> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[3 * i + j] = K(i, j);
  return out;
}

}  // namespace membrane
}  // namespace hyperqn

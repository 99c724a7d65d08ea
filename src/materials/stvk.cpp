// St. Venant-Kirchhoff: psi = mu ||E||^2 + lambda/2 (tr E)^2, E = (F^T F - I)/2 (Green strain),
// plus the reference code's compression term psi_k = kappa (1 - J)^3 / 2592 for J < 1
// (reference-implementation.md section 2.3). Plain StVK softens under compression: P = F S -> 0 as
// F -> 0 (crushing costs only the finite 3 mu/4 + 9 lambda/8), and psi depends on F^T F only, so an
// inverted element has the energy of its mirror image and nothing pushes it back. psi_k grows like
// |J|^3 as J -> -inf to resist collapse and inversion. (1 - J)^3 has zero value, slope and curvature
// at J = 1, so adding it only below J = 1 keeps psi C2.
// P_k and dP_k/dF use the cofactor cof(F) = dJ/dF instead of J F^{-T} (the reference forms F^{-1}),
// so J = 0 is an ordinary point.
#include <stdexcept>
#include <string>

#include "materials/cofactor.hpp"
#include "materials/material.hpp"

namespace hyperqn {
namespace {

constexpr double kKappaScale = 1.0 / 2592.0;  // (kappa/12) ((1 - J)/6)^3 = kappa (1 - J)^3 / 2592

// psi and P across a batch: E = (F^T F - I)/2, S = 2 mu E + lambda tr(E) I, P = F S, and the
// compression term through t = max(1 - J, 0) (0 adds nothing where J >= 1), with cof(F) as in
// Neo-Hookean's batch. Every lane is computed.
HYPERQN_VECTOR_CLONES void stvk_batch(double mu, double lambda, double kappa, StressBatch& b) {
  const Lanes* F = b.F;
  Lanes E[9], C[9];
  for (int a = 0; a < 3; ++a)  // E(a, c) = (F(:, a) . F(:, c) - delta_ac) / 2, symmetric
    for (int c = a; c < 3; ++c)
      E[a + 3 * c] = E[c + 3 * a] =
          0.5 * (F[3 * a] * F[3 * c] + F[3 * a + 1] * F[3 * c + 1] + F[3 * a + 2] * F[3 * c + 2] - (a == c ? 1.0 : 0.0));
  const Lanes tr = E[0] + E[4] + E[8];
  Lanes norm2 = {};
  for (int c = 0; c < 9; ++c) norm2 += E[c] * E[c];
  Lanes J;
  cofactor_lanes(F, C, J);
  const Lanes zero = {};
  const Lanes t = J < 1.0 ? 1.0 - J : zero;
  const Lanes slope = -kappa * t * t / 864.0;
  b.psi = mu * norm2 + 0.5 * lambda * tr * tr + kappa * kKappaScale * t * t * t;
  Lanes S[9];  // S = 2 mu E + lambda tr(E) I
  for (int c = 0; c < 9; ++c) S[c] = 2.0 * mu * E[c];
  for (int d = 0; d < 3; ++d) S[4 * d] += lambda * tr;
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c)  // P(i, c) = sum_a F(i, a) S(a, c) + slope cof(i, c)
      b.P[i + 3 * c] = F[i] * S[3 * c] + F[i + 3] * S[1 + 3 * c] + F[i + 6] * S[2 + 3 * c] + slope * C[i + 3 * c];
}

class StVK final : public Material {
 public:
  StVK(double mu, double lambda, double kappa) : mu_(mu), lambda_(lambda), kappa_(kappa) {}
  std::string name() const override { return "stvk"; }

  double energy(const Mat3& F) const override { return energy_of(F, green_strain(F)); }

  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    const Mat3 E = green_strain(F);
    P = F * (2.0 * mu_ * E + lambda_ * E.trace() * Mat3::Identity());
    const double J = F.determinant();
    if (J < 1.0) P += compression_slope(J) * cofactor(F);
    return energy_of(F, E);
  }

  // The same formulas across a batch (stvk_batch).
  void energy_and_stress_batch(StressBatch& b, int) const override { stvk_batch(mu_, lambda_, kappa_, b); }

  Mat9 stress_derivative(const Mat3& F) const override {
    const Mat3 E = green_strain(F);
    const Mat3 S = 2.0 * mu_ * E + lambda_ * E.trace() * Mat3::Identity();  // second Piola-Kirchhoff
    // dP = dF S + F (2 mu dE + lambda tr(dE) I), dE = sym(F^T dF): linear in dF, so column k of
    // dP/dF is dP for dF = the k-th unit matrix (exact, no differencing).
    Mat9 H;
    for (int k = 0; k < 9; ++k) {
      Mat3 dF = Mat3::Zero();
      dF(k) = 1.0;
      const Mat3 FtdF = F.transpose() * dF;
      const Mat3 dE = 0.5 * (FtdF + FtdF.transpose());
      const Mat3 dP = dF * S + F * (2.0 * mu_ * dE + lambda_ * dE.trace() * Mat3::Identity());
      H.col(k) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
    }
    const double J = F.determinant();
    if (J < 1.0) {
      // d/dF of psi_k'(J) cof(F): psi_k''(J) c c^T + psi_k'(J) dcof/dF.
      const Mat3 C = cofactor(F);
      const Eigen::Map<const Eigen::Matrix<double, 9, 1>> c(C.data());
      H += kappa_ * (1.0 - J) / 432.0 * c * c.transpose() + compression_slope(J) * cofactor_derivative(F);
    }
    return 0.5 * (H + H.transpose());  // exactly symmetric in exact arithmetic; remove round-off
  }

  // The reference code's "10% window" fit (reference-implementation.md section 3). The exact rest
  // slope is 2 mu + lambda (same linearization as corotated: E ~ sym(dF) at F = I, and psi_k has
  // zero curvature at J = 1); docs/materials.md has the derivation. kappa is ignored, as there.
  double laplacian_weight() const override { return 2.0 * mu_ + 1.0033 * lambda_; }
  bool projective_dynamics_exact() const override { return false; }

 private:
  static Mat3 green_strain(const Mat3& F) { return 0.5 * (F.transpose() * F - Mat3::Identity()); }

  // d psi_k / dJ = -kappa (1 - J)^2 / 864 (J < 1).
  double compression_slope(double J) const { return -kappa_ * (1.0 - J) * (1.0 - J) / 864.0; }

  double energy_of(const Mat3& F, const Mat3& E) const {
    const double tr = E.trace();
    double psi = mu_ * E.squaredNorm() + 0.5 * lambda_ * tr * tr;
    const double J = F.determinant();
    if (J < 1.0) psi += kappa_ * kKappaScale * (1.0 - J) * (1.0 - J) * (1.0 - J);
    return psi;
  }

  double mu_, lambda_, kappa_;
};

}  // namespace

std::unique_ptr<Material> make_stvk(double mu, double lambda, double kappa) {
  // A negative kappa would reward compression below J = 1 instead of resisting it.
  if (!(kappa >= 0.0)) throw std::invalid_argument("stvk: kappa must be >= 0, got " + std::to_string(kappa));
  return std::make_unique<StVK>(mu, lambda, kappa);
}

}  // namespace hyperqn

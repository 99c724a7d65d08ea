// Inversion-safe Neo-Hookean: psi = mu/2 (tr(F^T F) - 3) - mu f(J) + lambda/2 f(J)^2, J = det F,
// with f = log J above J0 and its C2 quadratic extension below (finite for J <= 0).
// Written with the cofactor matrix cof(F) = dJ/dF (= J F^{-T}), which needs no inverse and is
// defined at J = 0, so no SVD is needed either.
#include <cmath>

#include "materials/cofactor.hpp"
#include "materials/material.hpp"

namespace hyperqn {
namespace {

// f(J) and its first two derivatives.
struct LogExt {
  double f, df, d2f;
};

// f(J): log J above J0, below it the quadratic matching log's value, slope and curvature at J0.
LogExt log_ext_at(double J, double J0) {
  if (J > J0) return {std::log(J), 1.0 / J, -1.0 / (J * J)};
  const double r = J / J0 - 1.0;
  return {std::log(J0) + (J - J0) / J0 - 0.5 * r * r, (1.0 - r) / J0, -1.0 / (J0 * J0)};
}

// psi and P of the first n elements of a batch: cof(F) column by column (cross products of F's
// other two columns), J = F(:, 0) . cof(:, 0), then f(J) per element, then P and psi.
HYPERQN_VECTOR_CLONES void neohookean_batch(double mu, double lambda, double J0, StressBatch& b, int n) {
  const Lanes* F = b.F;
  Lanes C[9], f = {}, df = {};
  Lanes J;
  cofactor_lanes(F, C, J);
  for (int e = 0; e < n; ++e) {
    const LogExt g = log_ext_at(J[e], J0);
    f[e] = g.f;
    df[e] = g.df;
  }
  const Lanes h = (lambda * f - mu) * df;
  Lanes I1 = {};
  for (int c = 0; c < 9; ++c) {
    b.P[c] = mu * F[c] + h * C[c];
    I1 += F[c] * F[c];
  }
  b.psi = 0.5 * mu * (I1 - 3.0) - mu * f + 0.5 * lambda * f * f;
}

class NeoHookean final : public Material {
 public:
  NeoHookean(double mu, double lambda, double J0) : mu_(mu), lambda_(lambda), J0_(J0) {}
  std::string name() const override { return "neohookean"; }

  double energy(const Mat3& F) const override {
    const double f = log_ext(F.determinant()).f;
    return 0.5 * mu_ * (F.squaredNorm() - 3.0) - mu_ * f + 0.5 * lambda_ * f * f;
  }

  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    const LogExt g = log_ext(F.determinant());
    P = mu_ * F + (lambda_ * g.f - mu_) * g.df * cofactor(F);
    return 0.5 * mu_ * (F.squaredNorm() - 3.0) - mu_ * g.f + 0.5 * lambda_ * g.f * g.f;
  }

  // The same formulas across a batch (neohookean_batch).
  void energy_and_stress_batch(StressBatch& b, int n) const override { neohookean_batch(mu_, lambda_, J0_, b, n); }

  Mat9 stress_derivative(const Mat3& F) const override {
    const LogExt g = log_ext(F.determinant());
    const Mat3 C = cofactor(F);
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> c(C.data());
    // d/dF of mu F + h(J) cof, with h = (lambda f - mu) f':  mu I + h'(J) c c^T + h d cof/dF.
    const double h = (lambda_ * g.f - mu_) * g.df;
    const double dh = lambda_ * g.df * g.df + (lambda_ * g.f - mu_) * g.d2f;
    return mu_ * Mat9::Identity() + dh * c * c.transpose() + h * cofactor_derivative(F);
  }

  // The reference code's hard-coded "10% window" fit of the stress-strain slope near rest
  // (paper section 4.1; algorithm.md section 4, reference-implementation.md section 3). A plain
  // least-squares fit over stretch in [0.9, 1.1] gives 2.0060 mu + 1.0111 lambda; we keep the
  // reference constants so L matches the authors' code.
  double laplacian_weight() const override { return 2.0066 * mu_ + 1.0122 * lambda_; }
  // Not a squared distance to a constraint set (its weight is a fit): PD is only approximate.
  bool projective_dynamics_exact() const override { return false; }

 private:
  LogExt log_ext(double J) const { return log_ext_at(J, J0_); }
  double mu_, lambda_, J0_;
};

}  // namespace

std::unique_ptr<Material> make_neohookean(double mu, double lambda, double J0) {
  return std::make_unique<NeoHookean>(mu, lambda, J0);
}

}  // namespace hyperqn

// Corotated linear elasticity: psi = mu ||F - R||^2 + lambda/2 (tr(R^T F) - 3)^2
//                                  = mu sum (sigma_i - 1)^2 + lambda/2 (sum sigma_i - 3)^2 (signed sigma).
#include <cmath>

#include "materials/material.hpp"
#include "materials/svd3.hpp"

namespace hyperqn {
namespace {

// Where sigma_i + sigma_j = 0 (an inverted element with sigma_3 = -sigma_2) the polar rotation R
// jumps and the true Hessian is unbounded. We keep |sigma_i + sigma_j| >= this floor (keeping its
// sign) so dP/dF stays finite there; it only changes dP/dF within 1e-6 of that set.
constexpr double kPairSumFloor = 1e-6;

class Corotated final : public Material {
 public:
  Corotated(double mu, double lambda) : mu_(mu), lambda_(lambda) {}
  std::string name() const override { return "corotated"; }

  // Energy and stress need only the polar rotation R, not the full SVD (svd3.hpp).
  double energy(const Mat3& F) const override { return evaluate(F, nullptr); }

  double energy_and_stress(const Mat3& F, Mat3& P) const override { return evaluate(F, &P); }

  // dP/dF needs U, V and sigma: the full signed SVD (its U V^T is evaluate's R to round-off).
  Mat9 stress_derivative(const Mat3& F) const override {
    const SignedSVD s = signed_svd(F);
    const double trace_strain = s.sigma.sum() - 3.0;
    const Mat3 d2psi = 2.0 * mu_ * Mat3::Identity() + lambda_ * Mat3::Ones();
    Vec3 sym, skew;
    for (int k = 0; k < 3; ++k) {
      // With Psi_i = 2 mu (sigma_i - 1) + lambda (sum sigma - 3):
      // (Psi_i - Psi_j)/(sigma_i - sigma_j) = 2 mu exactly, so no sigma_i ~ sigma_j limit is needed;
      // (Psi_i + Psi_j)/(sigma_i + sigma_j) = 2 mu + (2 lambda tr - 4 mu)/(sigma_i + sigma_j)
      // is the rotational stiffness (0 at F = I: the three rotation modes).
      sym(k) = 2.0 * mu_;
      double d = s.sigma(kPairI[k]) + s.sigma(kPairJ[k]);
      if (std::abs(d) < kPairSumFloor) d = d < 0.0 ? -kPairSumFloor : kPairSumFloor;
      skew(k) = 2.0 * mu_ + (2.0 * lambda_ * trace_strain - 4.0 * mu_) / d;
    }
    return isotropic_stress_derivative(s, d2psi, sym, skew);
  }

  // Slope of the 1-D stress-strain curve at rest (paper section 4.1; algorithm.md section 4).
  double laplacian_weight() const override { return 2.0 * mu_ + lambda_; }
  // lambda = 0 is ARAP: psi = mu ||F - R||^2 with R the projection of F onto rotations, w = 2 mu.
  bool projective_dynamics_exact() const override { return lambda_ == 0.0; }

 private:
  double evaluate(const Mat3& F, Mat3* P) const {
    const Mat3 R = signed_polar_rotation(F);
    const Mat3 D = F - R;
    const double t = R.cwiseProduct(F).sum() - 3.0;  // tr(R^T F) - 3 = sum sigma - 3
    if (P) *P = 2.0 * mu_ * D + lambda_ * t * R;
    return mu_ * D.squaredNorm() + 0.5 * lambda_ * t * t;
  }
  double mu_, lambda_;
};

}  // namespace

std::unique_ptr<Material> make_corotated(double mu, double lambda) {
  return std::make_unique<Corotated>(mu, lambda);
}

}  // namespace hyperqn

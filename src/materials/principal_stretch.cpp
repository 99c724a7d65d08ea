// Principal-stretch materials (Xu, Sin, Zhu, Barbic, "Nonlinear material design using principal
// stretches", SIGGRAPH 2015): psi = sum_i f(sigma_i) + sum_{i<j} g(sigma_i sigma_j) + h(sigma_1 sigma_2 sigma_3)
// in the signed singular values (sigma_3 < 0 when inverted), so psi is isotropic and defined for
// every F. f, g, h are ScalarFunctions (polynomials or monotone splines of their derivative).
// P = U diag(dpsi/dsigma) V^T; dP/dF from isotropic_stress_derivative (svd3.hpp), which needs the
// 3x3 Hessian in sigma and, per pair (i,j), sym = (Psi_i - Psi_j)/(sigma_i - sigma_j) and
// skew = (Psi_i + Psi_j)/(sigma_i + sigma_j), Psi_i = dpsi/dsigma_i. Both quotients are expanded
// term by term below so that the parts that are finite in the limit are computed without division.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "materials/material.hpp"
#include "materials/scalar_function.hpp"
#include "materials/svd3.hpp"

namespace hyperqn {
namespace {

// Below this relative gap |a - b| the divided difference (phi'(a) - phi'(b))/(a - b) is replaced
// by its limit, the mean of phi''(a) and phi''(b). Dividing directly costs ~1e-16 |phi'|/|a - b|
// in round-off; the mean is off by O((a - b)^2 phi''''), so 1e-5 keeps both near 1e-11.
constexpr double kDividedDifferenceTol = 1e-5;
// Where sigma_i + sigma_j = 0 (inverted, sigma_3 = -sigma_2) the rotation of the SVD jumps and the
// rotational stiffness (Psi_i + Psi_j)/(sigma_i + sigma_j) is unbounded unless its numerator
// vanishes there. As in corotated.cpp we keep |sigma_i + sigma_j| >= this floor (keeping its sign),
// which only changes dP/dF within 1e-6 of that set.
constexpr double kPairSumFloor = 1e-6;

// Index of the pair {i, j} (i != j) in the order (0,1), (0,2), (1,2) of kPairI/kPairJ.
constexpr int pair_index(int i, int j) { return i + j - 1; }

double divided_difference(const ScalarFunction& phi, double a, double b) {
  const double d = a - b;
  if (std::abs(d) > kDividedDifferenceTol * std::max({1.0, std::abs(a), std::abs(b)}))
    return (phi.first(a) - phi.first(b)) / d;
  return 0.5 * (phi.second(a) + phi.second(b));
}

class PrincipalStretch final : public Material {
 public:
  PrincipalStretch(std::shared_ptr<const ScalarFunction> f, std::shared_ptr<const ScalarFunction> g,
                   std::shared_ptr<const ScalarFunction> h)
      : f_(or_zero(std::move(f))), g_(or_zero(std::move(g))), h_(or_zero(std::move(h))) {}
  std::string name() const override { return "principal-stretch"; }

  double energy(const Mat3& F) const override { return energy_of(signed_svd(F).sigma); }

  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    const SignedSVD s = signed_svd(F);
    P = s.U * gradient(s.sigma).asDiagonal() * s.V.transpose();
    return energy_of(s.sigma);
  }

  Mat9 stress_derivative(const Mat3& F) const override {
    const SignedSVD s = signed_svd(F);
    const Vec3& sg = s.sigma;
    const double J = sg.prod(), dh = h_->first(J), d2h = h_->second(J);
    Vec3 p, dg, d2g;  // pair products sigma_i sigma_j and g', g'' there
    for (int k = 0; k < 3; ++k) {
      p(k) = sg(kPairI[k]) * sg(kPairJ[k]);
      dg(k) = g_->first(p(k));
      d2g(k) = g_->second(p(k));
    }
    Vec3 c;  // c_i = dJ/dsigma_i = product of the other two
    for (int i = 0; i < 3; ++i) c(i) = p(pair_index((i + 1) % 3, (i + 2) % 3));

    Mat3 d2psi;
    for (int i = 0; i < 3; ++i) {
      d2psi(i, i) = f_->second(sg(i)) + d2h * c(i) * c(i);
      for (int j = 0; j < 3; ++j) {
        if (j == i) continue;
        const int k = pair_index(i, j), l = 3 - i - j;
        d2psi(i, i) += d2g(k) * sg(j) * sg(j);
        if (j > i)
          d2psi(i, j) = d2psi(j, i) = d2g(k) * p(k) + dg(k) + d2h * c(i) * c(j) + dh * sg(l);
      }
    }

    Vec3 sym, skew;
    for (int k = 0; k < 3; ++k) {
      const int i = kPairI[k], j = kPairJ[k], l = 3 - i - j;
      const double si = sg(i), sj = sg(j), sl = sg(l);
      const int kil = pair_index(i, l), kjl = pair_index(j, l);
      // Psi_i - Psi_j = [f'(si) - f'(sj)] - g'(si sj)(si - sj) + sl [g'(si sl) - g'(sj sl)] - h'(J) sl (si - sj)
      sym(k) = divided_difference(*f_, si, sj) - dg(k) + sl * sl * divided_difference(*g_, p(kil), p(kjl)) - dh * sl;
      // Psi_i + Psi_j = g'(si sj)(si + sj) + h'(J) sl (si + sj) + [f'(si) + f'(sj) + sl (g'(si sl) + g'(sj sl))]
      double d = si + sj;
      if (std::abs(d) < kPairSumFloor) d = d < 0.0 ? -kPairSumFloor : kPairSumFloor;
      skew(k) = dg(k) + dh * sl + (f_->first(si) + f_->first(sj) + sl * (dg(kil) + dg(kjl))) / d;
    }
    return isotropic_stress_derivative(s, d2psi, sym, skew);
  }

  // d^2 psi / d sigma_1^2 at sigma = (1,1,1): the slope of the uniaxial-strain stress curve at
  // rest, which is 2 mu + lambda of the linearized material (docs/materials.md).
  double laplacian_weight() const override { return rest_stiffness(*f_, *g_, *h_); }
  bool projective_dynamics_exact() const override { return false; }

  static double rest_stiffness(const ScalarFunction& f, const ScalarFunction& g, const ScalarFunction& h) {
    return f.second(1.0) + 2.0 * g.second(1.0) + h.second(1.0);
  }
  static std::shared_ptr<const ScalarFunction> or_zero(std::shared_ptr<const ScalarFunction> phi) {
    return phi ? phi : std::make_shared<PolynomialFunction>(std::vector<double>{});
  }

 private:
  double energy_of(const Vec3& sg) const {
    double psi = h_->value(sg.prod());
    for (int i = 0; i < 3; ++i) psi += f_->value(sg(i));
    for (int k = 0; k < 3; ++k) psi += g_->value(sg(kPairI[k]) * sg(kPairJ[k]));
    return psi;
  }

  // Psi_i = f'(sigma_i) + sum_{j != i} g'(sigma_i sigma_j) sigma_j + h'(J) prod_{j != i} sigma_j.
  Vec3 gradient(const Vec3& sg) const {
    const double dh = h_->first(sg.prod());
    Vec3 dg;
    for (int k = 0; k < 3; ++k) dg(k) = g_->first(sg(kPairI[k]) * sg(kPairJ[k]));
    Vec3 Psi;
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3, l = (i + 2) % 3;
      Psi(i) = f_->first(sg(i)) + dg(pair_index(i, j)) * sg(j) + dg(pair_index(i, l)) * sg(l) + dh * sg(j) * sg(l);
    }
    return Psi;
  }

  std::shared_ptr<const ScalarFunction> f_, g_, h_;
};

}  // namespace

std::unique_ptr<Material> make_principal_stretch(std::shared_ptr<const ScalarFunction> f,
                                                 std::shared_ptr<const ScalarFunction> g,
                                                 std::shared_ptr<const ScalarFunction> h) {
  if (!f && !g && !h) throw std::invalid_argument("principal-stretch: at least one of f, g, h is required");
  auto m = std::make_unique<PrincipalStretch>(std::move(f), std::move(g), std::move(h));
  // L must be positive semi-definite; a negative rest stiffness means the rest shape is unstable.
  const double w = m->laplacian_weight();
  if (!(w >= 0.0))
    throw std::invalid_argument("principal-stretch: rest stiffness f''(1) + 2 g''(1) + h''(1) must be >= 0, got " +
                                std::to_string(w));
  return m;
}

std::unique_ptr<Material> make_principal_stretch_corotated(double mu, double lambda) {
  // (sum sigma - 3)^2 = sum (sigma_i - 1)^2 + 2 sum_{i<j} (sigma_i sigma_j - 1) - 4 sum (sigma_i - 1),
  // so mu sum (sigma_i - 1)^2 + lambda/2 (sum sigma - 3)^2 splits into these f and g exactly.
  auto f = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, -2.0 * lambda, mu + 0.5 * lambda});
  auto g = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, lambda});
  return make_principal_stretch(f, g, nullptr);
}

std::unique_ptr<Material> make_principal_stretch_neohookean_like(double mu, double lambda) {
  // mu/2 (x^2 - 1) = mu (x-1) + mu/2 (x-1)^2. h replaces -mu log J + lambda/2 (log J)^2 by its
  // second-order Taylor polynomial at J = 1, so the rest Hessian equals Neo-Hookean's.
  auto f = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, mu, 0.5 * mu});
  auto h = std::make_shared<PolynomialFunction>(std::vector<double>{0.0, -mu, 0.5 * (mu + lambda)});
  return make_principal_stretch(f, nullptr, h);
}

}  // namespace hyperqn

// Anisotropic fibre term on top of any material: psi = base(F) + k/2 (||F d|| - 1)^2, d the unit
// fibre direction in the rest configuration, so ||F d|| is the fibre stretch. With a = F d,
// s = ||a||: P_fibre = k (s - 1)/s a d^T and
//   dP_fibre/dF = k [ (1 - 1/s) (d d^T (x) I3) + vec(a d^T) vec(a d^T)^T / s^3 ].
// At a = 0 (the fibre crushed to a point) s = ||a|| has a cone: P jumps and dP/dF ~ k/s blows up.
// We therefore write the term as k/2 (q - 2 r(q) + 1) in q = ||a||^2, with r(q) = sqrt(q) for
// q >= eps^2 and, inside the ball q < eps^2, r = the quadratic Taylor polynomial of sqrt(q) at
// q = eps^2 (matching value, slope and curvature, so psi stays C2 and is a polynomial in F near
// a = 0). eps = kFiberEpsilon = 1e-2: only fibres compressed below 1 % of their rest length are
// affected, their energy by at most 3 k eps / 8 (< 1 % of the k/2 the exact term has there), and
// |dP_fibre/dF| stays below about 1.5 k / eps = 150 k. A smaller eps is no more physical (such a
// fibre is crushed either way) but makes dP/dF stiffer and its third derivative ~k/eps^2 larger.
// Only the base term is isotropic: psi(QF) = psi(F) for rotations Q, but not psi(FQ).
#include <cmath>
#include <stdexcept>
#include <string>

#include "materials/material.hpp"

namespace hyperqn {
namespace {

class Fiber final : public Material {
 public:
  Fiber(std::unique_ptr<Material> base, const Vec3& d, double k) : base_(std::move(base)), d_(d), k_(k) {}
  std::string name() const override { return base_->name() + "+fiber"; }

  double energy(const Mat3& F) const override { return base_->energy(F) + fiber_energy(F * d_); }

  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    const double psi = base_->energy_and_stress(F, P);
    const Vec3 a = F * d_;
    P += k_ * terms(a).alpha * a * d_.transpose();
    return psi + fiber_energy(a);
  }

  Mat9 stress_derivative(const Mat3& F) const override {
    Mat9 H = base_->stress_derivative(F);
    const Vec3 a = F * d_;
    const Terms t = terms(a);
    const Mat3 ad = a * d_.transpose();
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> b(ad.data());
    // d(a d^T)/dF acting on dF is dF d d^T, i.e. (d d^T (x) I3) on vec(dF) (column-major).
    Mat9 DD = Mat9::Zero();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) DD.block<3, 3>(3 * i, 3 * j) = d_(i) * d_(j) * Mat3::Identity();
    H += k_ * (t.alpha * DD + t.beta * b * b.transpose());
    return H;
  }

  // Near rest the fibre term adds the rank-one stiffness k vec(d d^T) vec(d d^T)^T to dP/dF: the
  // uniaxial stiffness is base + k along d and base across it. L = w G^T G (x) I3 is isotropic, so
  // it cannot follow one direction; w = base + k is the largest uniaxial rest stiffness, an upper
  // bound, which keeps A = M + h^2 L from being softer than the true Hessian along the fibre
  // (where the fibre usually dominates the dynamics); it overestimates across the fibre by k.
  double laplacian_weight() const override { return base_->laplacian_weight() + k_; }
  // k/2 (||Fd|| - 1)^2 is a squared distance (to unit vectors), but its PD matrix would be the
  // anisotropic k (G d)(G d)^T, not part of the isotropic L: PD is only approximate.
  bool projective_dynamics_exact() const override { return false; }

 private:
  // P_fibre = k alpha a d^T, dP_fibre/dF = k (alpha DD + beta b b^T), with alpha = 1 - 2 r'(q) and
  // beta = -4 r''(q); exact branch: alpha = (s - 1)/s, beta = 1/s^3.
  struct Terms {
    double alpha, beta;
  };
  static Terms terms(const Vec3& a) {
    const double q = a.squaredNorm();
    if (q >= kFiberEpsilon * kFiberEpsilon) {
      const double s = std::sqrt(q);
      return {(s - 1.0) / s, 1.0 / (s * s * s)};
    }
    const double e = kFiberEpsilon, dq = q - e * e;
    return {1.0 - 1.0 / e + dq / (2.0 * e * e * e), 1.0 / (e * e * e)};
  }
  double fiber_energy(const Vec3& a) const {
    const double q = a.squaredNorm();
    if (q >= kFiberEpsilon * kFiberEpsilon) {
      const double s = std::sqrt(q);
      return 0.5 * k_ * (s - 1.0) * (s - 1.0);
    }
    const double e = kFiberEpsilon, dq = q - e * e;
    const double r = e + dq / (2.0 * e) - dq * dq / (8.0 * e * e * e);
    return 0.5 * k_ * (q - 2.0 * r + 1.0);
  }

  std::unique_ptr<Material> base_;
  Vec3 d_;
  double k_;
};

}  // namespace

std::unique_ptr<Material> make_fiber(std::unique_ptr<Material> base, const Vec3& direction, double k) {
  if (!base) throw std::invalid_argument("fiber: base material is null");
  const double n = direction.norm();
  if (!(n > 0.0) || !std::isfinite(n)) throw std::invalid_argument("fiber: direction must be a nonzero finite vector");
  if (!(k >= 0.0) || !std::isfinite(k)) throw std::invalid_argument("fiber: stiffness must be >= 0, got " + std::to_string(k));
  return std::make_unique<Fiber>(std::move(base), direction / n, k);
}

}  // namespace hyperqn

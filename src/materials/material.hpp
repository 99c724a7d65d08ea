// Hyperelastic material interface: strain energy density psi(F) per unit rest volume,
// first Piola-Kirchhoff stress P = dpsi/dF, its derivative dP/dF, and the weight w used in
// the constant matrix L = sum_e w V_e (G_e^T G_e (x) I3).
#pragma once
#include <Eigen/Dense>
#include <memory>
#include <string>

#include "materials/lanes.hpp"

namespace hyperqn {

class ScalarFunction;  // materials/scalar_function.hpp

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
// dP/dF as a 9x9 matrix acting on vec(F) in column-major order (Eigen's default):
// vec(dP) = dPdF * vec(dF), index of F(i,j) is i + 3*j.
using Mat9 = Eigen::Matrix<double, 9, 9>;

// Up to kBatch elements' F and P in structure-of-arrays form, for the element loops of the energy
// terms: F[c] holds component c (column-major, c = i + 3 j for F(i, j)) of the kBatch elements,
// and F[c][e] is element e's (Lanes: materials/lanes.hpp; whole-lane expressions vectorize
// whatever the compiler can prove about aliasing). Lanes past the batch's count hold whatever
// was there: a material computes them or not, and the term never reads them.
struct StressBatch {
  Lanes F[9], P[9], psi;
};

// For each of the first n elements e of a batch: psi[e] = f(e, F, P) with F unpacked from its
// lane and P packed back into it (the per-element fallback of a batch).
template <class PerElement>
void per_element(StressBatch& b, int n, PerElement&& f) {
  for (int e = 0; e < n; ++e) {
    Mat3 F, P;
    for (int c = 0; c < 9; ++c) F(c) = b.F[c][e];
    b.psi[e] = f(e, F, P);
    for (int c = 0; c < 9; ++c) b.P[c][e] = P(c);
  }
}

class Material {
 public:
  virtual ~Material() = default;
  virtual std::string name() const = 0;
  // Energy density psi(F). Finite for every F, including inverted (det F < 0) and det F = 0.
  virtual double energy(const Mat3& F) const = 0;
  // Energy density and first Piola-Kirchhoff stress P = dpsi/dF in one call (shares the SVD).
  virtual double energy_and_stress(const Mat3& F, Mat3& P) const = 0;
  // psi and P of the first n elements of a batch. This default calls energy_and_stress per
  // element; a material whose formula is a few arithmetic lines (Neo-Hookean, StVK) overrides it
  // with loops over the lanes.
  virtual void energy_and_stress_batch(StressBatch& b, int n) const {
    per_element(b, n, [this](int, const Mat3& F, Mat3& P) { return energy_and_stress(F, P); });
  }
  // dP/dF (the exact, possibly indefinite, Hessian of psi w.r.t. F). Symmetric.
  virtual Mat9 stress_derivative(const Mat3& F) const = 0;
  // Weight of this material in L (stiffness of the stress-strain curve near rest).
  virtual double laplacian_weight() const = 0;
  // True if E is a Projective Dynamics energy with L as its global matrix, i.e. psi is a squared
  // distance to a constraint manifold (w/2 ||F - P(F)||^2) and laplacian_weight() == w. Then the
  // step x - A^{-1} grad g(x) is exactly PD's local-global step and never increases g.
  virtual bool projective_dynamics_exact() const = 0;
};

// Lame parameters from Young's modulus and Poisson ratio.
inline double lame_mu(double E, double nu) { return E / (2.0 * (1.0 + nu)); }
inline double lame_lambda(double E, double nu) { return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)); }

// psi = mu ||F - R||^2 + lambda/2 (tr(R^T F) - 3)^2, R from the signed polar decomposition.
std::unique_ptr<Material> make_corotated(double mu, double lambda);
// psi = mu/2 (I1 - 3) - mu f(J) + lambda/2 f(J)^2, f = log J above J0, C2 quadratic below.
std::unique_ptr<Material> make_neohookean(double mu, double lambda, double J0);
// St. Venant-Kirchhoff, psi = mu ||E||^2 + lambda/2 (tr E)^2, E = (F^T F - I)/2, plus the reference
// code's compression term kappa (1 - J)^3 / 2592 for J < 1 (kappa >= 0; 0 disables it).
std::unique_ptr<Material> make_stvk(double mu, double lambda, double kappa);
// Principal-stretch material (Xu, Sin, Zhu, Barbic 2015) in the signed singular values:
// psi = sum_i f(sigma_i) + sum_{i<j} g(sigma_i sigma_j) + h(sigma_1 sigma_2 sigma_3). A null function
// is the zero function. Throws std::invalid_argument if all three are null or if the rest
// stiffness f''(1) + 2 g''(1) + h''(1) (its Laplacian weight) is negative.
std::unique_ptr<Material> make_principal_stretch(std::shared_ptr<const ScalarFunction> f,
                                                 std::shared_ptr<const ScalarFunction> g,
                                                 std::shared_ptr<const ScalarFunction> h);
// Principal-stretch sanity materials with polynomial f, g, h:
// exactly corotated: f(x) = (mu + lambda/2)(x-1)^2 - 2 lambda (x-1), g(y) = lambda (y-1), h = 0;
std::unique_ptr<Material> make_principal_stretch_corotated(double mu, double lambda);
// polynomial Neo-Hookean, same rest Hessian as make_neohookean:
// psi = mu/2 (I1 - 3) - mu (J-1) + (mu+lambda)/2 (J-1)^2, i.e. f(x) = mu/2 (x^2 - 1), g = 0,
// h(J) = -mu (J-1) + (mu+lambda)/2 (J-1)^2.
std::unique_ptr<Material> make_principal_stretch_neohookean_like(double mu, double lambda);
// Anisotropic fibre term on top of any material: psi = base(F) + k/2 (||F d|| - 1)^2, d the unit
// fibre direction in the rest configuration (normalized here). Throws std::invalid_argument for a
// null base, a zero or non-finite direction, or k < 0.
std::unique_ptr<Material> make_fiber(std::unique_ptr<Material> base, const Vec3& direction, double k);
// The fibre term is regularized where ||F d|| < this (see fiber.cpp).
inline constexpr double kFiberEpsilon = 1e-2;

}  // namespace hyperqn

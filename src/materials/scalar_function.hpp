// Scalar functions phi(x) with first and second derivatives, used as the f, g, h of the
// principal-stretch materials (Xu, Sin, Zhu, Barbic 2015). Two kinds, as in that paper:
// polynomials in (x - 1) and monotone cubic splines through control points of the STRESS curve
// phi'(x), with phi its exact integral.
#pragma once
#include <vector>

namespace hyperqn {

class ScalarFunction {
 public:
  virtual ~ScalarFunction() = default;
  virtual double value(double x) const = 0;   // phi(x)
  virtual double first(double x) const = 0;   // phi'(x)
  virtual double second(double x) const = 0;  // phi''(x)
};

// phi(x) = sum_{k=0..n} c_k (x - 1)^k. Expanding about x = 1 (the rest value of sigma_i, of
// sigma_i sigma_j and of J) makes the rest behaviour readable off the coefficients:
// c_0 = phi(1) (rest energy), c_1 = phi'(1) (rest stress), 2 c_2 = phi''(1) (rest stiffness).
// A principal-stretch material has psi(I) = 0 iff 3 c0_f + 3 c0_g + c0_h = 0 and P(I) = 0 iff
// c1_f + 2 c1_g + c1_h = 0. An empty coefficient list is the zero function.
class PolynomialFunction final : public ScalarFunction {
 public:
  explicit PolynomialFunction(std::vector<double> coefficients);
  double value(double x) const override;
  double first(double x) const override;
  double second(double x) const override;
  const std::vector<double>& coefficients() const { return c_; }

 private:
  std::vector<double> c_;
};

// The stress curve phi'(x) is the monotone (shape-preserving) piecewise-cubic Hermite interpolant
// of the control points (x_i, y_i) with Fritsch-Carlson slopes: on data that increase (decrease)
// it increases (decreases), with no overshoot between points, so a monotone stress-strain table
// gives a convex energy piece by piece. Outside [x_0, x_n] the stress curve continues linearly
// with the end slope, so phi' is C1 and phi is C2 everywhere (phi'' is continuous, its derivative
// jumps at the control points). The energy is phi(x) = value_at_one + integral_1^x phi'(t) dt,
// integrated exactly on each cubic piece; so phi(1) = value_at_one (default 0).
// Requires >= 2 points, strictly increasing finite x_i and finite y_i (std::invalid_argument).
class MonotoneSplineFunction final : public ScalarFunction {
 public:
  MonotoneSplineFunction(std::vector<double> x, std::vector<double> y, double value_at_one = 0.0);
  double value(double x) const override;
  double first(double x) const override;
  double second(double x) const override;
  const std::vector<double>& slopes() const { return m_; }  // phi''(x_i), the Hermite slopes

 private:
  int segment(double x) const;                    // i with x_i <= x < x_{i+1}, clamped to [0, n-2]
  double integral_from_start(double x) const;     // integral_{x_0}^x phi'(t) dt (x may be < x_0)
  std::vector<double> x_, y_, m_, cumulative_;    // cumulative_[i] = integral_{x_0}^{x_i} phi'
  double offset_ = 0.0;                           // value_at_one - integral_{x_0}^1 phi'
};

}  // namespace hyperqn

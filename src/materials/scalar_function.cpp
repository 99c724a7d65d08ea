#include "materials/scalar_function.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hyperqn {

// ---- polynomial in (x - 1), Horner's rule ----

PolynomialFunction::PolynomialFunction(std::vector<double> coefficients) : c_(std::move(coefficients)) {
  for (double c : c_)
    if (!std::isfinite(c)) throw std::invalid_argument("polynomial: coefficients must be finite");
}

double PolynomialFunction::value(double x) const {
  const double t = x - 1.0;
  double v = 0.0;
  for (auto k = c_.size(); k-- > 0;) v = v * t + c_[k];
  return v;
}

double PolynomialFunction::first(double x) const {
  const double t = x - 1.0;
  double v = 0.0;
  for (auto k = c_.size(); k-- > 1;) v = v * t + static_cast<double>(k) * c_[k];
  return v;
}

double PolynomialFunction::second(double x) const {
  const double t = x - 1.0;
  double v = 0.0;
  for (auto k = c_.size(); k-- > 2;) v = v * t + static_cast<double>(k * (k - 1)) * c_[k];
  return v;
}

// ---- monotone cubic spline of the derivative ----
// On [x_i, x_{i+1}], h = x_{i+1} - x_i, t = (x - x_i)/h, the stress curve is the cubic Hermite
//   phi'(x) = h00(t) y_i + h h10(t) m_i + h01(t) y_{i+1} + h h11(t) m_{i+1},
// h00 = 2t^3 - 3t^2 + 1, h10 = t^3 - 2t^2 + t, h01 = -2t^3 + 3t^2, h11 = t^3 - t^2.

MonotoneSplineFunction::MonotoneSplineFunction(std::vector<double> x, std::vector<double> y, double value_at_one)
    : x_(std::move(x)), y_(std::move(y)) {
  const std::size_t n = x_.size();
  if (n < 2 || y_.size() != n)
    throw std::invalid_argument("spline: needs >= 2 control points and as many y as x (got " +
                                std::to_string(x_.size()) + " x, " + std::to_string(y_.size()) + " y)");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x_[i]) || !std::isfinite(y_[i]))
      throw std::invalid_argument("spline: control points must be finite");
    if (i > 0 && !(x_[i] > x_[i - 1]))
      throw std::invalid_argument("spline: control point x must be strictly increasing");
  }
  if (!std::isfinite(value_at_one)) throw std::invalid_argument("spline: value_at_one must be finite");

  // Fritsch-Carlson (1980) slopes. Secants delta_i; interior slopes start as the mean of the two
  // neighbouring secants (0 at a local extremum of the data, so extrema stay at the data points),
  // end slopes are the end secants. Then on each interval (alpha, beta) = (m_i, m_{i+1})/delta_i
  // is pulled into the disc alpha^2 + beta^2 <= 9, which is sufficient for the cubic to be
  // monotone on that interval; a flat interval gets zero slopes at both ends.
  std::vector<double> delta(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) delta[i] = (y_[i + 1] - y_[i]) / (x_[i + 1] - x_[i]);
  m_.assign(n, 0.0);
  m_[0] = delta[0];
  m_[n - 1] = delta[n - 2];
  for (std::size_t i = 1; i + 1 < n; ++i)
    m_[i] = delta[i - 1] * delta[i] > 0.0 ? 0.5 * (delta[i - 1] + delta[i]) : 0.0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (delta[i] == 0.0) {
      m_[i] = m_[i + 1] = 0.0;
      continue;
    }
    const double a = m_[i] / delta[i], b = m_[i + 1] / delta[i];
    const double r2 = a * a + b * b;
    if (r2 > 9.0) {
      const double tau = 3.0 / std::sqrt(r2);
      m_[i] = tau * a * delta[i];
      m_[i + 1] = tau * b * delta[i];
    }
  }

  // Exact integral of each cubic piece: integral_0^1 of (h00, h10, h01, h11) = (1/2, 1/12, 1/2, -1/12).
  cumulative_.assign(n, 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double h = x_[i + 1] - x_[i];
    cumulative_[i + 1] = cumulative_[i] + h * (0.5 * (y_[i] + y_[i + 1]) + h * (m_[i] - m_[i + 1]) / 12.0);
  }
  offset_ = value_at_one - integral_from_start(1.0);
}

int MonotoneSplineFunction::segment(double x) const {
  const auto it = std::upper_bound(x_.begin(), x_.end(), x);
  const int i = static_cast<int>(it - x_.begin()) - 1;
  return std::clamp(i, 0, static_cast<int>(x_.size()) - 2);
}

double MonotoneSplineFunction::integral_from_start(double x) const {
  const std::size_t n = x_.size();
  if (x < x_[0]) {  // linear extension y_0 + m_0 (t - x_0), integrated from x_0 (signed)
    const double d = x - x_[0];
    return d * (y_[0] + 0.5 * m_[0] * d);
  }
  if (x > x_[n - 1]) {
    const double d = x - x_[n - 1];
    return cumulative_[n - 1] + d * (y_[n - 1] + 0.5 * m_[n - 1] * d);
  }
  const int i = segment(x);
  const double h = x_[i + 1] - x_[i], t = (x - x_[i]) / h;
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t;
  // Antiderivatives of the Hermite basis from 0 to t.
  const double H00 = t - t3 + 0.5 * t4, H10 = 0.5 * t2 - 2.0 / 3.0 * t3 + 0.25 * t4;
  const double H01 = t3 - 0.5 * t4, H11 = -t3 / 3.0 + 0.25 * t4;
  return cumulative_[i] + h * (H00 * y_[i] + h * H10 * m_[i] + H01 * y_[i + 1] + h * H11 * m_[i + 1]);
}

double MonotoneSplineFunction::value(double x) const { return offset_ + integral_from_start(x); }

double MonotoneSplineFunction::first(double x) const {
  const std::size_t n = x_.size();
  if (x < x_[0]) return y_[0] + m_[0] * (x - x_[0]);
  if (x > x_[n - 1]) return y_[n - 1] + m_[n - 1] * (x - x_[n - 1]);
  const int i = segment(x);
  const double h = x_[i + 1] - x_[i], t = (x - x_[i]) / h;
  const double t2 = t * t, t3 = t2 * t;
  return (2.0 * t3 - 3.0 * t2 + 1.0) * y_[i] + h * (t3 - 2.0 * t2 + t) * m_[i] + (-2.0 * t3 + 3.0 * t2) * y_[i + 1] +
         h * (t3 - t2) * m_[i + 1];
}

double MonotoneSplineFunction::second(double x) const {
  const std::size_t n = x_.size();
  if (x < x_[0]) return m_[0];
  if (x > x_[n - 1]) return m_[n - 1];
  const int i = segment(x);
  const double h = x_[i + 1] - x_[i], t = (x - x_[i]) / h;
  const double t2 = t * t;
  return (6.0 * t2 - 6.0 * t) * (y_[i] - y_[i + 1]) / h + (3.0 * t2 - 4.0 * t + 1.0) * m_[i] + (3.0 * t2 - 2.0 * t) * m_[i + 1];
}

}  // namespace hyperqn

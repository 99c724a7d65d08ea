// Spectral (isotropic) functions f(b) of a symmetric 3 x 3 matrix b without its eigenvectors: the
// eigenvalues in closed form (the characteristic cubic's roots, below) and f(b) in Newton's
// divided-difference form f[l1] I + f[l1,l2] (b - l1 I) + f[l1,l2,l3] (b - l1 I)(b - l2 I), which
// is f(b) exactly for any f when l1 <= l2 <= l3 are b's eigenvalues (the interpolating polynomial
// at the spectrum). The divided differences are the caller's; the helpers below write those of log
// and of x^k so that they keep full precision at (nearly) equal eigenvalues, and the second one
// divides by l3 - l1 >= 2.5 p (p the deviator's size), never by a small gap: once multiplied by
// (b - l1 I)(b - l2 I) its error is at most about eps |f'| (l3 - l2). Used by
// materials/maxwell_branches.cpp and materials/log_strain_plasticity.cpp (which also takes C's
// eigenvectors from eigensystem() below: tests/test_plasticity.cpp checks them); tests/test_viscoelastic.cpp checks it against Eigen's iterative
// solver at equal and nearly equal eigenvalues.
#pragma once
#include <algorithm>
#include <cmath>

#include "materials/material.hpp"

namespace hyperqn {
namespace spectral3 {

struct Spectrum {
  Mat3 dev;              // b - q I (b symmetrized)
  double q = 0;          // tr b / 3
  double shift[3] = {};  // l_a - q, ascending
  double lambda[3] = {}; // l_a
  double gap[2] = {};    // l2 - l1, l3 - l2 (from p and the roots, not by subtraction)
  double spread = 0;     // l3 - l1
};

// The eigenvalues of symmetric b: q = tr b / 3, p^2 = |b - q I|^2 / 6, r = det((b - q I) / p) / 2;
// l = q + p x with x the roots of x^3 - 3 x = 2 r (x = 2 cos(acos(r) / 3 + 2 pi k / 3), Smith 1961)
// in [-2, 2]. Instead of acos and sincos: y = 2 cos(acos(|r|) / 3) in [sqrt 3, 2], the largest root
// at |r|, is a simple root and smooth in |r| (a cubic fit within 1.4e-4, two Newton steps to ~1
// ulp); the other two are the quadratic's (-y -+ z) / 2, z = sqrt(3 (2 - y)(2 + y)); at r < 0 the
// roots change sign. Where |r| is near 1 (two eigenvalues close) z loses digits, but only in how
// the close pair splits, which a smooth spectral function sees at second order. q + shift has an
// absolute error of eps l3, too much for a small l1 (a strong compression): given det b > 0, l1 =
// det b / (l2 l3) where l1 < l2 / 4, to its relative precision.
inline Spectrum spectrum(const Mat3& b, double det_b = 0) {
  Spectrum s;
  s.q = (b(0, 0) + b(1, 1) + b(2, 2)) / 3.0;
  Mat3& B = s.dev;
  B(0, 0) = b(0, 0) - s.q;
  B(1, 1) = b(1, 1) - s.q;
  B(2, 2) = b(2, 2) - s.q;
  B(0, 1) = B(1, 0) = 0.5 * (b(0, 1) + b(1, 0));
  B(1, 2) = B(2, 1) = 0.5 * (b(1, 2) + b(2, 1));
  B(0, 2) = B(2, 0) = 0.5 * (b(0, 2) + b(2, 0));
  const double p2 = (B(0, 0) * B(0, 0) + B(1, 1) * B(1, 1) + B(2, 2) * B(2, 2) +
                     2.0 * (B(0, 1) * B(0, 1) + B(1, 2) * B(1, 2) + B(0, 2) * B(0, 2))) / 6.0;
  if (!(p2 > 0)) {  // b = q I (or NaN, which the caller's positivity test refuses)
    s.lambda[0] = s.lambda[1] = s.lambda[2] = s.q;
    return s;
  }
  const double p = std::sqrt(p2), ip = 1.0 / p;
  const double a = B(0, 0) * ip, d = B(1, 1) * ip, f = B(2, 2) * ip;
  const double u = B(0, 1) * ip, v = B(1, 2) * ip, w = B(0, 2) * ip;
  const double r = 0.5 * (a * (d * f - v * v) - u * (u * f - v * w) + w * (u * v - d * w));
  const double rho = std::min(std::fabs(r), 1.0);
  double y = 1.7321850378747825 + rho * (0.3304294345645239 + rho * (-0.081261010009823 + rho * 0.01874896904804373));
  for (int k = 0; k < 2; ++k) y -= (y * (y * y - 3.0) - 2.0 * rho) / (3.0 * (y * y - 1.0));
  const double z = std::sqrt(std::max(0.0, 3.0 * (2.0 - y) * (2.0 + y)));
  if (r >= 0) {
    s.shift[0] = -0.5 * p * (y + z);
    s.shift[1] = 0.5 * p * (z - y);
    s.shift[2] = p * y;
    s.gap[0] = p * z;
    s.gap[1] = 0.5 * p * (3.0 * y - z);
  } else {
    s.shift[0] = -p * y;
    s.shift[1] = 0.5 * p * (y - z);
    s.shift[2] = 0.5 * p * (y + z);
    s.gap[0] = 0.5 * p * (3.0 * y - z);
    s.gap[1] = p * z;
  }
  s.spread = 0.5 * p * (3.0 * y + z);
  for (int a = 0; a < 3; ++a) s.lambda[a] = s.q + s.shift[a];
  if (det_b > 0 && s.lambda[0] < 0.25 * s.lambda[1]) {
    s.lambda[0] = det_b / (s.lambda[1] * s.lambda[2]);
    s.shift[0] = s.lambda[0] - s.q;
    s.gap[0] = s.lambda[1] - s.lambda[0];
    s.spread = s.lambda[2] - s.lambda[0];
  }
  return s;
}

// b's eigenvectors too, for the paths whose result is not coaxial with b (plasticity's flowed tets,
// materials/log_strain_plasticity.cpp), without an iterative solver: the eigenvalue farther from
// the other two (a gap of at least a quarter of the spread; its shift from spectrum(), a simple
// root) has the kernel of b - l I as its vector, the largest cross product of two of its rows;
// in the plane orthogonal to it a Jacobi rotation diagonalizes the 2 x 2 block of b - q I, giving
// the other two vectors and their eigenvalues to the block's rounding however close they are.
// So N diag(l) N^T is b to about eps |b| (backward stable, as the iterative solver): a close pair's
// vectors are ill-determined, but what a spectral function's derivative does with them is not.
// The small-eigenvalue rule of spectrum() applies to the pair's lower one too. Eigenvalues in
// N's column order (not sorted); shift = l - q, whose differences are the gaps to full precision.
struct Eigensystem {
  Mat3 N = Mat3::Identity();
  double lambda[3] = {}, shift[3] = {};
};

inline Eigensystem eigensystem(const Mat3& b, double det_b = 0) {
  const Spectrum s = spectrum(b, det_b);
  Eigensystem e;
  for (int a = 0; a < 3; ++a) {
    e.lambda[a] = s.lambda[a];
    e.shift[a] = s.shift[a];
  }
  if (!(s.spread > 0)) return e;  // b = q I (or NaN)
  const int k = s.gap[0] >= s.gap[1] ? 0 : 2;  // the isolated eigenvalue
  const Mat3& B = s.dev;
  Mat3 M = B;
  M.diagonal().array() -= s.shift[k];
  const Vec3 c[3] = {M.row(0).cross(M.row(1)), M.row(0).cross(M.row(2)), M.row(1).cross(M.row(2))};
  int best = 0;
  for (int j = 1; j < 3; ++j)
    if (c[j].squaredNorm() > c[best].squaredNorm()) best = j;
  if (!(c[best].squaredNorm() > 0)) return e;  // NaN: the caller's positivity test refuses it
  const Vec3 v = c[best].normalized();
  // u: a unit vector orthogonal to v (from the axis v leans on least), w = v x u.
  int axis = 0;
  for (int j = 1; j < 3; ++j)
    if (std::fabs(v(j)) < std::fabs(v(axis))) axis = j;
  const Vec3 u = Vec3::Unit(axis).cross(v).normalized(), w = v.cross(u);
  const Vec3 Bu = B * u, Bw = B * w;
  const double p = u.dot(Bu), q = u.dot(Bw), r = w.dot(Bw);  // the block [[p, q], [q, r]]
  double t = 0;                                                // tan of the rotation
  if (q != 0) {
    const double tau = (r - p) / (2.0 * q);
    t = (tau >= 0 ? 1.0 : -1.0) / (std::fabs(tau) + std::sqrt(1.0 + tau * tau));
  }
  const double cs = 1.0 / std::sqrt(1.0 + t * t), sn = t * cs;
  const int i = k == 0 ? 1 : 0, j = k == 0 ? 2 : 1;  // the pair's columns
  e.N.col(k) = v;
  e.N.col(i) = cs * u - sn * w;
  e.N.col(j) = sn * u + cs * w;
  e.shift[i] = p - t * q;
  e.shift[j] = r + t * q;
  for (int a : {i, j}) e.lambda[a] = s.q + e.shift[a];
  const int lo = e.lambda[i] <= e.lambda[j] ? i : j, hi = i + j - lo;
  if (det_b > 0 && e.lambda[lo] < 0.25 * e.lambda[hi]) {
    e.lambda[lo] = det_b / (e.lambda[hi] * e.lambda[k]);
    e.shift[lo] = e.lambda[lo] - s.q;
  }
  return e;
}

// (log x - log y) / (x - y) from x and y (> 0) alone, also where they are close: 2 atanh(s) / (s (x +
// y)), s = (x - y) / (x + y) (the eigenbasis paths: Newton's tangents).
inline double log_divided(double x, double y) {
  const double s = (x - y) / (x + y);
  if (std::fabs(s) < 1e-3) {
    const double s2 = s * s;
    return 2.0 / (x + y) * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 / 7.0)));
  }
  return 2.0 * std::atanh(s) / (s * (x + y));
}

// (log x - log y) / (x - y) for x = y + gap (y > 0, gap >= 0) from their logs: where s = gap / (x +
// y) < 0.05, 2 atanh(s) / (s (x + y)) by its series (to 1e-17; it barely feels s's error, so the
// close pair's imprecise gap does no harm), else the logs' difference over the gap.
inline double log_divided(double y, double gap, double log_x, double log_y) {
  const double inv = 1.0 / (2.0 * y + gap), s = gap * inv;
  if (s >= 0.05) return (log_x - log_y) / gap;
  const double s2 = s * s;
  return 2.0 * inv *
         (1.0 + s2 * (1.0 / 3 + s2 * (1.0 / 5 + s2 * (1.0 / 7 + s2 * (1.0 / 9 + s2 * (1.0 / 11 + s2 / 13))))));
}

// (x^k - y^k) / (x - y) = y^(k-1) ratio with t = log x - log y: expm1(k t) / expm1(t), k at t = 0
// (whose slope in t is bounded, so t's rounding from the logs does not matter).
inline double power_ratio(double t, double k) { return t == 0 ? k : std::expm1(k * t) / std::expm1(t); }

// f[l1,l2,l3] = (f[l2,l3] - f[l1,l2]) / (l3 - l1) where the spread is at least 1e-8 of q; below,
// the caller's limit f''/2 (the quotient would do too, but overflows at a spread of 0).
inline bool spread_out(const Spectrum& s) { return s.spread > 1e-8 * std::fabs(s.q); }

// f(b) = f1 I + f12 (b - l1 I) + f123 (b - l1 I)(b - l2 I), b - l_a I = dev - shift_a I (symmetric).
inline Mat3 newton_form(const Spectrum& s, double f1, double f12, double f123) {
  const Mat3& B = s.dev;
  const double s1 = s.shift[0], s2 = s.shift[1];
  // (B - s1 I)(B - s2 I) = B^2 - (s1 + s2) B + s1 s2 I; symmetric, as B commutes with itself.
  const double xx = B(0, 0) * B(0, 0) + B(0, 1) * B(0, 1) + B(0, 2) * B(0, 2);
  const double yy = B(0, 1) * B(0, 1) + B(1, 1) * B(1, 1) + B(1, 2) * B(1, 2);
  const double zz = B(0, 2) * B(0, 2) + B(1, 2) * B(1, 2) + B(2, 2) * B(2, 2);
  const double xy = B(0, 0) * B(0, 1) + B(0, 1) * B(1, 1) + B(0, 2) * B(1, 2);
  const double yz = B(0, 1) * B(0, 2) + B(1, 1) * B(1, 2) + B(1, 2) * B(2, 2);
  const double xz = B(0, 0) * B(0, 2) + B(0, 1) * B(1, 2) + B(0, 2) * B(2, 2);
  const double lin = f12 - f123 * (s1 + s2);  // the coefficient of B
  const double diag = f1 - f12 * s1 + f123 * s1 * s2;
  Mat3 R;
  R(0, 0) = diag + lin * B(0, 0) + f123 * xx;
  R(1, 1) = diag + lin * B(1, 1) + f123 * yy;
  R(2, 2) = diag + lin * B(2, 2) + f123 * zz;
  R(0, 1) = R(1, 0) = lin * B(0, 1) + f123 * xy;
  R(1, 2) = R(2, 1) = lin * B(1, 2) + f123 * yz;
  R(0, 2) = R(2, 0) = lin * B(0, 2) + f123 * xz;
  return R;
}

// spectrum, log_divided(y, gap, log_x, log_y) and newton_form across a batch's lanes
// (materials/lanes.hpp), the same operations lane by lane (the branches become selections; only
// sqrt goes lane by lane): for the batched kernels of materials/maxwell_branches.cpp. A symmetric
// matrix is 6 lanes: xx, yy, zz, xy, yz, xz. Out-parameters, for the x86-64 and AVX clones.
struct SpectrumLanes {
  Lanes dev[6];  // b - q I
  Lanes q, shift[3], lambda[3], gap[2], spread;
};

inline void sqrt_lanes(const Lanes& x, Lanes& r) {
  for (int e = 0; e < kBatch; ++e) r[e] = std::sqrt(x[e]);
}

inline void spectrum_lanes(const Lanes (&b)[6], const Lanes& det_b, SpectrumLanes& s) {
  const Lanes zero = {}, one = zero + 1.0;
  s.q = (b[0] + b[1] + b[2]) / 3.0;
  Lanes* B = s.dev;
  for (int c = 0; c < 3; ++c) B[c] = b[c] - s.q;
  for (int c = 3; c < 6; ++c) B[c] = b[c];
  const Lanes p2 = (B[0] * B[0] + B[1] * B[1] + B[2] * B[2] + 2.0 * (B[3] * B[3] + B[4] * B[4] + B[5] * B[5])) / 6.0;
  Lanes p;
  sqrt_lanes(p2 > zero ? p2 : one, p);
  const Lanes ip = 1.0 / p;
  const Lanes a = B[0] * ip, d = B[1] * ip, f = B[2] * ip, u = B[3] * ip, v = B[4] * ip, w = B[5] * ip;
  const Lanes r = 0.5 * (a * (d * f - v * v) - u * (u * f - v * w) + w * (u * v - d * w));
  const Lanes absr = r < zero ? -r : r;
  const Lanes rho = absr < one ? absr : one;
  Lanes y = 1.7321850378747825 + rho * (0.3304294345645239 + rho * (-0.081261010009823 + rho * 0.01874896904804373));
  for (int k = 0; k < 2; ++k) y -= (y * (y * y - 3.0) - 2.0 * rho) / (3.0 * (y * y - 1.0));
  const Lanes z2 = 3.0 * (2.0 - y) * (2.0 + y);
  Lanes z;
  sqrt_lanes(z2 > zero ? z2 : zero, z);
  const auto first = r >= zero;  // the roots' first form (r >= 0) or the second
  s.shift[0] = first ? -0.5 * p * (y + z) : -p * y;
  s.shift[1] = first ? 0.5 * p * (z - y) : 0.5 * p * (y - z);
  s.shift[2] = first ? p * y : 0.5 * p * (y + z);
  s.gap[0] = first ? p * z : 0.5 * p * (3.0 * y - z);
  s.gap[1] = first ? 0.5 * p * (3.0 * y - z) : p * z;
  s.spread = 0.5 * p * (3.0 * y + z);
  for (int k = 0; k < 3; ++k) s.lambda[k] = s.q + s.shift[k];
  const auto small = (det_b > zero) & (s.lambda[0] < 0.25 * s.lambda[1]);
  const Lanes l0 = det_b / (s.lambda[1] * s.lambda[2]);
  s.lambda[0] = small ? l0 : s.lambda[0];
  s.shift[0] = small ? l0 - s.q : s.shift[0];
  s.gap[0] = small ? s.lambda[1] - l0 : s.gap[0];
  s.spread = small ? s.lambda[2] - l0 : s.spread;
  const auto round = p2 > zero;  // else b = q I (or NaN)
  for (int k = 0; k < 3; ++k) {
    s.lambda[k] = round ? s.lambda[k] : s.q;
    s.shift[k] = round ? s.shift[k] : zero;
  }
  for (int k = 0; k < 2; ++k) s.gap[k] = round ? s.gap[k] : zero;
  s.spread = round ? s.spread : zero;
}

inline void log_divided_lanes(const Lanes& y, const Lanes& gap, const Lanes& log_x, const Lanes& log_y, Lanes& r) {
  const Lanes inv = 1.0 / (2.0 * y + gap), s = gap * inv, s2 = s * s;
  const Lanes series =
      2.0 * inv * (1.0 + s2 * (1.0 / 3 + s2 * (1.0 / 5 + s2 * (1.0 / 7 + s2 * (1.0 / 9 + s2 * (1.0 / 11 + s2 / 13))))));
  const Lanes limit = {}, wide = limit + 0.05;
  r = s >= wide ? (log_x - log_y) / gap : series;
}

// R = f1 I + f12 (b - l1 I) + f123 (b - l1 I)(b - l2 I), 6 lanes, added times scale to R.
inline void add_newton_form_lanes(const SpectrumLanes& s, const Lanes& f1, const Lanes& f12, const Lanes& f123,
                                  const Lanes& scale, Lanes (&R)[6]) {
  const Lanes* B = s.dev;  // xx, yy, zz, xy, yz, xz
  const Lanes s1 = s.shift[0], s2 = s.shift[1];
  const Lanes xx = B[0] * B[0] + B[3] * B[3] + B[5] * B[5];
  const Lanes yy = B[3] * B[3] + B[1] * B[1] + B[4] * B[4];
  const Lanes zz = B[5] * B[5] + B[4] * B[4] + B[2] * B[2];
  const Lanes xy = B[0] * B[3] + B[3] * B[1] + B[5] * B[4];
  const Lanes yz = B[3] * B[5] + B[1] * B[4] + B[4] * B[2];
  const Lanes xz = B[0] * B[5] + B[3] * B[4] + B[5] * B[2];
  const Lanes lin = f12 - f123 * (s1 + s2);
  const Lanes diag = f1 - f12 * s1 + f123 * s1 * s2;
  R[0] += scale * (diag + lin * B[0] + f123 * xx);
  R[1] += scale * (diag + lin * B[1] + f123 * yy);
  R[2] += scale * (diag + lin * B[2] + f123 * zz);
  R[3] += scale * (lin * B[3] + f123 * xy);
  R[4] += scale * (lin * B[4] + f123 * yz);
  R[5] += scale * (lin * B[5] + f123 * xz);
}

}  // namespace spectral3
}  // namespace hyperqn

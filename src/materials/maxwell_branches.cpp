#include "materials/maxwell_branches.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "materials/cofactor.hpp"
#include "materials/spectral3.hpp"
#include "materials/symmetric6.hpp"

namespace hyperqn {

namespace {

// One branch at F for stress_derivative (Newton's tangent keeps Eigen's iterative eigensolver:
// Eigen's closed-form computeDirect failed its FD check at repeated eigenvalues): the trial b =
// F A F^T (A = C_v,n^{-1}) in its eigenbasis N with eigenvalues beta, the log strains e = 1/2 log
// beta and their deviator d.
struct Trial {
  Mat3 A, N;
  Vec3 beta, d;
  double mean = 0;  // tr e / 3
  bool ok = false;  // b positive definite
};

Trial trial(const Mat3& F, const double* history) {
  Trial t;
  t.A = unpack_symmetric(history);
  const Mat3 b = F * t.A * F.transpose();
  Eigen::SelfAdjointEigenSolver<Mat3> eig(0.5 * (b + b.transpose()));
  t.N = eig.eigenvectors();
  t.beta = eig.eigenvalues();
  t.ok = t.beta.minCoeff() > 0 && std::isfinite(t.beta.maxCoeff());
  if (!t.ok) return t;
  const Vec3 e = 0.5 * t.beta.array().log().matrix();
  t.mean = e.sum() / 3.0;
  t.d = e.array() - t.mean;
  return t;
}

// energy() across a batch's lanes (spectral3's lane helpers): per branch the lanes' A = C_v,n^{-1}
// gathered from the histories, b = F A F^T, its spectrum, the logs (lane by lane), W and K += m E;
// then P += 2 K F^{-T}, F^{-T} = cof(F) / J. About twice as fast as element by element.
HYPERQN_VECTOR_CLONES void maxwell_batch(const MaxwellBranch* branches, int count, double dt, StressBatch& b, int n,
                                         const double* const* history) {
  const Lanes* F = b.F;  // F(i, j) = F[i + 3 j]
  const Lanes zero = {};
  Lanes C[9], J;
  cofactor_lanes(F, C, J);
  Lanes W = {}, K[6] = {}, bad = {};
  for (int i = 0; i < count; ++i) {
    Lanes A[6] = {};  // xx, yy, zz, xy, yz, xz; the identity in unused lanes
    for (int e = 0; e < kBatch; ++e)
      for (int c = 0; c < 6; ++c) A[c][e] = e < n ? history[e][kViscousValues * i + c] : (c < 3 ? 1.0 : 0.0);
    const Lanes a[3][3] = {{A[0], A[3], A[5]}, {A[3], A[1], A[4]}, {A[5], A[4], A[2]}};
    Lanes FA[3][3];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) FA[r][c] = F[r] * a[0][c] + F[r + 3] * a[1][c] + F[r + 6] * a[2][c];
    const int rows[6] = {0, 1, 2, 0, 1, 0}, cols[6] = {0, 1, 2, 1, 2, 2};
    Lanes bb[6];
    for (int k = 0; k < 6; ++k) {  // (F A F^T)(r, c) = sum_j FA(r, j) F(c, j)
      const int r = rows[k], c = cols[k];
      bb[k] = FA[r][0] * F[c] + FA[r][1] * F[c + 3] + FA[r][2] * F[c + 6];
    }
    const Lanes detA = A[0] * (A[1] * A[2] - A[4] * A[4]) - A[3] * (A[3] * A[2] - A[4] * A[5]) +
                       A[5] * (A[3] * A[4] - A[1] * A[5]);
    spectral3::SpectrumLanes s;
    spectral3::spectrum_lanes(bb, J * J * detA, s);
    Lanes g[3] = {};
    for (int e = 0; e < n; ++e) {
      if (!(s.lambda[0][e] > 0) || !std::isfinite(s.lambda[2][e])) {
        bad[e] = 1.0;
        continue;
      }
      for (int k = 0; k < 3; ++k) g[k][e] = std::log(s.lambda[k][e]);
    }
    const Lanes mean = (g[0] + g[1] + g[2]) / 6.0;
    const Lanes d1 = 0.5 * g[0] - mean, d2 = 0.5 * g[1] - mean, d3 = 0.5 * g[2] - mean;
    const double m = branches[i].mu * branches[i].tau / (branches[i].tau + dt);
    W += m * (d1 * d1 + d2 * d2 + d3 * d3);
    Lanes f12, f23;  // divided differences of 1/2 log x
    spectral3::log_divided_lanes(s.lambda[0], s.gap[0], g[1], g[0], f12);
    spectral3::log_divided_lanes(s.lambda[1], s.gap[1], g[2], g[1], f23);
    f12 *= 0.5;
    f23 *= 0.5;
    const Lanes absq = s.q < zero ? -s.q : s.q;
    const Lanes f123 = s.spread > 1e-8 * absq ? (f23 - f12) / s.spread : -0.25 / (s.q * s.q);
    const Lanes mm = zero + m;
    spectral3::add_newton_form_lanes(s, d1, f12, f123, mm, K);
  }
  const Lanes k[3][3] = {{K[0], K[3], K[5]}, {K[3], K[1], K[4]}, {K[5], K[4], K[2]}};
  const Lanes two_over_J = 2.0 / J;
  const auto ok = bad == zero;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {  // 2 (K cof(F) / J)(r, c)
      const Lanes add = (k[r][0] * C[3 * c] + k[r][1] * C[1 + 3 * c] + k[r][2] * C[2 + 3 * c]) * two_over_J;
      b.P[r + 3 * c] = ok ? b.P[r + 3 * c] + add : b.P[r + 3 * c];
    }
  const Lanes inf = zero + std::numeric_limits<double>::infinity();
  b.psi = ok ? b.psi + W : inf;
}

}  // namespace

void MaxwellBranches::energy_batch(StressBatch& b, int n, const double* const* history, double dt) const {
  maxwell_batch(branches_.data(), size(), dt, b, n, history);
}

MaxwellBranches::MaxwellBranches(std::vector<MaxwellBranch> branches) : branches_(std::move(branches)) {
  if (branches_.empty() || (int)branches_.size() > kMaxMaxwellBranches)
    throw std::invalid_argument("viscoelastic: 1 to " + std::to_string(kMaxMaxwellBranches) + " branches, got " +
                                std::to_string(branches_.size()));
  for (const MaxwellBranch& b : branches_)
    if (!(b.mu > 0) || !(b.tau > 0) || !std::isfinite(b.mu) || !std::isfinite(b.tau))
      throw std::invalid_argument("viscoelastic: every branch needs a shear modulus > 0 and a relaxation time > 0");
}

void MaxwellBranches::rest(double* history) const {
  for (int i = 0; i < size(); ++i) pack_symmetric(Mat3::Identity(), history + kViscousValues * i);
}

double MaxwellBranches::laplacian_weight() const {
  double w = 0;
  for (const MaxwellBranch& b : branches_) w += 2.0 * b.mu;
  return w;
}

// W = m |d|^2 with m = mu tau / (tau + dt) and d = dev e, e = 1/2 log b: only b's eigenvalues. The
// stress: dW/dbeta_a = m d_a / beta_a, so S = dW/db = m b^{-1} E with E = dev e as a matrix
// (coaxial with b), and P = 2 S F A = 2 m E F^{-T} (b^{-1} F A = F^{-T}); E = 1/2 log b - mean I
// in Newton's divided-difference form (materials/spectral3.hpp), no eigenvectors. All branches
// share one F^{-T}: P += 2 (sum_i m_i E_i) F^{-T}. Equal to the eigensolver's within 1e-12
// (tests/test_viscoelastic.cpp), several times cheaper.
double MaxwellBranches::energy(const Mat3& F, const double* history, double dt, Mat3* P) const {
  // In stages over the branches: their chains of dependent operations (b, its roots, the logs)
  // overlap in the processor (a quarter less time than branch after branch).
  const int n = size();
  const double J = F.determinant();
  spectral3::Spectrum s[kMaxMaxwellBranches];
  for (int i = 0; i < n; ++i) {
    const Mat3 A = unpack_symmetric(history + kViscousValues * i);
    s[i] = spectral3::spectrum(F * A * F.transpose(), J * J * A.determinant());
  }
  double g[kMaxMaxwellBranches][3];
  for (int i = 0; i < n; ++i) {
    if (!(s[i].lambda[0] > 0) || !std::isfinite(s[i].lambda[2])) return std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) g[i][a] = std::log(s[i].lambda[a]);
  }
  double W = 0;
  Mat3 K = Mat3::Zero();  // sum_i m_i E_i
  for (int i = 0; i < n; ++i) {
    const double l1 = s[i].lambda[0], l2 = s[i].lambda[1];
    const double g1 = g[i][0], g2 = g[i][1], g3 = g[i][2];
    const double mean = (g1 + g2 + g3) / 6.0;
    const double d1 = 0.5 * g1 - mean, d2 = 0.5 * g2 - mean, d3 = 0.5 * g3 - mean;
    const double m = branches_[i].mu * branches_[i].tau / (branches_[i].tau + dt);
    W += m * (d1 * d1 + d2 * d2 + d3 * d3);
    if (P) {  // divided differences of 1/2 log x
      const double f12 = 0.5 * spectral3::log_divided(l1, s[i].gap[0], g2, g1);
      const double f23 = 0.5 * spectral3::log_divided(l2, s[i].gap[1], g3, g2);
      const double f123 = spectral3::spread_out(s[i]) ? (f23 - f12) / s[i].spread : -0.25 / (s[i].q * s[i].q);
      K += m * spectral3::newton_form(s[i], d1, f12, f123);
    }
  }
  if (P) *P += 2.0 * K * F.inverse().transpose();
  return W;
}

// dP = 2 (dS F A + S dF A), dS from db by the derivative of a spectral function of b: in the
// eigenbasis, dS'_aa = sum_b (dphi_a/dbeta_b) db'_bb and dS'_ab = (phi_a - phi_b) / (beta_a -
// beta_b) db'_ab (a != b), the divided difference written so that it holds at equal eigenvalues.
Mat9 MaxwellBranches::stress_derivative(const Mat3& F, const double* history, double dt) const {
  Mat9 C = Mat9::Zero();
  for (int i = 0; i < size(); ++i) {
    const Trial t = trial(F, history + kViscousValues * i);
    if (!t.ok) continue;
    const double m = branches_[i].mu * branches_[i].tau / (branches_[i].tau + dt);
    const Vec3 phi = m * t.d.cwiseQuotient(t.beta);
    const Mat3 S = t.N * phi.asDiagonal() * t.N.transpose();
    Mat3 f, D;  // dphi_a/dbeta_b; the divided differences
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const double delta = a == b ? 1.0 : 0.0;
        f(a, b) = m * ((delta - 1.0 / 3.0) / (2.0 * t.beta(a) * t.beta(b)) - delta * t.d(a) / (t.beta(a) * t.beta(a)));
        D(a, b) = a == b ? 0.0
                         : m * (0.5 * spectral3::log_divided(t.beta(a), t.beta(b)) / t.beta(a) - t.d(b) / (t.beta(a) * t.beta(b)));
      }
    const Mat3 FA = F * t.A, AFt = t.A * F.transpose();
    for (int c = 0; c < 9; ++c) {
      Mat3 dF = Mat3::Zero();
      dF(c) = 1.0;
      const Mat3 db = dF * AFt;
      const Mat3 dbp = t.N.transpose() * (db + db.transpose()) * t.N;
      Mat3 dSp;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          dSp(a, b) = a == b ? f.row(a).dot(dbp.diagonal()) : D(a, b) * dbp(a, b);
      const Mat3 dS = t.N * dSp * t.N.transpose();
      const Mat3 dP = 2.0 * (dS * FA + S * dF * t.A);
      for (int r = 0; r < 9; ++r) C(r, c) += dP(r);
    }
  }
  return C;
}

// b_e = exp(2 eps_e) = exp(2 mean (1 - keep)) b^keep (eps_e = keep d + mean I), a spectral function
// h of the trial b, in Newton's form like the stress; C_v^{-1} = F^{-1} b_e F^{-T}.
void MaxwellBranches::update(const Mat3& F, const double* start, double dt, double* end) const {
  const Mat3 Finv = F.inverse();
  const double J = F.determinant();
  for (int i = 0; i < size(); ++i) {
    const Mat3 A = unpack_symmetric(start + kViscousValues * i);
    const spectral3::Spectrum s = spectral3::spectrum(F * A * F.transpose(), J * J * A.determinant());
    const double l1 = s.lambda[0], l2 = s.lambda[1], l3 = s.lambda[2];
    if (!(l1 > 0) || !std::isfinite(l3)) {  // no finite step ends here (its energy is infinite): keep the history
      for (int k = 0; k < kViscousValues; ++k) end[kViscousValues * i + k] = start[kViscousValues * i + k];
      continue;
    }
    const double g1 = std::log(l1), g2 = std::log(l2), g3 = std::log(l3);
    const double mean = (g1 + g2 + g3) / 6.0;
    const double keep = branches_[i].tau / (branches_[i].tau + dt);
    // h(l_a) = exp(2 (keep d_a + mean)) = exp(keep g_a + 2 mean (1 - keep)).
    const double shift = 2.0 * mean * (1.0 - keep);
    const double h1 = std::exp(keep * g1 + shift), h2 = std::exp(keep * g2 + shift);
    const double h12 = h1 / l1 * spectral3::power_ratio(g2 - g1, keep);
    const double h23 = h2 / l2 * spectral3::power_ratio(g3 - g2, keep);
    const double h123 = spectral3::spread_out(s) ? (h23 - h12) / s.spread
                                                 : 0.5 * keep * (keep - 1.0) * h1 / (l1 * l1);  // h''/2 at ~l1
    const Mat3 be = spectral3::newton_form(s, h1, h12, h123);
    pack_symmetric(Finv * be * Finv.transpose(), end + kViscousValues * i);
  }
}

// |dev e|^2 from the trial b's eigenvalues in closed form, as energy() (once per step and tet, but
// Eigen's iterative eigensolver here cost a sixth of a 4-branch run's time).
double MaxwellBranches::dissipation(const Mat3& F, const double* start, double dt, const double*) const {
  const double J = F.determinant();
  double D = 0;
  for (int i = 0; i < size(); ++i) {
    const Mat3 A = unpack_symmetric(start + kViscousValues * i);
    const spectral3::Spectrum s = spectral3::spectrum(F * A * F.transpose(), J * J * A.determinant());
    if (!(s.lambda[0] > 0) || !std::isfinite(s.lambda[2])) continue;
    const double g1 = std::log(s.lambda[0]), g2 = std::log(s.lambda[1]), g3 = std::log(s.lambda[2]);
    const double mean = (g1 + g2 + g3) / 6.0;
    const double d1 = 0.5 * g1 - mean, d2 = 0.5 * g2 - mean, d3 = 0.5 * g3 - mean;
    const double tau = branches_[i].tau;
    D += 2.0 * branches_[i].mu * tau * dt / ((tau + dt) * (tau + dt)) * (d1 * d1 + d2 * d2 + d3 * d3);
  }
  return D;
}

double MaxwellBranches::measure(HistoryMeasure m, const double* history) const {
  if (m != HistoryMeasure::viscous_strain) return 0;
  double largest = 0;
  for (int i = 0; i < size(); ++i) {  // |1/2 log C_v| = |1/2 log C_v^{-1}|: from C_v^{-1}'s eigenvalues
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(unpack_symmetric(history + kViscousValues * i), Eigen::EigenvaluesOnly);
    largest = std::max(largest, 0.5 * eig.eigenvalues().array().log().matrix().norm());
  }
  return largest;
}

}  // namespace hyperqn

// J2 (von Mises) plasticity in the Lagrangian logarithmic strain (docs/inelastic.md#plasticity):
// the additive form of Miehe, Apel and Lambrecht 2002. With E = 1/2 log C (C = F^T F), a plastic
// strain E_p (symmetric, traceless: isochoric flow) and an equivalent plastic strain alpha, the
// stored energy is the Hencky one of the elastic strain plus linear hardening,
//   psi = mu |dev E - E_p|^2 + kappa/2 (tr E)^2 + H_iso/2 alpha^2 + H_kin/3 |E_p|^2,
// kappa = lambda + 2 mu / 3, the stress conjugate to E is T = 2 mu (dev E - E_p) + kappa tr E I,
// the back stress beta = 2/3 H_kin E_p, and the yield function |dev T - beta| - sqrt(2/3)
// (sigma_y + H_iso alpha). A step's variational update (Ortiz and Stainier 1999) minimizes psi plus
// the dissipation sqrt(2/3) sigma_y |E_p - E_p,n| (alpha = alpha_n + sqrt(2/3) |E_p - E_p,n|) over
// E_p: the minimizer is the closed-form radial return of small-strain J2 in E-space, and the
// minimum, W(F; E_p,n, alpha_n), is C^1 across the yield surface (dW/dE = T, the envelope theorem).
// The rate-independent W does not depend on dt.
//
// P = F S with S = Dlog(C)[T] (the symmetric Frechet derivative of log at C), and dP/dF follows
// from the consistent tangent dT/dE and the second derivative of log (Daleckii-Krein: first and
// second divided differences of log at C's eigenvalues). Where E_p,n = 0, T is coaxial with C and
// no eigenvectors are needed (coaxial_value); elsewhere C's eigenbasis comes in closed form
// (spectral3::eigensystem, no iterative eigensolver: docs/inelastic.md#cost).
//
// The elastic model `hencky` (material_factory.cpp) is the same energy without flow (E_p = 0).
// A model of the InelasticModel seam: this file and one registration line each in
// material_factory.cpp (plasticity_kind, make_hencky).
#include <cmath>
#include <limits>
#include <stdexcept>

#include "materials/material_factory.hpp"
#include "materials/spectral3.hpp"
#include "materials/symmetric6.hpp"

namespace hyperqn {

namespace {

// The history: E_p (xx, yy, zz, xy, yz, xz), then alpha.
constexpr int kPlasticValues = 7;

// The second divided difference log[x, y, z] (symmetric). Where the three are within 1e-4 of their
// mean m, the Hermite-Genocchi integral of log'' = -1/t^2 over the simplex expanded about m:
// -1/(2 m^2) - sum (x_i - m)^2 / (8 m^4) (error of order 1e-12 relative); else the recurrence over
// the widest pair, whose cancellation costs at most the same.
double log_divided2(double x, double y, double z) {
  double a = std::max(x, std::max(y, z)), c = std::min(x, std::min(y, z));
  const double b = x + y + z - a - c;
  const double m = (x + y + z) / 3.0;
  if (a - c <= 1e-4 * m) {
    const double d2 = (x - m) * (x - m) + (y - m) * (y - m) + (z - m) * (z - m);
    return -1.0 / (2.0 * m * m) - d2 / (8.0 * m * m * m * m);
  }
  return (spectral3::log_divided(a, b) - spectral3::log_divided(b, c)) / (a - c);
}

// The return map at F from history h: C's eigenbasis N and eigenvalues l (in closed form,
// spectral3::eigensystem), E and T in that basis (primes), and the step's flow. flow = false: the
// stored state (no flow).
struct Return {
  bool ok = false;     // C positive definite
  Mat3 N;              // C = N diag(l) N^T
  Vec3 l;
  Vec3 shift;          // l - tr C / 3: their differences are the gaps
  Vec3 g;              // log l
  double alpha = 0;    // alpha at its end
  double gamma = 0;    // the flow's size |E_p - E_p,n|
  Mat3 n;              // its direction (primed), where gamma > 0
  double xi = 0;       // |trial relative stress|
  Mat3 Tp;             // T (primed)
  double psi = 0;      // the stored energy at the end, plus the step's dissipation
};

struct Params {
  double mu, kappa, sigma_y, H_iso, H_kin;
};

Return return_map(const Params& p, const Mat3& F, const double* h, bool flow) {
  Return r;
  const double J = F.determinant();
  const spectral3::Eigensystem eig = spectral3::eigensystem(F.transpose() * F, J * J);
  r.N = eig.N;
  r.l = Vec3(eig.lambda[0], eig.lambda[1], eig.lambda[2]);
  r.shift = Vec3(eig.shift[0], eig.shift[1], eig.shift[2]);
  r.ok = r.l.minCoeff() > 0 && std::isfinite(r.l.maxCoeff());
  if (!r.ok) return r;
  r.g = r.l.array().log().matrix();
  const Vec3 Ediag = 0.5 * r.g;
  const double theta = Ediag.sum();
  Mat3 e = Mat3::Zero();  // dev E (primed)
  for (int a = 0; a < 3; ++a) e(a, a) = Ediag(a) - theta / 3.0;
  const Mat3 Epn = h ? unpack_symmetric(h) : Mat3::Zero();
  const double alpha_n = h ? h[6] : 0.0;
  const Mat3 Epn_p = r.N.transpose() * Epn * r.N;
  Mat3 Ep_p = Epn_p;
  r.alpha = alpha_n;
  if (flow) {
    const Mat3 xi_tr = 2.0 * p.mu * (e - Epn_p) - (2.0 / 3.0) * p.H_kin * Epn_p;
    r.xi = xi_tr.norm();
    const double f = r.xi - std::sqrt(2.0 / 3.0) * (p.sigma_y + p.H_iso * alpha_n);
    if (f > 0) {
      r.gamma = f / (2.0 * p.mu + (2.0 / 3.0) * (p.H_kin + p.H_iso));
      r.n = xi_tr / r.xi;
      Ep_p += r.gamma * r.n;
      r.alpha += std::sqrt(2.0 / 3.0) * r.gamma;
    }
  }
  const Mat3 ee = e - Ep_p;  // the elastic strain's deviator
  r.Tp = 2.0 * p.mu * ee + p.kappa * theta * Mat3::Identity();
  r.psi = p.mu * ee.squaredNorm() + 0.5 * p.kappa * theta * theta + 0.5 * p.H_iso * r.alpha * r.alpha +
          p.H_kin / 3.0 * Ep_p.squaredNorm() + std::sqrt(2.0 / 3.0) * p.sigma_y * r.gamma;
  return r;
}

// Whether a history's E_p,n is zero (no history: hencky): then the step is coaxial with C (below).
bool no_plastic_strain(const double* h) {
  return !h || (h[0] == 0.0 && h[1] == 0.0 && h[2] == 0.0 && h[3] == 0.0 && h[4] == 0.0 && h[5] == 0.0);
}

// return_map and first_piola where E_p,n = 0 (the elastic model hencky, and every tet that has not
// yielded yet): dev E, the trial stress, the flow and T are then spectral functions of C, so no
// eigenvectors are needed. C's eigenvalues in closed form, E = 1/2 log C in Newton's form
// (materials/spectral3.hpp, as the Maxwell branches' kernel); T coaxial with C makes S = Dlog(C)[T]
// = C^{-1} T, so P = F^{-T} T. The same numbers as the eigensolver's to round-off, several times
// cheaper (tests/test_plasticity.cpp checks hencky and this path by finite differences, and against
// the general path from a flowed history). psi (+inf where det F = 0); P added to *P if not null;
// *end the step's end history (E_p, alpha) if not null.
double coaxial_value(const Params& p, const Mat3& F, double alpha_n, bool flow, Mat3* P, double* end) {
  const double J = F.determinant();
  const spectral3::Spectrum s = spectral3::spectrum(F.transpose() * F, J * J);
  if (!(s.lambda[0] > 0) || !std::isfinite(s.lambda[2])) return std::numeric_limits<double>::infinity();
  const double g1 = std::log(s.lambda[0]), g2 = std::log(s.lambda[1]), g3 = std::log(s.lambda[2]);
  const double theta = 0.5 * (g1 + g2 + g3);  // tr E
  const double e1 = 0.5 * g1 - theta / 3.0, e2 = 0.5 * g2 - theta / 3.0, e3 = 0.5 * g3 - theta / 3.0;
  const double norm = std::sqrt(e1 * e1 + e2 * e2 + e3 * e3);  // |dev E|
  double k = 1.0, gamma = 0.0, alpha = alpha_n;                 // elastic strain = k dev E
  if (flow) {
    const double f = 2.0 * p.mu * norm - std::sqrt(2.0 / 3.0) * (p.sigma_y + p.H_iso * alpha_n);
    if (f > 0) {  // n = dev E / |dev E|
      gamma = f / (2.0 * p.mu + (2.0 / 3.0) * (p.H_kin + p.H_iso));
      k = 1.0 - gamma / norm;
      alpha += std::sqrt(2.0 / 3.0) * gamma;
    }
  }
  if (P || end) {  // dev E = 1/2 log C - theta/3 I
    const double f12 = 0.5 * spectral3::log_divided(s.lambda[0], s.gap[0], g2, g1);
    const double f23 = 0.5 * spectral3::log_divided(s.lambda[1], s.gap[1], g3, g2);
    const double f123 = spectral3::spread_out(s) ? (f23 - f12) / s.spread : -0.25 / (s.q * s.q);
    const Mat3 devE = spectral3::newton_form(s, 0.5 * g1, f12, f123) - (theta / 3.0) * Mat3::Identity();
    if (P) *P += F.inverse().transpose() * (2.0 * p.mu * k * devE + p.kappa * theta * Mat3::Identity());
    if (end) {
      pack_symmetric(gamma > 0 ? Mat3(gamma / norm * devE) : Mat3::Zero(), end);
      end[6] = alpha;
    }
  }
  return p.mu * k * k * norm * norm + 0.5 * p.kappa * theta * theta + 0.5 * p.H_iso * alpha * alpha +
         p.H_kin / 3.0 * gamma * gamma + std::sqrt(2.0 / 3.0) * p.sigma_y * gamma;
}

// log[l_a, l_b] from the logs and the gaps (the shifts' differences): no atanh.
Mat3 log_divided1(const Return& r) {
  Mat3 f1;
  for (int a = 0; a < 3; ++a) {
    f1(a, a) = 1.0 / r.l(a);
    for (int b = a + 1; b < 3; ++b) {
      const int lo = r.l(a) <= r.l(b) ? a : b, hi = a + b - lo;
      f1(a, b) = f1(b, a) = spectral3::log_divided(r.l(lo), r.shift(hi) - r.shift(lo), r.g(hi), r.g(lo));
    }
  }
  return f1;
}

// P = F S, S = Dlog(C)[T]: in C's eigenbasis S'_ab = log[l_a, l_b] T'_ab.
Mat3 first_piola(const Mat3& F, const Return& r) {
  const Mat3 Sp = log_divided1(r).cwiseProduct(r.Tp);
  return F * (r.N * Sp * r.N.transpose());
}

// dP/dF: dP = dF S + F dS, dS' = log[l_a, l_b] dT'_ab + sum_k log[l_a, l_k, l_b] (T'_ak dC'_kb +
// dC'_ak T'_kb), dT' the consistent tangent applied to dE' = 1/2 log[l_a, l_b] dC'_ab.
Mat9 tangent(const Params& p, const Mat3& F, const Return& r) {
  const Mat3 f1 = log_divided1(r);
  double f2[3][3][3];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int k = 0; k < 3; ++k) f2[a][k][b] = log_divided2(r.l(a), r.l(k), r.l(b));
  Mat3 Sp = f1.cwiseProduct(r.Tp);
  const Mat3 S = r.N * Sp * r.N.transpose();
  // dev dT = a dev dE + b (n : dE) n (b = 0 in the elastic range), tr dT = 3 kappa tr dE.
  double ca = 2.0 * p.mu, cb = 0.0;
  if (r.gamma > 0) {
    const double c = 2.0 * p.mu + (2.0 / 3.0) * (p.H_kin + p.H_iso);
    ca = 2.0 * p.mu * (1.0 - 2.0 * p.mu * r.gamma / r.xi);
    cb = 4.0 * p.mu * p.mu * (r.gamma / r.xi - 1.0 / c);
  }
  Mat9 H;
  for (int col = 0; col < 9; ++col) {
    Mat3 dF = Mat3::Zero();
    dF(col) = 1.0;
    const Mat3 FtdF = F.transpose() * dF;
    const Mat3 dCp = r.N.transpose() * (FtdF + FtdF.transpose()) * r.N;
    const Mat3 dEp = 0.5 * f1.cwiseProduct(dCp);
    const double dtheta = dEp.trace();
    const Mat3 de = dEp - dtheta / 3.0 * Mat3::Identity();
    Mat3 dTp = ca * de + p.kappa * dtheta * Mat3::Identity();
    if (cb != 0.0) dTp += cb * r.n.cwiseProduct(de).sum() * r.n;
    Mat3 dSp = f1.cwiseProduct(dTp);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int k = 0; k < 3; ++k) dSp(a, b) += f2[a][k][b] * (r.Tp(a, k) * dCp(k, b) + dCp(a, k) * r.Tp(k, b));
    const Mat3 dP = dF * S + F * (r.N * dSp * r.N.transpose());
    H.col(col) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
  }
  return H;
}

class LogStrainPlasticity : public InelasticModel {
 public:
  explicit LogStrainPlasticity(const Params& p) : p_(p) {}
  std::string name() const override { return "plastic hencky"; }
  int history_width() const override { return kPlasticValues; }
  void rest(double* h) const override {
    for (int k = 0; k < kPlasticValues; ++k) h[k] = 0.0;
  }
  double energy(const Mat3& F, const double* h, double, Mat3* P) const override { return value(F, h, true, P); }
  double stored_energy(const Mat3& F, const double* h, Mat3* P) const override { return value(F, h, false, P); }
  Mat9 stress_derivative(const Mat3& F, const double* h, double) const override {
    const Return r = return_map(p_, F, h, true);
    return r.ok ? tangent(p_, F, r) : Mat9::Zero();
  }
  void update(const Mat3& F, const double* start, double, double* end) const override {
    if (no_plastic_strain(start)) {
      if (std::isinf(coaxial_value(p_, F, start[6], true, nullptr, end)))  // no finite step ends here
        for (int k = 0; k < kPlasticValues; ++k) end[k] = start[k];
      return;
    }
    const Return r = return_map(p_, F, start, true);
    if (!r.ok) {  // no finite step ends here: keep the history
      for (int k = 0; k < kPlasticValues; ++k) end[k] = start[k];
      return;
    }
    // E_p at the step's end in the reference basis (only here: an evaluation needs it primed).
    const Mat3 Epn = unpack_symmetric(start);
    pack_symmetric(r.gamma > 0 ? Mat3(Epn + r.gamma * (r.N * r.n * r.N.transpose())) : Epn, end);
    end[6] = r.alpha;
  }
  // sqrt(2/3) sigma_y |E_p - E_p,n|: the stress power T : dE_p less the hardening's stored share.
  double dissipation(const Mat3&, const double* start, double, const double* end) const override {
    double d2 = 0;
    for (int k = 0; k < 6; ++k) d2 += (k < 3 ? 1.0 : 2.0) * (end[k] - start[k]) * (end[k] - start[k]);
    return std::sqrt(2.0 / 3.0) * p_.sigma_y * std::sqrt(d2);
  }
  double laplacian_weight() const override { return 2.0 * p_.mu + (p_.kappa - 2.0 * p_.mu / 3.0); }
  // equivalent_plastic_strain: alpha.
  bool has_measure(HistoryMeasure m) const override { return m == HistoryMeasure::equivalent_plastic_strain; }
  double measure(HistoryMeasure m, const double* h) const override {
    return m == HistoryMeasure::equivalent_plastic_strain ? h[6] : 0.0;
  }

 private:
  double value(const Mat3& F, const double* h, bool flow, Mat3* P) const {
    if (no_plastic_strain(h)) return coaxial_value(p_, F, h[6], flow, P, nullptr);
    const Return r = return_map(p_, F, h, flow);
    if (!r.ok) return std::numeric_limits<double>::infinity();
    if (P) *P += first_piola(F, r);
    return r.psi;
  }
  Params p_;
};

// Hencky's elastic energy mu |dev E|^2 + kappa/2 (tr E)^2: the plastic model at rest history, no flow.
class Hencky : public Material {
 public:
  Hencky(double mu, double lambda) : p_{mu, lambda + 2.0 * mu / 3.0, 0, 0, 0} {}
  std::string name() const override { return "hencky"; }
  double energy(const Mat3& F) const override { return coaxial_value(p_, F, 0.0, false, nullptr, nullptr); }
  double energy_and_stress(const Mat3& F, Mat3& P) const override {
    P.setZero();
    return coaxial_value(p_, F, 0.0, false, &P, nullptr);
  }
  Mat9 stress_derivative(const Mat3& F) const override {
    const Return r = return_map(p_, F, nullptr, false);
    return r.ok ? tangent(p_, F, r) : Mat9::Zero();
  }
  double laplacian_weight() const override { return 2.0 * p_.mu + (p_.kappa - 2.0 * p_.mu / 3.0); }
  bool projective_dynamics_exact() const override { return false; }

 private:
  Params p_;
};

std::string check_plastic(const InelasticSpec&, std::string*) { return ""; }

std::unique_ptr<InelasticModel> create_plastic(const MaterialSpec& spec) {
  const InelasticSpec& s = spec.inelastic;
  const Params p{spec.mu, spec.lambda + 2.0 * spec.mu / 3.0, s.value("yield_stress"), s.value("isotropic_hardening"),
                 s.value("kinematic_hardening")};
  if (!(p.mu > 0) || !(p.kappa > 0) || !(p.sigma_y > 0) || !(p.H_iso >= 0) || !(p.H_kin >= 0))
    throw std::invalid_argument("plastic: needs mu > 0, a bulk modulus > 0, yield_stress > 0 and hardening moduli >= 0");
  return std::make_unique<LogStrainPlasticity>(p);
}

}  // namespace

std::unique_ptr<Material> make_hencky(const MaterialParams& p) { return std::make_unique<Hencky>(p.mu, p.lambda); }

const InelasticKind& plasticity_kind() {
  static const InelasticKind kind = [] {
    InelasticKind k{"plastic", "plastic", {}, {}, 0, 0, {"hencky"}, true,
                    "plastic: {yield_stress, isotropic_hardening, kinematic_hardening}", check_plastic, create_plastic};
    k.keys = {
        {"plastic", {},
         "J2 (von Mises) plasticity in the logarithmic strain over the Hencky elastic law, with linear isotropic and "
         "kinematic hardening; the history per element is E_p and the equivalent plastic strain "
         "([inelastic.md](inelastic.md#plasticity))",
         {}, "map", false, "none"},
        {"plastic.yield_stress", {}, "σ_y, the uniaxial (Kirchhoff) yield stress", above(0), "number", true},
        {"plastic.isotropic_hardening", {}, "H_iso: the yield stress grows by H_iso per unit equivalent plastic strain",
         at_least(0), "number", false, "0"},
        {"plastic.kinematic_hardening", {}, "H_kin: the back stress is 2/3 H_kin E_p (Prager); uniaxially the "
         "slope σ/ε_p is H_iso + H_kin", at_least(0), "number", false, "0"},
    };
    return k;
  }();
  return kind;
}

}  // namespace hyperqn

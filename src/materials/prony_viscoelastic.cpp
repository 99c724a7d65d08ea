// Finite-strain viscoelasticity by a Prony series of stress histories (material.viscoelastic_prony;
// docs/viscoelastic-prony.md): the model of FEBio's `viscoelastic` material, Simo (1987) and
// Holzapfel (2000, Nonlinear Solid Mechanics) without their isochoric split (the whole elastic stress relaxes).
// The deck's model psi(C) (with its fibre, if any) is the equilibrium part; with S0 = dpsi/dE its
// second Piola-Kirchhoff stress,
//   S = S0(C) + sum_i H_i,   dH_i/dt = -H_i / tau_i + gt_i dS0/dt,
// gt_i = g_i / (1 - sum g) the branch's modulus relative to the equilibrium one (the deck's g_i is
// its fraction of the instantaneous modulus, as for material.viscoelastic). Integrated exactly for
// S0 linear in time over a step of dt (Taylor, Pister and Goudreau 1970; FEBio's update):
//   H_i^{n+1} = q_i H_i^n + gamma_i (S0(C^{n+1}) - S0(C^n)),  q_i = e^{-dt/tau_i},
//   gamma_i = gt_i (1 - q_i) / (dt / tau_i).
// Within a step the history is constant, and the step's stress is the gradient in E = (C - I)/2 of
//   W(F) = (1 + G) psi(C) + Q : E,  G = sum gamma_i,  Q = sum_i (q_i H_i^n - gamma_i S0(C^n)),
// since dW/dE = (1 + G) S0(C) + Q = S0(C^{n+1}) + sum_i H_i^{n+1}: all branches collapse into one
// evaluation of psi and a 3x3 contraction. P = (1 + G) P0 + F Q; dP/dF = (1 + G) dP0/dF + Q's geometric
// stiffness (dP = dF Q). History per element: H_i (6 values each, symmetric) then S0(C^n) (6).
// Dissipation: the model postulates the evolution of H_i, not a finite-strain free energy of its
// branches, so a branch stores its small-strain one, H_i : D0^{-1} : H_i / (2 gt_i), D0 the base's
// isotropic rest tangent (mu, lambda; a fibre's share left out), and dissipates H_i : D0^{-1} : H_i /
// (gt_i tau_i), integrated exactly over the step along the same S0 linear in time (>= 0).
// Registered as one InelasticKind (viscoelastic_prony_kind, listed in material_factory.cpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "materials/material_factory.hpp"
#include "materials/symmetric6.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

std::string check_viscoelastic(const InelasticSpec& s, std::string* key);  // material_factory.cpp

namespace {

constexpr int kMaxBranches = 4;

struct PronyBranch {
  double g = 0;    // gt: modulus relative to the equilibrium part's, > 0
  double tau = 0;  // relaxation time, > 0
};

// The step's constants of a dt: q_i, gamma_i, G = sum gamma_i, and the dissipation's integrals
// (dissipation below).
struct StepCoefficients {
  double dt = -1;
  double q[kMaxBranches] = {}, gamma[kMaxBranches] = {};
  double G = 0;
  double I1[kMaxBranches] = {}, I2[kMaxBranches] = {}, I3[kMaxBranches] = {};
};

// sum of the symmetric 6-vectors' a : b (off-diagonals twice).
double contract(const double* a, const double* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

// W's kernel across a batch's lanes: psi and P0 of the base in base, each lane's Q (its step values),
// then psi (1 + G) + Q : E and P0 (1 + G) + F Q added to b.
HYPERQN_VECTOR_CLONES void prony_batch(double G, const StressBatch& base, StressBatch& b, int n,
                                       const double* const* Qs) {
  // Each Q[c] built as one vector (lane stores then a vector load would stall store forwarding);
  // lanes past n repeat lane 0.
  const double* r[kBatch];
  for (int e = 0; e < kBatch; ++e) r[e] = Qs[e < n ? e : 0];
  Lanes Q[6];
  for (int c = 0; c < 6; ++c) Q[c] = Lanes{r[0][c], r[1][c], r[2][c], r[3][c], r[4][c], r[5][c], r[6][c], r[7][c]};
  const Lanes* F = b.F;  // F(i, j) = F[i + 3 j]
  // E = (F^T F - I) / 2: C(r, c) = sum_k F(k, r) F(k, c).
  const int rows[6] = {0, 1, 2, 0, 1, 0}, cols[6] = {0, 1, 2, 1, 2, 2};
  Lanes QE = {};
  for (int m = 0; m < 6; ++m) {
    const int r = rows[m], c = cols[m];
    const Lanes C = F[3 * r] * F[3 * c] + F[1 + 3 * r] * F[1 + 3 * c] + F[2 + 3 * r] * F[2 + 3 * c];
    QE += (m < 3 ? 0.5 : 1.0) * Q[m] * (m < 3 ? C - 1.0 : C);
  }
  const double scale = 1.0 + G;
  b.psi += scale * base.psi + QE;
  const Lanes q[3][3] = {{Q[0], Q[3], Q[5]}, {Q[3], Q[1], Q[4]}, {Q[5], Q[4], Q[2]}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)  // (F Q)(r, c)
      b.P[r + 3 * c] += scale * base.P[r + 3 * c] + F[r] * q[0][c] + F[r + 3] * q[1][c] + F[r + 6] * q[2][c];
}

class PronyViscoelastic : public InelasticModel {
 public:
  PronyViscoelastic(std::unique_ptr<Material> base, std::vector<PronyBranch> branches, double mu, double lambda)
      : base_(std::move(base)), branches_(std::move(branches)), mu_(mu), lambda_(lambda) {
    if (branches_.empty() || (int)branches_.size() > kMaxBranches)
      throw std::invalid_argument("viscoelastic_prony: 1 to " + std::to_string(kMaxBranches) + " branches, got " +
                                  std::to_string(branches_.size()));
    for (const PronyBranch& b : branches_)
      if (!(b.g > 0) || !(b.tau > 0) || !std::isfinite(b.g) || !std::isfinite(b.tau))
        throw std::invalid_argument("viscoelastic_prony: every branch needs g > 0 and a relaxation time > 0");
    if (!(mu_ > 0) || !(2.0 * mu_ + 3.0 * lambda_ > 0))
      throw std::invalid_argument("viscoelastic_prony: needs mu > 0 and a bulk modulus > 0");
  }
  std::string name() const override { return "viscoelastic_prony " + base_->name(); }
  int history_width() const override { return 6 * count() + 6; }
  void rest(double* history) const override {  // no branch stress; S0(I) = 0
    for (int c = 0; c < history_width(); ++c) history[c] = 0.0;
  }
  double energy(const Mat3& F, const double* history, double dt, Mat3* P) const override {
    const StepCoefficients& k = coefficients(dt);
    Mat3 P0;
    const double psi = base_->energy_and_stress(F, P0);
    const Mat3 Q = step_stress(history, k);
    if (P) *P += (1.0 + k.G) * P0 + F * Q;
    const Mat3 E = 0.5 * (F.transpose() * F - Mat3::Identity());
    return (1.0 + k.G) * psi + (Q.array() * E.array()).sum();
  }
  // A step reads Q alone: 6 values per tet (the term computes them once per step).
  int step_width() const override { return 6; }
  void step_values(const double* history, double dt, double* Q) const override {
    pack_symmetric(step_stress(history, coefficients(dt)), Q);
  }
  void energy_batch(StressBatch& b, int n, const double* const* Q, double dt) const override {
    StressBatch base;
    for (int c = 0; c < 9; ++c) base.F[c] = b.F[c];
    base_->energy_and_stress_batch(base, n);
    prony_batch(coefficients(dt).G, base, b, n, Q);
  }
  // psi + the branches' small-strain stored energies; the stress P0 + F sum H_i (the state's).
  double stored_energy(const Mat3& F, const double* history, Mat3* P) const override {
    Mat3 P0;
    double psi = base_->energy_and_stress(F, P0);
    Mat3 H = Mat3::Zero();
    for (int i = 0; i < count(); ++i) {
      H += unpack_symmetric(history + 6 * i);
      psi += 0.5 * compliance(history + 6 * i, history + 6 * i) / branches_[i].g;
    }
    if (P) *P += P0 + F * H;
    return psi;
  }
  Mat9 stress_derivative(const Mat3& F, const double* history, double dt) const override {
    const StepCoefficients& k = coefficients(dt);
    const Mat3 Q = step_stress(history, k);
    Mat9 D = (1.0 + k.G) * base_->stress_derivative(F);
    // P(i, j) = sum_m F(i, m) Q(m, j): dP(i, j)/dF(i, m) = Q(m, j).
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int m = 0; m < 3; ++m) D(i + 3 * j, i + 3 * m) += Q(m, j);
    return D;
  }
  // H_i = q_i H_i,n + gamma_i (S0(C) - S0(C_n)); S0 = F^{-1} P0 (det F != 0).
  void update(const Mat3& F, const double* start, double dt, double* end) const override {
    const StepCoefficients& k = coefficients(dt);
    Mat3 P0;
    base_->energy_and_stress(F, P0);
    double s0[6];
    pack_symmetric(F.inverse() * P0, s0);
    const double* s0n = start + 6 * count();
    for (int i = 0; i < count(); ++i)
      for (int c = 0; c < 6; ++c) end[6 * i + c] = k.q[i] * start[6 * i + c] + k.gamma[i] * (s0[c] - s0n[c]);
    for (int c = 0; c < 6; ++c) end[6 * count() + c] = s0[c];
    reach_ = std::max(reach_, (0.5 * (F.transpose() * F - Mat3::Identity())).norm());
  }
  double small_strain_reach() const override { return reach_; }
  // Per branch the integral over the step of H : D0^{-1} : H / (gt tau), H(s) = e^{-s/tau} H_n +
  // phi(s) R, phi(s) = tau/dt (1 - e^{-s/tau}), R = gt (S0 end - S0 start): the Gram form of
  // e^{-s/tau} and phi over [0, dt] (positive semidefinite; its round-off below 0 clamped).
  double dissipation(const Mat3& /*F*/, const double* start, double dt, const double* end) const override {
    if (!(dt > 0)) return 0.0;
    const StepCoefficients& k = coefficients(dt);
    double sum = 0;
    for (int i = 0; i < count(); ++i) {
      const double g = branches_[i].g;
      double R[6];
      for (int c = 0; c < 6; ++c) R[c] = g * (end[6 * count() + c] - start[6 * count() + c]);
      const double* Hn = start + 6 * i;
      sum += k.I1[i] * compliance(Hn, Hn) + 2.0 * k.I2[i] * compliance(Hn, R) + k.I3[i] * compliance(R, R);
    }
    return std::max(0.0, sum);
  }
  // A step's stiffness is (1 + G) the base's, G between 0 (dt >> tau) and sum gt (dt << tau), and dt
  // is not known here: the geometric mean of the two ends, sqrt(1 + sum gt) the base's, is off by at
  // most that factor either way (on bar66792 at h = 1/30 s, sum gt = 1, G = 0.67: 26 iterations a frame
  // against 32 with the instantaneous weight and 28 with the step's own; docs/viscoelastic-prony.md).
  double laplacian_weight() const override {
    double g = 0;
    for (const PronyBranch& b : branches_) g += b.g;
    return std::sqrt(1.0 + g) * base_->laplacian_weight();
  }

 private:
  int count() const { return (int)branches_.size(); }
  // Q = sum_i (q_i H_i - gamma_i S0(C_n)), the step's constant stress.
  Mat3 step_stress(const double* history, const StepCoefficients& k) const {
    Mat3 Q = -k.G * unpack_symmetric(history + 6 * count());
    for (int i = 0; i < count(); ++i) Q += k.q[i] * unpack_symmetric(history + 6 * i);
    return Q;
  }
  // a : D0^{-1} : b, D0 = 2 mu I + lambda I (x) I: D0^{-1} b = (b - lambda / (2 mu + 3 lambda) tr b I) / (2 mu).
  double compliance(const double* a, const double* b) const {
    const double tra = a[0] + a[1] + a[2], trb = b[0] + b[1] + b[2];
    return (contract(a, b) - lambda_ / (2.0 * mu_ + 3.0 * lambda_) * tra * trb) / (2.0 * mu_);
  }
  // The constants of a step of dt, kept for the last dt (a step evaluates many times at one dt;
  // each evaluation would otherwise pay 2 exponentials per branch per batch). dt = 0: the limit
  // gamma = gt, q = 1 (an instantaneous response).
  const StepCoefficients& coefficients(double dt) const {
    if (dt == last_.dt) return last_;
    StepCoefficients k;
    k.dt = dt;
    for (int i = 0; i < count(); ++i) {
      const double x = dt / branches_[i].tau;
      k.q[i] = std::exp(-x);
      k.gamma[i] = x > 0 ? branches_[i].g * -std::expm1(-x) / x : branches_[i].g;
      k.G += k.gamma[i];
      if (!(x > 0)) continue;
      // The integrals over [0, dt] of e^{-2s/tau}, e^{-s/tau} phi and phi^2, over g tau. With p = 1 - q:
      // x - p - p^2/2 = x^3/3 - x^4/4 + 7 x^5/60 - ..., its series where the difference cancels.
      const double tau = branches_[i].tau, p = -std::expm1(-x), q = 1.0 - p, over = 1.0 / (branches_[i].g * tau);
      const double cubic = x < 1e-3 ? x * x * x * (1.0 / 3.0 - x / 4.0 + 7.0 * x * x / 60.0) : x - p - 0.5 * p * p;
      k.I1[i] = over * 0.5 * tau * (1.0 - q * q);
      k.I2[i] = over * 0.5 * tau * p * p / x;
      k.I3[i] = over * tau * cubic / (x * x);
    }
    last_ = k;
    return last_;
  }

  std::unique_ptr<Material> base_;
  std::vector<PronyBranch> branches_;
  double mu_, lambda_;
  mutable StepCoefficients last_;  // one rank, one thread per model
  mutable double reach_ = 0;       // small_strain_reach
};

std::unique_ptr<InelasticModel> create_prony(const MaterialSpec& spec) {
  double sum = 0;
  for (const auto& b : spec.inelastic.items) sum += b.at("g");
  std::vector<PronyBranch> branches;
  for (const auto& b : spec.inelastic.items) branches.push_back({b.at("g") / (1.0 - sum), b.at("tau")});
  return std::make_unique<PronyViscoelastic>(make_material(spec), std::move(branches), spec.mu, spec.lambda);
}

}  // namespace

const InelasticKind& viscoelastic_prony_kind() {
  static const InelasticKind kind = [] {
    InelasticKind k{"viscoelastic_prony", "prony", {}, {}, 1, kMaxBranches, {}, true,
                    "viscoelastic_prony: {branches: [{g, tau}, ...]}", check_viscoelastic, create_prony};
    k.keys = {
        {"viscoelastic_prony", {},
         "the model's whole stress relaxes by a Prony series of stress histories (Simo 1987, FEBio's viscoelastic): "
         "μ and λ are the relaxed ones, 1/(1 − Σg) times them the instantaneous; one evaluation of the model per tet "
         "whatever the branches ([viscoelastic-prony.md](viscoelastic-prony.md))",
         {}, "map", false, "none"},
        {"viscoelastic_prony.branches", {},
         "1 to 4 branches `{g: …, tau: …}` as for `viscoelastic`", {}, "list of maps", true},
    };
    k.item_keys = {
        {"g", {}, "", above(0, "the branch's fraction of the instantaneous modulus"), "", true},
        {"tau", {}, "", above(0, "a relaxation time, s"), "", true},
    };
    return k;
  }();
  return kind;
}

}  // namespace hyperqn

// A spring whose rest length flows (docs/yielding-springs.md): 1-D rate-independent
// plasticity of the strain eps = l/L - 1 (L the spring's original rest length), plastic strain
// eps_p (the flowing rest length is L (1 + eps_p)), linear isotropic hardening with internal
// variable alpha (the accumulated |d eps_p|):
//   stored      k L^2 [ (eps - eps_p)^2 / 2 + hardening alpha^2 / 2 ]   (k L^2 (eps - eps_p)^2/2 = k/2 (l - L_p)^2)
//   yield       |eps - eps_p| <= yield_strain + hardening alpha          (an elastic strain, in units of 1)
//   dissipation k L^2 yield_strain |d eps_p|
// Variational (Ortiz and Stainier 1999): within a step, from (eps_p, alpha) at its start, the
// increment dgamma >= 0 minimizes stored + dissipation, which in 1-D is the closed-form return map
// below; the minimum W(l) is the spring's condensed energy, C1 in l, its slope the tension
// k L (eps - eps_p_new) and its curvature k (elastic) or k hardening/(1 + hardening) (flowing).
#pragma once
#include <algorithm>
#include <cmath>

namespace hyperqn {

// A spring set's yield (deck: yield_strain, hardening); strain 0: elastic (no history).
struct SpringYield {
  double strain = 0;     // the elastic strain at first yield (> 0)
  double hardening = 0;  // H / k: the growth of the yield strain per unit of accumulated plastic strain (>= 0)
  bool active() const { return strain > 0; }
};

namespace yielding_spring {

constexpr int kValues = 3;  // per spring: eps_p, alpha, the energy it has dissipated (J)
// What a torn edge's second spring takes from the edge's spring (ElementState::inherited): eps_p
// and alpha, so each half stores half of what the whole did; the energy dissipated stays with the
// spring that dissipated it, so the run's total is unchanged.
constexpr int kInherited = 2;

// The step's return map at strain eps from the history h (eps_p, alpha) at the step's start.
struct Flow {
  double elastic = 0;  // eps - eps_p at the step's end
  double dgamma = 0;   // the plastic increment |d eps_p| >= 0
  double w = 0;        // condensed energy per k L^2: stored + dissipated in the step
  double slope = 0;    // dw/deps
  double curvature = 0;  // d2w/deps2 (1 elastic, h/(1+h) flowing)
};

inline Flow flow(double eps, const double* h, const SpringYield& y) {
  Flow f;
  const double trial = eps - h[0], alpha = h[1];
  const double over = std::fabs(trial) - (y.strain + y.hardening * alpha);
  if (over <= 0) {
    f.elastic = trial;
    f.w = 0.5 * trial * trial + 0.5 * y.hardening * alpha * alpha;
    f.slope = trial;
    f.curvature = 1;
    return f;
  }
  f.dgamma = over / (1 + y.hardening);
  f.elastic = trial - std::copysign(f.dgamma, trial);
  const double a = alpha + f.dgamma;
  f.w = 0.5 * f.elastic * f.elastic + 0.5 * y.hardening * a * a + y.strain * f.dgamma;
  f.slope = f.elastic;
  f.curvature = y.hardening / (1 + y.hardening);
  return f;
}

// The history at the step's end (into next) from the start's (h) at strain eps, for a spring of
// k L^2 = kl2: eps_p, alpha, and the dissipated energy grown by kl2 yield_strain dgamma.
inline void update(double eps, const double* h, const SpringYield& y, double kl2, double* next) {
  const Flow f = flow(eps, h, y);
  next[0] = eps - f.elastic;
  next[1] = h[1] + f.dgamma;
  next[2] = h[2] + kl2 * y.strain * f.dgamma;
}

}  // namespace yielding_spring
}  // namespace hyperqn

// When a frame's solve may stop, for every solver (the same tests, so that solvers compare).
//
// Converged: ||grad g|| < rtol ||grad g(x0)|| (TAO's relative test) or ||grad g|| <= rtol S (an
// absolute floor), and in either case ||grad g|| <= kFloor S; S is the force scale of the step
// (Objective::force_scale: the impulse of the forces acting, at least the body's own weight's over
// a step), rtol the deck's grad_rtol. The relative test alone means little at either end:
//  - a warm start y that inverts elements has ||grad g(x0)|| up to 1e15, and "converged" was then
//    reported at ||grad g|| = 5e8: hence kFloor, the residual force at most 0.1 % of the forces acting;
//  - a body at rest (or a small step) starts with ||grad g(x0)|| -> 0, and rtol ||grad g(x0)||
//    falls below what the round-off of g lets a line search reach: L-BFGS then ran its whole
//    budget every frame (200 iterations per frame on a free bar damped to rest): hence the floor
//    rtol S, the deck's tolerance of the forces acting. At the initial guess (||grad g|| =
//    ||grad g(x0)||) only the floor can hold: an initial guess that is already the answer (a body
//    in free fall starts at y with g = 0) takes no iteration, and a line search from there could
//    only fail on round-off.
//
// Where the round-off of g allows no ||grad g|| as small as rtol S (a stiff body at rest: measured
// 8e-4 against rtol S = 5e-6 on a free bar of E = 1e9 Pa), a body at rest still runs the budget
// (docs/guardrails.md#fallback).
//
// Far from converged (the fallback chain goes on, model/fallback_chain.hpp), unless
// ||grad g|| <= kFloor S (a residual that small is no reason to work on, e.g. a frame that started
// almost at its answer and stalled at the round-off of g): the solver could not decrease g, or
// ||grad g|| is above kFarGradient ||grad g(x0)||, or the last iteration still decreased g by more
// than kFarDecrease of the frame's whole decrease so far (g is about quadratic near the answer:
// a relative error of about sqrt(kFarDecrease) in the norm of the Hessian, whatever the
// stiffness), or the last two decreases, read as a linear convergence of rate r = d_k / d_{k-1},
// leave more than that still to go (d_k r / (1 - r); none left only while r < 1), counted once
// d_k is above kTrendGate of the frame's decrease, or it still moved a dof by more than kFarStep D
// (D the body's rest diagonal). Without the rate, L-BFGS creeping along a barrier's wall by 0.77
// an iteration (a bunny cut at 2 ranks, its last decrease 0.9998 % of the frame's) was accepted
// at |grad g| = 667 S. The
// tests are relative to the frame and to the body's size, not to forces, so a stiff body, whose
// ||grad g|| stays many times S while its positions are already right, is not "far" for that.
// A static step (equilibrium: Objective::seeks_equilibrium) is also far while its residual is
// above kFarResidual S: its answer is the equilibrium, which tests of how little the last
// iterations changed cannot see (a slack rope whose support moved: L-BFGS crept by < 1e-4 D an
// iteration at 5 S and the frame was accepted, sagging 20 % less than with the rule).
#pragma once
#include <algorithm>

namespace hyperqn {

// Where a frame's solve stands after `iterations`.
struct FrameProgress {
  int iterations = 0;
  double g0 = 0, g = 0;     // g at the initial guess and now
  double last_decrease = 0; // g_{k-1} - g_k of the last iteration
  double gnorm0 = 0, gnorm = 0;
  bool failed = false;      // the solver could not decrease g further
  double last_step = 0;     // largest dof change of the last iteration (computed past the budget only)
  double previous_decrease = 0;  // g_{k-2} - g_{k-1}, the iteration before the last
};

struct FrameBudget {
  // Measured on the stability suite (docs/guardrails.md#fallback), after 10 lbfgs iterations:
  // ||grad g|| / ||grad g(x0)|| is 2e-2 at most on the stiff, h <= 1/5 and thin cases (median
  // 1e-2), 0.2 to 34 on those that ran away or ended far from the converged answer; the last
  // decrease is at most 2e-3 of the frame's decrease on the former, 1e-2 to 0.2 on nu >= 0.49.
  // kFarStep: 1e-3 left the random start running away, 1e-4 kept every case (docs).
  static constexpr double kFarGradient = 0.1;
  static constexpr double kFarDecrease = 1e-2;
  static constexpr double kFarStep = 1e-4;
  // The last decrease, of the frame's, below which its trend is not read: 1e-3, the square of
  // about 3 % in the norm of the Hessian (none of the 25 decks of scripts/compare_revisions.py
  // has a frame this rule extends).
  static constexpr double kTrendGate = 1e-3;
  static constexpr double kFloor = 1e-3;
  // A static step's residual past which it is far (0.5 % of the forces acting): the rope above
  // at 5 S; a 90 degree twist in one load step split into 4 ends at 1.4e-3 S, within 1e-2 of the
  // converged answer (tests/python/test_static.py).
  static constexpr double kFarResidual = 5e-3;

  int budget = 10;     // iterations the deck gives a frame
  int cap = 10;        // iterations a frame may take while it is far from converged
  double rtol = 1e-6;  // the deck's grad_rtol

  FrameBudget() = default;
  // budget_iterations: the deck's solver.iterations, or what the options made of it.
  FrameBudget(int budget_iterations, int max_iterations, double grad_rtol)
      : budget(budget_iterations), cap(std::max(budget_iterations, max_iterations)), rtol(grad_rtol) {}

  // TAO's relative test (strict, as TAO's).
  bool relative(double gnorm, double gnorm0) const { return gnorm0 != 0 && gnorm / gnorm0 < rtol; }
  // The rule (above); scale: the force scale S at the iterate.
  bool converged(double gnorm, double gnorm0, double scale) const {
    return (relative(gnorm, gnorm0) || gnorm <= rtol * scale) && gnorm <= kFloor * scale;
  }
  // scale: the force scale S; length: the body's length scale D.
  static bool far(const FrameProgress& p, double scale, double length, bool equilibrium = false) {
    if (!(p.gnorm > kFloor * scale)) return false;
    if ((equilibrium && p.gnorm > kFarResidual * scale) || p.iterations == 0 || p.failed || p.gnorm > kFarGradient * p.gnorm0)
      return true;
    return p.last_decrease > kFarDecrease * (p.g0 - p.g) || creeping(p) || p.last_step > kFarStep * length;
  }
  // What a constant rate of decrease leaves to go is still above kFarDecrease of the frame's.
  static bool creeping(const FrameProgress& p) {
    const double done = p.g0 - p.g, d = p.last_decrease, before = p.previous_decrease;
    if (!(d > kTrendGate * done) || !(before > 0)) return false;
    const double rate = d / before;
    return rate >= 1 || d * rate / (1 - rate) > kFarDecrease * done;
  }
  // Past the budget: stop at the cap, or once the frame is not far from converged.
  bool spent(const FrameProgress& p, double scale, double length, bool equilibrium = false) const {
    return p.iterations >= cap || !far(p, scale, length, equilibrium);
  }
};

}  // namespace hyperqn

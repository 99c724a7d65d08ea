// A time-step solver's settings (the deck's solver: section).
#pragma once
#include <string>
#include <vector>

#include "io/deck_keys.hpp"

namespace hyperqn {

// The most L-BFGS pairs a run may keep (the deck's history, or the option that sets it): each
// holds two vectors of all unknowns, and the paper uses 5.
inline constexpr int kMaxHistory = 1000;

struct SolverSpec {
  std::string type = "lbfgs";        // lbfgs | lbfgs-identity | newton | pd
  int iterations = 10;               // per frame
  double grad_atol = 0;              // stop when ||grad g|| <= grad_atol, or
  double grad_rtol = 1e-6;           //   ||grad g|| <= grad_rtol * ||grad g(x0)||
  int history = 5;                   // L-BFGS pairs
  // lbfgs: forget the pairs when the set of contacts changes between iterates (measured to cost
  // iterations, docs/contact.md): never | contact-change
  std::string history_reset = "never";
  std::string line_search = "more-thuente";  // TAO line search type: more-thuente | armijo | unit
  std::string warm_start = "inertial";  // inertial (x0 = y) | previous (x0 = x_n) | lower (of the two; the default with colliders)
  // Pull y back towards x_n until it leaves no tet upright at x_n inverted, nor past the element
  // limit (-hyperqn_element_limit) unless it was (StepObjective::upright_guess; docs/guardrails.md#element-blow-up-and-inversion).
  bool upright_guess = true;
  std::string newton_method = "nls";         // newton: TAO method, nls | ntr
  std::string linear_solver = "auto";        // newton: auto (newton_uses_amg) | mumps (Cholesky) | cg-amg (CG + BoomerAMG)
  std::string newton_hessian = "projected";  // newton: projected (PSD fix per element) | exact
  std::string h0 = "auto";                   // lbfgs: its constant matrix, laplacian (M + h^2 L) |
                                             //   rest-stiffness (M + h^2 K(x_rest)) | amg (M + h^2 L
                                             //   by one AMG V-cycle instead of a factorization) |
                                             //   auto (laplacian or amg by the mesh: auto_h0_is_amg)
  // The fallback chain of a frame that ends far from converged (docs/guardrails.md#fallback):
  // iterate on up to max_iterations, then redo the frame in 2, 4, ... 2^max_halvings sub-steps,
  // then with Newton. max_iterations <= iterations, max_halvings = 0, newton_fallback = false
  // turn the stages off one by one; use_fixed_budget turns them all off.
  int max_iterations = 100;
  int max_halvings = 3;
  bool newton_fallback = true;
  bool quiet = false;  // set up without a word (the chain's solvers: the run's own one has spoken)
};

// The deck's solver: keys (io/deck_keys.hpp; solvers/solver_registry.cpp, which knows the types).
const std::vector<DeckKey<SolverSpec>>& solver_keys();

// The paper's fixed budget (the deck's solver: {budget: fixed}, and every study contender): a
// frame takes `iterations` iterations (fewer only if it converges), never more, never sub-steps,
// never Newton.
inline void use_fixed_budget(SolverSpec& s) {
  s.max_iterations = 0;
  s.max_halvings = 0;
  s.newton_fallback = false;
}

}  // namespace hyperqn

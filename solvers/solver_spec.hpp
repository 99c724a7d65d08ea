// A time-step solver's settings (the deck's solver: section).
#pragma once
#include <string>
#include <vector>

#include "params/deck_keys.hpp"

namespace hyperqn {

// The most L-BFGS pairs a run may keep (the deck's history, or the option that sets it): each
// holds two vectors of all unknowns, and the paper uses 5.
inline constexpr int kMaxHistory = 1000;

// lbfgs's constant matrix A, its initial inverse Hessian (solver.h0): M + h^2 L factored, M + h^2
// K(x_rest) factored, or M + h^2 L by one AMG V-cycle. automatic is resolved by the mesh, in one
// place: resolved_h0 (solvers/solver_registry.hpp).
enum class H0 { automatic, laplacian, rest_stiffness, amg, volumetric };

// The precision of a factored H0's values (solver.h0_precision): double, or single, floats widened
// to double as a solve loads them, all arithmetic in double (SupernodalCholesky::keep_single_precision).
enum class H0Precision { double_precision, single_precision };

// Where each step's solve starts: at the inertial target y, at x_n, or at the one of the two with
// the lower g (two evaluations per step; for contact, where y often lies deep in an obstacle
// while x_n rests on it).
enum class WarmStart { inertial, previous, lower };
// Newton's linear solver: automatic is resolved by the Hessian's size (newton_uses_amg).
enum class LinearSolver { automatic, mumps, cg_amg };
enum class NewtonHessian { projected, exact };  // a per-element PSD fix of dP/dF, or none
enum class NewtonMethod { nls, ntr };           // TAO's line search or trust region
enum class HistoryReset { never, contact_change };
// lbfgs: what of the contacts' stiffness its initial Hessian holds (solvers/contact_h0.hpp).
enum class H0Contact { off, woodbury, refactor };
// lbfgs: the stiff clusters' rigid rotations left out of its H0 (solvers/rigid_mode_h0.hpp): where a
// tet contrast reaches RigidModeH0::kStiffRatio (automatic), always where one does (on), never (off).
enum class H0Rigid { automatic, on, off };
// lbfgs: who applies the (s, y) pairs: PETSc's BFGS matrix, or solvers/streamed_two_loop.hpp.
enum class TwoLoop { petsc, streamed };

// The deck's words for these, in each enum's order.
inline const std::vector<std::string> kH0Names = {"auto", "laplacian", "rest-stiffness", "amg", "volumetric"};
inline const std::vector<std::string> kH0PrecisionNames = {"double", "single"};
inline const std::vector<std::string> kWarmStartNames = {"inertial", "previous", "lower"};
inline const std::vector<std::string> kLinearSolverNames = {"auto", "mumps", "cg-amg"};
inline const std::vector<std::string> kNewtonHessianNames = {"projected", "exact"};
inline const std::vector<std::string> kNewtonMethodNames = {"nls", "ntr"};
inline const std::vector<std::string> kHistoryResetNames = {"never", "contact-change"};
inline const std::vector<std::string> kH0ContactNames = {"off", "woodbury", "refactor"};
inline const std::vector<std::string> kH0RigidNames = {"auto", "true", "false"};
inline const std::vector<std::string> kTwoLoopNames = {"petsc", "streamed"};

struct SolverSpec {
  std::string type = "lbfgs";        // lbfgs | lbfgs-identity | newton | pd
  int iterations = 10;               // per frame
  double grad_atol = 0;              // stop when ||grad g|| <= grad_atol, or
  double grad_rtol = 1e-6;           //   ||grad g|| <= grad_rtol * ||grad g(x0)||
  int history = 5;                   // L-BFGS pairs
  // lbfgs: forget the pairs when the set of contacts changes between iterates (measured to cost
  // iterations, docs/contact.md): never | contact-change
  HistoryReset history_reset = HistoryReset::never;
  std::string line_search = "more-thuente";  // TAO line search type: more-thuente | armijo | unit
  H0Contact h0_contact = H0Contact::refactor;  // lbfgs
  TwoLoop two_loop = TwoLoop::petsc;           // lbfgs
  H0Rigid h0_rigid = H0Rigid::automatic;       // lbfgs
  WarmStart warm_start = WarmStart::inertial;  // (lower: the default with colliders)
  // Pull y back towards x_n until it leaves no tet upright at x_n inverted, nor past the element
  // limit (-hyperqn_element_limit) unless it was (StepObjective::upright_guess; docs/guardrails.md#element-blow-up-and-inversion).
  bool upright_guess = true;
  NewtonMethod newton_method = NewtonMethod::nls;              // newton
  LinearSolver linear_solver = LinearSolver::automatic;        // newton: mumps (Cholesky) | cg-amg (CG + BoomerAMG)
  NewtonHessian newton_hessian = NewtonHessian::projected;     // newton
  H0 h0 = H0::automatic;                     // lbfgs: its constant matrix (pd's is M + h^2 L)
  H0Precision h0_precision = H0Precision::double_precision;  // lbfgs: its factor's values
  // The fallback chain of a frame that ends far from converged (docs/guardrails.md#fallback):
  // iterate on up to max_iterations, then redo the frame in 2, 4, ... 2^max_halvings sub-steps,
  // then with Newton. max_iterations <= iterations, max_halvings = 0, newton_fallback = false
  // turn the stages off one by one; use_fixed_budget turns them all off.
  int max_iterations = 100;
  int max_halvings = 3;
  int keep_substeps = 8;  // the longest a sub-step size is kept before a larger one is tried (model/substep_memory.hpp; 0: never kept)
  bool newton_fallback = true;
  bool quiet = false;  // set up without a word (the chain's solvers: the run's own one has spoken)
};

// The deck's solver: keys (params/deck_keys.hpp; solvers/solver_registry.cpp, which knows the types).
const std::vector<DeckKey<SolverSpec>>& solver_keys();

// A solver key's default under a rule of the scene, written as a deck would write it: the deck
// reader sets it where the deck leaves the key out (and `hyperqn config` names the rule), and the
// key's default in the docs is made from it.
struct RuleDefault {
  const char* key;    // a key of solver_keys()
  const char* value;
};
// With contact (colliders or self-contact; docs/contact.md#defaults): contact's stiff, lagged
// friction is learnt from more (s, y) pairs, and y often lies deep inside an obstacle while x_n
// rests on it.
inline const char* const kContactRule = "contact (colliders or self-contact)";
inline const std::vector<RuleDefault> kContactSolverDefaults = {{"history", "20"}, {"warm_start", "lower"}};

// The paper's fixed budget (the deck's solver: {budget: fixed}, and every study contender): a
// frame takes `iterations` iterations (fewer only if it converges), never more, never sub-steps,
// never Newton.
inline void use_fixed_budget(SolverSpec& s) {
  s.max_iterations = 0;
  s.max_halvings = 0;
  s.newton_fallback = false;
}

}  // namespace hyperqn

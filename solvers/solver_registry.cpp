#include "solvers/solver_registry.hpp"

#include "solvers/lbfgs_solver.hpp"
#include "solvers/newton_solver.hpp"
#include "solvers/pd_solver.hpp"

namespace hyperqn {

namespace {

// Constructs a solver of type S with args and runs its setup(spec).
template <class S, class... Args>
PetscErrorCode set_up(const SolverSpec& spec, std::unique_ptr<TimeStepSolver>& solver, Args&&... args) {
  PetscFunctionBeginUser;
  auto s = std::make_unique<S>(std::forward<Args>(args)...);
  PetscCall(s->setup(spec));
  solver = std::move(s);
  PetscFunctionReturn(0);
}

}  // namespace

const std::vector<SolverInfo>& solver_registry() {
  static const std::vector<SolverInfo> solvers = {
      {"lbfgs", "L-BFGS (TAO) with the factored M + h^2 L (or solver.h0) as initial inverse Hessian (Liu, Bouaziz & Kavan 2017)", true, true,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem* h0, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<LbfgsSolver>(spec, s, g, h0);
       }},
      {"lbfgs-identity", "L-BFGS (TAO) with TAO's own initial Hessian: the ablation of lbfgs", false, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem*, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<LbfgsSolver>(spec, s, g, nullptr);
       }},
      {"newton", "Newton (TAO NLS or NTR) with a per-element PSD fix (or the exact Hessian), MUMPS or CG + BoomerAMG",
       false, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem*, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<NewtonSolver>(spec, s, g);
       }},
      {"pd", "Projective Dynamics / fast mass-springs: x <- x - A^{-1} grad g, exact steps for PD energies", true, false,
       [](const SolverSpec& spec, Objective& g, const FactoredSystem* h0, std::unique_ptr<TimeStepSolver>& s) {
         return set_up<PdSolver>(spec, s, g, *h0);
       }},
  };
  return solvers;
}

std::vector<std::string> solver_names() {
  std::vector<std::string> names;
  for (const SolverInfo& s : solver_registry()) names.push_back(s.name);
  return names;
}

const SolverInfo* find_solver(const std::string& name) {
  for (const SolverInfo& s : solver_registry())
    if (s.name == name) return &s;
  return nullptr;
}

bool solver_uses_constant_matrix(const std::string& type) {
  const SolverInfo* s = find_solver(type);
  return s && s->uses_constant_matrix;
}

bool solver_takes_h0(const std::string& type) {
  const SolverInfo* s = find_solver(type);
  return s && s->takes_h0;
}

H0 solver_h0(const SolverSpec& spec) { return solver_takes_h0(spec.type) ? spec.h0 : H0::laplacian; }

std::vector<std::string> solver_keys_ignored(const SolverSpec& spec, const std::map<std::string, std::string>& rule_sources) {
  const SolverSpec defaults;
  std::vector<std::string> ignored;
  const auto by_rule = [&](const char* key) { return rule_sources.count(std::string("solver.") + key) > 0; };
  const auto check = [&](const char* key, int value, int default_value, const std::vector<std::string>& names) {
    if (value != default_value && !by_rule(key)) ignored.push_back(std::string(key) + ": " + names[value]);
  };
  if (!solver_takes_h0(spec.type)) {
    check("h0", (int)spec.h0, (int)defaults.h0, kH0Names);
    check("h0_precision", (int)spec.h0_precision, (int)defaults.h0_precision, kH0PrecisionNames);
    check("h0_contact", (int)spec.h0_contact, (int)defaults.h0_contact, kH0ContactNames);
    check("h0_rigid", (int)spec.h0_rigid, (int)defaults.h0_rigid, kH0RigidNames);
    check("two_loop", (int)spec.two_loop, (int)defaults.two_loop, kTwoLoopNames);
  }
  if (spec.type != "lbfgs" && spec.type != "lbfgs-identity") {
    if (spec.history != defaults.history && !by_rule("history")) ignored.push_back("history: " + std::to_string(spec.history));
    check("history_reset", (int)spec.history_reset, (int)defaults.history_reset, kHistoryResetNames);
  }
  return ignored;
}

H0 resolved_h0(H0 h0, int64_t tets, double poisson_ratio, double weight_deflection) {
  if (h0 != H0::automatic) return h0;
  // One V-cycle of M + h^2 L reaches a given accuracy sooner than the factor from this size on,
  // whatever the rank count (the crossover measured in docs/performance.md#distributed-h0). Tets,
  // not vertices: the factor's fill comes from the volume (a strand's or a cloth's vertices add little).
  if (tets >= kAmgFromTets) return H0::amg;
  // A stiff scene held still bends little: K(x_rest) is then nearly its Hessian all along, while
  // L (I_3 on each vertex, no rotation-free bending) leaves its bending mode far behind
  // (docs/method.md, the record of kRestStiffnessBelowDeflection).
  if (tets > 0 && weight_deflection > 0 && weight_deflection < kRestStiffnessBelowDeflection) return H0::rest_stiffness;
  // Near incompressibility the weight of L is dominated by lambda, so (M + h^2 L)^-1 barely moves
  // the bending modes; the volumetric H0 keeps the volume in its own term (docs/method.md).
  return tets > 0 && poisson_ratio >= kVolumetricFromPoisson - kPoissonSlack ? H0::volumetric : H0::laplacian;
}

ConstantMatrix constant_matrix_of(H0 h0) {
  return h0 == H0::rest_stiffness ? ConstantMatrix::rest_stiffness
         : h0 == H0::volumetric   ? ConstantMatrix::volumetric
                                  : ConstantMatrix::laplacian;
}

PetscErrorCode create_solver(const SolverSpec& spec, Objective& objective, const FactoredSystem* h0,
                             std::unique_ptr<TimeStepSolver>& solver) {
  const SolverInfo* s = find_solver(spec.type);
  PetscFunctionBeginUser;
  PetscCheck(s, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "unknown solver type %s", spec.type.c_str());
  PetscCheck(!s->uses_constant_matrix || h0, PETSC_COMM_SELF, PETSC_ERR_ARG_NULL, "solver %s needs its factored constant matrix",
             spec.type.c_str());
  const H0 wanted = solver_h0(spec);
  // auto: M + h^2 L, or the rest stiffness or the volumetric H0 by the scene (resolved_h0).
  PetscCheck(!h0 || !s->uses_constant_matrix || h0->kind() == constant_matrix_of(wanted) ||
                 (wanted == H0::automatic &&
                  (h0->kind() == ConstantMatrix::volumetric || h0->kind() == ConstantMatrix::rest_stiffness)),
             PETSC_COMM_SELF, PETSC_ERR_PLIB,
             "solver %s was given the wrong constant matrix", spec.type.c_str());
  PetscCheck(!h0 || !s->uses_constant_matrix || wanted == H0::automatic ||
                 (h0->package() == FactorPackage::amg) == (wanted == H0::amg),
             PETSC_COMM_SELF, PETSC_ERR_PLIB, "solver %s was given the wrong kind of constant matrix solve (AMG or factor)",
             spec.type.c_str());
  PetscCall(s->create(spec, objective, h0, solver));
  PetscFunctionReturn(0);
}

namespace {

// The default column of a key with a contact default (kContactSolverDefaults): "5; 20 with contact".
void add_contact_defaults(std::vector<DeckKey<SolverSpec>>& keys) {
  static std::vector<std::string> texts;  // the keys' default_text point into it
  texts.reserve(kContactSolverDefaults.size());
  const std::vector<KeyInfo> infos = key_infos("solver", keys);
  for (const RuleDefault& rule : kContactSolverDefaults)
    for (size_t i = 0; i < keys.size(); ++i)
      if (std::string(keys[i].name) == rule.key) {
        const bool word = !keys[i].choices.empty();
        const auto shown = [&](const std::string& v) { return word ? "`" + v + "`" : v; };
        texts.push_back(shown(infos[i].default_value) + "; " + shown(rule.value) + " with colliders or self-contact");
        keys[i].default_text = texts.back().c_str();
      }
}

}  // namespace

const std::vector<DeckKey<SolverSpec>>& solver_keys() {
  using S = SolverSpec;
  static const std::vector<DeckKey<S>> keys = [] {
  std::vector<DeckKey<S>> keys = {
      {"type", &S::type,
       "minimiser of the incremental potential. `lbfgs`: L-BFGS with initial inverse Hessian (M + h²L)⁻¹ (Liu et al. "
       "2017). `lbfgs-identity`: the same L-BFGS with TAO's default initial Hessian instead (ablation, no "
       "factorization; in PETSc 3.18 a diagonal scaling updated from the (s, y) pairs, "
       "`-tao_lmvm_mat_lmvm_scale_type scalar` makes it γI). `newton`: the Newton baseline. `pd`: Projective "
       "Dynamics, x ← x − α(M + h²L)⁻¹∇g; exact local-global steps (α = 1) for ARAP (`corotated` with λ = 0), "
       "otherwise with a backtracking Armijo line search (the log says which)",
       {}, solver_names()},
      {"iterations", &S::iterations,
       "iteration budget per time step (the paper's 10); a frame still far from converged goes on, see "
       "`max_iterations`",
       between(1, 1e6)},
      {"max_iterations", &S::max_iterations,
       "fallback chain, stage 1: a frame still far from converged after `iterations` (‖∇g‖ > 0.1 · min(‖∇g(x₀)‖, "
       "W), see [guardrails.md](guardrails.md#fallback)) iterates on up to this many; ≤ `iterations` turns the stage off",
       between(0, 1e6)},
      {"max_halvings", &S::max_halvings,
       "stage 2: a frame still far from converged is redone from x_n in 2, 4, … 2^max_halvings sub-steps of the same "
       "solver (each sub-step size factors its own M + (h/k)²L the first time it is needed); 0 turns it off",
       between(0, 10, "each halving may factor one more M + h^2 L")},
      {"newton_fallback", &S::newton_fallback, "stage 3: then the frame is redone by `newton` (projected Hessian)"},
      {"keep_substeps", &S::keep_substeps,
       "stage 2 kept: a frame accepted in 2^k sub-steps makes the next ones start at 2^k (the full step and the "
       "sizes between only if it and the finer ones fail). The frame after one accepted at 2^k tries 2^(k−1); each "
       "try that fails doubles the frames kept at 2^k before the next try, up to this many; a try that holds sets "
       "them back to 1. 0: every frame starts at the full step ([guardrails.md](guardrails.md#fallback))",
       between(0, 1e6)},
      {"budget", std::monostate{},
       "`adaptive`: the fallback chain as the keys above set it. `fixed`: the paper's fixed budget, every frame "
       "takes `iterations` iterations (fewer only when it converges by `grad_atol`/`grad_rtol`; set both to 0 for "
       "exactly `iterations`), with no stage of the chain: no more iterations, no sub-steps, no Newton (and none of "
       "their factorizations). Giving `max_iterations`, `max_halvings`, `newton_fallback` or `keep_substeps` beside `fixed` is an "
       "error. Without it, `max_iterations: 10` alone still leaves stages 2 and 3 on: the 81 × 81 sheet of "
       "`input/cloth/sheet_corners.yaml` then took 60 iterations per frame over 20 frames (5 frames sub-stepped, 15 "
       "by Newton) and still ended `flagged: 11 of 20 frames could not decrease g or stayed far from converged`; "
       "with `budget: fixed`, 10 and `ok` (1 rank, 214cdf4, 2026-12-08, the deck with `frames: 20` and `solver: "
       "{type: lbfgs, iterations: 10, max_iterations: 10}`)",
       {}, {"adaptive", "fixed"}, "", "",
       [](S& s, const std::string& name) {
         if (name == "fixed") use_fixed_budget(s);
       },
       [](const S& s) {
         return std::string(s.max_iterations == 0 && s.max_halvings == 0 && !s.newton_fallback ? "fixed" : "adaptive");
       }},
      {"grad_atol", &S::grad_atol, "stop when ‖∇g‖ ≤ grad_atol", at_least(0)},
      {"grad_rtol", &S::grad_rtol,
       "or stop when ‖∇g‖ < grad_rtol · ‖∇g(x₀)‖ or ‖∇g‖ ≤ grad_rtol · S, and in either case ‖∇g‖ ≤ 10⁻³ S; S the "
       "force scale of the step, at least W, the ‖∇g‖ of the body's own weight over one step (so a huge initial "
       "gradient does not make a huge residual \"converged\", nor a body at rest run its whole budget; "
       "[guardrails.md](guardrails.md#fallback))",
       at_least(0)},
      {"history", &S::history,
       "number of L-BFGS correction pairs (`lbfgs`, `lbfgs-identity`; `newton` and `pd` ignore it); with 0 and an ARAP material, `lbfgs` takes the "
       "same steps as `pd`. With colliders or self-contact the default is larger: contact and friction stiffness are "
       "not in M + h²L and L-BFGS learns them from its pairs ([contact.md](contact.md#defaults))",
       between(0, kMaxHistory, "each pair holds two vectors of all unknowns; the paper uses 5")},
      {"line_search", &S::line_search,
       "TAO line search. `unit` always takes the full step. Not used by `pd`, which has its own (see `type`).", {},
       {"more-thuente", "armijo", "unit"}},
      enum_key<S>("history_reset", &S::history_reset, kHistoryResetNames,
       "`lbfgs` only: `contact-change` forgets the L-BFGS pairs whenever the set of vertices in contact changes "
       "between iterates. Measured to cost iterations on every contact scene (the bunny drop: 47.8 → 118.8 "
       "iterations per frame; [contact.md](contact.md#what-l-bfgs-does-with-contact)), so it is off"),
      enum_key<S>("warm_start", &S::warm_start, kWarmStartNames,
       "initial guess: the inertial prediction y, the previous positions x_n, or whichever of the two has the lower g "
       "(two evaluations per step; with contact y often lies deep inside an obstacle while x_n rests on it: a cube "
       "resting on the ground takes 33 iterations per frame from y and 6.3 from the lower, "
       "[contact.md](contact.md#defaults))"),
      {"upright_guess", &S::upright_guess,
       "the guess from y (`inertial`, and the y of `lower`) is pulled back to x_n + t(y − x_n), t = 1, ½, ¼, …, until "
       "it leaves no tet that is upright at x_n inverted, nor past the element limit (\\|det F\\| = 100, "
       "`-hyperqn_element_limit`) unless it was; where y does neither (every ordinary mesh: "
       "`scripts/compare_revisions.py` bitwise unchanged) the guess is y itself. `summary.json` counts the steps "
       "pulled back (`pulled_back_guesses`). Without it y inverts or blows up the slivers next to a clamp, and no "
       "solver recovers within the frame ([guardrails.md](guardrails.md#element-blow-up-and-inversion)). `false`: y "
       "itself (the tests of run-aways use it)"},
      enum_key<S>("h0", &S::h0, kH0Names,
       "`lbfgs` only: its initial inverse Hessian. `auto`: `amg` on meshes of 200,000 tetrahedra or more (the "
       "crossover measured in [performance.md](performance.md#distributed-h0)), else `rest-stiffness` for a stiff "
       "scene held still: one body of plain hyperelastic tets under gravity, held by fixed regions that do not move "
       "or let go, nothing else acting (no loads, attachments, colliders, self-contact, cuts, `fracture` (whose "
       "changes need one constant matrix), `initial`, strands, "
       "cloth; not `static`), whose self-weight deflection scale ρ|g|D³/(E w²) is below 0.1 (D the rest bounding "
       "box's diagonal, w its smallest side, ρ/E the largest of its materials'; steel bars and plates; the "
       "crossover measured in [method.md](method.md#the-initial-hessian-h0); the log says so), else `volumetric` "
       "when a hyperelastic tet material's Poisson ratio is 0.499 or more (the largest of the scene's; not with "
       "`h0_contact: woodbury`; the crossover measured in [method.md](method.md#the-initial-hessian-h0)), else "
       "`laplacian`. `laplacian`: (M + "
       "h²L)⁻¹, L the weighted Laplacian (the paper's). `rest-stiffness`: (M + h²K(x_rest))⁻¹, K the energy's "
       "Hessian at the rest shape (per-element PSD fix), a full 3n × 3n matrix factored once per scene; it sees the "
       "volumetric modes but not rotations, so it wins on stiff, little-deformed scenes and loses on large "
       "deformations (measured in [method.md](method.md#the-initial-hessian-h0)). `volumetric`: (M + h²K_vol)⁻¹, "
       "K_vol per tet V(μ GᵀG ⊗ I₃ + ½(λ + μ) d dᵀ), d the rest divergence (μ, λ the material's rest stiffness; "
       "other terms add their L), factored like `rest-stiffness`: it sees near-incompressibility (the stability "
       "suite's ν = 0.4999 becomes ok) but not a stiffness contrast "
       "([record](records/2026-12-03-volumetric-h0.md)). `amg`: M + h²L applied through "
       "one algebraic-multigrid V-cycle (GAMG; options `-h0_*`) instead of a factorization, for meshes whose factor "
       "does not fit or whose solve does not scale: more iterations, no factor "
       "([performance.md](performance.md#amg-h0)). `pd` is defined by M + h²L (and `pd` with `h0: amg` is an "
       "error: its steps need the exact solve); `newton`, `lbfgs-identity` factor no constant matrix: they ignore "
       "`h0`"),
      enum_key<S>("h0_precision", &S::h0_precision, kH0PrecisionNames,
       "`lbfgs` only: the precision of its factored initial Hessian's values. `double`: as CHOLMOD computes them. "
       "`single`: each rounded to a float once it is factored (the doubles dropped), widened back to double as a "
       "solve reads it, every product and sum in double: the solve streams half the bytes, H0 = (L_f L_fᵀ)⁻¹ of "
       "the rounded factor stays symmetric positive definite, about 1e-7 from `double`'s, and runs stay bitwise "
       "reproducible ([performance.md](performance.md#single-precision-factor)). Solved by hyperqn's own loops "
       "only (`-hyperqn_h0_package` `auto`, `supernodal` or `split`; `mumps`, `cholmod` are an error); a V-cycle "
       "(`h0: amg`, an error beside `single`, or `auto`'s on large meshes) factors nothing and ignores it. In a "
       "study the `pd` contender shares `lbfgs`'s factor of M + h²L and so its precision; `type: pd` with "
       "`single` is an error"),
      enum_key<S>("h0_contact", &S::h0_contact, kH0ContactNames,
       "`lbfgs` only: the stiffness of obstacle contact, self-contact and their friction in its initial Hessian, "
       "taken at each step's start x_n, and in a static step at each iterate its frame resumes from (the 3 × 3 diagonal blocks h²K_v of the vertices within the activation "
       "distance; a self-contact pair's blocks between two vertices are left out); a scene without contact has none "
       "and runs none of it. `off`: (M + h²L)⁻¹ alone. `refactor`: (M + h²L + h²D_c)⁻¹, D_c the blocks' mean "
       "eigenvalues rounded to powers of 2 on the diagonal (a vertex below 1/64 of A's diagonal there left out), "
       "factored again when a rounded value changes, the pattern analysed once (so H0 is a function of x_n: "
       "restarts stay bitwise, ranks agree as with `off`). `woodbury`: (M + h²L + h²K_c)⁻¹ with the "
       "blocks themselves, by a Sherman–Morrison–Woodbury correction of the scene's factor (one A⁻¹ solve per 3 new "
       "vertices in contact, a dense system of up to 3 rows per vertex per step: fast for a few dozen vertices, slow "
       "for hundreds; it needs A = A1 ⊗ I3: beside `h0: rest-stiffness` or `volumetric` it is an error). Measured in "
       "[contact.md](contact.md#what-l-bfgs-does-with-contact): the bunny drop's 60 frames 32.5 → 15.8 iterations "
       "per frame and about half the ms per frame with `refactor`"),
      enum_key<S>("h0_rigid", &S::h0_rigid, kH0RigidNames,
       "`lbfgs` only: leave the rigid rotations of the scene's stiff parts out of its initial Hessian. A stiff "
       "cluster is a connected set of tets whose weight in L is at least 100 times the softest tet's (without a "
       "fixed vertex); M + h²L charges its rotations the stiff material's stiffness, A' = A − s h²L_q R (RᵀL_q R)⁻¹ "
       "RᵀL_q (R its 3 rotations about its centroid at the step's start, s = 0.999) about the soft coupling's and "
       "the mass's only. Applied beside the factor by Woodbury (3 solves of A per cluster per step, no new "
       "factorization); with `h0: laplacian` (auto's choice of it included), not with `amg` or rollers. `auto`: on "
       "where a cluster exists; `true` (an error beside another `h0`), `false`: forced. A scene without such a "
       "contrast runs none of it. The stability suite's 1e4 contrast: degraded, 0.379 of the diagonal from the "
       "converged reference → ok, 0.0096, at 12.1 → 26.5 iterations per frame "
       "([method.md](method.md#stiff-parts-rotations-h0_rigid))"),
      enum_key<S>("two_loop", &S::two_loop, kTwoLoopNames,
       "`lbfgs` only: who applies the L-BFGS pairs in each iteration's direction. `petsc`: TAO's BFGS matrix "
       "(PETSc 3.18's two-loop: two reductions per pair). `streamed`: hyperqn's, the pairs in one block, two "
       "reductions per iteration and half the vector reads and writes but 2 × history more products; the same "
       "iterates to round-off, bitwise repeatable and restartable, and measured no faster at 1 and 2 ranks "
       "([performance.md](performance.md#what-stops-scaling-first)); `lbfgs-identity` ignores it"),
      enum_key<S>("newton_hessian", &S::newton_hessian, kNewtonHessianNames,
       "`newton` only: per-element PSD fix of dP/dF, or the exact Hessian (see below)"),
      enum_key<S>("newton_method", &S::newton_method, kNewtonMethodNames,
       "`newton` only: TAO's Newton line search (TAONLS, with `line_search`) or trust region (TAONTR)"),
      enum_key<S>("linear_solver", &S::linear_solver, kLinearSolverNames,
       "`newton` (and the fallback chain's Newton): `auto` is `mumps` below 50,000 free vertices and `cg-amg` from "
       "there (MUMPS's factor of the whole Hessian on every rank would take 1.6 GB per rank at 50,000 vertices and "
       "22 GB at 350,000, [guardrails.md](guardrails.md#memory)). `mumps`: MUMPS Cholesky (symbolic analysis once "
       "per run, a numeric factorization per iteration; on more than one rank every rank factors the whole Hessian "
       "itself, sequentially, so that runs are reproducible: PCREDUNDANT, whose inner solver takes the options "
       "`-tao_nls_redundant_*`), or CG preconditioned by hypre BoomerAMG, with the rigid-body near-null space set on "
       "the matrix. With `ntr` the Krylov method is STCG (TAONTR requires a trust-region CG), preconditioned by the "
       "Cholesky factor or by BoomerAMG."),
  };
  add_contact_defaults(keys);
  return keys;
  }();
  return keys;
}

}  // namespace hyperqn

#include "model/fallback_chain.hpp"

#include <algorithm>
#include <cmath>

#include "solvers/frame_budget.hpp"
#include "solvers/solver_registry.hpp"
#include "solvers/stop_request.hpp"

namespace hyperqn {

FallbackChain::FallbackChain(Scene& scene, const SolverSpec& spec, TimeStepSolver& solver, double element_limit)
    : scene_(scene), spec_(spec), solver_(solver), element_limit_(element_limit) {
  record_ = [this](const IterationRecord& r) {
    records_.push_back(r);
    if (r.iteration > 0) ++iterations_seen_;
    if (watch_ && *watch_) (*watch_)(r);
    return false;
  };
}

// The cost of another solve of the frame, added to out's.
static void add_cost(const StepSolve& part, StepSolve& out) {
  out.iterations += part.iterations;
  out.evaluations += part.evaluations;
  out.seconds += part.seconds;
}

FallbackChain::~FallbackChain() {
  VecDestroy(&kept_x_);
  VecDestroy(&velocity_);
}

// A solver that could not decrease g very near the answer (a line search stalled at the
// round-off of g) is converged enough (frame_budget.hpp's floor): no fallback does better there.
PetscErrorCode FallbackChain::judge(const FrameResult& r, Objective& g, Vec x, Outcome* o) const {
  double scale;
  PetscFunctionBeginUser;
  *o = Outcome{};
  if (Objective::rejected(r.energy) || !std::isfinite(r.grad_norm)) PetscFunctionReturn(0);
  o->finite = true;
  o->energy = r.energy;
  PetscCall(g.force_scale(x, &scale));
  o->residual = r.grad_norm / scale;
  o->converged_enough = !FrameBudget::far(
      {(int)r.iterations, r.energy0, r.energy, r.last_decrease, r.grad_norm0, r.grad_norm, r.failed, r.last_step,
       r.previous_decrease},
      scale, g.length_scale(), g.seeks_equilibrium());
  PetscCall(scene_.body->volume_ratios(x, &o->min_J, &o->max_abs_J));
  o->sound = !(element_limit_ > 0 && o->max_abs_J > element_limit_) && !(o->min_J < 0 && start_min_J_ >= 0);
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::level(int halvings, Level** out) {
  PetscFunctionBeginUser;
  if ((int)levels_.size() < halvings) levels_.resize(halvings);
  Level& l = levels_[halvings - 1];
  if (!l.solver) {
    PetscCall(scene_.step->create_substep(1 << halvings, l.step));
    if (solver_uses_constant_matrix(spec_.type)) {
      // By the package that factored the scene's own (-hyperqn_h0_package), in its precision.
      const FactoredSystem* scene_matrix = scene_.constant_matrix(spec_);
      l.factored = std::make_unique<FactoredSystem>();
      PetscCall(l.factored->setup(*l.step, scene_matrix ? scene_matrix->kind() : constant_matrix_of(solver_h0(spec_)),
                                  scene_matrix ? scene_matrix->package() : default_factor_package(),
                                  scene_matrix ? scene_matrix->precision() : H0Precision::double_precision));
    }
    SolverSpec spec = spec_;
    spec.quiet = true;
    PetscCall(create_solver(spec, *l.step, l.factored.get(), l.solver));
  }
  *out = &l;
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::substeps(State& s, int halvings, StepSolve& out, bool* ok) {
  Level* l;
  const int parts = 1 << halvings;
  PetscFunctionBeginUser;
  *ok = false;
  PetscCall(level(halvings, &l));
  PetscCall(sub_.copy_from(s));
  sub_.drop_history();  // its steps are h / parts apart: their own history starts at x_n
  sub_.frame = s.frame * parts;  // so that sub-step j ends at (frame + (j + 1) / parts) h exactly
  double residual = 0;           // the largest of the sub-steps'
  for (int j = 0; j < parts; ++j) {
    StepSolve part;
    records_.clear();
    PetscCall(l->step->solve_step(*l->solver, sub_, record_, part));
    add_cost(part, out);
    // s is still at x_n; the element state goes back to the frame's start with it
    if (stop_agreed()) {
      scene_.step->lifecycle().restart_element_states();
      PetscFunctionReturn(0);
    }
    PetscCall(judge(part.result, *l->step, sub_.x, &outcome_));
    if (!outcome_.acceptable()) {
      scene_.step->lifecycle().restart_element_states();
      PetscFunctionReturn(0);
    }
    PetscCall(l->step->lifecycle().accept(sub_));
    out.result = part.result;
    residual = std::fmax(residual, outcome_.residual);
  }
  outcome_.residual = residual;
  if (!velocity_) PetscCall(VecDuplicate(s.v, &velocity_));
  PetscCall(VecCopy(sub_.x, s.x));
  PetscCall(VecCopy(sub_.v, velocity_));
  out.velocity = velocity_;
  out.substeps = parts;
  *ok = true;
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::solve_frame(State& s, const IterationCallback& on_iteration, StepSolve& out,
                                          const IterationWatch& watch) {
  StepObjective& g = *scene_.step;
  PetscFunctionBeginUser;
  const StepObjective::RunCounts counts = g.counts();  // put back if the frame is given up
  const double t0 = MPI_Wtime();
  watch_ = &watch;
  iterations_seen_ = 0;
  if (!start_known_) {  // else the last frame's end, measured then
    double unused;
    PetscCall(scene_.body->volume_ratios(s.x, &start_min_J_, &unused));
    start_known_ = true;
  }
  // Stage 2 kept from the frames before (model/substep_memory.hpp): start at their sub-step size;
  // the full step and the sizes between only if it and every finer size fail.
  const int start = spec_.keep_substeps > 0 ? std::min(s.substeps.halvings, spec_.max_halvings) : 0;
  int accepted = -1;  // the sub-step size the frame is accepted at (0: the full step), -1: none
  StepSolve kept;     // the attempts from start on
  if (start > 0) {
    PetscCall(g.lifecycle().begin_substepped(s));
    bool ok = false;
    for (int k = start; k <= spec_.max_halvings && !ok && !stop_agreed(); ++k) {
      PetscCall(substeps(s, k, kept, &ok));
      if (ok) accepted = k;
    }
  }
  if (accepted > 0) {
    out = kept;
    out.kept_substeps = true;
  } else if (!stop_agreed()) {
    PetscCall(solve_from_full_step(s, start > 0 ? start - 1 : spec_.max_halvings, out, &accepted));
    add_cost(kept, out);
  }
  watch_ = nullptr;
  if (stop_agreed()) {  // given up: nothing of the frame stays, nothing of it is reported
    g.restore_counts(counts);
    out = StepSolve{};
    out.interrupted = true;
    out.iterations = iterations_seen_;
    out.seconds = MPI_Wtime() - t0;
    PetscFunctionReturn(0);
  }
  s.substeps.after_frame(start, accepted, spec_.keep_substeps);
  out.min_J = outcome_.min_J;
  out.max_abs_J = outcome_.max_abs_J;
  out.residual = outcome_.residual;
  out.measured = true;
  out.unresolved = accepted < 0 && !outcome_.acceptable() && (spec_.max_halvings > 0 || spec_.newton_fallback);
  out.newton_ran_away = out.unresolved && out.newton_ran_away;
  start_min_J_ = out.min_J;  // the next frame starts here (the caller stops the run otherwise)
  for (const IterationRecord& r : records_) on_iteration(r);
  PetscFunctionReturn(0);
}

// Stages 1 to 3 from the full step, with sub-steps of up to 2^finest.
PetscErrorCode FallbackChain::solve_from_full_step(State& s, int finest, StepSolve& out, int* accepted) {
  StepObjective& g = *scene_.step;
  PetscFunctionBeginUser;
  records_.clear();
  PetscCall(g.solve_step(solver_, s, record_, out));
  if (stop_agreed()) PetscFunctionReturn(0);  // solve_frame gives the frame up
  out.extended = out.result.extended;
  PetscCall(judge(out.result, g, s.x, &outcome_));
  if (outcome_.acceptable()) *accepted = 0;
  if (!outcome_.acceptable() && (spec_.max_halvings > 0 || spec_.newton_fallback)) {
    const FrameResult first = out.result;
    const Outcome first_outcome = outcome_;
    std::vector<IterationRecord> first_records = std::move(records_);
    if (!kept_x_) PetscCall(VecDuplicate(s.x, &kept_x_));
    PetscCall(VecCopy(s.x, kept_x_));
    PetscCall(g.lifecycle().keep());  // how that solve's step ends (the midpoint's may end by Euler)
    bool ok = false;
    for (int k = 1; k <= finest && !ok; ++k) {
      PetscCall(g.lifecycle().undo(s));
      PetscCall(substeps(s, k, out, &ok));
      if (stop_agreed()) PetscFunctionReturn(0);
      if (ok) *accepted = k;
    }
    if (!ok) {
      StepSolve newton;
      if (spec_.newton_fallback) {
        if (!newton_) {
          SolverSpec spec = spec_;
          spec.type = "newton";
          spec.quiet = true;
          PetscCall(create_solver(spec, g, nullptr, newton_));
        }
        PetscCall(g.lifecycle().undo(s));
        records_.clear();
        PetscCall(g.solve_step(*newton_, s, record_, newton));
        add_cost(newton, out);
        if (stop_agreed()) PetscFunctionReturn(0);
      } else {
        PetscCall(g.lifecycle().undo(s));
        PetscCall(g.begin_step(s));  // the step again, to keep the first solve's x
      }
      // Neither acceptable: the one worth more (finite, then sound, then the lower g).
      Outcome newton_outcome;
      if (spec_.newton_fallback) PetscCall(judge(newton.result, g, s.x, &newton_outcome));
      const bool newton_better = spec_.newton_fallback && worth_more(newton_outcome, first_outcome);
      out.newton_ran_away = spec_.newton_fallback && !(newton_outcome.finite && newton_outcome.sound);
      if (newton_better) {
        out.result = newton.result;
        out.newton = true;
        outcome_ = newton_outcome;
      } else {
        PetscCall(VecCopy(kept_x_, s.x));
        PetscCall(g.lifecycle().restore());
        out.result = first;
        outcome_ = first_outcome;
        records_ = std::move(first_records);
      }
    }
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

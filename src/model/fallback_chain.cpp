#include "model/fallback_chain.hpp"

#include <cmath>

#include "solvers/frame_budget.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {

FallbackChain::FallbackChain(Scene& scene, const SolverSpec& spec, TimeStepSolver& solver)
    : scene_(scene), spec_(spec), solver_(solver) {}

FallbackChain::~FallbackChain() {
  VecDestroy(&kept_x_);
  VecDestroy(&velocity_);
}

// A solver that could not decrease g very near the answer (a line search stalled at the
// round-off of g) is acceptable (frame_budget.hpp's floor): no fallback does better there.
PetscErrorCode FallbackChain::acceptable(const FrameResult& r, Objective& g, Vec x, bool* ok) const {
  double scale;
  PetscFunctionBeginUser;
  *ok = false;
  if (Objective::rejected(r.energy) || !std::isfinite(r.grad_norm)) PetscFunctionReturn(0);
  PetscCall(g.force_scale(x, &scale));
  *ok = !FrameBudget::far(
      {(int)r.iterations, r.energy0, r.energy, r.last_decrease, r.grad_norm0, r.grad_norm, r.failed, r.last_step},
      scale, g.length_scale());
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::level(int halvings, Level** out) {
  PetscFunctionBeginUser;
  if ((int)levels_.size() < halvings) levels_.resize(halvings);
  Level& l = levels_[halvings - 1];
  if (!l.solver) {
    PetscCall(scene_.integrator->create_substep(1 << halvings, l.integrator));
    if (solver_uses_constant_matrix(spec_.type)) {
      l.factored = std::make_unique<FactoredSystem>();
      PetscCall(l.factored->setup(*l.integrator, constant_matrix_of(spec_)));
    }
    SolverSpec spec = spec_;
    spec.quiet = true;
    PetscCall(create_solver(spec, *l.integrator, l.factored.get(), l.solver));
  }
  *out = &l;
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::substeps(State& s, int halvings, StepSolve& out, bool* ok) {
  Level* l;
  const int parts = 1 << halvings;
  const IterationCallback record = [this](const IterationRecord& r) {
    records_.push_back(r);
    return false;
  };
  PetscFunctionBeginUser;
  *ok = false;
  PetscCall(level(halvings, &l));
  PetscCall(sub_.copy_from(s));
  sub_.frame = s.frame * parts;  // so that sub-step j ends at (frame + (j + 1) / parts) h exactly
  for (int j = 0; j < parts; ++j) {
    StepSolve part;
    records_.clear();
    PetscCall(l->integrator->solve_step(*l->solver, sub_, record, part));
    out.iterations += part.iterations;
    out.evaluations += part.evaluations;
    out.seconds += part.seconds;
    bool ok;
    PetscCall(acceptable(part.result, *l->integrator, sub_.x, &ok));
    if (!ok) PetscFunctionReturn(0);
    PetscCall(l->integrator->end_step(sub_));
    out.result = part.result;
  }
  if (!velocity_) PetscCall(VecDuplicate(s.v, &velocity_));
  PetscCall(VecCopy(sub_.x, s.x));
  PetscCall(VecCopy(sub_.v, velocity_));
  out.velocity = velocity_;
  out.substeps = parts;
  *ok = true;
  PetscFunctionReturn(0);
}

PetscErrorCode FallbackChain::solve_frame(State& s, const IterationCallback& on_iteration, StepSolve& out) {
  ImplicitEuler& g = *scene_.integrator;
  const IterationCallback record = [this](const IterationRecord& r) {
    records_.push_back(r);
    return false;
  };
  PetscFunctionBeginUser;
  records_.clear();
  PetscCall(g.solve_step(solver_, s, record, out));
  out.extended = out.result.extended;
  bool first_ok;
  PetscCall(acceptable(out.result, g, s.x, &first_ok));
  if (!first_ok && (spec_.max_halvings > 0 || spec_.newton_fallback)) {
    const FrameResult first = out.result;
    std::vector<IterationRecord> first_records = std::move(records_);
    if (!kept_x_) PetscCall(VecDuplicate(s.x, &kept_x_));
    PetscCall(VecCopy(s.x, kept_x_));
    bool ok = false;
    for (int k = 1; k <= spec_.max_halvings && !ok; ++k) {
      PetscCall(g.undo_step(s));
      PetscCall(substeps(s, k, out, &ok));
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
        PetscCall(g.undo_step(s));
        records_.clear();
        PetscCall(g.solve_step(*newton_, s, record, newton));
        out.iterations += newton.iterations;
        out.evaluations += newton.evaluations;
        out.seconds += newton.seconds;
      } else {
        PetscCall(g.undo_step(s));
        PetscCall(g.begin_step(s));  // the step again, to keep the first solve's x
      }
      bool newton_ok = false;
      if (spec_.newton_fallback) PetscCall(acceptable(newton.result, g, s.x, &newton_ok));
      const bool newton_better = spec_.newton_fallback && !Objective::rejected(newton.result.energy) &&
                                 std::isfinite(newton.result.grad_norm) &&
                                 (newton_ok || Objective::rejected(first.energy) ||
                                  !(newton.result.grad_norm >= first.grad_norm));
      if (newton_better) {
        out.result = newton.result;
        out.newton = true;
      } else {
        PetscCall(VecCopy(kept_x_, s.x));
        out.result = first;
        records_ = std::move(first_records);
      }
    }
  }
  for (const IterationRecord& r : records_) on_iteration(r);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "solvers/line_search.hpp"

#include <cmath>

#include "io/log_events.hpp"
#include "solvers/stop_request.hpp"

namespace hyperqn {

PetscErrorCode backtrack(Objective& step, Vec x, PetscReal g, Vec grad, Vec dir, double alpha0,
                         const Backtracking& ls, bool accept_first, Vec trial, PetscReal* g_trial, Vec trial_grad,
                         double* alpha, bool* accepted) {
  PetscReal slope;
  PetscFunctionBeginUser;
  *accepted = false;
  *alpha = 0;
  PetscCall(VecDot(grad, dir, &slope));
  if (!(slope < 0)) PetscFunctionReturn(0);  // not a descent direction (or NaN): no decrease to find
  PetscCall(event_begin(&LogEvents::backtrack));
  double a = alpha0;
  if (step.bounds_steps()) PetscCall(step.limit_step(x, dir, &a));  // e.g. no vertex crosses an obstacle
  for (int halvings = 0; halvings <= ls.max_halvings; ++halvings, a *= ls.shrink) {
    PetscCall(VecWAXPY(trial, a, dir, x));
    PetscCall(step.objective(trial, g_trial, trial_grad));
    if (stop_agreed()) break;  // a stop signal: nothing accepted, the solve ends
    if (Objective::rejected(*g_trial)) continue;  // non-finite g or grad g: never accepted
    if ((accept_first && halvings == 0) || *g_trial <= g + ls.c1 * a * slope) {
      *accepted = true;
      *alpha = a;
      break;
    }
  }
  PetscCall(event_end(&LogEvents::backtrack));
  PetscFunctionReturn(0);
}

PetscErrorCode backtrack_and_move(Objective& step, Vec x, PetscReal* g, Vec grad, Vec dir, double alpha0,
                                  const Backtracking& ls, double* alpha, bool* accepted) {
  Vec trial, trial_grad;
  PetscReal g_trial = 0;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &trial));
  PetscCall(VecDuplicate(x, &trial_grad));
  PetscCall(backtrack(step, x, *g, grad, dir, alpha0, ls, false, trial, &g_trial, trial_grad, alpha, accepted));
  if (*accepted) {
    PetscCall(VecCopy(trial, x));
    PetscCall(VecCopy(trial_grad, grad));
    *g = g_trial;
  }
  PetscCall(VecDestroy(&trial));
  PetscCall(VecDestroy(&trial_grad));
  PetscFunctionReturn(0);
}

PetscErrorCode retry_descent(Objective& step, const FactoredSystem* h0, double gradient_length, Vec x, PetscReal* g,
                             Vec grad, double* alpha, std::string* along, bool* recovered) {
  Vec dir;
  PetscReal gnorm;
  PetscFunctionBeginUser;
  *recovered = false;
  *alpha = 0;
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecNorm(grad, NORM_2, &gnorm));
  if (h0) {
    PetscCall(h0->solve(grad, dir));
    PetscCall(VecScale(dir, -1.0));
    PetscCall(VecNorm(dir, NORM_2, &gradient_length));
    PetscCall(backtrack_and_move(step, x, g, grad, dir, 1.0, Backtracking{}, alpha, recovered));
    *along = "-H0 grad g";
  }
  if (!*recovered && gnorm > 0) {
    Backtracking ls;
    ls.max_halvings = 50;
    PetscCall(VecCopy(grad, dir));
    PetscCall(VecScale(dir, -1.0));  // dir = -grad g
    const double alpha0 = gradient_length > 0 && std::isfinite(gradient_length) ? gradient_length / gnorm : 1.0;
    PetscCall(backtrack_and_move(step, x, g, grad, dir, alpha0, ls, alpha, recovered));
    *along = "-grad g";
  }
  PetscCall(VecDestroy(&dir));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

// The solvers' own line search and their recovery after a line-search failure (guardrails).
//
// A point whose g or grad g is not finite is reported by Objective::objective as
// Objective::kRejectedEnergy, so it never passes a sufficient-decrease test and is never accepted.
// After a failed line search the solvers call retry_descent: a backtracking Armijo line search
// from the last accepted iterate along -H0 grad g (or their own direction), then along -grad g.
#pragma once
#include <petscvec.h>

#include <string>

#include "solvers/factored_system.hpp"
#include "solvers/objective.hpp"

namespace hyperqn {

struct Backtracking {
  double c1 = 1e-4;      // sufficient decrease: g(x + a d) <= g(x) + c1 a grad g(x).d
  double shrink = 0.5;   // a <- shrink a after a rejected trial
  int max_halvings = 30;
};

// Trial points x + alpha d, alpha = alpha0, alpha0 shrink, ...: the first one whose g is not
// rejected and satisfies the Armijo condition is accepted (accept_first: the first trial only
// needs a non-rejected g; Projective Dynamics' exact step). d must be a descent direction
// (grad.d < 0), else nothing is evaluated and nothing is accepted. On success trial, *g_trial and
// trial_grad hold the accepted point and *alpha its step; on failure *alpha = 0.
PetscErrorCode backtrack(Objective& step, Vec x, PetscReal g, Vec grad, Vec dir, double alpha0,
                         const Backtracking& ls, bool accept_first, Vec trial, PetscReal* g_trial, Vec trial_grad,
                         double* alpha, bool* accepted);

// backtrack with accept_first = false, and on success x, *g and grad become the accepted point.
PetscErrorCode backtrack_and_move(Objective& step, Vec x, PetscReal* g, Vec grad, Vec dir, double alpha0,
                                  const Backtracking& ls, double* alpha, bool* accepted);

// Recovery from a line-search failure at x (g and grad g at x given): backtracking along
// d = -H0 grad g (if h0 is not null; alpha0 = 1), then along d = -grad g with a first trial of the
// length of -H0 grad g (or gradient_length if h0 is null; <= 0: alpha0 = 1) and up to 50 halvings.
// On success x, *g and grad are the new point, *alpha its step, *along names the direction.
PetscErrorCode retry_descent(Objective& step, const FactoredSystem* h0, double gradient_length, Vec x, PetscReal* g,
                             Vec grad, double* alpha, std::string* along, bool* recovered);

}  // namespace hyperqn

#include "terms/nan_injection.hpp"

#include <cmath>

namespace hyperqn {

PetscErrorCode NanInjection::begin_step(const StepStart& step) {
  y_ = step.y;
  ++steps_;
  return 0;
}

// Collective (a norm over all ranks) when beyond >= 0; NaN on one rank is NaN on all after the
// body's reduction.
PetscErrorCode NanInjection::add_energy(Vec x, const std::vector<double>&, double* energy, PetscScalar*) const {
  PetscFunctionBeginUser;
  if (from_step_ >= 0 && steps_ >= from_step_) *energy = NAN;
  if (beyond_ >= 0 && y_) {
    PetscReal dist;
    if (!diff_) PetscCall(VecDuplicate(x, &diff_));
    PetscCall(VecWAXPY(diff_, -1.0, y_, x));
    PetscCall(VecNorm(diff_, NORM_INFINITY, &dist));
    if (dist > beyond_) *energy = NAN;
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

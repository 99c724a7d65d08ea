// Extreme initial states for stability tests: the free vertices start squashed onto a plane,
// collapsed to a point, at random points, or mirrored (every element inverted).
#pragma once
#include <petscvec.h>

#include "model/scene_spec.hpp"
#include "model/body.hpp"

namespace hyperqn {

// Overwrites the free positions x (global vector) according to the deck's initial: section.
// Rank-independent: the random state is drawn per input vertex id.
PetscErrorCode apply_initial_state(const InitialSpec& initial, const Body& body, Vec x);

}  // namespace hyperqn

// The error-against-time study (hyperqn study DECK): the paper's comparison, automated.
//
// Per-frame mode: at each frame in study.frames, every solver in study.solvers starts from the
// same state and runs up to study.iterations iterations (or study.time_limit seconds), logging
// (wall time, g, |grad g|) per iteration. A Newton solve driven to |grad g| <= reference_rtol
// |grad g(x0)| gives g*, and e = (g - g*) / (g(x0) - g*).
//
// Trajectory mode: every solver runs the whole scene at its per-frame budget, in lockstep with a
// converged-Newton trajectory, and its RMS vertex error against it is logged with its total time.
// The per-frame states come from that converged trajectory, so they do not depend on any solver.
//
// With study.integrators, all of it once per time integrator (its own scene, factor and
// reference), each into OUTDIR/<integrator>/.
#pragma once
#include <petscsys.h>

#include <string>

#include "app/deck.hpp"

namespace hyperqn {

// Returns the process exit code (0 ok, 1 input or run error).
int run_study(MPI_Comm comm, const Deck& deck, const std::string& outdir);

}  // namespace hyperqn

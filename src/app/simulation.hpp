// Runs one deck: load and check the mesh, distribute it, set up the time step and solver,
// then step through the frames writing VTK, iterations.csv and summary.json.
#pragma once
#include <petscsys.h>

#include <string>

#include "app/deck.hpp"

namespace hyperqn {

// A run that went through every frame but has inverted elements (status "inverted: ...").
inline constexpr int kExitInverted = 2;
// A run stopped by SIGTERM or SIGUSR1 after writing a checkpoint: `--restart latest` continues it.
inline constexpr int kExitInterrupted = 3;

// SIGTERM and SIGUSR1 from now on only ask a run to stop, with a checkpoint of its last whole
// frame: a frame whose solve they interrupt is given up (docs/outputs.md#checkpoints). main calls
// it first thing for a simulation, so that a signal during start-up (MPI, PETSc, reading the deck
// and mesh) is not fatal either.
void catch_stop_signals();

// Returns the process exit code: 0 on success, 1 on input errors (nothing written) or when the
// run could not continue (summary.json says why), kExitInverted, kExitInterrupted.
// restart: "" (from frame 0), a checkpoint file, "latest" (the newest whole checkpoint of the
// run that last wrote OUTDIR) or "auto" (that, or from frame 0 if there is none).
int run_simulation(MPI_Comm comm, const Deck& deck, const std::string& outdir, const std::string& restart = "");

}  // namespace hyperqn

// A stop asked of a run by a signal (SIGTERM, SIGUSR1, SIGINT: app/run_checkpoints.cpp catches them and
// records them here) while a frame is being solved (docs/outputs.md#checkpoints).
//
// A signal reaches one rank, or each rank at a moment of its own, but the ranks must give up their
// solve at the same iteration. So the stop travels with the reduction that every evaluation of g
// makes anyway (Body::energy_gradient sums the ranks' energies): each rank adds its vote to it, and
// from that evaluation on every rank sees the stop agreed, with no reduction of its own. Between
// two evaluations (which are collective) stop_agreed() is the same on every rank, so a solver may
// test it anywhere: each ends its solve at the end of the iteration at hand (or at the next trial
// of a line-search retry), and the fallback chain gives the frame up.
#pragma once
#include <mpi.h>

namespace hyperqn {

// The signal handler's: records sig (async-signal-safe: one write of a sig_atomic_t).
void record_stop_signal(int sig);
// The stop signal this process received, or 0. Not agreed: another rank may have none yet.
int stop_signal();

// This rank's part of an evaluation's reduction (1: a signal arrived, else 0), and what to make of
// the reduced sum (every rank calls it with the same sum): positive, the stop is agreed from now on.
double stop_vote();
void count_stop_votes(double sum);
// Whether the ranks agreed on a stop in an evaluation so far (then for the rest of the process).
bool stop_agreed();

// Between frames: the stop signal any rank of comm received (collective; 0: none), and its name.
int stop_signal_on_any_rank(MPI_Comm comm);
const char* stop_signal_name(int sig);  // "SIGTERM", "SIGINT" or "SIGUSR1"

}  // namespace hyperqn

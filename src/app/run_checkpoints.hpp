// A run's checkpoints and stop signals, as an observer of the time loop (app/time_loop.hpp), and
// the restart that reads a checkpoint back (docs/outputs.md#checkpoints).
#pragma once
#include <string>

#include "app/run_observers.hpp"
#include "app/run_options.hpp"
#include "io/checkpoint_store.hpp"

namespace hyperqn {

// The stop signal (SIGTERM, SIGUSR1) this process received, or 0 (catch_stop_signals).
int stop_signal();

// After every frame that stands: a checkpoint if one is due (every N frames, every S seconds),
// and a stop with a checkpoint if a signal asked for one (also before the first frame); every rank
// learns both from one reduction per frame. The checkpoint holds the state, the summary's
// counters and the writers' restart state; the logs are flushed first.
class Checkpointer : public FrameObserver {
 public:
  struct Setup {
    const RunOptions& options;          // the test hooks -hyperqn_signal_after_frame, -hyperqn_kill_after_frame
    const CheckpointHeader& identity;   // whose run and what scene
    CheckpointStore& store;             // OUTDIR/checkpoints
    FrameWriters& frames;
    RunLogs& logs;
    bool started_inverted;              // goes into every checkpoint
    double t_start;                     // the process's start (MPI_Wtime)
    const RunSummary& earlier;          // the work before a restart
    bool restarted;                     // the state is a checkpoint's (on disk already)
  };
  Checkpointer(const RunContext& run, const Setup& setup);
  PetscErrorCode begin(LoopControl& control) override;
  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override;
  // Stopped by a signal, with a checkpoint.
  bool interrupted() const { return interrupted_; }

 private:
  PetscErrorCode write_checkpoint();
  // A signal `sig` (0: none) asked to stop after `frame`.
  PetscErrorCode stop_for_signal(int sig, int frame);

  RunContext run_;
  Setup setup_;
  double last_checkpoint_wtime_ = 0;  // rank 0's clock
  int last_checkpoint_frame_ = -1;    // the frame of the newest checkpoint on disk
  bool interrupted_ = false;
};

// A restart: the state (frame, time, released parts, x, v, the integrator's history) and the
// fixed vertices' motion from the checkpoint at path with header h.
PetscErrorCode resume_state(MPI_Comm comm, const std::string& path, const CheckpointHeader& h, const Scene& scene,
                            State& state);

}  // namespace hyperqn

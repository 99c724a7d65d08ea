// A run's checkpoints and stop signals, as an observer of the time loop (app/time_loop.hpp), and
// the restart that reads a checkpoint back (docs/outputs.md#checkpoints).
#pragma once
#include <string>

#include "app/run_observers.hpp"
#include "app/run_options.hpp"
#include "io/checkpoint_store.hpp"
#include "solvers/stop_request.hpp"  // stop_signal

namespace hyperqn {

// After every frame that stands: a checkpoint if one is due (every N frames, every S seconds),
// and a stop with a checkpoint if a signal asked for one (also before the first frame); every rank
// learns both from one reduction per frame. A signal during a frame's solve ends it (the ranks
// agree through its evaluations, solvers/stop_request.hpp): the frame is given up and undone, and
// the run stops with a checkpoint of the frame before. The checkpoint holds the state, the
// summary's counters and the writers' restart state; the logs are flushed first.
class Checkpointer : public FrameObserver {
 public:
  struct Setup {
    const RunOptions& options;          // the test hooks -hyperqn_test_signal_after_frame, _in_frame, _kill_after_frame
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
  PetscErrorCode before_frame(int frame) override;
  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override;
  PetscErrorCode interrupted(const FrameOutcome& outcome) override;
  // Every iteration of the frame's solve, as it comes (FallbackChain's watch): the test hook
  // -hyperqn_test_signal_in_frame.
  void watch(const IterationRecord& r);
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
  int frame_ = 0;            // the frame being solved
  PetscInt iterations_ = 0;  // its iterations so far, every stage's (the test hook's count)
};

// A restart: the state (frame, time, released parts, x, v, the integrator's history) and the
// fixed vertices' motion from the checkpoint at path with header h.
PetscErrorCode resume_state(MPI_Comm comm, const std::string& path, const CheckpointHeader& h, const Scene& scene,
                            State& state);

}  // namespace hyperqn

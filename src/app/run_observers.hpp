// What a simulation run does with its frames, as observers of the time loop (app/time_loop.hpp):
// the console's frame lines and the summary's counters, the logs (iterations.csv and the terms'
// own), the frame series (VTK, XDMF). Checkpoints and signals are in app/run_checkpoints.hpp.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "app/deck.hpp"
#include "app/time_loop.hpp"
#include "io/output_writer.hpp"
#include "io/run_log.hpp"
#include "model/energy_balance.hpp"
#include "model/reactions.hpp"

namespace hyperqn {

// What the run's observers share; the run owns it all.
struct RunContext {
  MPI_Comm comm;
  const Deck& deck;
  LiveScene& scene;
  State& state;
  RunSummary& summary;
};

// The run's timings and counts so far, from the log events (over every scene of the run).
void read_log_events(RunSummary& s);
// The run counters a scene's StepObjective keeps (its sub-steps' included) into a summary.
void add_step_counters(RunSummary& summary, const StepObjective& step);

// The console's line per frame and the summary's frame counters (iterations, flagged and inverted
// frames, min det F, the largest residual, a free scene's momentum, the frames done); after a
// release, the scene's new size. During a slow frame, a progress line every `progress_seconds`
// (-hyperqn_progress_seconds; rank 0's clock alone decides, so it costs no reduction).
class ProgressLog : public FrameObserver {
 public:
  ProgressLog(const RunContext& run, bool inverted_at_start, double progress_seconds)
      : run_(run), inverted_now_(inverted_at_start), progress_seconds_(progress_seconds) {}
  PetscErrorCode begin(LoopControl& control) override;
  PetscErrorCode scene_changed(const Scene& old_scene, Scene& fresh) override;
  PetscErrorCode before_frame(int frame) override;
  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override;
  PetscErrorCode stopped(const FrameOutcome& outcome, const std::string& why) override;
  PetscErrorCode interrupted(const FrameOutcome& outcome) override;
  // Every iteration of the frame's solve, as it comes (FallbackChain's watch).
  void watch(const IterationRecord& r);
  // Whether the last frame done has inverted or flat elements.
  bool inverted_now() const { return inverted_now_; }

 private:
  // A free scene's momentum at the end of the frame done (summary.momentum_drift).
  PetscErrorCode measure_momentum(int frame);

  // A free scene's momentum at the state the loop holds now (the last frame's end, or a restart's).
  std::array<double, 3> momentum_now_{0, 0, 0};

  RunContext run_;
  bool inverted_now_;
  double progress_seconds_;
  int frame_ = 0;
  double frame_start_ = 0, next_line_ = 0;  // MPI_Wtime: the frame's start, the next progress line's time
};

// iterations.csv, the terms' own logs (EnergyTerm::log, e.g. contact.csv) and, if the deck asks
// (output.reactions), reactions.csv and the summary's reactions (model/reactions.hpp), and
// (output.energy) energy.csv (model/energy_balance.hpp, from a row of frame 0 on), and in a scene
// whose topology may change (cuts, fracture, snapping strands, tearing cloth; output.topology_csv) topology.csv:
// rows appended during a frame, written at its end as whole lines (a kill leaves complete rows).
class RunLogs : public FrameObserver {
 public:
  explicit RunLogs(const RunContext& run);
  // Opens the logs in outdir (rank 0), or, at a restart, cuts them back to `restart_frame` and
  // continues them (the summary's reactions read back from reactions.csv; topology.csv's totals
  // from its rows, with `earlier` the checkpoint's summary). Throws std::runtime_error.
  void open(const std::string& outdir, int rank, const Scene& scene, int restart_frame = -1,
            const RunSummary* earlier = nullptr);
  // At a restart, before anything is written (rank 0): throws std::runtime_error if a log the deck
  // asks for cannot go on from the checkpoint's frame (the checkpointed run did not write it).
  void check_restart(const std::string& outdir, int restart_frame) const;
  // On every rank after open (collective): whether the run restarts, and the energy balance's
  // state read back on rank 0 (every rank evaluates the balance, so every rank resumes it).
  PetscErrorCode share_restart(bool restart);
  PetscErrorCode begin(LoopControl& control) override;
  PetscErrorCode scene_changed(const Scene& old_scene, Scene& fresh) override;
  PetscErrorCode before_frame(int frame) override;
  IterationCallback iterations(int frame) override;
  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override;
  // Writes the rows appended so far; collective: a failure on rank 0 ends the run on every rank.
  void flush();
  // The same on this rank alone (the end of a run). Throws std::runtime_error.
  void write_rows();

 private:
  // The summary's dissipated_energy: the elements' sum now (inelastic materials), and what the
  // elements topology changes removed had dissipated. Collective.
  PetscErrorCode note_dissipated();
  PetscErrorCode record_terms(int frame);
  PetscErrorCode record_reactions(int frame);
  void append_energy(int frame, double time, const EnergyRow& row);
  // topology.csv's counts, each summed over the run's frames so far as summary.json counts them.
  struct TopologyTotals {
    long long faces = 0, vertices = 0, segments = 0, edges = 0, corrections = 0, refactorizations = 0, removed = 0;
  };
  TopologyTotals topology_totals() const;
  void record_topology(int frame);
  bool writes_topology() const;  // topology.csv: asked for, in a scene whose topology changes

  RunContext run_;
  IterationLog log_;
  std::unique_ptr<Reactions> reactions_;  // output.reactions only
  FrameLog reaction_log_;
  std::unique_ptr<EnergyBalance> energy_;  // output.energy only
  FrameLog energy_log_;
  bool restarted_ = false;
  EnergyRow energy_at_restart_;         // rank 0: energy.csv's row of the restart's frame
  double energy_at_start_ = 0;          // and its kinetic + stored + dissipated at frame 0
  bool topology_ = false;           // topology.csv is written
  FrameLog topology_log_;
  TopologyTotals topology_rows_;    // the sums of topology.csv's rows so far
  TopologyTotals topology_earlier_; // before a restart: the H0 corrections and refactorizations of cuts
  // Per term of the scene (Body::terms, the same kinds in the same order after a release): its
  // own log (null if it keeps none or the deck turned it off).
  std::vector<std::unique_ptr<FrameLog>> term_logs_;
  std::vector<double> pos_;  // work: local positions
};

// Whether the scene's terms give every field of the deck's output.fields (EnergyTerm::element_fields);
// if not, an error naming the field's deck line is said and false returned. Collective.
bool check_element_fields(MPI_Comm comm, const Deck& deck, const Scene& scene);

// The frame series (OutputWriter: VTK, XDMF) at the output frames and the last; at a stop, the
// last good frame if it was not written. Nothing non-finite is ever written.
class FrameWriters : public FrameObserver {
 public:
  FrameWriters(const RunContext& run, bool restarted) : run_(run), restarted_(restarted) {}
  ~FrameWriters() override { VecDestroy(&field_); }
  std::vector<std::unique_ptr<OutputWriter>>& writers() { return writers_; }
  // A restart's series the deck no longer writes (frames off, or the other format): its state, cut
  // back to the checkpoint's frame, goes into every later checkpoint, so that a restart that
  // writes it again continues it instead of starting it afresh over its earlier frames.
  std::vector<std::pair<std::string, std::string>>& kept_series() { return kept_series_; }
  // Frame 0 of a new run; at a restart, its frame counts as written if it was an output frame.
  PetscErrorCode begin(LoopControl& control) override;
  PetscErrorCode scene_changed(const Scene& old_scene, Scene& fresh) override;
  PetscErrorCode after_frame(const FrameOutcome& outcome, LoopControl& control) override;
  PetscErrorCode stopped(const FrameOutcome& outcome, const std::string& why) override;
  int last_written() const { return last_written_; }

 private:
  // Writes frame `frame` from the state, unless a position, velocity or J is not finite.
  // unlisted_only: only to the writers whose series does not list the frame yet.
  PetscErrorCode write_frame(int frame, bool* written, bool unlisted_only = false);

  RunContext run_;
  std::vector<std::unique_ptr<OutputWriter>> writers_;
  std::vector<std::pair<std::string, std::string>> kept_series_;  // (restart key, state)
  bool restarted_;
  int last_written_ = -1;
  std::vector<double> pos_, vel_, J_;                // work: local arrays of a frame
  std::vector<std::vector<double>> field_values_;    // work: the terms' point fields, local
  std::vector<ElementFieldValues> element_values_;   // work: the deck's element fields, local
  Vec field_ = nullptr;                              // work: one point field (global free dofs)
};

}  // namespace hyperqn

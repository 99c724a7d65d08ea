// The one time loop of the simulation and the study: it advances states frame by frame through
// FrameStepper (app/frame_step.hpp) and tells a list of observers what happened; everything a run
// or a study does with a frame (writers, logs, checkpoints, signals, the study's error curves) is
// an observer (docs/architecture.md#the-time-loop).
//
// The loop steps a lead state and, in lockstep after it, any followers. The lead is the run's one
// state, or the study's converged reference: its time decides the releases of the scene, its
// positions the cuts and breaks (every follower moves to the changed scene with it), and a lead
// that cannot go on ends the loop. A follower (a study trajectory at a solver's budget) has
// its own solve; one that cannot go on stops alone. Lockstep rather than one loop per state: the
// study compares every trajectory with the reference at the same frame, so nothing of the
// reference has to be stored, and the scene is released once for all of them.
#pragma once
#include <string>
#include <vector>

#include "app/frame_step.hpp"
#include "model/scene.hpp"

namespace hyperqn {

// A follower's frame: not stepped (it stopped at an earlier frame, or the lead stopped), or its step.
struct FollowerStep {
  bool stepped = false;
  FrameStep step;       // step.stop: the follower stopped here (its step undone)
  double seconds = 0;   // wall time of the step (solve, guardrails, end or undo)
};

// What the loop tells its observers after a frame.
struct FrameOutcome {
  int frame = 0;
  FrameStep lead;                       // lead.stop: the lead cannot go on from this frame
  std::vector<FollowerStep> followers;  // in the order they follow
};

// What observers may ask of the loop.
struct LoopControl {
  std::string stop;          // why the lead cannot go on: the loop undoes its step and ends
  bool interrupted = false;  // end after this frame, which stands (a signal asked to stop between frames)
};

// Everything has a do-nothing default: an observer overrides what it needs. All are collective.
class FrameObserver {
 public:
  virtual ~FrameObserver() = default;
  // Before the first frame, the lead at its start (frame 0 or a restart's). May end the loop
  // before any frame (control.interrupted).
  virtual PetscErrorCode begin(LoopControl& /*control*/) { return 0; }
  // A release, a cut or a break rebuilt the scene (LiveScene::release_due, cut_due, snap_due); the
  // owner's rebind has run.
  virtual PetscErrorCode scene_changed(const Scene& /*old_scene*/, Scene& /*fresh*/) { return 0; }
  // Frame `frame` is about to be solved: the lead is at frame - 1, any release is done.
  virtual PetscErrorCode before_frame(int /*frame*/) { return 0; }
  // What sees the iterations of the lead's solve of `frame` (empty: nothing). Asked once per
  // frame; with one observer answering, its callback is the solver's, with nothing in between.
  virtual IterationCallback iterations(int /*frame*/) { return {}; }
  // After the frame. control.stop starts as the lead's stop; an observer that finds the frame
  // cannot stand (it could not be written) sets it, and the observers after it see it set.
  virtual PetscErrorCode after_frame(const FrameOutcome& /*outcome*/, LoopControl& /*control*/) { return 0; }
  // The lead could not go on from outcome.frame (why): its step is undone, it is at
  // outcome.frame - 1, and the loop ends.
  virtual PetscErrorCode stopped(const FrameOutcome& /*outcome*/, const std::string& /*why*/) { return 0; }
  // A stop signal ended the lead's solve of outcome.frame (outcome.lead.solve.interrupted): the
  // frame is given up, its step undone (the lead at outcome.frame - 1, as that frame left it), no
  // follower stepped, and the loop ends. after_frame is not called for it.
  virtual PetscErrorCode interrupted(const FrameOutcome& /*outcome*/) { return 0; }
};

class TimeLoop {
 public:
  // lead: solved by `solve`; rebind: the owner moves its solvers to a rebuilt scene.
  TimeLoop(LiveScene& scene, const Guardrails& limits, State& lead, FrameSolve solve, LiveScene::Rebind rebind);
  // A state stepped after the lead at every frame, by its own solve.
  void follow(State& state, FrameSolve solve);
  // A state carried over to a rebuilt scene but never stepped (a work state).
  void carry(State& state) { carried_.push_back(&state); }
  // Observers are told in the order they were added.
  void observe(FrameObserver& observer) { observers_.push_back(&observer); }

  // Steps until the lead reaches last_frame, cannot go on, or an observer interrupts.
  PetscErrorCode run(int last_frame);
  // Why the lead could not go on ("": it could) and at which frame.
  const std::string& stop() const { return stop_; }
  int stop_frame() const { return stop_frame_; }

 private:
  struct Follower {
    State* state;
    FrameSolve solve;
    bool stopped = false;
    // Its elements' history (a material with history: viscoelastic): the terms hold the lead's
    // between steps, and a follower's own while it steps.
    std::vector<ElementState> elements;
  };
  IterationCallback iterations(int frame);
  PetscErrorCode resolve_after_breaks(int frame, double time, const std::vector<State*>& carried,
                                      const LiveScene::Rebind& rebind, FrameStep& lead);

  LiveScene& scene_;
  FrameStepper stepper_;
  State& lead_;
  FrameSolve solve_;
  LiveScene::Rebind rebind_;
  std::vector<Follower> followers_;
  std::vector<State*> carried_;
  std::vector<FrameObserver*> observers_;
  std::string stop_;
  int stop_frame_ = -1;
};

}  // namespace hyperqn

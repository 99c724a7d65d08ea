#include "app/time_loop.hpp"

#include <utility>

#include "io/log_events.hpp"

namespace hyperqn {

TimeLoop::TimeLoop(LiveScene& scene, const Guardrails& limits, State& lead, FrameSolve solve, LiveScene::Rebind rebind)
    : scene_(scene), stepper_(limits), lead_(lead), solve_(std::move(solve)), rebind_(std::move(rebind)) {}

void TimeLoop::follow(State& state, FrameSolve solve) { followers_.push_back({&state, std::move(solve), false, {}}); }

IterationCallback TimeLoop::iterations(int frame) {
  std::vector<IterationCallback> callbacks;
  for (FrameObserver* o : observers_)
    if (IterationCallback c = o->iterations(frame)) callbacks.push_back(std::move(c));
  if (callbacks.size() <= 1) return callbacks.empty() ? IterationCallback() : std::move(callbacks.front());
  return [callbacks](const IterationRecord& r) {  // any of them may end the solve
    bool stop = false;
    for (const auto& c : callbacks) stop = c(r) || stop;
    return stop;
  };
}

PetscErrorCode TimeLoop::run(int last_frame) {
  PetscFunctionBeginUser;
  LoopControl control;
  for (FrameObserver* o : observers_) PetscCall(o->begin(control));
  std::vector<State*> carried = carried_;
  for (const Follower& f : followers_) carried.push_back(f.state);
  for (Follower& f : followers_) f.elements = scene_.current().body->copy_element_states();
  const LiveScene::Rebind rebind = [this](const Scene& old_scene, Scene& fresh) {
    PetscFunctionBeginUser;
    // The fresh terms took the lead's history (LiveScene::release_due); each follower's own moves
    // over the same way, through the old terms.
    if (!followers_.empty() && !old_scene.body->element_states().empty()) {
      const std::vector<ElementState> lead = old_scene.body->copy_element_states();
      const std::vector<ElementState> lead_fresh = fresh.body->copy_element_states();
      for (Follower& f : followers_) {
        old_scene.body->set_element_states(f.elements);
        fresh.body->carry_element_states(*old_scene.body);
        f.elements = fresh.body->copy_element_states();
      }
      old_scene.body->set_element_states(lead);
      fresh.body->set_element_states(lead_fresh);
    }
    PetscCall(rebind_(old_scene, fresh));
    for (FrameObserver* o : observers_) PetscCall(o->scene_changed(old_scene, fresh));
    PetscFunctionReturn(0);
  };

  while (!control.interrupted && lead_.frame < last_frame) {
    const int frame = lead_.frame + 1;
    const double time = lead_.time;
    bool released;
    PetscCall(scene_.release_due(lead_, carried, rebind, &released));
    // After the step before, once: its faces crossed by a blade (or overloaded) separate, its
    // segments and edges past their strains snap and tear. Not again after a restart from a
    // checkpoint that a signal wrote once they had (LiveScene::changes_decided_after).
    if (!scene_.changes_decided_after(lead_.frame)) {
      bool cut, snapped;
      PetscCall(scene_.cut_due(lead_, carried, rebind, &cut));
      PetscCall(scene_.snap_due(lead_, carried, rebind, &snapped));
      scene_.decide_changes_after(lead_.frame);
    }
    if (!scene_.nothing_left().empty()) {  // the blades would remove the whole body: the run ends here
      FrameOutcome outcome;
      outcome.frame = frame;
      stop_ = scene_.nothing_left();
      stop_frame_ = frame;
      for (FrameObserver* o : observers_) PetscCall(o->stopped(outcome, stop_));
      break;
    }
    for (FrameObserver* o : observers_) PetscCall(o->before_frame(frame));

    FrameOutcome outcome;
    outcome.frame = frame;
    PetscCall(stepper_.step(scene_.current(), solve_, lead_, iterations(frame), outcome.lead));
    PetscCall(resolve_after_breaks(frame, time, carried, rebind, outcome.lead));
    const Scene& scene = scene_.current();
    outcome.followers.resize(followers_.size());
    if (outcome.lead.solve.interrupted) {  // a stop signal during the solve: the frame is given up
      PetscCall(scene.step->lifecycle().undo(lead_));
      for (FrameObserver* o : observers_) PetscCall(o->interrupted(outcome));
      break;
    }
    const bool own_elements = !followers_.empty() && !scene.body->element_states().empty();
    const std::vector<ElementState> lead_elements =
        own_elements ? scene.body->copy_element_states() : std::vector<ElementState>();
    for (size_t k = 0; k < followers_.size() && outcome.lead.stop.empty(); ++k) {
      Follower& f = followers_[k];
      if (f.stopped) continue;
      FollowerStep& out = outcome.followers[k];
      if (own_elements) scene.body->set_element_states(f.elements);
      const double t0 = MPI_Wtime();
      PetscCall(stepper_.step(scene, f.solve, *f.state, IterationCallback(), out.step));
      if (!out.step.stop.empty()) PetscCall(scene.step->lifecycle().undo(*f.state));
      out.seconds = MPI_Wtime() - t0;
      if (own_elements) f.elements = scene.body->copy_element_states();
      out.stepped = true;
      f.stopped = !out.step.stop.empty();
    }
    if (own_elements) scene.body->set_element_states(lead_elements);

    control.stop = outcome.lead.stop;
    for (FrameObserver* o : observers_) PetscCall(o->after_frame(outcome, control));
    if (control.stop.empty()) continue;
    if (lead_.frame == frame) {  // it ended, but an observer found it cannot stand
      lead_.frame = frame - 1;
      lead_.time = time;
    }
    PetscCall(scene.step->lifecycle().undo(lead_));
    stop_ = control.stop;
    stop_frame_ = frame;
    for (FrameObserver* o : observers_) PetscCall(o->stopped(outcome, stop_));
    break;
  }
  PetscFunctionReturn(0);
}

// Re-solves (docs/topology.md#fracture, docs/snapping.md): while the step's converged state breaks
// faces, snaps a segment or tears an edge (LiveScene::resolve_breaks, at most material.fracture.resolve,
// strand_material.snap.resolve or cloth.tear.resolve times), the step is undone, they separate at its
// start and it is solved again; the frame's solve counts every solve's iterations, evaluations and time.
PetscErrorCode TimeLoop::resolve_after_breaks(int frame, double time, const std::vector<State*>& carried,
                                              const LiveScene::Rebind& rebind, FrameStep& lead) {
  PetscFunctionBeginUser;
  if (scene_.resolves() == 0) PetscFunctionReturn(0);
  std::vector<TetPair> batch;
  std::vector<int64_t> segments;
  std::vector<std::array<int64_t, 2>> edges;
  while (lead.stop.empty() && !lead.solve.interrupted) {
    PetscCall(scene_.resolve_breaks(lead_, batch, segments, edges));
    if (batch.empty() && segments.empty() && edges.empty()) break;
    lead_.frame = frame - 1;  // back at the step's start
    lead_.time = time;
    PetscCall(scene_.current().step->lifecycle().undo(lead_));
    PetscCall(event_begin(&LogEvents::topology));
    if (!batch.empty()) PetscCall(scene_.separate_due(batch, lead_, carried, rebind));
    if (!segments.empty() || !edges.empty()) PetscCall(scene_.break_due(segments, edges, lead_, carried, rebind));
    PetscCall(event_end(&LogEvents::topology));
    for (FrameObserver* o : observers_) PetscCall(o->before_frame(frame));
    const StepSolve before = lead.solve;
    PetscCall(stepper_.step(scene_.current(), solve_, lead_, iterations(frame), lead));
    lead.solve.iterations += before.iterations;
    lead.solve.evaluations += before.evaluations;
    lead.solve.seconds += before.seconds;
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

// Per-element values that a term carries from step to step (a material with history: plastic
// strain, damage), owned with its elements: n values for each of the term's local elements, keyed
// by the element's global id (DistributedMesh::cell_ids and the like), so that what they mean does
// not depend on the partition. Like the positions, they have a value at the step's start (t_n,
// start) and a current one (current): the step's begin takes the current values as its start, its
// accept writes the current ones (EnergyTerm::update_state), its undo puts the start back, also
// after an accept (a frame an observer refuses). A frame the fallback chain solves in sub-steps
// moves them once per sub-step (begin_substep, the sub-step's accept); the frame's start is kept
// then (only then: no copy for a frame of one step), and the frame's undo goes back to it. The
// midpoint updates them at its z over h/2 and extrapolates (extrapolate, advance). A checkpoint saves the current values and a
// restart restores them (io/checkpoint.hpp, elements_<name>); a rebuilt scene (a release) carries
// them over by id (Body::carry_element_states). docs/architecture.md, "The step core".
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace hyperqn {

class ElementState {
 public:
  // name: the term's key for its values; ids: the global id of each local element, in the term's order.
  ElementState(std::string name, int per_element, std::vector<int64_t> ids, double initial = 0)
      : name_(std::move(name)), per_element_(per_element), ids_(std::move(ids)),
        start_(ids_.size() * per_element, initial), current_(start_) {}

  const std::string& name() const { return name_; }
  int per_element() const { return per_element_; }
  // An element made by a change of the mesh that carries on an old one's history (a torn edge's
  // second spring: Body::carry_element_states) takes the old one's first `inherited()` values;
  // the rest (what the old one has dissipated, which stays with it) start at 0. 0 (the default):
  // no element of this state carries on another's.
  int inherited() const { return inherited_; }
  void set_inherited(int values) { inherited_ = values; }
  size_t elements() const { return ids_.size(); }
  const std::vector<int64_t>& ids() const { return ids_; }
  // Element e's values at the step's start, and its current ones.
  const double* start(size_t e) const { return &start_[per_element_ * e]; }
  double* current(size_t e) {
    materialize();
    return &current_[per_element_ * e];
  }
  const double* current(size_t e) const { return &current_values()[per_element_ * e]; }
  const std::vector<double>& current_values() const { return current_is_start_ ? start_ : current_; }
  // For a term whose update writes every element's current values (InelasticTets): the values
  // current has before are not needed, so a step's begin need not have copied them.
  double* overwrite(size_t e) {
    current_is_start_ = false;
    return &current_[per_element_ * e];
  }
  // Changes whenever the start values may have (each call below but extrapolate): what a term
  // computes once per step from them (InelasticTets' step values) is kept under it. Unique to one
  // set of start values across every ElementState, so that a copy put back (a study's trajectory,
  // Body::set_element_states) does not take another history's revision.
  uint64_t revision() const { return revision_; }

  // A frame's step: its start, and back to it (after sub-steps too).
  void begin() {
    touch();
    take_current_as_start();
    frame_kept_ = advanced_ = false;
  }
  void undo() {
    touch();
    back_from_advance();
    if (frame_kept_) start_ = frame_start_;
    current_is_start_ = true;
  }
  // A sub-step of the frame: its start (the frame's kept at the first), and back to it.
  void begin_substep() {
    touch();
    if (!frame_kept_) frame_start_ = start_;
    frame_kept_ = true;
    advanced_ = false;
    take_current_as_start();
  }
  void undo_substep() {
    touch();
    back_from_advance();
    current_is_start_ = true;
  }
  // The midpoint (docs/inelastic.md#the-midpoint): current, updated at the step's z over h/2, becomes
  // 2 current - start, the midpoint rule for the values' ODE (the energy dissipated: start + 2 D_half).
  void extrapolate() {
    if (current_is_start_) return;  // 2 start - start
    for (size_t i = 0; i < current_.size(); ++i) current_[i] = 2 * current_[i] - start_[i];
  }
  // A midpoint step completed by implicit Euler: its second half starts from the values at z
  // (current, as updated there); undo and undo_substep still go back to the step's start.
  void advance() {
    touch();
    if (!advanced_) step_start_ = start_;
    advanced_ = true;
    take_current_as_start();
  }
  // Values saved by a checkpoint or kept by the scene before a rebuild (in ids' order): both the
  // start and the current ones, as after an accepted step.
  void restore(std::vector<double> values) {
    touch();
    start_ = std::move(values);
    current_is_start_ = true;
    frame_kept_ = advanced_ = false;
  }

 private:
  // The current values become the start's, and current stands for them until written: a swap,
  // not a copy of every value (a step's begin).
  void take_current_as_start() {
    if (current_is_start_) return;
    start_.swap(current_);
    current_is_start_ = true;
  }
  // current_ holding the values again before one is written (a copy only after a begin or undo).
  void materialize() {
    if (!current_is_start_) return;
    current_ = start_;
    current_is_start_ = false;
  }
  void touch() { revision_ = ++last_revision_; }
  void back_from_advance() {
    if (advanced_) start_ = step_start_;
    advanced_ = false;
  }

  std::string name_;
  int per_element_;
  int inherited_ = 0;
  std::vector<int64_t> ids_;
  std::vector<double> start_, current_;
  bool current_is_start_ = false;  // current's values are start's (current_ is stale until written)
  std::vector<double> frame_start_;  // the frame's start while sub-steps move start_
  bool frame_kept_ = false;
  std::vector<double> step_start_;  // the step's start while advance() moved start_ to its z
  bool advanced_ = false;
  inline static uint64_t last_revision_ = 0;  // of all ElementStates
  uint64_t revision_ = ++last_revision_;
};

// from's current values into to's (both as after an accepted step), element by element through the
// global ids; elements of `to` that from does not hold keep theirs. Nothing unless both have the
// same name and width (Body::carry_element_states; the reactions' copy of the terms).
void carry_values(ElementState& to, const ElementState& from);

}  // namespace hyperqn

// The state of a run: everything that changes from frame to frame and that a restart needs,
// beside the scene description itself.
#pragma once
#include <petscvec.h>

#include <vector>

#include "model/substep_memory.hpp"

namespace hyperqn {

struct State {
  Vec x = nullptr, v = nullptr;  // positions and velocities of the free dofs (global vectors)
  int frame = 0;                 // frames done; the next step goes to frame + 1
  double time = 0;               // frame * dt
  std::vector<char> released;    // per fixed region: 1 once its vertices are free
  std::vector<char> released_attachments;  // per attachment: 1 once its springs are gone
  // The integrator's history x_{n-1}, v_{n-1}, for one that keeps it (model/time_integrator.hpp):
  // null before its first step, after a release and at a sub-step's first (the integrator takes a
  // starting step there).
  Vec x_prev = nullptr, v_prev = nullptr;
  SubstepMemory substeps;  // where the fallback chain starts the next frame

  State() = default;
  ~State() { destroy(); }
  State(const State&) = delete;
  State& operator=(const State&) = delete;

  // x, v in the layout of `layout` (both zero).
  PetscErrorCode create(Vec layout) {
    PetscFunctionBeginUser;
    destroy();
    PetscCall(VecDuplicate(layout, &x));
    PetscCall(VecDuplicate(layout, &v));
    PetscCall(VecSet(x, 0.0));
    PetscCall(VecSet(v, 0.0));
    PetscFunctionReturn(0);
  }
  // A copy of other (x, v in other's layout).
  PetscErrorCode copy_from(const State& other) {
    PetscFunctionBeginUser;
    if (!x) PetscCall(create(other.x));
    PetscCall(VecCopy(other.x, x));
    PetscCall(VecCopy(other.v, v));
    if (other.x_prev) {
      PetscCall(set_history(other.x_prev, other.v_prev));
    } else {
      drop_history();
    }
    frame = other.frame;
    time = other.time;
    released = other.released;
    released_attachments = other.released_attachments;
    substeps = other.substeps;
    PetscFunctionReturn(0);
  }
  // Copies x_prev, v_prev into the history.
  PetscErrorCode set_history(Vec x_prev_new, Vec v_prev_new) {
    PetscFunctionBeginUser;
    if (!x_prev) PetscCall(VecDuplicate(x_prev_new, &x_prev));
    if (!v_prev) PetscCall(VecDuplicate(v_prev_new, &v_prev));
    PetscCall(VecCopy(x_prev_new, x_prev));
    PetscCall(VecCopy(v_prev_new, v_prev));
    PetscFunctionReturn(0);
  }
  void drop_history() {
    VecDestroy(&x_prev);
    VecDestroy(&v_prev);
  }
  // Takes x_new and v_new (another layout, e.g. after a release) in place of x and v; the history
  // is dropped.
  void replace(Vec x_new, Vec v_new) {
    destroy();
    x = x_new;
    v = v_new;
  }

 private:
  void destroy() {
    VecDestroy(&x);
    VecDestroy(&v);
    drop_history();
  }
};

}  // namespace hyperqn

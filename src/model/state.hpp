// The state of a run: everything that changes from frame to frame and that a restart needs,
// beside the scene description itself.
#pragma once
#include <petscvec.h>

#include <vector>

namespace hyperqn {

struct State {
  Vec x = nullptr, v = nullptr;  // positions and velocities of the free dofs (global vectors)
  int frame = 0;                 // frames done; the next step goes to frame + 1
  double time = 0;               // frame * dt
  std::vector<char> released;    // per fixed region: 1 once its vertices are free
  std::vector<char> released_attachments;  // per attachment: 1 once its springs are gone

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
    frame = other.frame;
    time = other.time;
    released = other.released;
    released_attachments = other.released_attachments;
    PetscFunctionReturn(0);
  }
  // Takes x_new and v_new (another layout, e.g. after a release) in place of x and v.
  void replace(Vec x_new, Vec v_new) {
    destroy();
    x = x_new;
    v = v_new;
  }

 private:
  void destroy() {
    VecDestroy(&x);
    VecDestroy(&v);
  }
};

}  // namespace hyperqn

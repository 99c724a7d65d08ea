// StepLifecycle (model/step_lifecycle.hpp): a step begun, changed and undone leaves the state and
// the fixed vertices as they were, bit for bit; accept advances frame, time and the history with
// the integrator's end map; keep and restore carry a step's end (the midpoint's completion by
// Euler) across another attempt. At 1 and 2 ranks, on the shared test scene with its fixed end
// moving.
#include <petscdmplex.h>

#include <cstring>

#include "check.hpp"
#include "model/step_lifecycle.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

constexpr double kDt = 0.05;

// a == b bit for bit on every rank (collective).
bool same_bits(Vec a, Vec b) {
  const PetscScalar *pa, *pb;
  PetscInt na, nb;
  VecGetLocalSize(a, &na);
  VecGetLocalSize(b, &nb);
  int same = na == nb;
  VecGetArrayRead(a, &pa);
  VecGetArrayRead(b, &pb);
  if (same && na > 0) same = std::memcmp(pa, pb, sizeof(PetscScalar) * na) == 0;
  VecRestoreArrayRead(a, &pa);
  VecRestoreArrayRead(b, &pb);
  MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD);
  return same;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  int same = a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0);
  MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD);
  return same;
}

// The test scene with its fixed end moving at 1 m/s in y, at frame 1 (the body at t = h, its fixed
// vertices' velocities the mean over the step), x deformed and v nonzero.
PetscErrorCode start(TestScene& sc, State& s) {
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("neohookean", true, sc));
  BoxRegion end{{-0.1, -0.1, -0.1}, {0.01, 1.1, 1.1}, 0};
  end.motion.active = true;
  end.motion.velocity = {0, 1, 0};
  sc.body->set_fixed_motion({end});
  sc.body->set_time(kDt);
  PetscCall(s.create(sc.step->layout()));
  PetscCall(test_scene::deformed_positions(sc, s.x, 0.1));
  PetscCall(test_scene::deformed_positions(sc, s.v, 0.3));
  s.frame = 1;
  s.time = kDt;
  PetscFunctionReturn(0);
}

// begin, change s, undo: s and the fixed vertices as before, bit for bit (with and without a history).
PetscErrorCode check_undo(TimeIntegrator kind, bool history) {
  TestScene sc;
  State s, before;
  std::vector<double> pos0, vel0, pos1, vel1;
  PetscFunctionBeginUser;
  PetscCall(start(sc, s));
  if (history) PetscCall(s.set_history(s.v, s.x));  // any values: the step must not touch them
  PetscCall(before.copy_from(s));
  PetscCall(sc.body->local_positions(s.x, pos0));
  PetscCall(sc.body->local_velocities(s.v, vel0));
  StepLifecycle life(*sc.body, kDt, 0.1, kind);
  PetscCall(life.setup(sc.step->layout()));
  PetscCall(life.begin(s));
  CHECK(same_bits(life.x_n(), before.x) && same_bits(life.v_n(), before.v));
  CHECK(sc.body->time() == life.solve_time(s) && life.solve_time(s) > kDt);
  PetscCall(VecScale(s.x, 1.1));  // the solver's iterate
  PetscCall(VecShift(s.v, 0.2));
  PetscCall(life.undo(s));
  CHECK(same_bits(s.x, before.x) && same_bits(s.v, before.v));
  CHECK(s.frame == 1 && s.time == kDt && sc.body->time() == kDt);
  CHECK(!history || (same_bits(s.x_prev, before.x_prev) && same_bits(s.v_prev, before.v_prev)));
  PetscCall(sc.body->local_positions(s.x, pos1));
  PetscCall(sc.body->local_velocities(s.v, vel1));
  CHECK_MSG(same_bits(pos0, pos1) && same_bits(vel0, vel1), "the fixed vertices back at t_n with their velocities");
  PetscFunctionReturn(0);
}

// accept: implicit Euler's end map v = (1 - damping) (z - x_n) / h, frame and time advance, the
// fixed vertices at t_{n+1}; BDF2's history becomes x_n, v_n.
PetscErrorCode check_accept() {
  TestScene sc;
  State s, before;
  Vec expected;
  PetscFunctionBeginUser;
  PetscCall(start(sc, s));
  PetscCall(before.copy_from(s));
  PetscCall(VecDuplicate(s.v, &expected));
  {
    StepLifecycle life(*sc.body, kDt, 0.1, TimeIntegrator::implicit_euler);
    PetscCall(life.setup(sc.step->layout()));
    PetscCall(life.begin(s));
    PetscCall(VecShift(s.x, 0.01));  // z
    PetscCall(VecWAXPY(expected, -1.0, before.x, s.x));
    PetscCall(VecScale(expected, (1.0 - 0.1) / kDt));
    PetscCall(life.accept(s));
    CHECK(same_bits(s.v, expected));
    CHECK(s.frame == 2 && s.time == 2 * kDt && sc.body->time() == 2 * kDt && !s.x_prev);
  }
  {
    StepLifecycle life(*sc.body, kDt, 0.0, TimeIntegrator::bdf2);
    PetscCall(life.setup(sc.step->layout()));
    PetscCall(before.copy_from(s));
    PetscCall(life.begin(s));
    PetscCall(VecShift(s.x, 0.01));
    PetscCall(life.accept(s));
    CHECK_MSG(s.x_prev && same_bits(s.x_prev, before.x) && same_bits(s.v_prev, before.v), "BDF2's history is x_n, v_n");
    CHECK(s.frame == 3);
    // The sub-steps' end: s.x as it is, the velocity given.
    PetscCall(before.copy_from(s));
    PetscCall(life.begin_substepped(s));
    PetscCall(VecSet(expected, 0.5));
    PetscCall(life.accept(s, expected));
    CHECK(same_bits(s.x, before.x) && same_bits(s.v, expected) && s.frame == 4);
  }
  PetscCall(VecDestroy(&expected));
  PetscFunctionReturn(0);
}

// keep, another attempt, restore: the midpoint's step completed by Euler ends as Euler's from the
// kept z, v = (x - z) / h'.
PetscErrorCode check_keep_restore() {
  TestScene sc;
  State s;
  Vec z, x, expected;
  PetscFunctionBeginUser;
  PetscCall(start(sc, s));
  StepLifecycle life(*sc.body, kDt, 0.0, TimeIntegrator::implicit_midpoint);
  PetscCall(life.setup(sc.step->layout()));
  PetscCall(VecDuplicate(s.x, &z));
  PetscCall(VecDuplicate(s.x, &x));
  PetscCall(VecDuplicate(s.x, &expected));
  PetscCall(life.begin(s));
  PetscCall(VecWAXPY(z, 0.02, s.v, s.x));
  PetscCall(life.complete_by_euler(z));
  CHECK(life.euler_completed() && same_bits(life.x_hat(), z));
  PetscCall(VecShift(s.x, 0.03));  // the Euler step's end
  PetscCall(VecCopy(s.x, x));
  PetscCall(life.keep());
  PetscCall(life.undo(s));   // another attempt from x_n
  PetscCall(life.begin(s));
  CHECK(!life.euler_completed());
  PetscCall(VecCopy(x, s.x));  // the kept attempt's x back
  PetscCall(life.restore());
  CHECK(life.euler_completed() && same_bits(life.x_hat(), z));
  PetscCall(VecWAXPY(expected, -1.0, z, x));
  PetscCall(VecScale(expected, 1.0 / life.solve_dt()));
  PetscCall(life.accept(s));
  CHECK(same_bits(s.v, expected) && same_bits(s.x, x) && s.frame == 2);
  PetscCall(VecDestroy(&z));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&expected));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  for (TimeIntegrator kind : {TimeIntegrator::implicit_euler, TimeIntegrator::implicit_midpoint, TimeIntegrator::bdf2,
                              TimeIntegrator::quasi_static})
    for (bool history : {false, true}) PetscCall(check_undo(kind, history));
  PetscCall(check_accept());
  PetscCall(check_keep_restore());
  const int code = test_scene::tally("test_step_lifecycle");
  PetscCall(PetscFinalize());
  return code;
}

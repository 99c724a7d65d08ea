// The contact term (terms/contact.hpp) on the shared test box (2 x 1 x 1, fixed at x = 0, mass
// 7.5): its energy, gradient and Hessian against finite differences, near and away from contact,
// with friction sticking and sliding; and its measured forces against its gradient. At 1 and N
// ranks.
#include <petscdmplex.h>

#include "check.hpp"
#include "io/log_events.hpp"
#include "terms/contact.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

constexpr double kDistance = 0.05;

// A floor, a ball above the top face, a capsule along the far end: vertices within the activation
// layer and away from every collider; for the penalty also inside them (the floor cuts 0.02 into
// the bottom face, the ball and capsule into the top and the end), for the barrier all outside.
std::vector<ColliderSpec> colliders(double friction, bool barrier) {
  ColliderSpec floor, ball, rod;
  floor.type = ColliderType::plane;
  floor.point = {0, barrier ? -0.03 : 0.02, 0};
  floor.normal = {0, 2, 0};  // any length
  floor.friction = friction;
  ball.type = ColliderType::sphere;
  ball.center = {1.0, 1.3, 0.5};
  ball.radius = barrier ? 0.27 : 0.35;
  ball.friction = friction;
  rod.type = ColliderType::capsule;
  rod.a = {2.1, 0.3, -0.2};
  rod.b = {2.1, 0.7, 1.2};
  rod.radius = barrier ? 0.08 : 0.12;
  return {floor, ball, rod};
}

PetscErrorCode make_contact_scene(double friction, const std::string& model, TestScene& s, ContactTerm** contact) {
  PetscFunctionBeginUser;
  ContactSpec spec;
  spec.model = model == "barrier" ? ContactModel::barrier : ContactModel::penalty;
  spec.distance = kDistance;
  spec.stiffness = 1e4;          // contact dominates the elastic forces: the check sees it
  spec.friction_velocity = 0.2;  // eps h = 0.01: the deformation below both sticks and slides
  const test_scene::ExtraTerms extra = [&](const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
    std::vector<std::unique_ptr<Collider>> list;
    int k = 0;
    for (const ColliderSpec& c : colliders(friction, model == "barrier")) list.push_back(make_collider(c, "test", k++));
    auto term = std::make_unique<ContactTerm>(mesh, std::move(list), spec, log_events().contact);
    *contact = term.get();
    terms.push_back(std::move(term));
  };
  PetscCall(test_scene::make_scene("corotated", true, s, {0, -9.81, 0}, extra));
  PetscCall((*contact)->set_masses(s.step->mass()));
  PetscFunctionReturn(0);
}

PetscErrorCode check_derivatives(double friction, const std::string& model) {
  TestScene s;
  ContactTerm* contact = nullptr;
  Vec x, v, grad;
  PetscRandom rnd;
  PetscReal E;
  Mat K;
  PetscFunctionBeginUser;
  PetscCall(make_contact_scene(friction, model, s, &contact));
  const bool barrier = model == "barrier";
  PetscCall(VecDuplicate(s.step->layout(), &x));
  for (Vec* w : {&v, &grad}) PetscCall(VecDuplicate(x, w));
  // The step starts at the rest shape (friction freezes its normal forces there), then x moves.
  PetscCall(s.body->rest_positions(x));
  PetscCall(VecSet(v, 0.0));
  PetscCall(test_scene::set_inertial_target(s, x, v));
  PetscCall(test_scene::deformed_positions(s, x, barrier ? 0.01 : 0.05));  // the barrier: all outside

  ContactMeasure m;
  std::vector<double> pos;
  PetscCall(s.body->local_positions(x, pos));
  PetscCall(contact->measure(pos, m, nullptr));
  long active = 0;
  for (long a : m.active) active += a;
  CHECK_MSG(m.active[0] > 0 && m.active[1] > 0 && m.active[2] > 0, "every collider touches the body");
  if (barrier)
    CHECK_MSG(m.penetration[0] == 0 && m.penetration[1] == 0 && m.penetration[2] == 0, "no vertex inside for the barrier");
  else
    CHECK_MSG(m.penetration[0] > 0 && m.penetration[1] > 0, "the floor and the ball cut into it");
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s, friction %g: %ld vertices in contact; normal forces %.4g %.4g %.4g, friction %.4g %.4g %.4g\n",
                        model.c_str(), friction, active, m.normal_force[0], m.normal_force[1], m.normal_force[2], m.friction_force[0],
                        m.friction_force[1], m.friction_force[2]));
  if (friction > 0) CHECK_MSG(m.friction_force[0] > 0, "friction acts on the floor's contacts");

  // Gradient: central differences of E along random directions.
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(s.body->energy_gradient(x, &E, grad));
  PetscCall(test_scene::check_gradient(*s.body, x, grad, rnd));
  // Hessian (exact: with the obstacles' curvature) against differences of the gradient.
  double err;
  PetscCall(test_scene::stiffness(s, x, false, &K));
  PetscCall(test_scene::fd_error(K, x, [&](Vec at, Vec g) { PetscReal e; return s.body->energy_gradient(at, &e, g); }, rnd, &err));
  CHECK_MSG(err < 1e-5, "Hessian vs FD of the gradient: " + std::to_string(err));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s, friction %g: Hessian vs FD: %.2e\n", model.c_str(), friction, err));
  PetscCall(MatDestroy(&K));

  // The measured total forces are minus the contact gradient: compare with the body without it.
  TestScene plain;
  Vec g_plain, force;
  PetscCall(test_scene::make_scene("corotated", true, plain, {0, -9.81, 0}));
  PetscCall(VecDuplicate(x, &g_plain));
  PetscCall(VecDuplicate(x, &force));
  PetscCall(plain.body->energy_gradient(x, &E, g_plain));
  PetscCall(contact->measure(pos, m, force));
  PetscCall(VecAXPY(grad, -1.0, g_plain));  // the contact gradient alone
  PetscCall(VecAXPY(grad, 1.0, force));     // + force: 0
  PetscReal residual, scale;
  PetscCall(VecNorm(force, NORM_INFINITY, &scale));
  PetscCall(VecNorm(grad, NORM_INFINITY, &residual));
  CHECK_MSG(scale > 0 && residual <= 1e-10 * scale, "measured force = -contact gradient: " + std::to_string(residual));
  for (Vec* w : {&x, &v, &grad, &g_plain, &force}) PetscCall(VecDestroy(w));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscFunctionReturn(0);
}

// Every vertex moves down at 0.1 (1 + 0.1 x): the step bound is 0.8 of the earliest impact.
PetscErrorCode check_step_bound_is_the_earliest_impact(TestScene& s, Vec x) {
  Vec dir;
  const PetscScalar* p;
  PetscScalar* d;
  PetscInt n;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &p));
  PetscCall(VecGetArray(dir, &d));
  for (PetscInt i = 0; i < n; i += 3) {
    d[i] = d[i + 2] = 0;
    d[i + 1] = -0.1 * (1 + 0.1 * p[i]);
  }
  PetscCall(VecRestoreArrayRead(x, &p));
  PetscCall(VecRestoreArray(dir, &d));
  double alpha = 1;
  PetscCall(s.body->limit_step(x, dir, &alpha));
  const double earliest = 0.03 / (0.1 * 1.2);  // the bottom face's far end, x = 2
  CHECK_MSG(std::fabs(alpha - 0.8 * earliest) < 1e-12,
            "step bound 0.8 of the earliest time of impact 0.25: " + std::to_string(alpha));
  PetscCall(VecDestroy(&dir));
  PetscFunctionReturn(0);
}

// The barrier: infinite at and inside an obstacle (the point is rejected), and its step bound
// stops a straight path short of the first obstacle it would reach.
PetscErrorCode check_barrier() {
  TestScene s;
  ContactTerm* contact = nullptr;
  Vec x, dir;
  PetscReal E;
  PetscFunctionBeginUser;
  PetscCall(make_contact_scene(0.0, "barrier", s, &contact));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(s.body->rest_positions(x));
  PetscCall(s.body->energy_gradient(x, &E, nullptr));
  CHECK_MSG(std::isfinite(E), "finite at the rest shape, all vertices outside");
  // Everything moves down by 0.1: the bottom face (0.03 above the floor) would cross it.
  PetscCall(VecSet(dir, 0.0));
  PetscCall(VecStrideSet(dir, 1, -0.1));
  double alpha = 1;
  PetscCall(s.body->limit_step(x, dir, &alpha));
  CHECK_MSG(std::fabs(alpha - 0.8 * 0.3) < 1e-12, "step bound 0.8 of the time of impact 0.3: " + std::to_string(alpha));
  // Faster towards x = 2: the bottom face's impact times run from 0.3 at x = 0 down to 0.25 at
  // x = 2, and the bound is 0.8 of the earliest, whichever vertex a rank looks at first and
  // however the ranks share them (the same at 1 and N ranks).
  PetscCall(check_step_bound_is_the_earliest_impact(s, x));
  PetscCall(VecAXPY(x, 0.5, dir));  // half the way: the bottom face 0.02 below the floor
  PetscCall(s.body->energy_gradient(x, &E, nullptr));
  CHECK_MSG(!std::isfinite(E), "the barrier is infinite inside the floor");
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&dir));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  for (const char* model : {"penalty", "barrier"}) {
    PetscCall(check_derivatives(0.0, model));
    PetscCall(check_derivatives(0.6, model));
  }
  PetscCall(check_barrier());
  const int code = test_scene::tally("test_contact");
  PetscCall(PetscFinalize());
  return code;
}

// The static integrator's step objective (model/step_objective.hpp, time.integrator: static), at 1
// and 2 ranks on the shared test scene (fixed at x = 0, gravity): g(x) - g(x_n) = s^2 (E(x) - E(x_n))
// - s^2 sum m a . (x - x_n) (no inertia, gravity's work kept); grad g = s^2 (dE/dx - M a) and
// against central differences of g; the automatic pseudo step from its formula; the step ends with
// x_{n+1} = z and v = 0; a sub-step keeps s.
#include <cmath>

#include "check.hpp"
#include "model/ordered_assembly.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

constexpr double kDt = 0.05;
const std::array<double, 3> kGravity{0.5, -9.81, 0.2};

// s^2 = 1e8 N^(2/3) max m_i / L_ii, computed here from the pieces (collective).
PetscErrorCode expected_pseudo_step(test_scene::TestScene& sc, Vec mass, double* s) {
  Mat L;
  Vec d;
  const PetscScalar *m, *l;
  PetscInt n;
  double local = 0, global;
  PetscFunctionBeginUser;
  PetscCall(DMCreateMatrix(sc.mesh.vertex_dm, &L));
  PetscCall(add_in_rank_order(L, [&](Mat S) { return sc.body->add_laplacian(S, 1.0, 1); }));
  PetscCall(MatCreateVecs(L, &d, nullptr));
  PetscCall(MatGetDiagonal(L, d));
  PetscCall(VecGetLocalSize(d, &n));
  PetscCall(VecGetArrayRead(d, &l));
  PetscCall(VecGetArrayRead(mass, &m));
  for (PetscInt i = 0; i < n; ++i) local = std::fmax(local, m[3 * i] / l[i]);
  PetscCall(VecRestoreArrayRead(mass, &m));
  PetscCall(VecRestoreArrayRead(d, &l));
  PetscCallMPI(MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD));
  const double N = sc.mesh.global_dofs / 3.0;
  *s = std::sqrt(1e8 * std::pow(N, 2.0 / 3.0) * global);
  PetscCall(VecDestroy(&d));
  PetscCall(MatDestroy(&L));
  PetscFunctionReturn(0);
}

PetscErrorCode check_static() {
  test_scene::TestScene sc;
  State state;
  Vec x, grad, dE, expected, dir, xp;
  PetscReal g, g_n, E, E_n, gp, gm, analytic, work;
  PetscRandom rnd;
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("neohookean", true, sc, kGravity));
  sc.step = std::make_unique<StepObjective>(*sc.body, kDt, kGravity, 0.0, WarmStart::inertial, true, 0.0,
                                           TimeIntegrator::quasi_static);
  PetscCall(sc.step->setup());
  CHECK(!sc.step->has_inertia());
  double s_expected;
  PetscCall(expected_pseudo_step(sc, sc.step->mass(), &s_expected));
  const double s = sc.step->solve_dt();
  CHECK_MSG(std::fabs(s / s_expected - 1) <= 1e-14, "s " + std::to_string(s) + " vs " + std::to_string(s_expected));

  PetscCall(state.create(sc.step->layout()));
  PetscCall(test_scene::deformed_positions(sc, state.x, 0.1));
  PetscCall(test_scene::deformed_positions(sc, state.v, 0.3));
  Vec x_n;
  PetscCall(VecDuplicate(state.x, &x_n));
  PetscCall(VecCopy(state.x, x_n));
  PetscCall(sc.step->begin_step(state));
  PetscCall(VecDuplicate(state.x, &x));
  PetscCall(VecDuplicate(state.x, &grad));
  PetscCall(VecDuplicate(state.x, &dE));
  PetscCall(VecDuplicate(state.x, &expected));
  PetscCall(VecDuplicate(state.x, &dir));
  PetscCall(VecDuplicate(state.x, &xp));
  PetscCall(test_scene::deformed_positions(sc, x, 0.2));

  // g and its gradient against s^2 (E - W) and s^2 (dE/dx - M a).
  PetscCall(sc.step->objective(x, &g, grad));
  PetscCall(sc.step->objective(x_n, &g_n, nullptr));
  PetscCall(sc.body->energy_gradient(x, &E, dE));
  PetscCall(sc.body->energy_gradient(x_n, &E_n, nullptr));
  PetscCall(VecCopy(sc.step->mass(), expected));  // M a, then s^2 (dE/dx - M a)
  {
    PetscScalar* e;
    PetscInt lo, hi;
    PetscCall(VecGetOwnershipRange(expected, &lo, &hi));
    PetscCall(VecGetArray(expected, &e));
    for (PetscInt i = lo; i < hi; ++i) e[i - lo] *= kGravity[i % 3];
    PetscCall(VecRestoreArray(expected, &e));
  }
  PetscCall(VecWAXPY(dir, -1.0, x_n, x));
  PetscCall(VecDot(expected, dir, &work));  // sum m a . (x - x_n)
  const double g_expected = s * s * (E - E_n) - s * s * work;
  CHECK_MSG(std::fabs((g - g_n) - g_expected) <= 1e-11 * std::fabs(g_expected),
            "g(x) - g(x_n) " + std::to_string(g - g_n) + " vs " + std::to_string(g_expected));
  PetscCall(VecAYPX(expected, -1.0, dE));
  PetscCall(VecScale(expected, s * s));
  PetscReal diff, norm;
  PetscCall(VecAXPY(expected, -1.0, grad));
  PetscCall(VecNorm(expected, NORM_INFINITY, &diff));
  PetscCall(VecNorm(grad, NORM_INFINITY, &norm));
  CHECK_MSG(diff <= 1e-13 * norm, "grad g vs s^2 (dE/dx - M a): " + std::to_string(diff / norm));

  // grad g against central differences of g.
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(PetscRandomSetSeed(rnd, 7));
  PetscCall(PetscRandomSeed(rnd));
  for (int trial = 0; trial < 3; ++trial) {
    const double eps = 1e-6;
    PetscCall(VecSetRandom(dir, rnd));
    PetscCall(VecDot(grad, dir, &analytic));
    PetscCall(VecWAXPY(xp, eps, dir, x));
    PetscCall(sc.step->objective(xp, &gp, nullptr));
    PetscCall(VecWAXPY(xp, -eps, dir, x));
    PetscCall(sc.step->objective(xp, &gm, nullptr));
    const double fd = (gp - gm) / (2 * eps);
    CHECK_MSG(std::fabs(fd - analytic) <= 1e-6 * std::fabs(analytic),
              "grad g . d " + std::to_string(analytic) + " vs FD " + std::to_string(fd));
  }

  // The end: x_{n+1} = z, v = 0, frame and time advance.
  PetscCall(VecCopy(x, state.x));
  PetscCall(sc.step->lifecycle().accept(state));
  PetscReal vmax, dx;
  PetscCall(VecNorm(state.v, NORM_INFINITY, &vmax));
  PetscCall(VecWAXPY(xp, -1.0, x, state.x));
  PetscCall(VecNorm(xp, NORM_INFINITY, &dx));
  CHECK(vmax == 0 && dx == 0 && state.frame == 1 && state.time == kDt);

  // A sub-step of h/2 keeps s (the same matrix) and has no inertia either.
  std::unique_ptr<StepObjective> sub;
  PetscCall(sc.step->create_substep(2, sub));
  CHECK(sub->solve_dt() == s && !sub->has_inertia() && sub->dt() == kDt / 2);

  PetscCall(PetscRandomDestroy(&rnd));
  for (Vec* v : {&x, &x_n, &grad, &dE, &expected, &dir, &xp}) PetscCall(VecDestroy(v));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_static());
  const int code = test_scene::tally("test_static_step");
  PetscCall(PetscFinalize());
  return code;
}

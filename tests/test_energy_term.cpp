// The recipe "Add an energy term" of docs/architecture.md, followed in a test: a uniform
// acceleration field a acting on the tets' mass, E = -sum_e (rho V_e / 4) sum_k a . x_k, whose
// force on each vertex is its lumped mass times a. Checked against finite differences of its
// energy, and as physics: with gravity 0 and a = g, a scene moves exactly as it does under
// gravity g (the two g differ by a constant), at 1 and N ranks.
#include <petscdmplex.h>

#include "check.hpp"
#include "solvers/solver_registry.hpp"
#include "terms/element_kernels.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

// 1. The term: one class implementing EnergyTerm.
class UniformAcceleration : public EnergyTerm {
 public:
  UniformAcceleration(const DistributedMesh& mesh, double density, const Vec3& a) : mesh_(mesh), density_(density), a_(a) {}
  std::string name() const override { return "uniform-acceleration"; }
  PetscErrorCode add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override {
    for (PetscInt c = 0; c < mesh_.num_cells; ++c) {
      const PetscInt* cell = &mesh_.cells[4 * c];
      const double quarter = density_ * edge_matrix(mesh_.rest.data(), cell).determinant() / 24.0;  // rho V / 4
      for (int k = 0; k < 4; ++k) {
        *energy -= quarter * a_.dot(Vec3(&pos[3 * cell[k]]));
        if (gradient) add_vertex_vector(mesh_, cell[k], -quarter * a_, gradient);
      }
    }
    return 0;
  }
  // Linear in x: no curvature, nothing in L, and PD stays exact.
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }

 private:
  const DistributedMesh& mesh_;
  double density_;
  Vec3 a_;
};

constexpr double kDensity = 7.5 / 2.0;  // the test box: mass 7.5 over a volume of 2
const Vec3 kGravity(0.0, -9.81, 0.0);

// 2. Adding it to a scene.
const test_scene::ExtraTerms kField = [](const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
  terms.push_back(std::make_unique<UniformAcceleration>(mesh, kDensity, kGravity));
};

// 3. Its gradient against central differences of its energy along a random direction.
PetscErrorCode check_gradient() {
  TestScene s;
  Vec x, grad, dir, xp;
  PetscRandom rnd;
  PetscReal f, fp, fm, analytic;
  PetscFunctionBeginUser;
  PetscCall(make_scene("corotated", true, s, {0, 0, 0}, kField));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecDuplicate(x, &xp));
  PetscCall(test_scene::deformed_positions(s, x, 0.1));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(VecSetRandom(dir, rnd));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(s.body->energy_gradient(x, &f, grad));
  PetscCall(VecDot(grad, dir, &analytic));
  const double eps = 1e-6;
  PetscCall(VecWAXPY(xp, eps, dir, x));
  PetscCall(s.body->energy_gradient(xp, &fp, nullptr));
  PetscCall(VecWAXPY(xp, -eps, dir, x));
  PetscCall(s.body->energy_gradient(xp, &fm, nullptr));
  const double fd = (fp - fm) / (2 * eps);
  CHECK_MSG(std::fabs(fd - analytic) <= 1e-6 * std::fabs(analytic), "dE/dx . d " + std::to_string(analytic) + " vs FD " + std::to_string(fd));
  // Its force is M a: the body's gradient minus the elastic one is -M a, dof by dof.
  TestScene plain;
  PetscReal residual, Ma_norm;
  PetscCall(make_scene("corotated", true, plain, {0, 0, 0}));
  PetscCall(plain.body->energy_gradient(x, &f, xp));
  PetscCall(VecAXPY(grad, -1.0, xp));                  // the field's gradient alone
  PetscCall(VecSet(dir, 0.0));
  PetscCall(VecStrideSet(dir, 1, kGravity[1]));          // a per dof (x, y, z interleaved)
  PetscCall(VecPointwiseMult(dir, s.step->mass(), dir));  // M a
  PetscCall(VecNorm(dir, NORM_INFINITY, &Ma_norm));
  PetscCall(VecAXPY(grad, 1.0, dir));
  PetscCall(VecNorm(grad, NORM_INFINITY, &residual));
  CHECK_MSG(residual <= 1e-12 * Ma_norm, "field gradient + M a: " + std::to_string(residual));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&xp));
  PetscFunctionReturn(0);
}

// 4. Physics: 10 steps of lbfgs with the field and no gravity against 10 with gravity.
PetscErrorCode run(TestScene& s, State& state) {
  FactoredSystem h0;
  std::unique_ptr<TimeStepSolver> solver;
  SolverSpec spec;
  spec.grad_rtol = 0;  // the whole budget every step, so both runs take the same iterations
  PetscFunctionBeginUser;
  PetscCall(s.step->setup());
  PetscCall(h0.setup(*s.step));
  PetscCall(create_solver(spec, *s.step, &h0, solver));
  PetscCall(state.create(s.step->layout()));
  PetscCall(s.body->rest_positions(state.x));
  for (int frame = 0; frame < 10; ++frame) {
    StepSolve step;
    PetscCall(s.step->solve_step(*solver, state, IterationCallback(), step));
    PetscCall(s.step->lifecycle().accept(state));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode check_same_motion_as_gravity() {
  TestScene with_gravity, with_field;
  State a, b;
  PetscReal diff, sag;
  Vec rest;
  PetscFunctionBeginUser;
  PetscCall(make_scene("neohookean", true, with_gravity));
  PetscCall(make_scene("neohookean", true, with_field, {0, 0, 0}, kField));
  PetscCall(run(with_gravity, a));
  PetscCall(run(with_field, b));
  PetscCall(VecDuplicate(a.x, &rest));
  PetscCall(with_gravity.body->rest_positions(rest));
  PetscCall(VecAXPY(rest, -1.0, a.x));
  PetscCall(VecNorm(rest, NORM_INFINITY, &sag));
  PetscCall(VecAXPY(b.x, -1.0, a.x));
  PetscCall(VecNorm(b.x, NORM_INFINITY, &diff));
  CHECK_MSG(sag > 1e-3, "the bar sags: " + std::to_string(sag));
  CHECK_MSG(diff <= 1e-10 * sag, "field vs gravity: " + std::to_string(diff) + " of a sag of " + std::to_string(sag));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "field vs gravity after 10 steps: max |x_a - x_b| = %.3e, sag %.3e\n", diff, sag));
  PetscCall(VecDestroy(&rest));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_gradient());
  PetscCall(check_same_motion_as_gravity());
  const int code = test_scene::tally("test_energy_term");
  PetscCall(PetscFinalize());
  return code;
}

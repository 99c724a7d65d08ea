// The loads (terms/load_kind.hpp, model/load_kinds.hpp) on the test box (2 x 1 x 1, 4 x 2 x 2
// cubes, fixed at x = 0): each kind's gradient against finite differences of its energy and its
// Hessian against finite differences of its gradient, and what each must add up to: a traction's
// and a force's total is the deck's, a body force's gradient is -M a, a pressure on the whole closed surface has the energy p V(x)
// (V the body's deformed volume), and on one end face (open) it pushes with p times the face's
// area vector at the step's start. At 1 and 2 ranks (the same faces and totals).
#include <petscdmplex.h>

#include "check.hpp"
#include "model/load_kinds.hpp"
#include "terms/element_kernels.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

LoadSpec load(const std::string& type, Array3 min, Array3 max) {
  LoadSpec l;
  l.type = type;
  l.min = min;
  l.max = max;
  return l;
}
const Array3 kEndMin{2, -0.1, -0.1}, kEndMax{2, 1.1, 1.1};      // the free end x = 2
const Array3 kAllMin{-0.1, -0.1, -0.1}, kAllMax{2.1, 1.1, 1.1};  // the whole box

test_scene::ExtraTerms with_loads(const std::vector<LoadSpec>& loads) {
  return [loads](const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
    for (auto& t : load_terms(mesh, loads)) terms.push_back(std::move(t));
  };
}

// The loads' own energy and gradient at x: the scene's minus the same scene without them.
PetscErrorCode load_part(TestScene& with, TestScene& without, Vec x, double* E, Vec grad) {
  double E0;
  Vec g0;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(grad, &g0));
  PetscCall(with.body->energy_gradient(x, E, grad));
  PetscCall(without.body->energy_gradient(x, &E0, g0));
  *E -= E0;
  PetscCall(VecAXPY(grad, -1.0, g0));
  PetscCall(VecDestroy(&g0));
  PetscFunctionReturn(0);
}

// The sum of -grad's components along each axis: the loads' total force on the free vertices.
PetscErrorCode total_force(Vec grad, Vec3& f) {
  PetscFunctionBeginUser;
  for (int d = 0; d < 3; ++d) {
    PetscScalar s;
    PetscCall(VecStrideSum(grad, d, &s));
    f[d] = -s;
  }
  PetscFunctionReturn(0);
}

// The deformed volume of the tets, over all ranks.
double volume(const TestScene& s, const std::vector<double>& pos) {
  double local = 0, total = 0;
  for (PetscInt c = 0; c < s.mesh.num_cells; ++c) local += edge_matrix(pos.data(), &s.mesh.cells[4 * c]).determinant() / 6;
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  return total;
}

// FD of the energy (gradient) and of the gradient (Hessian, exact and psd-free) of the loads' scene at x.
PetscErrorCode check_derivatives(TestScene& s, Vec x, const std::string& what) {
  Vec grad;
  Mat K;
  PetscRandom rnd;
  double E, worst;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(s.body->energy_gradient(x, &E, grad));
  const int before = check::failures();
  PetscCall(test_scene::check_gradient(*s.body, x, grad, rnd));
  PetscCall(test_scene::stiffness(s, x, false, &K));
  PetscCall(test_scene::fd_error(K, x, [&](Vec y, Vec g) {
    double e;
    return s.body->energy_gradient(y, &e, g);
  }, rnd, &worst));
  CHECK_MSG(worst < 1e-6, what + ": Hessian against FD of the gradient " + std::to_string(worst));
  CHECK_MSG(check::failures() == before, what + ": derivatives");
  PetscCall(MatDestroy(&K));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VecDestroy(&grad));
  PetscFunctionReturn(0);
}

PetscErrorCode check_loads() {
  TestScene plain;
  Vec x, grad;
  std::vector<double> pos;
  PetscFunctionBeginUser;
  PetscCall(make_scene("neohookean", true, plain, {0, 0, 0}));
  PetscCall(VecDuplicate(plain.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(test_scene::deformed_positions(plain, x, 0.1));
  PetscCall(plain.body->local_positions(x, pos));

  {  // a traction on the end face (area 1): its total is the traction, however the face deforms
    LoadSpec l = load("traction", kEndMin, kEndMax);
    l.vectors["traction"] = {3.0, -2.0, 0.5};
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    double E;
    Vec3 f;
    PetscCall(load_part(s, plain, x, &E, grad));
    PetscCall(total_force(grad, f));
    CHECK_MSG((f - Vec3(3.0, -2.0, 0.5)).norm() < 1e-13, "traction's total " + std::to_string(f[0]));
    CHECK_MSG(s.body->terms().back()->describe().find("8 boundary faces") != std::string::npos,
              s.body->terms().back()->describe());
    PetscCall(check_derivatives(s, x, "traction"));
  }
  {  // a force on the end's vertices: shared equally, its total the deck's
    LoadSpec l = load("force", kEndMin, kEndMax);
    l.vectors["force"] = {0.0, -4.0, 1.0};
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    double E;
    Vec3 f;
    PetscCall(load_part(s, plain, x, &E, grad));
    PetscCall(total_force(grad, f));
    CHECK_MSG((f - Vec3(0.0, -4.0, 1.0)).norm() < 1e-13, "force's total");
    CHECK_MSG(s.body->terms().back()->describe().find("9 free vertices") != std::string::npos,
              s.body->terms().back()->describe());
  }
  {  // a body force on the whole box: -M a per free dof, as gravity's weight
    LoadSpec l = load("body_force", kAllMin, kAllMax);
    l.vectors["acceleration"] = {0.5, -9.81, 2.0};
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    double E;
    Vec Ma;
    PetscReal residual, scale;
    PetscCall(load_part(s, plain, x, &E, grad));
    PetscCall(VecDuplicate(x, &Ma));
    for (int d = 0; d < 3; ++d) PetscCall(VecStrideSet(Ma, d, l.vectors["acceleration"][d]));
    PetscCall(VecPointwiseMult(Ma, s.step->mass(), Ma));
    PetscCall(VecNorm(Ma, NORM_INFINITY, &scale));
    PetscCall(VecAXPY(grad, 1.0, Ma));
    PetscCall(VecNorm(grad, NORM_INFINITY, &residual));
    CHECK_MSG(residual <= 1e-14 * scale, "body force: gradient + M a = " + std::to_string(residual));
    PetscCall(VecDestroy(&Ma));
  }
  {  // a pressure on the whole (closed) surface: E = p V(x)
    LoadSpec l = load("pressure", kAllMin, kAllMax);
    l.numbers["pressure"] = 7.0;
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    double E;
    PetscCall(load_part(s, plain, x, &E, grad));
    const double V = volume(s, pos);
    CHECK_MSG(std::fabs(E - 7.0 * V) <= 1e-12 * 7.0 * V, "closed surface: E = p V, " + std::to_string(E) + " vs " +
                                                                 std::to_string(7.0 * V));
    CHECK_MSG(s.body->terms().back()->describe().find("80 boundary faces, closed") != std::string::npos,
              s.body->terms().back()->describe());
    PetscCall(check_derivatives(s, x, "pressure, closed"));
  }
  {  // a pressure on the end face (open): a step from rest pushes with -p n A, n = +x, A = 1,
     // wherever x goes within the step
    LoadSpec l = load("pressure", kEndMin, kEndMax);
    l.numbers["pressure"] = 5.0;
    l.normal = {1, 0, 0};
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    CHECK_MSG(s.body->terms().back()->describe().find("8 boundary faces, open") != std::string::npos,
              s.body->terms().back()->describe());
    double E;
    Vec3 f;
    Vec rest, v;
    PetscCall(VecDuplicate(x, &rest));
    PetscCall(VecDuplicate(x, &v));
    PetscCall(VecSet(v, 0.0));
    PetscCall(s.body->rest_positions(rest));
    PetscCall(test_scene::set_inertial_target(s, rest, v));
    PetscCall(load_part(s, plain, x, &E, grad));
    PetscCall(total_force(grad, f));
    CHECK_MSG((f - Vec3(-5.0, 0, 0)).norm() < 1e-12, "end face: -p n A, " + std::to_string(f[0]));
    PetscCall(check_derivatives(s, x, "pressure, open"));
    PetscCall(VecDestroy(&rest));
    PetscCall(VecDestroy(&v));
  }
  {  // a normal that no face of the box has: nothing selected, and the term says so at the start
    LoadSpec l = load("traction", kAllMin, kAllMax);
    l.vectors["traction"] = {1, 0, 0};
    l.normal = {1, 1, 0};
    l.angle = 10;
    l.line = 12;
    TestScene s;
    PetscCall(make_scene("neohookean", true, s, {0, 0, 0}, with_loads({l})));
    InputProblem problem;
    PetscCall(s.body->terms().back()->check_start(pos, problem));
    CHECK_MSG(problem.line == 12 && problem.key == "loads[0].box" && problem.what.find("selects no boundary face") == 0,
              problem.what);
  }
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_loads());
  const int code = test_scene::tally("test_loads");
  PetscCall(PetscFinalize());
  return code;
}

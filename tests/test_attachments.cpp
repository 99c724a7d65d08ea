// The attachments term (terms/attachments.hpp) at 1 or N ranks, on the test box with its x = 0 end
// fixed and springs on the 18 vertices of x >= 1.5 (two attachments: one still, one moving):
// energy and gradient against central differences, the Hessian against differences of the
// gradient, and its L equal to the Hessian with k per vertex counted once over the ranks (ghosts
// carry no spring), in both layouts of A.
#include <petscdmplex.h>

#include "check.hpp"
#include "model/elastic_terms.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

constexpr double kStill = 50.0, kMoving = 20.0;  // N/m per vertex
constexpr int kAttached = 18;                    // vertices of the test box at x = 1.5 and x = 2

std::vector<AttachmentSpec> attachments() {
  AttachmentSpec still, moving;
  still.region.min = {1.49, -0.1, -0.1};
  still.region.max = {1.51, 1.1, 1.1};
  still.stiffness = kStill;
  moving.region.min = {1.99, -0.1, -0.1};
  moving.region.max = {2.01, 1.1, 1.1};
  moving.stiffness = kMoving;
  moving.region.motion.active = true;
  moving.region.motion.axis = {1, 0, 0};
  moving.region.motion.center = {0, 0.5, 0.5};
  moving.region.motion.rate_deg = 90;
  moving.region.motion.velocity = {0.3, -0.2, 0.1};
  return {still, moving};
}

// The body of the attachments alone on the test scene's mesh.
std::unique_ptr<Body> attachments_only(const TestScene& s) {
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  terms.push_back(attachment_term(s.mesh, attachments(), {}));
  return std::make_unique<Body>(s.mesh, std::move(terms));
}

PetscErrorCode assembled(Mat A) {
  PetscFunctionBeginUser;
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

// Sum of all entries of A (over all ranks).
PetscErrorCode entry_sum(Mat A, double* sum) {
  Vec ones, Aones;
  PetscFunctionBeginUser;
  PetscCall(MatCreateVecs(A, &ones, &Aones));
  PetscCall(VecSet(ones, 1.0));
  PetscCall(MatMult(A, ones, Aones));
  PetscCall(VecSum(Aones, sum));
  PetscCall(VecDestroy(&ones));
  PetscCall(VecDestroy(&Aones));
  PetscFunctionReturn(0);
}

PetscErrorCode check_derivatives() {
  TestScene s;
  Vec x, grad, dir, xp;
  Mat K, L, L1;
  PetscRandom rnd;
  PetscReal E, Ep, Em, analytic, err_K, diff, knorm;
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("corotated", true, s));
  std::unique_ptr<Body> body = attachments_only(s);
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecDuplicate(x, &xp));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));

  // At the rest shape and t = 0 every spring is at its target.
  PetscCall(body->rest_positions(x));
  PetscCall(body->energy_gradient(x, &E, grad));
  CHECK_MSG(E == 0, "energy at the targets " + std::to_string(E));

  // Targets moved (t = 0.4), positions deformed: E > 0, and its derivatives.
  PetscCall(body->begin_step({0.4, 0.05, x, x}));
  PetscCall(test_scene::deformed_positions(s, x, 0.2));
  PetscCall(body->energy_gradient(x, &E, grad));
  CHECK_MSG(E > 1.0, "energy away from the moved targets " + std::to_string(E));
  PetscCall(VecSetRandom(dir, rnd));
  PetscCall(VecDot(grad, dir, &analytic));
  const double eps = 1e-6;
  PetscCall(VecWAXPY(xp, eps, dir, x));
  PetscCall(body->energy_gradient(xp, &Ep, nullptr));
  PetscCall(VecWAXPY(xp, -eps, dir, x));
  PetscCall(body->energy_gradient(xp, &Em, nullptr));
  const double fd = (Ep - Em) / (2 * eps);
  CHECK_MSG(std::fabs(fd - analytic) <= 1e-7 * std::fabs(analytic),
            "dE/dx . d " + std::to_string(analytic) + " vs FD " + std::to_string(fd));

  PetscCall(s.step->create_hessian(&K));
  PetscCall(MatZeroEntries(K));
  PetscCall(body->add_hessian(x, K, 1.0, false));
  PetscCall(assembled(K));
  PetscCall(test_scene::fd_error(K, x, [&](Vec at, Vec g) { PetscReal e; return body->energy_gradient(at, &e, g); },
                                 rnd, &err_K));
  CHECK_MSG(err_K <= 1e-7, "K d vs FD, relative error " + std::to_string(err_K));

  // L = K, and k per attached vertex once over the ranks, in the dof and the vertex layout.
  PetscCall(MatDuplicate(K, MAT_DO_NOT_COPY_VALUES, &L));
  PetscCall(MatZeroEntries(L));
  PetscCall(body->add_laplacian(L, 1.0, 3));
  PetscCall(assembled(L));
  PetscCall(MatAXPY(L, -1.0, K, SAME_NONZERO_PATTERN));
  PetscCall(MatNorm(L, NORM_INFINITY, &diff));
  PetscCall(MatNorm(K, NORM_INFINITY, &knorm));
  CHECK_MSG(diff == 0 && knorm == kStill, "L - K " + std::to_string(diff) + ", |K| " + std::to_string(knorm));
  const double per_vertex = 0.5 * kAttached * (kStill + kMoving);  // half the vertices in each box
  double sum;
  PetscCall(entry_sum(K, &sum));
  CHECK_MSG(std::fabs(sum - 3 * per_vertex) <= 1e-12 * sum, "sum of K " + std::to_string(sum));
  PetscCall(DMCreateMatrix(s.mesh.vertex_dm, &L1));
  PetscCall(body->add_laplacian(L1, 1.0, 1));
  PetscCall(assembled(L1));
  PetscCall(entry_sum(L1, &sum));
  CHECK_MSG(std::fabs(sum - per_vertex) <= 1e-12 * sum, "sum of L in the vertex layout " + std::to_string(sum));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "attachments: E = %.6g, FD errors: gradient %.2e, Hessian %.2e\n", E,
                        std::fabs(fd - analytic) / std::fabs(analytic), err_K));

  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&L));
  PetscCall(MatDestroy(&L1));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&xp));
  PetscFunctionReturn(0);
}

// A vertex both fixed and in an attachment box is left to the fixed region; a released
// attachment has no spring.
PetscErrorCode check_fixed_and_released() {
  TestScene s;
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("corotated", true, s));
  AttachmentSpec at_fixed_end;
  at_fixed_end.region.min = {-0.1, -0.1, -0.1};
  at_fixed_end.region.max = {0.6, 1.1, 1.1};  // x = 0 (fixed) and x = 0.5 (free): 9 free vertices
  at_fixed_end.stiffness = 1.0;
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  terms.push_back(attachment_term(s.mesh, {at_fixed_end}, {}));
  Body body(s.mesh, std::move(terms));
  Mat L;
  double sum;
  PetscCall(DMCreateMatrix(s.mesh.vertex_dm, &L));
  PetscCall(body.add_laplacian(L, 1.0, 1));
  PetscCall(assembled(L));
  PetscCall(entry_sum(L, &sum));
  CHECK_MSG(sum == 9.0, "springs on the free vertices only: sum of L " + std::to_string(sum));
  PetscCall(MatDestroy(&L));
  CHECK(attachment_term(s.mesh, {at_fixed_end}, {1}) == nullptr);
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_derivatives());
  PetscCall(check_fixed_and_released());
  const int code = test_scene::tally("test_attachments");
  PetscCall(PetscFinalize());
  return code;
}

// The assembled Hessian at 1 or N ranks: the exact K(x) = d^2E/dx^2 and H = M + h^2 K against
// central differences of the assembled gradients, symmetry, and the per-element PSD fix (K stays
// PSD, and changes nothing at the rest pose where dP/dF is already PSD).
#include <petscdmplex.h>

#include <functional>

#include "check.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;
using test_scene::deformed_positions;
using test_scene::make_scene;
using test_scene::fd_error;

enum class Pose { rest, scaled, general, inverted };
const char* pose_name(Pose p) {
  switch (p) {
    case Pose::rest: return "rest";
    case Pose::scaled: return "scaled 1.2";
    case Pose::general: return "general";
    default: return "inverted";
  }
}

// Folds the last column of cubes (rest x in [1.5, 2]) back over itself: x -= 1.5 (X - 1.5) there,
// so those tets get F_xx ~ -0.5, inverted but far from degenerate.
PetscErrorCode fold_end(const TestScene& s, Vec x) {
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
  PetscCall(DMGlobalToLocal(s.mesh.dm, x, INSERT_VALUES, xl));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v) {
    const double X = s.mesh.rest[3 * v];
    if (s.mesh.local_dof[v] >= 0 && X > 1.5) a[s.mesh.local_dof[v]] -= 1.5 * (X - 1.5);
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
  PetscFunctionReturn(0);
}

// Positions for a pose; the scaled pose has no fixed vertices (so every F is 1.2 I).
PetscErrorCode pose_positions(const TestScene& s, Pose pose, Vec x) {
  PetscFunctionBeginUser;
  PetscCall(s.body->rest_positions(x));
  if (pose == Pose::scaled) PetscCall(VecScale(x, 1.2));
  if (pose == Pose::general || pose == Pose::inverted) PetscCall(deformed_positions(s, x, 0.3));
  if (pose == Pose::inverted) PetscCall(fold_end(s, x));
  PetscFunctionReturn(0);
}

// Number of inverted tets (det F < 0) over all ranks.
PetscErrorCode count_inverted(const TestScene& s, Vec x, int* count) {
  std::vector<double> pos, J;
  PetscFunctionBeginUser;
  PetscCall(s.body->local_positions(x, pos));
  s.body->cell_jacobians(pos, J);
  int local = 0;
  for (double j : J) local += j < 0;
  PetscCallMPI(MPI_Allreduce(&local, count, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD));
  PetscFunctionReturn(0);
}

// Number of negative eigenvalues of K + shift I (MUMPS LDL^T inertia).
PetscErrorCode negative_eigenvalues(Mat K, double shift, PetscInt* count) {
  Mat A, F;
  MatFactorInfo info;
  PetscFunctionBeginUser;
  PetscCall(MatDuplicate(K, MAT_COPY_VALUES, &A));
  PetscCall(MatShift(A, shift));
  PetscCall(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatGetFactor(A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatCholeskyFactorSymbolic(F, A, nullptr, &info));
  PetscCall(MatCholeskyFactorNumeric(F, A, &info));
  PetscCall(MatMumpsGetInfog(F, 12, count));
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

PetscErrorCode check_pose(const std::string& model, Pose pose, PetscRandom rnd) {
  TestScene s;
  Vec x, v;
  Mat K, Kpsd, H;
  PetscReal knorm, diff_norm;
  PetscBool symmetric, spd_set, spd;
  int inverted;
  double err_K, err_H;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, pose != Pose::scaled, s));
  const std::string what = model + ", " + pose_name(pose) + ": ";
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &v));
  PetscCall(pose_positions(s, pose, x));
  PetscCall(count_inverted(s, x, &inverted));
  if (pose == Pose::inverted) CHECK_MSG(inverted > 0, what + "no inverted tet");
  else CHECK_MSG(inverted == 0, what + std::to_string(inverted) + " inverted tets");

  // Exact K against differences of the assembled dE/dx.
  PetscCall(test_scene::stiffness(s, x, false, &K));
  PetscCall(fd_error(K, x, [&](Vec at, Vec g) { PetscReal E; return s.body->energy_gradient(at, &E, g); }, rnd, &err_K));
  CHECK_MSG(err_K <= 1e-6, what + "K d vs FD, relative error " + std::to_string(err_K));
  PetscCall(MatNorm(K, NORM_INFINITY, &knorm));
  PetscCall(MatIsSymmetric(K, 1e-14 * knorm, &symmetric));
  CHECK_MSG(symmetric, what + "K symmetric");

  // Exact H = M + h^2 K against differences of grad g (with a nonzero inertial target).
  PetscCall(VecSetRandom(v, rnd));
  PetscCall(set_inertial_target(s, x, v));
  PetscCall(s.step->create_hessian(&H));
  PetscCall(s.step->assemble_hessian(x, H, true));
  PetscCall(fd_error(H, x, [&](Vec at, Vec g) { PetscReal f; return s.step->objective(at, &f, g); }, rnd, &err_H));
  CHECK_MSG(err_H <= 1e-6, what + "H d vs FD, relative error " + std::to_string(err_H));

  // PSD fix: d^T K d >= 0 up to round-off; no change at rest, a real change when inverted.
  PetscCall(test_scene::stiffness(s, x, true, &Kpsd));
  PetscCall(MatIsSymmetric(Kpsd, 1e-14 * knorm, &symmetric));
  CHECK_MSG(symmetric, what + "projected K symmetric");
  double min_curvature = HUGE_VAL;
  for (int trial = 0; trial < 20; ++trial) {
    PetscReal dKd, dd;
    PetscCall(VecSetRandom(v, rnd));
    PetscCall(MatMult(Kpsd, v, x));  // x is no longer needed as a pose
    PetscCall(VecDot(x, v, &dKd));
    PetscCall(VecDot(v, v, &dd));
    min_curvature = std::fmin(min_curvature, dKd / (knorm * dd));
  }
  CHECK_MSG(min_curvature >= -1e-12, what + "projected d^T K d / (|K| |d|^2) = " + std::to_string(min_curvature));
  // Stronger than random directions: the inertia. Shifted by 1e-10 |K| so that K's exact zero
  // modes (rotations at rest, clamped eigenvalues) do not show up as round-off-signed pivots.
  PetscInt negative_psd, negative_exact;
  PetscCall(negative_eigenvalues(Kpsd, 1e-10 * knorm, &negative_psd));
  PetscCall(negative_eigenvalues(K, 1e-10 * knorm, &negative_exact));
  CHECK_MSG(negative_psd == 0, what + "projected K has " + std::to_string(negative_psd) + " negative eigenvalues");
  if (pose == Pose::inverted) CHECK_MSG(negative_exact > 0, what + "exact K is not indefinite: the fix is untested");
  PetscCall(MatAXPY(Kpsd, -1.0, K, SAME_NONZERO_PATTERN));
  PetscCall(MatNorm(Kpsd, NORM_INFINITY, &diff_norm));
  if (pose == Pose::rest) CHECK_MSG(diff_norm <= 1e-12 * knorm, what + "projection changed K by " + std::to_string(diff_norm / knorm));
  if (pose == Pose::inverted) CHECK_MSG(diff_norm >= 1e-3 * knorm, what + "projection did nothing");

  // Reassembly keeps the pattern and the flags the Cholesky solver relies on.
  PetscCall(pose_positions(s, pose, x));
  for (int again = 0; again < 2; ++again) {
    PetscCall(s.step->assemble_hessian(x, H));
    PetscCall(MatIsSPDKnown(H, &spd_set, &spd));
    CHECK_MSG(spd_set && spd, what + "H flagged SPD after reassembly");
  }
  PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                        "%-22s inverted tets %2d  |Kd-FD|/|FD| %.1e  |Hd-FD|/|FD| %.1e  min d'Kd/(|K||d|^2) %+.1e  "
                        "|Kpsd-K|/|K| %.1e  negative eigenvalues: exact K %d, projected %d\n",
                        (model + " " + pose_name(pose)).c_str(), inverted, err_K, err_H, min_curvature, diff_norm / knorm,
                        (int)negative_exact, (int)negative_psd));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&Kpsd));
  PetscCall(MatDestroy(&H));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&v));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscRandom rnd;
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  // "+strands": strand segments (axial springs) in the same body, their Hessian blocks and PSD fix.
  for (const char* model : {"corotated", "neohookean", "neohookean+strands"})
    for (Pose pose : {Pose::rest, Pose::scaled, Pose::general, Pose::inverted}) PetscCall(check_pose(model, pose, rnd));
  PetscCall(PetscRandomDestroy(&rnd));
  const int code = test_scene::tally("test_hessian");  // every rank agrees on the outcome
  PetscCall(PetscFinalize());
  return code;
}

// The distributed building blocks at 1 or N ranks: lumped mass, L, A = M + h^2 L, the rest
// stiffness A = M + h^2 K(x_rest) against finite differences of grad g at rest, and the assembled
// energy gradient against finite differences of the assembled energy; the factored systems and the
// AMG V-cycle of solver.h0: amg.
#include <algorithm>
#include <cstring>
#include <functional>
#include <petscdmplex.h>

#include "check.hpp"
#include "solvers/contact_h0.hpp"
#include "mesh/vertex_matrix.hpp"
#include "solvers/factored_system.hpp"
#include "terms/continuum_tets.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;
using test_scene::deformed_positions;
using test_scene::make_scene;

PetscErrorCode check_mass_and_laplacian(const std::string& model) {
  TestScene s;
  Mat A;
  Vec ones, Aones;
  PetscReal mass_sum, residual, anorm;
  PetscBool symmetric;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, false, s));
  // Lumped mass: each dof carries its vertex's mass, so the sum is 3 x total mass.
  PetscCall(VecSum(s.step->mass(), &mass_sum));
  const double mass = test_scene::expected_mass(model);
  CHECK_NEAR(mass_sum / 3.0, mass, 1e-12 * mass);
  CHECK_NEAR(s.body->total_mass(), mass, 1e-12 * mass);

  // Without fixed vertices, (A - M) 1 = h^2 L 1 = 0: L's rows sum to zero.
  PetscCall(s.step->assemble_constant_matrix(&A));
  PetscCall(MatCreateVecs(A, &ones, &Aones));
  PetscCall(VecSet(ones, 1.0));
  PetscCall(MatMult(A, ones, Aones));
  PetscCall(VecAXPY(Aones, -1.0, s.step->mass()));
  PetscCall(VecNorm(Aones, NORM_INFINITY, &residual));
  PetscCall(MatNorm(A, NORM_INFINITY, &anorm));
  CHECK_MSG(residual <= 1e-13 * anorm, model + ": L row sums " + std::to_string(residual));
  PetscCall(MatIsSymmetric(A, 1e-14, &symmetric));
  CHECK_MSG(symmetric, model + ": A symmetric");
  PetscCall(VecDestroy(&ones));
  PetscCall(VecDestroy(&Aones));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// A with fixed vertices eliminated is SPD: MUMPS LDL^T finds no negative and no null pivot.
PetscErrorCode check_spd(const std::string& model, ConstantMatrix kind) {
  TestScene s;
  Mat A, F;
  MatFactorInfo info;
  PetscInt negative, null_pivots;
  PetscBool symmetric;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, true, s));
  PetscCall(s.step->assemble_constant_matrix(&A, 3, kind));
  PetscCall(MatIsSymmetric(A, 1e-14, &symmetric));
  CHECK_MSG(symmetric, model + ": A symmetric");
  PetscCall(MatSetOption(A, MAT_SPD, PETSC_FALSE));  // LDL^T, so the inertia is counted
  PetscCall(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatGetFactor(A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F));
  PetscCall(MatMumpsSetIcntl(F, 24, 1));  // detect null pivots
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatCholeskyFactorSymbolic(F, A, nullptr, &info));
  PetscCall(MatCholeskyFactorNumeric(F, A, &info));
  PetscCall(MatMumpsGetInfog(F, 12, &negative));
  PetscCall(MatMumpsGetInfog(F, 28, &null_pivots));
  CHECK_MSG(negative == 0, model + ": negative pivots: " + std::to_string(negative));
  CHECK_MSG(null_pivots == 0, model + ": null pivots: " + std::to_string(null_pivots));
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// Directional derivative of the assembled E and g against central differences.
PetscErrorCode check_gradients(const std::string& model, double amplitude) {
  TestScene s;
  Vec x, grad, dir, xp;
  PetscRandom rnd;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, true, s));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecDuplicate(x, &xp));
  PetscCall(deformed_positions(s, x, amplitude));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(VecSetRandom(dir, rnd));
  PetscCall(PetscRandomDestroy(&rnd));

  // Inertial target from a nonzero velocity, so both parts of g are exercised.
  PetscCall(set_inertial_target(s, x, dir));
  for (int which = 0; which < 2; ++which) {
    auto eval = [&](Vec at, PetscReal* f, Vec g) -> PetscErrorCode {
      return which == 0 ? s.body->energy_gradient(at, f, g) : s.step->objective(at, f, g);
    };
    PetscReal f, fp, fm, analytic;
    PetscCall(eval(x, &f, grad));
    PetscCall(VecDot(grad, dir, &analytic));
    const double eps = 1e-6;
    PetscCall(VecWAXPY(xp, eps, dir, x));
    PetscCall(eval(xp, &fp, nullptr));
    PetscCall(VecWAXPY(xp, -eps, dir, x));
    PetscCall(eval(xp, &fm, nullptr));
    const double fd = (fp - fm) / (2 * eps);
    const double err = std::fabs(fd - analytic) / std::fmax(1e-8, std::fabs(analytic));
    CHECK_MSG(err < 1e-6, model + (which ? " g" : " E") + " amplitude " + std::to_string(amplitude) +
                              ": directional derivative " + std::to_string(analytic) + " vs FD " + std::to_string(fd));
  }
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&xp));
  PetscFunctionReturn(0);
}

// The rest stiffness A = M + h^2 K(x_rest) is the Hessian of g at rest: A d equals
// (grad g(x_rest + eps d) - grad g(x_rest - eps d)) / (2 eps) for random d. (The per-element PSD
// fix changes nothing there: dP/dF(I) is PSD for these materials.)
PetscErrorCode check_rest_stiffness(const std::string& model) {
  TestScene s;
  Mat A;
  Vec x, v;
  PetscRandom rnd;
  double worst;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, true, s));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &v));
  PetscCall(s.body->rest_positions(x));
  PetscCall(VecSet(v, 0.0));
  PetscCall(test_scene::set_inertial_target(s, x, v));
  PetscCall(s.step->assemble_constant_matrix(&A, 3, ConstantMatrix::rest_stiffness));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  const test_scene::Gradient grad_g = [&s](Vec y, Vec grad) {
    PetscReal g;
    return s.step->objective(y, &g, grad);
  };
  PetscCall(test_scene::fd_error(A, x, grad_g, rnd, &worst));
  CHECK_MSG(worst <= 1e-7, model + ": |A d - FD| / |FD| = " + std::to_string(worst));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&v));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// h0: volumetric on a free box (no fixed vertex, mu = 3, lambda = 5 as in make_scene, h = 0.05):
// u^T (A - M) u = h^2 V (mu |grad u|^2 + c (lambda + mu) (div u)^2) for affine u, c its
// volumetric share: a dilation u = x (|grad u|^2 = 3, div u = 3), a rotation u = (-y, x, 0)
// (2, 0: only the shear part, rotation invariant), and a translation (0: A u = M u).
PetscErrorCode check_volumetric_h0(const std::string& model) {
  TestScene s;
  Mat A;
  Vec X, u, Au;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, false, s));
  PetscCall(s.step->assemble_constant_matrix(&A, 3, ConstantMatrix::volumetric));
  PetscCall(VecDuplicate(s.step->layout(), &X));
  PetscCall(VecDuplicate(X, &u));
  PetscCall(VecDuplicate(X, &Au));
  PetscCall(s.body->rest_positions(X));
  const double mu = 3, lambda = 5, h = 0.05, V = 2.0, c = ContinuumTets::kVolumetricShare;
  struct Field {
    const char* name;
    std::function<Vec3(const Vec3&)> u;
    double expected;
  };
  const Field fields[] = {{"dilation", [](const Vec3& x) { return x; }, h * h * V * (3 * mu + 9 * c * (lambda + mu))},
                          {"rotation", [](const Vec3& x) { return Vec3(-x[1], x[0], 0); }, h * h * V * 2 * mu},
                          {"translation", [](const Vec3&) { return Vec3(0.3, -0.2, 0.7); }, 0.0}};
  for (const Field& f : fields) {
    const PetscScalar* x;
    const PetscScalar* m;
    PetscScalar* a;
    PetscInt n;
    double local[2] = {0, 0}, uMu[2];
    PetscCall(VecGetLocalSize(X, &n));
    PetscCall(VecGetArrayRead(X, &x));
    PetscCall(VecGetArrayRead(s.step->mass(), &m));
    PetscCall(VecGetArray(u, &a));
    for (PetscInt i = 0; i < n; i += 3) {
      const Vec3 v = f.u(Vec3(x[i], x[i + 1], x[i + 2]));
      for (int d = 0; d < 3; ++d) {
        a[i + d] = v[d];
        local[0] += m[i + d] * v[d] * v[d];
      }
    }
    PetscCall(VecRestoreArray(u, &a));
    PetscCall(VecRestoreArrayRead(s.step->mass(), &m));
    PetscCall(VecRestoreArrayRead(X, &x));
    PetscCallMPI(MPI_Allreduce(local, uMu, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD));
    PetscReal uAu;
    PetscCall(MatMult(A, u, Au));
    PetscCall(VecDot(u, Au, &uAu));
    const double stiffness = uAu - uMu[0];
    CHECK_MSG(std::fabs(stiffness - f.expected) <= 1e-10 * (uAu + 1e-3),
              model + " volumetric h0, " + f.name + ": u^T (A - M) u = " + std::to_string(stiffness) + ", expected " +
                  std::to_string(f.expected));
  }
  PetscCall(VecDestroy(&X));
  PetscCall(VecDestroy(&u));
  PetscCall(VecDestroy(&Au));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// At the rest shape E = 0 and dE/dx = 0.
PetscErrorCode check_rest(const std::string& model) {
  TestScene s;
  Vec x, grad;
  PetscReal E, gnorm;
  PetscFunctionBeginUser;
  PetscCall(make_scene(model, true, s));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(s.body->rest_positions(x));
  PetscCall(s.body->energy_gradient(x, &E, grad));
  PetscCall(VecNorm(grad, NORM_INFINITY, &gnorm));
  CHECK_NEAR(E, 0.0, 1e-12);
  CHECK_NEAR(gnorm, 0.0, 1e-12);
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscFunctionReturn(0);
}

}  // namespace

// The factored system works on A1 for the Laplacian (A = A1 (x) I3), on the full A for the rest
// stiffness: its solve must invert the full 3n x 3n A and its mult must equal A's. Each package
// (MUMPS, CHOLMOD, supernodal), at 1 and at N ranks (factored on rank 0); all must give the same
// A^{-1} b.
PetscErrorCode check_factored_system(const std::string& model, ConstantMatrix kind, FactorPackage package,
                                     Vec reference = nullptr) {
  TestScene s;
  Mat A;
  Vec b, x, Ax, Ab;
  PetscRandom rnd;
  PetscReal residual, bnorm, diff;
  FactoredSystem sys;
  PetscFunctionBeginUser;
  const std::string what = model + " (" + factor_package_name(package) + ")";
  PetscCall(make_scene(model, true, s));
  PetscCall(s.step->assemble_constant_matrix(&A, 3, kind));
  PetscCall(sys.setup(*s.step, kind, package));
  CHECK(sys.package() == package);
  PetscCall(MatCreateVecs(A, &b, &x));
  PetscCall(VecDuplicate(b, &Ax));
  PetscCall(VecDuplicate(b, &Ab));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetSeed(rnd, 7));
  PetscCall(PetscRandomSeed(rnd));
  PetscCall(VecSetRandom(b, rnd));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(sys.solve(b, x));
  PetscCall(MatMult(A, x, Ax));
  PetscCall(VecAXPY(Ax, -1.0, b));
  PetscCall(VecNorm(Ax, NORM_2, &residual));
  PetscCall(VecNorm(b, NORM_2, &bnorm));
  CHECK_MSG(residual <= 1e-12 * bnorm, what + ": |A A^{-1} b - b| / |b| = " + std::to_string(residual / bnorm));
  if (reference) {  // the other package's A^{-1} b for the same b
    PetscReal xnorm;
    PetscCall(VecNorm(x, NORM_2, &xnorm));
    PetscCall(VecAXPY(reference, -1.0, x));
    PetscCall(VecNorm(reference, NORM_2, &diff));
    CHECK_MSG(diff <= 1e-12 * xnorm, what + ": A^{-1} b differs from MUMPS's by " + std::to_string(diff / xnorm));
  }
  PetscCall(sys.mult(b, Ax));
  PetscCall(MatMult(A, b, Ab));
  PetscCall(VecAXPY(Ax, -1.0, Ab));
  PetscCall(VecNorm(Ax, NORM_2, &diff));
  PetscCall(VecNorm(Ab, NORM_2, &bnorm));
  CHECK_MSG(diff <= 1e-13 * bnorm, what + ": the factored system's mult differs from A");
  CHECK(sys.factorizations() == 1);
  if (package == FactorPackage::mumps) {  // the others against MUMPS's answer, each on a copy of it
    for (FactorPackage other : {FactorPackage::cholmod, FactorPackage::supernodal, FactorPackage::split}) {
      if (!factor_package_available(other)) continue;
      PetscCall(VecCopy(x, Ab));  // check_factored_system subtracts its own answer from the reference
      PetscCall(check_factored_system(model, kind, other, Ab));
    }
  }
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&Ax));
  PetscCall(VecDestroy(&Ab));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// solver.h0: amg. B, one V-cycle of A1 on each of x, y, z (distributed at N ranks), must be what
// L-BFGS takes as H0: a fixed linear operator (the same B u at every call), symmetric
// (<Bu, v> = <u, Bv> to round-off) and positive definite (<Bu, u> > 0), and, being a V-cycle of A,
// a convergent iteration: |u - B A u|_A < |u|_A; with GAMG, the interleaved cycle equal to GAMG's
// own cycle on each column. On a 24 x 12 x 12 box (4225 vertices), so that
// the hierarchy has coarse levels; with GAMG (the default) and BoomerAMG (-h0_pc_type hypre).
PetscErrorCode check_amg(const char* pc_type) {
  TestScene s;
  FactoredSystem sys;
  Mat A1;
  MatInfo info;
  Vec u, v, Bu, Bv, again, Au, e;
  PetscRandom rnd;
  PetscReal uBv, vBu, uBu, vBv, uAu, eAe;
  PetscBool same;
  PetscFunctionBeginUser;
  const std::string what = std::string("amg (") + pc_type + ")";
  PetscCall(make_scene("neohookean", true, s, {0, -9.81, 0}, nullptr, {24, 12, 12}));
  // h = 1 s, so that h^2 L dominates M as in stiff scenes: at the scene's h = 0.05 s A is nearly
  // its diagonal mass, which one smoothing step inverts.
  s.step = std::make_unique<StepObjective>(*s.body, 1.0, std::array<double, 3>{0, -9.81, 0});
  PetscCall(s.step->setup());
  PetscCall(PetscOptionsSetValue(nullptr, "-h0_pc_type", pc_type));
  PetscCall(sys.setup(*s.step, ConstantMatrix::laplacian, FactorPackage::amg));
  PetscCall(PetscOptionsClearValue(nullptr, "-h0_pc_type"));
  CHECK(sys.package() == FactorPackage::amg && sys.factorizations() == 1);
  // GAMG with its default smoothers runs the interleaved cycle; BoomerAMG one V-cycle per column.
  CHECK_MSG(sys.interleaved() == (std::string(pc_type) == "gamg"), what + ": interleaved " +
                                                                      std::to_string(sys.interleaved()));
  PetscCall(s.step->assemble_constant_matrix(&A1, 1));
  PetscCall(MatGetInfo(A1, MAT_GLOBAL_SUM, &info));
  if (std::string(pc_type) == "gamg")  // A1 and at least one coarser level (BoomerAMG's are not counted)
    CHECK_MSG(sys.factor_nonzeros() > 1.05 * info.nz_used, what + ": " + std::to_string(sys.factor_nonzeros()) +
                                                               " entries in the hierarchy, " +
                                                               std::to_string(info.nz_used) + " in A1");
  else
    CHECK(sys.factor_nonzeros() == info.nz_used);
  PetscCall(MatCreateVecs(sys.inverse_operator(), &u, nullptr));
  for (Vec* w : {&v, &Bu, &Bv, &again, &Au, &e}) PetscCall(VecDuplicate(u, w));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  for (unsigned long seed = 1; seed <= 5; ++seed) {
    PetscCall(PetscRandomSetSeed(rnd, seed));
    PetscCall(PetscRandomSeed(rnd));
    PetscCall(VecSetRandom(u, rnd));
    PetscCall(VecSetRandom(v, rnd));
    PetscCall(sys.solve(u, Bu));
    PetscCall(sys.solve(v, Bv));
    PetscCall(VecDot(u, Bv, &uBv));
    PetscCall(VecDot(v, Bu, &vBu));
    PetscCall(VecDot(u, Bu, &uBu));
    PetscCall(VecDot(v, Bv, &vBv));
    CHECK_MSG(uBu > 0 && vBv > 0, what + ": <Bu, u> = " + std::to_string(uBu));
    // Measured (first pair, printed below): at most 1.2e-16 for both AMGs at 1 and 2 ranks.
    const double asymmetry = std::fabs(uBv - vBu) / std::sqrt(uBu * vBv);
    CHECK_MSG(asymmetry <= 1e-13, what + ": <Bu, v> - <u, Bv> relative " + std::to_string(asymmetry));
    PetscCall(sys.solve(u, again));  // after another right-hand side: the same operator, bit for bit
    PetscCall(VecEqual(again, Bu, &same));
    CHECK_MSG(same, what + ": B u changed between calls");
    if (sys.interleaved()) {  // the interleaved cycle is GAMG's cycle on each column, to round-off
      PetscReal difference, size;
      PetscCall(sys.solve_by_columns(u, again));
      PetscCall(VecNorm(Bu, NORM_INFINITY, &size));
      PetscCall(VecAXPY(again, -1.0, Bu));
      PetscCall(VecNorm(again, NORM_INFINITY, &difference));
      CHECK_MSG(difference <= 1e-12 * size, what + ": interleaved and column-by-column V-cycles differ by " +
                                                std::to_string(difference / size));
      if (seed == 1) PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s: interleaved against columns %.1e\n", what.c_str(),
                                           difference / size));
    }
    PetscCall(sys.mult(u, Au));  // e = u - B A u, in A's norm
    PetscCall(sys.solve(Au, e));
    PetscCall(VecAYPX(e, -1.0, u));
    PetscCall(VecDot(u, Au, &uAu));
    PetscCall(sys.mult(e, Au));
    PetscCall(VecDot(e, Au, &eAe));
    CHECK_MSG(eAe < 0.5 * uAu, what + ": |u - B A u|_A^2 / |u|_A^2 = " + std::to_string(eAe / uAu));
    if (seed == 1) PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s: asymmetry %.1e, |u - B A u|_A^2 / |u|_A^2 = %.3g\n",
                                         what.c_str(), asymmetry, eAe / uAu));
  }
  PetscCall(PetscRandomDestroy(&rnd));
  if (std::string(pc_type) == "gamg") {  // a W-cycle is not what the interleaved cycle runs: columns
    FactoredSystem w_cycle;
    PetscCall(PetscOptionsSetValue(nullptr, "-h0_pc_mg_cycle_type", "w"));
    PetscCall(w_cycle.setup(*s.step, ConstantMatrix::laplacian, FactorPackage::amg));
    PetscCall(PetscOptionsClearValue(nullptr, "-h0_pc_mg_cycle_type"));
    CHECK_MSG(!w_cycle.interleaved(), what + ": -h0_pc_mg_cycle_type w ran the interleaved V-cycle");
  }
  for (Vec* w : {&u, &v, &Bu, &Bv, &again, &Au, &e}) PetscCall(VecDestroy(w));
  PetscCall(MatDestroy(&A1));
  PetscFunctionReturn(0);
}

// An objective that passes everything to another (the tests below change one thing each).
class ForwardingObjective : public Objective {
 public:
  explicit ForwardingObjective(Objective& o) : o_(o) {}
  Vec layout() const override { return o_.layout(); }
  PetscErrorCode objective(Vec x, PetscReal* g, Vec grad) override { return o_.objective(x, g, grad); }
  PetscInt evaluations() const override { return o_.evaluations(); }
  void reset_evaluations() override { o_.reset_evaluations(); }
  PetscInt rejected_evaluations() const override { return o_.rejected_evaluations(); }
  PetscErrorCode force_scale(Vec x, double* scale) override { return o_.force_scale(x, scale); }
  double length_scale() const override { return o_.length_scale(); }
  bool bounds_steps() const override { return o_.bounds_steps(); }
  bool has_vertex_stiffness() const override { return o_.has_vertex_stiffness(); }
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const override { return o_.limit_step(x, dir, alpha); }
  PetscErrorCode assemble_constant_matrix(Mat* A, int components, ConstantMatrix kind) const override {
    return o_.assemble_constant_matrix(A, components, kind);
  }
  PetscErrorCode create_hessian(Mat* H) const override { return o_.create_hessian(H); }
  PetscErrorCode assemble_hessian(Vec x, Mat H, bool exact) override { return o_.assemble_hessian(x, H, exact); }
  bool projective_dynamics_exact() const override { return o_.projective_dynamics_exact(); }
  std::string energy_names() const override { return o_.energy_names(); }

 protected:
  Objective& o_;
};

// The scene's objective with its constant matrix made singular (the first row and column zero):
// not positive definite, a zero pivot for LL^T and LDL^T alike.
class SingularConstantMatrix : public ForwardingObjective {
 public:
  using ForwardingObjective::ForwardingObjective;
  PetscErrorCode assemble_constant_matrix(Mat* A, int components, ConstantMatrix kind) const override {
    PetscFunctionBeginUser;
    PetscMPIInt rank;
    const PetscInt first = 0;
    PetscCall(o_.assemble_constant_matrix(A, components, kind));
    PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)*A), &rank));
    PetscCall(MatZeroRowsColumns(*A, rank == 0 ? 1 : 0, &first, 0.0, nullptr, nullptr));
    PetscFunctionReturn(0);
  }
};

// The scene's objective with given stiffness blocks on a few vertices (by global vertex number,
// whichever rank owns it): full rank, rank 2, rank 1 and zero, c times A's mean diagonal.
class GivenVertexStiffness : public ForwardingObjective {
 public:
  GivenVertexStiffness(Objective& o, double c) : ForwardingObjective(o), c_(c) {}
  double c() const { return c_; }
  void set_c(double c) { c_ = c; }
  bool has_vertex_stiffness() const override { return true; }
  PetscErrorCode vertex_stiffness(std::vector<VertexStiffness>& out, Vec = nullptr) const override {
    PetscInt lo, hi, n;
    PetscFunctionBeginUser;
    PetscCall(VecGetOwnershipRange(o_.layout(), &lo, &hi));
    PetscCall(VecGetSize(o_.layout(), &n));
    const Eigen::Vector3d u = Eigen::Vector3d(1, 2, -1).normalized(), w = Eigen::Vector3d(0, 1, 2).normalized();
    const std::vector<std::pair<PetscInt, Eigen::Matrix3d>> given = {
        {0, c_ * (Eigen::Matrix3d::Identity() + u * u.transpose())},
        {5, c_ * (u * u.transpose() + 3 * w * w.transpose())},
        {17, 4 * c_ * w * w.transpose()},
        {18, Eigen::Matrix3d::Zero()},
        {n / 3 - 1, c_ * u * u.transpose()}};
    out.clear();
    for (const auto& [vertex, K] : given) {
      if (3 * vertex < lo || 3 * vertex >= hi) continue;
      VertexStiffness s;
      s.dof = 3 * vertex;
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s.K.data()) = K;
      out.push_back(s);
    }
    PetscFunctionReturn(0);
  }

 private:
  double c_;
};

// solver.h0_contact: ContactH0's solve is (A + K_c)^{-1} against the explicitly assembled A + K_c
// (woodbury: K_c the blocks; refactor: their trace / 3, rounded to a power of 2, on the diagonal),
// and its mult is A + K_c.
PetscErrorCode check_contact_h0(H0Contact mode, FactorPackage package) {
  TestScene s;
  FactoredSystem sys;
  Mat A;
  Vec b, x, r, diag;
  PetscReal mean, residual, bnorm;
  std::vector<VertexStiffness> blocks;
  PetscFunctionBeginUser;
  const std::string what = std::string(kH0ContactNames[(int)mode]) + " (" + factor_package_name(package) + ")";
  PetscCall(make_scene("neohookean", true, s));
  PetscCall(s.step->assemble_constant_matrix(&A, 3));
  PetscCall(MatCreateVecs(A, &b, &x));
  PetscCall(VecDuplicate(b, &r));
  PetscCall(VecDuplicate(b, &diag));
  PetscCall(MatGetDiagonal(A, diag));
  PetscCall(VecSum(diag, &mean));
  PetscInt n;
  PetscCall(VecGetSize(diag, &n));
  GivenVertexStiffness step(*s.step, 10 * mean / n);
  PetscCall(sys.setup(step, ConstantMatrix::laplacian, package));
  ContactH0 h0(step, sys, mode);
  PetscCall(h0.setup());
  PetscCall(h0.update());
  CHECK_MSG(h0.vertices() == 5, what + ": " + std::to_string(h0.vertices()) + " vertices");
  // A + K_c, assembled
  PetscCall(step.vertex_stiffness(blocks));
  for (const VertexStiffness& k : blocks) {
    const PetscInt idx[3] = {k.dof, k.dof + 1, k.dof + 2};
    if (mode == H0Contact::woodbury) {
      PetscCall(MatSetValues(A, 3, idx, 3, idx, k.K.data(), ADD_VALUES));
    } else {
      const double d = rounded_mean_stiffness(k);
      for (PetscInt i : idx) PetscCall(MatSetValue(A, i, i, d, ADD_VALUES));
    }
  }
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscRandom rnd;
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetSeed(rnd, 11));
  PetscCall(PetscRandomSeed(rnd));
  PetscCall(VecSetRandom(b, rnd));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(h0.solve(b, x));
  PetscCall(MatMult(A, x, r));
  PetscCall(VecAXPY(r, -1.0, b));
  PetscCall(VecNorm(r, NORM_2, &residual));
  PetscCall(VecNorm(b, NORM_2, &bnorm));
  CHECK_MSG(residual <= 1e-10 * bnorm, what + ": |(A + K_c) H0 b - b| / |b| = " + std::to_string(residual / bnorm));
  PetscCall(h0.mult(b, x));
  PetscCall(MatMult(A, b, r));
  PetscCall(VecAXPY(r, -1.0, x));
  PetscCall(VecNorm(r, NORM_2, &residual));
  PetscCall(VecNorm(x, NORM_2, &bnorm));
  CHECK_MSG(residual <= 1e-12 * bnorm, what + ": its mult differs from A + K_c");
  // The same blocks again: no new columns, no new factorization.
  const long long solves = h0.column_solves();
  const int factorizations = h0.refactorizations();
  PetscCall(h0.update());
  CHECK(h0.column_solves() == solves && h0.refactorizations() == factorizations);
  CHECK(mode == H0Contact::woodbury ? solves == 2 : factorizations == 1);  // 5 vertices, 3 per solve
  if (mode == H0Contact::refactor) {
    // The blocks' mean eigenvalues are 4c/3 and c/3 (a factor 4 apart): moved to the middle of the
    // power of 2 they round to, then 20% stiffer, they round the same (the factor is kept); twice as
    // stiff, they do not (a new one).
    const double centred = std::exp2(std::round(std::log2(4 * step.c() / 3))) * 3 / 4;
    for (double scale : {1.0, 1.2}) {
      step.set_c(scale * centred);
      PetscCall(h0.update());
      CHECK_MSG(h0.refactorizations() == 1, what + ": refactored at " + std::to_string(scale) + " times the middle");
    }
    step.set_c(2 * centred);
    PetscCall(h0.update());
    CHECK_MSG(h0.refactorizations() == 2, what + ": twice as stiff kept the factor");
    // Every block below kNegligibleStiffness of its vertex's diagonal in A: left out, H0 is A^{-1}
    // itself (the same bits) with no factorization.
    PetscReal smallest;
    PetscCall(VecMin(diag, nullptr, &smallest));
    step.set_c(kNegligibleStiffness * smallest / 4);
    PetscCall(h0.update());
    CHECK_MSG(h0.refactorizations() == 2, what + ": negligible stiffness refactored");
    Vec y;
    PetscBool same;
    PetscCall(VecDuplicate(b, &y));
    PetscCall(h0.solve(b, x));
    PetscCall(sys.solve(b, y));
    PetscCall(VecEqual(x, y, &same));
    CHECK_MSG(same, what + ": with negligible stiffness H0 is not A^{-1}");
    PetscCall(VecDestroy(&y));
  }
  for (Vec* v : {&b, &x, &r, &diag}) PetscCall(VecDestroy(v));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// Records the first error message instead of printing a trace.
PetscErrorCode record_error(MPI_Comm, int, const char*, const char*, PetscErrorCode n, PetscErrorType type,
                            const char* message, void* ctx) {
  auto* first = static_cast<std::string*>(ctx);
  if (type == PETSC_ERROR_INITIAL && first->empty()) *first = message ? message : "";
  return n;
}

// A factorization that fails is an error that says the matrix is not positive definite, on every
// rank (the factorization runs on rank 0), for either package.
PetscErrorCode check_not_positive_definite(FactorPackage package) {
  TestScene s;
  std::string message;
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCall(make_scene("corotated", true, s));
  SingularConstantMatrix singular(*s.step);
  {
    FactoredSystem sys;
    PetscCall(PetscPushErrorHandler(record_error, &message));
    const PetscErrorCode ierr = sys.setup(singular, ConstantMatrix::laplacian, package);
    PetscCall(PetscPopErrorHandler());
    CHECK_MSG(ierr != 0, std::string(factor_package_name(package)) + ": factoring a singular A did not fail");
    if (rank == 0)
      CHECK_MSG(message.find("not positive definite") != std::string::npos &&
                    message.find(factor_package_name(package)) != std::string::npos,
                std::string(factor_package_name(package)) + ": message '" + message + "'");
  }
  PetscFunctionReturn(0);
}

// The run's counters of an integrator take in those of its sub-step integrators (the fallback
// chain's): a point rejected by a sub-step (g not finite) counts in rejected_evaluations.
PetscErrorCode check_substep_counts() {
  TestScene s;
  Vec x;
  PetscReal g;
  std::unique_ptr<StepObjective> sub;
  PetscFunctionBeginUser;
  PetscCall(make_scene("neohookean", true, s));
  PetscCall(s.step->create_substep(2, sub));
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecSet(x, NAN));
  const PetscInt before = s.step->rejected_evaluations();
  PetscCall(sub->objective(x, &g, nullptr));
  CHECK(Objective::rejected(g));
  CHECK_MSG(s.step->rejected_evaluations() == before + 1 && sub->rejected_evaluations() == before + 1,
            "a sub-step's rejected point is not in the run's count");
  PetscCall(s.step->objective(x, &g, nullptr));
  CHECK(sub->rejected_evaluations() == before + 2);
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

// One rank: create_vertex_matrix's pattern is DMCreateMatrix(vertex_dm)'s, row by row (explicit
// zeros included), and A1 assembled on it (StepObjective::pattern_from_cells, the path of a scene
// rebuilt after a cut) equals the default's bit for bit.
PetscErrorCode check_vertex_matrix(const std::string& model, bool fix_end) {
  PetscMPIInt size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  if (size > 1) PetscFunctionReturn(0);
  TestScene s;
  PetscCall(make_scene(model, fix_end, s));
  Mat plex, cells, A, B;
  PetscCall(DMCreateMatrix(s.mesh.vertex_dm, &plex));
  PetscCall(create_vertex_matrix(s.mesh, &cells));
  PetscCall(s.step->assemble_constant_matrix(&A, 1));
  s.step->pattern_from_cells();
  PetscCall(s.step->assemble_constant_matrix(&B, 1));
  PetscInt m1, m2, n1, n2;
  PetscCall(MatGetSize(plex, &m1, &n1));
  PetscCall(MatGetSize(cells, &m2, &n2));
  const std::string what = model + (fix_end ? ", fixed end" : "");
  CHECK_MSG(m1 == m2 && n1 == n2, what + ": create_vertex_matrix's size");
  long differing_rows = 0, differing_values = 0;
  for (PetscInt r = 0; r < std::min(m1, m2); ++r) {
    PetscInt c1, c2;
    const PetscInt *j1, *j2;
    PetscCall(MatGetRow(plex, r, &c1, &j1, nullptr));
    PetscCall(MatGetRow(cells, r, &c2, &j2, nullptr));
    differing_rows += c1 != c2 || !std::equal(j1, j1 + c1, j2);
    PetscCall(MatRestoreRow(cells, r, &c2, &j2, nullptr));
    PetscCall(MatRestoreRow(plex, r, &c1, &j1, nullptr));
    const PetscScalar *a, *b;
    PetscCall(MatGetRow(A, r, &c1, &j1, &a));
    PetscCall(MatGetRow(B, r, &c2, &j2, &b));
    differing_values += c1 != c2 || !std::equal(j1, j1 + c1, j2) || std::memcmp(a, b, c1 * sizeof(PetscScalar)) != 0;
    PetscCall(MatRestoreRow(B, r, &c2, &j2, &b));
    PetscCall(MatRestoreRow(A, r, &c1, &j1, &a));
  }
  CHECK_MSG(differing_rows == 0, what + ": rows of create_vertex_matrix unlike DMCreateMatrix's: " + std::to_string(differing_rows));
  CHECK_MSG(differing_values == 0, what + ": rows of A1 on the cells' pattern unlike the default's: " + std::to_string(differing_values));
  for (Mat* M : {&plex, &cells, &A, &B}) PetscCall(MatDestroy(M));
  PetscFunctionReturn(0);
}

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  // "+strands": the same box with strand segments attached and free (see test_scene.hpp).
  for (const char* model : {"corotated", "neohookean", "neohookean+strands"}) {
    PetscCall(check_mass_and_laplacian(model));
    PetscCall(check_rest(model));
    PetscCall(check_factored_system(model, ConstantMatrix::laplacian, FactorPackage::mumps));  // then the others
    PetscCall(check_factored_system(model, ConstantMatrix::rest_stiffness, FactorPackage::mumps));
    PetscCall(check_rest_stiffness(model));
    PetscCall(check_factored_system(model, ConstantMatrix::volumetric, FactorPackage::mumps));
    if (std::string(model) != "neohookean+strands") PetscCall(check_volumetric_h0(model));  // strands add their L
    PetscCall(check_gradients(model, 0.05));
    PetscCall(check_gradients(model, 0.5));  // large deformation, inverted elements likely
    PetscCall(check_spd(model, ConstantMatrix::laplacian));
    PetscCall(check_spd(model, ConstantMatrix::rest_stiffness));
    PetscCall(check_spd(model, ConstantMatrix::volumetric));
    for (bool fix_end : {false, true}) PetscCall(check_vertex_matrix(model, fix_end));
  }
  PetscCall(check_substep_counts());
  PetscCall(check_not_positive_definite(FactorPackage::mumps));
  if (factor_package_available(FactorPackage::cholmod)) PetscCall(check_not_positive_definite(FactorPackage::cholmod));
  PetscCall(check_not_positive_definite(FactorPackage::supernodal));
  PetscCall(check_not_positive_definite(FactorPackage::split));
  for (H0Contact mode : {H0Contact::woodbury, H0Contact::refactor})
    for (FactorPackage package : {FactorPackage::supernodal, FactorPackage::split, FactorPackage::mumps})
      PetscCall(check_contact_h0(mode, package));
  PetscCall(check_amg("gamg"));
  PetscCall(check_amg("hypre"));
  const int code = test_scene::tally("test_assembly");  // every rank agrees on the outcome
  PetscCall(PetscFinalize());
  return code;
}

// Cloth terms assembled at 1 or N ranks (terms/cloth_*.hpp, terms/surface_mass.hpp), on a small
// generated sheet with every stretching and bending model: the lumped mass is area x density; L's
// rows sum to zero and A = M + h^2 L is SPD once an edge is fixed; the assembled gradient and exact
// Hessian against central differences at rest, stretched, sheared, folded past 90 degrees and
// squashed to near-degenerate triangles; the PSD-fixed Hessian has no negative eigenvalue; the
// models exact in L say so; springs arranged for speed (SpringSet::arrange) give what
// they gave as added.
#include <petscdmplex.h>

#include <cmath>
#include <random>

#include "check.hpp"
#include "terms/element_kernels.hpp"  // segment_edge
#include "terms/spring_set.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

constexpr double kWidth = 1.5, kHeight = 1.0, kDensity = 0.3;

struct ClothCase {
  const char* name;
  ClothModel stretch;
  membrane::Model material;  // of the membrane
  BendingModel bending;      // not none
  bool pd_exact;
};

using membrane::Model;
const ClothCase kModels[] = {
    {"springs + bending springs", ClothModel::mass_spring, Model::stvk, BendingModel::springs, true},
    {"springs + quadratic", ClothModel::mass_spring, Model::stvk, BendingModel::quadratic, true},
    {"springs + dihedral", ClothModel::mass_spring, Model::stvk, BendingModel::dihedral, false},
    {"stvk membrane + quadratic", ClothModel::membrane, Model::stvk, BendingModel::quadratic, false},
    {"corotated membrane + dihedral", ClothModel::membrane, Model::corotated, BendingModel::dihedral, false},
    {"neohookean membrane + springs", ClothModel::membrane, Model::neohookean, BendingModel::springs, false},
};

PetscErrorCode make_cloth(const ClothCase& model, bool fix_edge, TestScene& s) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  TetMesh serial;
  std::vector<BoxRegion> boxes;
  if (fix_edge) boxes.push_back({{-0.01, -0.01, -0.01}, {0.01, 0.01, 1.01}, 0});
  if (rank == 0) {
    serial = generate_sheet({kWidth, kHeight}, {6, 5});
    clean_mesh(serial, "sheet");
  }
  const MeshPiece piece = scatter_serial_mesh(PETSC_COMM_WORLD, serial);
  const std::vector<int32_t> fixed = select_fixed_vertices(PETSC_COMM_WORLD, piece.mesh, boxes, "test");
  PetscCall(distribute_mesh(PETSC_COMM_WORLD, piece, fixed, {}, s.mesh));
  ClothSpec cloth;
  cloth.model = model.stretch;
  cloth.material = model.material;
  cloth.stretch_stiffness = 40.0;
  cloth.mu = 30.0;
  cloth.lambda = 20.0;
  cloth.bending = model.bending;
  cloth.bending_stiffness = model.bending == BendingModel::springs ? 4.0 : 0.5;
  cloth.areal_density = kDensity;
  s.body = std::make_unique<Body>(s.mesh, elastic_terms(s.mesh, {}, {}, cloth));
  s.step = std::make_unique<StepObjective>(*s.body, 0.05, std::array<double, 3>{0, -9.81, 0});
  PetscCall(s.step->setup());
  PetscFunctionReturn(0);
}

enum class Pose { rest, stretched, sheared, folded, squashed };
const char* pose_name(Pose p) {
  switch (p) {
    case Pose::rest: return "rest";
    case Pose::stretched: return "stretched";
    case Pose::sheared: return "sheared";
    case Pose::folded: return "folded 120 deg";
    default: return "squashed 1e-3";
  }
}

// Positions of a pose, the same at every rank count (noise seeded by the vertex's input id).
PetscErrorCode pose_positions(const TestScene& s, Pose pose, Vec x) {
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
  PetscCall(VecGetArray(xl, &a));
  const double angle = 2.0 * std::acos(-1.0) / 3.0;
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v) {
    const PetscInt off = s.mesh.local_dof[v];
    if (off < 0) continue;
    const double* X = &s.mesh.rest[3 * v];
    std::mt19937 gen((unsigned)s.mesh.vertex_ids[v] + 11);
    std::uniform_real_distribution<double> u(-1, 1);
    const double noise = pose == Pose::rest ? 0.0 : 0.02;
    double p[3] = {X[0], X[1], X[2]};
    if (pose == Pose::stretched) p[0] *= 1.3, p[2] *= 1.1;
    if (pose == Pose::sheared) p[0] += 0.4 * X[2];
    if (pose == Pose::folded && X[0] > 0.75) {  // the part beyond x = 0.75 turned 120 degrees about that line
      p[0] = 0.75 + (X[0] - 0.75) * std::cos(angle);
      p[1] = (X[0] - 0.75) * std::sin(angle);
    }
    if (pose == Pose::squashed) p[2] *= 1e-3;
    for (int d = 0; d < 3; ++d) a[off + d] = p[d] + noise * (pose == Pose::squashed ? 1e-3 : 1.0) * u(gen);
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
  PetscFunctionReturn(0);
}

// Number of negative and of null pivots of the symmetric A (MUMPS LDL^T inertia).
PetscErrorCode inertia(Mat A0, double shift, PetscInt* negative, PetscInt* null_pivots) {
  Mat A, F;
  MatFactorInfo info;
  PetscFunctionBeginUser;
  PetscCall(MatDuplicate(A0, MAT_COPY_VALUES, &A));
  if (shift != 0) PetscCall(MatShift(A, shift));
  PetscCall(MatSetOption(A, MAT_SPD, PETSC_FALSE));
  PetscCall(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatGetFactor(A, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F));
  PetscCall(MatMumpsSetIcntl(F, 24, 1));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatCholeskyFactorSymbolic(F, A, nullptr, &info));
  PetscCall(MatCholeskyFactorNumeric(F, A, &info));
  PetscCall(MatMumpsGetInfog(F, 12, negative));
  PetscCall(MatMumpsGetInfog(F, 28, null_pivots));
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

PetscErrorCode check_constant_matrices(const ClothCase& model) {
  const std::string what = std::string(model.name) + ": ";
  PetscFunctionBeginUser;
  {
    TestScene s;
    Mat A;
    Vec ones, Aones;
    PetscReal mass_sum, residual, anorm;
    PetscCall(make_cloth(model, false, s));
    PetscCall(VecSum(s.step->mass(), &mass_sum));
    const double mass = kWidth * kHeight * kDensity;
    CHECK_MSG(std::fabs(mass_sum / 3.0 - mass) <= 1e-12 * mass, what + "lumped mass " + std::to_string(mass_sum / 3));
    CHECK_NEAR(s.body->total_mass(), mass, 1e-12 * mass);
    CHECK_MSG(s.body->projective_dynamics_exact() == model.pd_exact, what + "projective_dynamics_exact");
    for (int components : {1, 3}) {  // (A - M) 1 = h^2 L 1 = 0
      PetscCall(s.step->assemble_constant_matrix(&A, components));
      PetscCall(MatCreateVecs(A, &ones, &Aones));
      PetscCall(VecSet(ones, 1.0));
      PetscCall(MatMult(A, ones, Aones));
      if (components == 3) {
        PetscCall(VecAXPY(Aones, -1.0, s.step->mass()));
      } else {  // the vertex layout: one mass per vertex
        const PetscScalar* m;
        PetscScalar* r;
        PetscInt n;
        PetscCall(VecGetLocalSize(Aones, &n));
        PetscCall(VecGetArrayRead(s.step->mass(), &m));
        PetscCall(VecGetArray(Aones, &r));
        for (PetscInt i = 0; i < n; ++i) r[i] -= m[3 * i];
        PetscCall(VecRestoreArray(Aones, &r));
        PetscCall(VecRestoreArrayRead(s.step->mass(), &m));
      }
      PetscCall(VecNorm(Aones, NORM_INFINITY, &residual));
      PetscCall(MatNorm(A, NORM_INFINITY, &anorm));
      CHECK_MSG(residual <= 1e-13 * anorm, what + "L row sums " + std::to_string(residual / anorm));
      PetscCall(VecDestroy(&ones));
      PetscCall(VecDestroy(&Aones));
      PetscCall(MatDestroy(&A));
    }
  }
  TestScene s;
  Mat A;
  PetscInt negative, null_pivots;
  PetscBool symmetric;
  PetscCall(make_cloth(model, true, s));
  PetscCall(s.step->assemble_constant_matrix(&A, 3));
  PetscCall(MatIsSymmetric(A, 1e-14, &symmetric));
  CHECK_MSG(symmetric, what + "A symmetric");
  PetscCall(inertia(A, 0, &negative, &null_pivots));
  CHECK_MSG(negative == 0 && null_pivots == 0, what + "A is not SPD: " + std::to_string(negative) + " negative, " +
                                                   std::to_string(null_pivots) + " null pivots");
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(0);
}

// (E(x + eps d) - E(x - eps d)) / (2 eps) against grad E . d, worst of 3 random d, relative to |grad E||d|.
PetscErrorCode gradient_error(TestScene& s, Vec x, PetscRandom rnd, double eps, double* worst) {
  Vec d, g, xs;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &d));
  PetscCall(VecDuplicate(x, &g));
  PetscCall(VecDuplicate(x, &xs));
  PetscReal E, Ep, Em, gd, gn, dn;
  PetscCall(s.body->energy_gradient(x, &E, g));
  PetscCall(VecNorm(g, NORM_2, &gn));
  *worst = 0;
  for (int trial = 0; trial < 3; ++trial) {
    PetscCall(VecSetRandom(d, rnd));
    PetscCall(VecNorm(d, NORM_2, &dn));
    PetscCall(VecWAXPY(xs, eps, d, x));
    PetscCall(s.body->energy_gradient(xs, &Ep, nullptr));
    PetscCall(VecWAXPY(xs, -eps, d, x));
    PetscCall(s.body->energy_gradient(xs, &Em, nullptr));
    PetscCall(VecDot(g, d, &gd));
    const double scale = gn * dn;
    *worst = std::fmax(*worst, std::fabs((Ep - Em) / (2 * eps) - gd) / scale);
  }
  PetscCall(VecDestroy(&d));
  PetscCall(VecDestroy(&g));
  PetscCall(VecDestroy(&xs));
  PetscFunctionReturn(0);
}

PetscErrorCode check_pose(const ClothCase& model, Pose pose, PetscRandom rnd) {
  TestScene s;
  Vec x;
  Mat K, Kpsd;
  PetscReal knorm;
  PetscBool symmetric;
  double err_g, err_K;
  PetscFunctionBeginUser;
  PetscCall(make_cloth(model, false, s));
  const std::string what = std::string(model.name) + ", " + pose_name(pose) + ": ";
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(pose_positions(s, pose, x));
  // Differences at a step well below the pose's smallest length (squashed: 1e-3 of the others).
  const double eps = pose == Pose::squashed ? 1e-9 : 1e-6;
  PetscCall(test_scene::stiffness(s, x, false, &K));
  PetscCall(MatNorm(K, NORM_INFINITY, &knorm));
  if (pose == Pose::rest) {  // a minimum: the gradient vanishes (to round-off of |K| x the sheet's size)
    Vec g;
    PetscReal E, gn;
    PetscCall(VecDuplicate(x, &g));
    PetscCall(s.body->energy_gradient(x, &E, g));
    PetscCall(VecNorm(g, NORM_INFINITY, &gn));
    err_g = gn / knorm;
    CHECK_MSG(err_g <= 1e-13, what + "gradient at rest / |K| " + std::to_string(err_g));
    PetscCall(VecDestroy(&g));
  } else {
    PetscCall(gradient_error(s, x, rnd, eps, &err_g));
    CHECK_MSG(err_g <= 1e-6, what + "gradient vs FD " + std::to_string(err_g));
  }
  PetscCall(MatIsSymmetric(K, 1e-12 * knorm, &symmetric));
  CHECK_MSG(symmetric, what + "K symmetric");
  if (pose == Pose::rest) {
    err_K = 0;  // the gradient vanishes at rest: check K against differences of it only away from 0
    Vec d, Kd, xs, gp;
    PetscReal e, n;
    PetscCall(VecDuplicate(x, &d));
    PetscCall(VecDuplicate(x, &Kd));
    PetscCall(VecDuplicate(x, &xs));
    PetscCall(VecDuplicate(x, &gp));
    PetscCall(VecSetRandom(d, rnd));
    PetscCall(MatMult(K, d, Kd));
    PetscCall(VecWAXPY(xs, 1e-6, d, x));
    PetscReal E;
    PetscCall(s.body->energy_gradient(xs, &E, gp));  // grad(x + eps d) = eps K d + O(eps^2) at rest
    PetscCall(VecAXPY(Kd, -1e6, gp));
    PetscCall(VecNorm(Kd, NORM_2, &e));
    PetscCall(VecScale(gp, 1e6));
    PetscCall(VecNorm(gp, NORM_2, &n));
    err_K = e / n;
    PetscCall(VecDestroy(&d));
    PetscCall(VecDestroy(&Kd));
    PetscCall(VecDestroy(&xs));
    PetscCall(VecDestroy(&gp));
    CHECK_MSG(err_K <= 1e-4, what + "K d vs grad(x + eps d) / eps " + std::to_string(err_K));
  } else {
    PetscCall(test_scene::fd_error(K, x, [&](Vec at, Vec g) { PetscReal E; return s.body->energy_gradient(at, &E, g); },
                                   rnd, &err_K, eps));
    CHECK_MSG(err_K <= 1e-5, what + "K d vs FD " + std::to_string(err_K));
  }
  PetscCall(test_scene::stiffness(s, x, true, &Kpsd));
  PetscInt negative, null_pivots, negative_exact, unused;
  PetscCall(inertia(Kpsd, 1e-10 * knorm, &negative, &null_pivots));
  PetscCall(inertia(K, 1e-10 * knorm, &negative_exact, &unused));
  CHECK_MSG(negative == 0, what + "PSD-fixed K has " + std::to_string(negative) + " negative eigenvalues");
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%-34s %-15s |grad-FD| %.1e  |Kd-FD|/|FD| %.1e  negative eigenvalues: exact %d, fixed %d\n",
                        model.name, pose_name(pose), err_g, err_K, (int)negative_exact, (int)negative));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&Kpsd));
  PetscCall(VecDestroy(&x));
  PetscFunctionReturn(0);
}

// SpringSet::arrange() only reorders: the edge and bending springs of the sheet, with and without
// it, give the same energy and gradient (to the round-off of another summation order) at a
// perturbed pose, and the same count of springs.
PetscErrorCode check_arranged_springs() {
  TestScene s;
  PetscFunctionBeginUser;
  PetscCall(make_cloth(kModels[0], true, s));
  const DistributedMesh& m = s.mesh;
  SpringSet as_added(m), arranged(m);
  auto add_all = [&](SpringSet& set) {
    for (PetscInt t = 0; t < m.num_triangles; ++t)
      for (int e = 0; e < 3; ++e)
        if (m.triangle_edges[t] & (1u << e)) {
          const PetscInt ab[2] = {m.triangles[3 * t + e], m.triangles[3 * t + (e + 1) % 3]};
          set.add(ab[0], ab[1], segment_edge(m.rest.data(), ab).norm(), 40.0 + t);
        }
    for (PetscInt h = 0; h < m.num_hinges; ++h) {
      const PetscInt cd[2] = {m.hinges[4 * h + 2], m.hinges[4 * h + 3]};
      set.add(cd[0], cd[1], segment_edge(m.rest.data(), cd).norm(), 4.0 + h);
    }
  };
  add_all(as_added);
  add_all(arranged);
  arranged.arrange();
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> noise(-0.05, 0.05);
  std::vector<double> pos(m.rest);
  for (double& p : pos) p += noise(gen);
  PetscInt dofs = 0;
  for (PetscInt d : m.local_dof) dofs = std::max(dofs, d + 3);
  std::vector<PetscScalar> g1(dofs, 0.0), g2(dofs, 0.0);
  double e1 = 0, e2 = 0;
  as_added.add_energy(pos.data(), &e1, g1.data());
  arranged.add_energy(pos.data(), &e2, g2.data());
  double dg = 0, gn = 0;
  for (PetscInt i = 0; i < dofs; ++i) {
    dg = std::max(dg, std::fabs(g1[i] - g2[i]));
    gn = std::max(gn, std::fabs(g1[i]));
  }
  CHECK(arranged.size() == as_added.size() && as_added.size() > 0);
  CHECK_MSG(e1 > 0 && std::fabs(e1 - e2) <= 1e-13 * e1, "arranged springs' energy " + std::to_string(e2) + " vs " + std::to_string(e1));
  CHECK_MSG(gn > 0 && dg <= 1e-13 * gn, "arranged springs' gradient differs by " + std::to_string(dg / gn));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscRandom rnd;
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  for (const ClothCase& model : kModels) {
    PetscCall(check_constant_matrices(model));
    for (Pose pose : {Pose::rest, Pose::stretched, Pose::sheared, Pose::folded, Pose::squashed})
      PetscCall(check_pose(model, pose, rnd));
  }
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(check_arranged_springs());
  const int code = test_scene::tally("test_cloth");
  PetscCall(PetscFinalize());
  return code;
}

// The self-contact term (terms/self_contact.hpp): one pair's energy, gradient and Hessian against
// central differences, for the penalty and the barrier, nearly touching and nearly parallel pairs
// included; then two blocks 0.02 apart with activation distance 0.05 (faces nearly parallel, their
// edges nearly parallel): the surface found (partition faces left out), the term's gradient and
// Hessian in the body against differences, the count of pairs and the energy the same at any rank
// count, and the barrier's step bound stopping a step that closes the gap short of contact (and,
// with a thickness offset, short of the offset); then the candidate pairs kept between evaluations
// against a search of every pair, over random motions. Pairs with a thickness offset xi: the same
// derivative checks, and the energy at distance xi + s that of a pair without offset at s. Then
// friction between surfaces: one pair's lagged friction (vertex-triangle and edge-edge) and the
// two blocks' with the body's gradient and Hessian, against differences. The blocks solver.h0_contact
// takes (add_vertex_stiffness) against the diagonal blocks of the term's Hessian, with and without
// friction, the same at any rank count. Newton's Hessian: its pattern grown once for the pairs, its
// values those of a matrix that takes every entry as it comes.
#include <petscdmplex.h>

#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>

#include "check.hpp"
#include "io/log_events.hpp"
#include "mesh/mesh_piece.hpp"
#include "terms/self_contact.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;
using Vec3 = Eigen::Vector3d;

constexpr double kDistance = 0.05, kGap = 0.02, kSize = 0.5;

ContactSpec spec_of(const std::string& model) {
  ContactSpec spec;
  spec.model = model == "barrier" ? ContactModel::barrier : ContactModel::penalty;
  spec.distance = kDistance;
  spec.stiffness = 1e3;
  spec.friction_velocity = 0.01;
  spec.self = true;
  return spec;
}

Vector12d stack(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  Vector12d x;
  x << x0, x1, x2, x3;
  return x;
}

// A pair function's gradient and Hessian against central differences of step h (relative to their
// largest entry).
using PairFunction = std::function<double(const Vector12d& x, Vector12d* g, Matrix12d* H)>;
void check_derivatives(const std::string& what, const PairFunction& f, const Vector12d& x, double h) {
  Vector12d g, gp, gm, fd_g;
  Matrix12d H, fd_H;
  const double e = f(x, &g, &H);
  for (int i = 0; i < 12; ++i) {
    Vector12d xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    fd_g[i] = (f(xp, nullptr, nullptr) - f(xm, nullptr, nullptr)) / (2 * h);
    f(xp, &gp, nullptr);
    f(xm, &gm, nullptr);
    fd_H.col(i) = (gp - gm) / (2 * h);
  }
  const double eg = (fd_g - g).cwiseAbs().maxCoeff() / g.cwiseAbs().maxCoeff();
  const double eH = (fd_H - H).cwiseAbs().maxCoeff() / H.cwiseAbs().maxCoeff();
  std::printf("%s: energy %.4g, gradient error %.1e, Hessian error %.1e\n", what.c_str(), e, eg, eH);
  CHECK_MSG(eg < 1e-6, what + ": gradient vs FD " + std::to_string(eg));
  CHECK_MSG(eH < 1e-5, what + ": Hessian vs FD " + std::to_string(eH));
}

// One pair's contact energy (self_contact_pair_energy), with thickness offset xi.
void check_pair(const std::string& what, const ContactSpec& spec, PairKind kind, const Vector12d& x, double eps_x,
                double xi = 0) {
  const double e = self_contact_pair_energy(spec, kind, x, eps_x, xi);
  CHECK_MSG(e > 0 && std::isfinite(e), what + ": within the activation distance");
  check_derivatives(what, [&](const Vector12d& at, Vector12d* g, Matrix12d* H) {
    return self_contact_pair_energy(spec, kind, at, eps_x, xi, g, H);
  }, x, 1e-7 * kDistance);
}

void check_pairs(const std::string& model) {
  const ContactSpec spec = spec_of(model);
  const Vec3 t0(0, 0, 0), t1(1, 0, 0.1), t2(0.2, 1, 0);
  const Vec3 n = (t1 - t0).cross(t2 - t0).normalized();
  const Vec3 inside = (t0 + t1 + t2) / 3;
  for (double frac : {0.5, 1e-2}) {  // a vertex above the face, halfway and nearly touching
    check_pair(model + ", vertex over a face at " + std::to_string(frac) + " d", spec, PairKind::vertex_triangle,
               stack(inside + frac * kDistance * n + Vec3(0.01, 0.02, 0), t0, t1, t2), 0);
  }
  check_pair(model + ", vertex beside an edge", spec, PairKind::vertex_triangle,
             stack(Vec3(0.5, -0.02, 0.05) + 0.01 * n, t0, t1, t2), 0);
  // Edges: crossing at 0.3 d, and nearly parallel (the mollifier active: c < eps_x).
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  const Vector12d crossing = stack(a0, a1, Vec3(0.4, -0.5, 0.3 * kDistance), Vec3(0.6, 0.5, 0.3 * kDistance));
  check_pair(model + ", crossing edges", spec, PairKind::edge_edge, crossing,
             edge_edge_mollifier_threshold(a0, a1, Vec3(0.5, -0.5, 0), Vec3(0.5, 0.5, 0)));
  const Vector12d parallel = stack(a0, a1, Vec3(0.2, 0.01, 0.4 * kDistance), Vec3(1.3, 0.01 + 1e-3, 0.4 * kDistance + 1e-3));
  const double eps_x = edge_edge_mollifier_threshold(a0, a1, Vec3(0.2, 0.01, 0), Vec3(1.3, 0.01, 0));
  const Vec3 ea = a1 - a0, eb = parallel.segment<3>(9) - parallel.segment<3>(6);
  CHECK_MSG(ea.cross(eb).squaredNorm() < eps_x, "the nearly parallel edges are mollified");
  check_pair(model + ", nearly parallel edges", spec, PairKind::edge_edge, parallel, eps_x);
  // Outside d: nothing; the barrier at contact: infinite.
  CHECK(self_contact_pair_energy(spec, PairKind::vertex_triangle, stack(inside + 1.01 * kDistance * n, t0, t1, t2), 0, 0) == 0);
  if (model == "barrier")
    CHECK(std::isinf(self_contact_pair_energy(spec, PairKind::vertex_triangle, stack(t0, t0, t1, t2), 0, 0)));

  // A thickness offset xi (two layers of a cloth 0.03 thick): the same energy at xi + s as without
  // it at s, zero from xi + d on, infinite for the barrier within xi; derivatives as above.
  const double xi = 0.03;
  const auto over_face = [&](double distance) { return stack(inside + distance * n, t0, t1, t2); };
  const double e_offset = self_contact_pair_energy(spec, PairKind::vertex_triangle, over_face(xi + 0.5 * kDistance), 0, xi);
  const double e_plain = self_contact_pair_energy(spec, PairKind::vertex_triangle, over_face(0.5 * kDistance), 0, 0);
  CHECK_MSG(e_offset > 0 && std::abs(e_offset - e_plain) <= 1e-12 * e_plain,
            model + ": offset energy " + std::to_string(e_offset) + " against " + std::to_string(e_plain));
  CHECK(self_contact_pair_energy(spec, PairKind::vertex_triangle, over_face(1.01 * (xi + kDistance)), 0, xi) == 0);
  if (model == "barrier")
    CHECK(std::isinf(self_contact_pair_energy(spec, PairKind::vertex_triangle, over_face(0.99 * xi), 0, xi)));
  for (double frac : {0.5, 1e-2}) {
    Vector12d x = over_face(xi + frac * kDistance);
    const Vec3 shift(0.01, 0.02, 0);
    x.segment<3>(0) += shift - shift.dot(n) * n;  // off the centroid, in the face's plane
    check_pair(model + ", thickness offset, vertex over a face at xi + " + std::to_string(frac) + " d", spec,
               PairKind::vertex_triangle, x, 0, xi);
  }
  const Vector12d crossing_offset = stack(a0, a1, Vec3(0.4, -0.5, xi + 0.3 * kDistance), Vec3(0.6, 0.5, xi + 0.3 * kDistance));
  check_pair(model + ", thickness offset, crossing edges", spec, PairKind::edge_edge, crossing_offset,
             edge_edge_mollifier_threshold(a0, a1, Vec3(0.5, -0.5, 0), Vec3(0.5, 0.5, 0)), xi);
}

// A pair's lagged friction (frozen at x_n by lagged_pair_friction, then pair_friction_energy along
// the step; mu 0.4, k 2, eps h 1e-3): the closest points' weights sum to 1 on the first primitive
// and -1 on the second, so a rigid translation of the pair does not slide; mu lambda is mu times
// the normal force on the first primitive (k |b'|); moving the first primitive along the normal
// costs no friction; the gradient and Hessian against central differences while sticking (|u| =
// 0.3 eps h) and sliding (5 eps h), where the friction force is mu lambda.
void check_friction(const std::string& what, PairKind kind, const Vector12d& start, double eps_x) {
  const ContactSpec spec = spec_of("barrier");
  const double k = 2.0, mu = 0.4, eps_h = 1e-3;
  PairFriction f;
  CHECK_MSG(lagged_pair_friction(spec, kind, start, eps_x, 0, k, mu, &f), what + ": within d, frozen");
  const int first = kind == PairKind::vertex_triangle ? 1 : 2;  // the first primitive's points
  double w_first = 0, w_second = 0;
  for (int i = 0; i < 4; ++i) (i < first ? w_first : w_second) += f.weights[i];
  CHECK_MSG(std::abs(w_first - 1) < 1e-12 && std::abs(w_second + 1) < 1e-12,
            what + ": weights " + std::to_string(w_first) + ", " + std::to_string(w_second));
  Vector12d g_normal;
  self_contact_pair_energy(spec, kind, start, eps_x, 0, &g_normal);
  Vec3 normal_force = Vec3::Zero();
  for (int i = 0; i < first; ++i) normal_force += k * g_normal.segment<3>(3 * i);
  CHECK_MSG(std::abs(f.mu_lambda - mu * normal_force.norm()) < 1e-10 * f.mu_lambda, what + ": mu lambda");
  const Vec3 n = f.T.col(0).cross(f.T.col(1));
  CHECK_MSG(std::abs(std::abs(n.dot(normal_force.normalized())) - 1) < 1e-10, what + ": the normal");

  const auto energy = [&](const Vector12d& x, Vector12d* g, Matrix12d* H) { return pair_friction_energy(f, eps_h, x, g, H); };
  const double at_rest = energy(start, nullptr, nullptr);
  Vector12d moved = start, pushed = start;
  for (int i = 0; i < 4; ++i) moved.segment<3>(3 * i) += Vec3(0.3, -0.2, 0.1);
  for (int i = 0; i < first; ++i) pushed.segment<3>(3 * i) += 0.1 * kDistance * n;
  CHECK_MSG(std::abs(energy(moved, nullptr, nullptr) - at_rest) < 1e-9 * at_rest, what + ": a rigid translation slides");
  CHECK_MSG(std::abs(energy(pushed, nullptr, nullptr) - at_rest) < 1e-9 * at_rest, what + ": a normal motion slides");
  const Vec3 slide = 0.8 * f.T.col(0) - 0.6 * f.T.col(1) + 0.3 * n;  // tangential part of length 1
  for (double amount : {0.3 * eps_h, 5 * eps_h}) {
    Vector12d x = start;
    for (int i = 0; i < first; ++i) x.segment<3>(3 * i) += amount * slide;
    const std::string label = what + " friction, " + (amount < eps_h ? "sticking" : "sliding");
    check_derivatives(label, energy, x, 1e-5 * eps_h);
    if (amount < eps_h) continue;
    Vector12d g;
    energy(x, &g, nullptr);
    Vec3 force = Vec3::Zero();
    for (int i = 0; i < first; ++i) force += g.segment<3>(3 * i);
    CHECK_MSG(std::abs(force.norm() - f.mu_lambda) < 1e-10 * f.mu_lambda, label + ": the force is mu lambda");
  }
}

void check_frictions() {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0.1), t2(0.2, 1, 0);
  const Vec3 n = (t1 - t0).cross(t2 - t0).normalized();
  check_friction("vertex over a face", PairKind::vertex_triangle,
                 stack((t0 + t1 + t2) / 3 + 0.5 * kDistance * n + Vec3(0.01, 0.02, 0), t0, t1, t2), 0);
  check_friction("vertex beside an edge", PairKind::vertex_triangle, stack(Vec3(0.5, -0.02, 0.05) + 0.01 * n, t0, t1, t2), 0);
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  check_friction("crossing edges", PairKind::edge_edge,
                 stack(a0, a1, Vec3(0.4, -0.5, 0.3 * kDistance), Vec3(0.6, 0.5, 0.3 * kDistance)),
                 edge_edge_mollifier_threshold(a0, a1, Vec3(0.5, -0.5, 0), Vec3(0.5, 0.5, 0)));
  // Outside d: nothing frozen.
  PairFriction f;
  CHECK(!lagged_pair_friction(spec_of("barrier"), PairKind::vertex_triangle, stack((t0 + t1 + t2) / 3 + 1.01 * kDistance * n, t0, t1, t2),
                              0, 0, 2.0, 0.4, &f));
}

// Two blocks of 2 x 2 x 2 cubes side by side along x, kGap apart, the second shifted in y and z.
TetMesh two_blocks() {
  TetMesh serial = generate_box({kSize, kSize, kSize}, {2, 2, 2});
  const TetMesh other = generate_box({kSize, kSize, kSize}, {2, 2, 2});
  const int32_t n = (int32_t)serial.num_vertices();
  for (int64_t v = 0; v < other.num_vertices(); ++v) {
    serial.coords.push_back(other.coords[3 * v] + kSize + kGap);
    serial.coords.push_back(other.coords[3 * v + 1] + 0.1);
    serial.coords.push_back(other.coords[3 * v + 2] + 0.07);
  }
  for (int32_t t : other.tets) serial.tets.push_back(t + n);
  serial.tet_tags.assign(serial.num_tets(), 0);
  serial.vertex_ids.resize(serial.num_vertices());
  for (int64_t v = 0; v < serial.num_vertices(); ++v) serial.vertex_ids[v] = v;
  return serial;
}

// thickness: every pair's offset xi (both blocks counted as one body with that cloth thickness);
// mu: friction between the surfaces.
PetscErrorCode make_two_blocks(const std::string& model, TestScene& s, SelfContactTerm** term, double thickness = 0,
                               double mu = 0) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  const MeshPiece piece = scatter_serial_mesh(PETSC_COMM_WORLD, rank == 0 ? two_blocks() : TetMesh());
  const std::vector<int32_t> fixed = select_fixed_vertices(PETSC_COMM_WORLD, piece.mesh, {}, "test");
  PetscCall(distribute_mesh(PETSC_COMM_WORLD, piece, fixed, {}, s.mesh));
  MaterialSpec mat;
  mat.model = "corotated";
  mat.mu = 3.0;
  mat.lambda = 5.0;
  mat.has_density = true;
  mat.density = 100;
  std::vector<std::unique_ptr<EnergyTerm>> terms = elastic_terms(s.mesh, {mat}, StrandMaterial());
  ContactSpec spec = spec_of(model);
  spec.self_friction = mu;
  auto self = std::make_unique<SelfContactTerm>(s.mesh, spec, log_events().self_contact, log_events().self_gather,
                                                log_events().self_pairs,
                                                std::vector<SelfContactBody>{{"", thickness, 0, 0}});
  *term = self.get();
  terms.push_back(std::move(self));
  s.body = std::make_unique<Body>(s.mesh, std::move(terms));
  s.step = std::make_unique<StepObjective>(*s.body, 0.05, std::array<double, 3>{0, 0, 0});
  PetscCall(s.step->setup());
  PetscCall(s.body->set_masses(s.step->mass()));
  PetscFunctionReturn(0);
}

// The step that moves the second block by 2 gaps towards the first (sign -1: away), bounded by
// Body::limit_step from x: its alpha and the energy where it ends.
PetscErrorCode closing_step_bound(TestScene& s, Vec x, double sign, double* alpha, PetscReal* E_end) {
  Vec xl, dir, end;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(x, &dir));
  PetscCall(VecDuplicate(x, &end));
  PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
  PetscCall(VecSet(xl, 0.0));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
    if (s.mesh.local_dof[v] >= 0 && s.mesh.rest[3 * v] > kSize + kGap / 2) a[s.mesh.local_dof[v]] = -2 * kGap * sign;
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(VecSet(dir, 0.0));
  PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, dir));
  PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
  *alpha = 1;
  PetscCall(s.body->limit_step(x, dir, alpha));
  PetscCall(VecWAXPY(end, *alpha, dir, x));
  PetscCall(s.body->energy_gradient(end, E_end, nullptr));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&end));
  PetscFunctionReturn(0);
}

// The barrier's step bound with a thickness offset xi = 0.01 (half the gap): the continuous
// collision test stops the closing step where the pairs still keep xi apart, at about a quarter
// of it (0.01 of the 0.04 closing, +-0.008 of wiggle), sooner than without the offset.
PetscErrorCode check_step_bound_with_thickness() {
  double alpha[2];
  PetscReal E[2];
  PetscFunctionBeginUser;
  for (int k = 0; k < 2; ++k) {
    TestScene s;
    SelfContactTerm* term = nullptr;
    Vec x;
    PetscCall(make_two_blocks("barrier", s, &term, k == 0 ? 0.0 : 0.01));
    PetscCall(VecDuplicate(s.step->layout(), &x));
    PetscCall(test_scene::deformed_positions(s, x, 0.01));
    PetscCall(closing_step_bound(s, x, 1.0, &alpha[k], &E[k]));
    PetscCall(VecDestroy(&x));
  }
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "barrier: the closing step bounded at %.4f, with thickness 0.01 at %.4f\n",
                        alpha[0], alpha[1]));
  CHECK_MSG(alpha[1] > 0.02 && alpha[1] < 0.45 && alpha[1] < alpha[0] && std::isfinite(E[1]),
            "step bound with thickness " + std::to_string(alpha[1]));
  PetscFunctionReturn(0);
}

// The blocks solver.h0_contact takes at x (Body::vertex_stiffness, the self-contact term's alone):
// each at a vertex this rank owns, equal to the 3 x 3 diagonal block of the term's Hessian (psd,
// assembled alone) there to round-off (a block's sums run in another order than the matrix's), and
// no free vertex with a nonzero diagonal block left out. Over the ranks: how many vertices have one
// and the sum of their traces, expected as printed at 1 rank (vertices exactly, the trace to 1e-12).
PetscErrorCode check_vertex_stiffness(TestScene& s, SelfContactTerm& term, Vec x, const std::string& what,
                                      long expected_vertices, double expected_trace) {
  std::vector<double> pos;
  std::vector<VertexStiffness> blocks;
  Mat K;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(s.body->vertex_stiffness(x, 1.0, blocks));
  PetscCall(s.body->local_positions(x, pos));
  PetscCall(s.step->create_hessian(&K));
  PetscCall(MatZeroEntries(K));
  PetscCall(term.add_hessian(pos, K, 1.0, true));
  PetscCall(MatAssemblyBegin(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatGetOwnershipRange(K, &lo, &hi));
  const auto diagonal_block = [&](PetscInt dof, Eigen::Matrix<double, 3, 3, Eigen::RowMajor>* D) {
    const PetscInt idx[3] = {dof, dof + 1, dof + 2};
    return MatGetValues(K, 3, idx, 3, idx, D->data());
  };
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> D;
  double worst = 0, largest = 0, trace = 0;
  long elsewhere = 0, missing = 0;
  std::set<PetscInt> have;
  for (const VertexStiffness& b : blocks) {
    if (b.dof < lo || b.dof >= hi) {
      ++elsewhere;
      continue;
    }
    have.insert(b.dof);
    PetscCall(diagonal_block(b.dof, &D));
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> B(b.K.data());
    worst = std::max(worst, (B - D).cwiseAbs().maxCoeff());
    largest = std::max(largest, D.cwiseAbs().maxCoeff());
    trace += B.trace();
  }
  for (PetscInt dof = lo; dof < hi; dof += 3) {
    PetscCall(diagonal_block(dof, &D));
    missing += D.cwiseAbs().maxCoeff() > 0 && !have.count(dof);
  }
  PetscCall(MatDestroy(&K));
  long counts[3] = {(long)have.size(), elsewhere + (long)(blocks.size() - elsewhere - have.size()), missing};
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &trace, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                        "%s: H0's blocks at %ld vertices, traces summed %.17g; against the Hessian's diagonal blocks %.1e "
                        "of %.1e\n",
                        what.c_str(), counts[0], trace, worst, largest));
  CHECK_MSG(counts[1] == 0, what + ": blocks not at their owner or twice: " + std::to_string(counts[1]));
  CHECK_MSG(counts[2] == 0, what + ": vertices with a diagonal block and no H0 block: " + std::to_string(counts[2]));
  CHECK_MSG(largest > 0 && worst <= 1e-12 * largest, what + ": blocks against the Hessian's: " + std::to_string(worst / largest));
  CHECK_MSG(counts[0] == expected_vertices, what + ": vertices with blocks " + std::to_string(counts[0]));
  CHECK_MSG(std::abs(trace - expected_trace) <= 1e-12 * expected_trace, what + ": the traces summed " + std::to_string(trace));
  PetscFunctionReturn(0);
}

PetscErrorCode check_two_blocks(const std::string& model) {
  TestScene s;
  SelfContactTerm* term = nullptr;
  Vec x, grad;
  PetscRandom rnd;
  PetscReal E;
  Mat K;
  PetscFunctionBeginUser;
  PetscCall(make_two_blocks(model, s, &term));
  // Each block: 6 faces of 2 x 2 squares of 2 triangles; 26 surface vertices, 72 edges (Euler).
  CHECK_MSG(term->surface_triangles() == 96 && term->surface_vertices() == 52 && term->surface_edges() == 144,
            "the surface: " + std::to_string(term->surface_triangles()) + " triangles, " +
                std::to_string(term->surface_vertices()) + " vertices, " + std::to_string(term->surface_edges()) + " edges");
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(test_scene::deformed_positions(s, x, 0.01));  // moves a vertex by at most 0.004: the blocks stay apart
  PetscCall(s.body->energy_gradient(x, &E, grad));
  long pairs = (long)term->active_pairs();
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &pairs, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s: %ld pairs within d, E = %.17g\n", model.c_str(), pairs, E));
  // The same pairs at any rank count (each evaluated once; the count printed at 1 rank).
  CHECK_MSG(pairs == 67, "pairs within d: " + std::to_string(pairs));
  // The ghost layer: on more than one rank, some rank knows only part of the surface's positions
  // (its own vertices and those within reach: here the near faces of the other block).
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  long known = (long)term->known_vertices();
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &known, 1, MPI_LONG, MPI_MIN, PETSC_COMM_WORLD));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s: the fewest surface vertices a rank knows: %ld of 52\n", model.c_str(), known));
  CHECK_MSG(size == 1 ? known == 52 : known < 52, "surface vertices known: " + std::to_string(known));

  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  PetscCall(test_scene::check_gradient(*s.body, x, grad, rnd));
  double err;
  PetscCall(test_scene::stiffness(s, x, false, &K));  // its pattern grows with the pairs
  PetscCall(test_scene::fd_error(K, x, [&](Vec at, Vec g) { PetscReal e; return s.body->energy_gradient(at, &e, g); }, rnd, &err));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s: Hessian vs FD of the gradient: %.2e\n", model.c_str(), err));
  CHECK_MSG(err < 1e-5, "Hessian vs FD of the gradient: " + std::to_string(err));
  PetscCall(MatDestroy(&K));
  PetscCall(check_vertex_stiffness(s, *term, x, model, 28, model == "penalty" ? 17119589.841492631 : 94621032.811991885));

  if (model == "barrier") {  // the second block moves by 2 gaps towards the first: stopped short
    double alpha, Ep;
    PetscCall(closing_step_bound(s, x, 1.0, &alpha, &Ep));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "barrier: a step closing the gap twice over is bounded at %.4f\n", alpha));
    // Contact at about 0.5 (the wiggle of the faces: +-0.004 of the 0.04 closing): within it, finite.
    CHECK_MSG(alpha > 0.2 && alpha < 0.6 && std::isfinite(Ep), "step bound " + std::to_string(alpha));
    PetscCall(closing_step_bound(s, x, -1.0, &alpha, &Ep));  // apart: no bound
    CHECK_MSG(alpha == 1, "moving apart is not bounded: " + std::to_string(alpha));
  }
  for (Vec* w : {&x, &grad}) PetscCall(VecDestroy(w));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscFunctionReturn(0);
}

// The two blocks with friction (self_friction 0.5, eps h = 0.01 * 0.05): a step begun at x_n (the
// blocks deformed a little) freezes the pairs within d there, as many at any rank count; where the
// second block has slid along the first by 0.2 and 4 eps h, the body's gradient and Hessian against
// differences.
PetscErrorCode check_two_blocks_friction() {
  TestScene s;
  SelfContactTerm* term = nullptr;
  Vec x0, x, grad, xl;
  PetscRandom rnd;
  PetscFunctionBeginUser;
  PetscCall(make_two_blocks("barrier", s, &term, 0, 0.5));
  PetscCall(VecDuplicate(s.step->layout(), &x0));
  for (Vec* w : {&x, &grad}) PetscCall(VecDuplicate(x0, w));
  PetscCall(test_scene::deformed_positions(s, x0, 0.01));
  PetscCall(s.body->begin_step(StepStart{0.05, 0.05, x0, x0}));
  long pairs = (long)term->friction_pairs();
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &pairs, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "friction: %ld pairs frozen at x_n\n", pairs));
  CHECK_MSG(pairs == 67, "friction pairs within d at x_n: " + std::to_string(pairs));
  PetscCall(check_vertex_stiffness(s, *term, x0, "barrier with friction", 28, 2305904067.1535816));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1.0, 1.0));
  const double eps_h = 0.01 * 0.05;
  for (double slide : {0.2 * eps_h, 4 * eps_h}) {
    PetscScalar* a;
    PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
    PetscCall(DMGlobalToLocal(s.mesh.dm, x0, INSERT_VALUES, xl));
    PetscCall(VecGetArray(xl, &a));
    for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
      if (s.mesh.local_dof[v] >= 0 && s.mesh.rest[3 * v] > kSize + kGap / 2) {
        a[s.mesh.local_dof[v] + 1] += 0.6 * slide;
        a[s.mesh.local_dof[v] + 2] += 0.8 * slide;
      }
    PetscCall(VecRestoreArray(xl, &a));
    PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
    PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
    PetscReal E;
    PetscCall(s.body->energy_gradient(x, &E, grad));
    PetscCall(test_scene::check_gradient(*s.body, x, grad, rnd));
    Mat K;
    double err;
    PetscCall(test_scene::stiffness(s, x, false, &K));
    PetscCall(test_scene::fd_error(K, x, [&](Vec at, Vec g) { PetscReal e; return s.body->energy_gradient(at, &e, g); }, rnd,
                                   &err, 1e-3 * eps_h));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "friction, slid %.1e: Hessian vs FD of the gradient: %.2e\n", slide, err));
    CHECK_MSG(err < 1e-5, "friction: Hessian vs FD of the gradient: " + std::to_string(err));
    PetscCall(MatDestroy(&K));
  }
  for (Vec* w : {&x0, &x, &grad}) PetscCall(VecDestroy(w));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscFunctionReturn(0);
}

// Newton's Hessian (StepObjective::assemble_hessian) in a matrix made with the mesh's pattern only
// (create_hessian), without and with friction (mu): at x_n and where the second block has slid, equal to
// h^2 K(x) + M assembled into a fresh matrix that takes every entry as it comes (an entry the
// couplings left out would be an error in assemble_hessian). Its pattern grows once, at the first
// assembly; not again at points the candidate list still covers, nor at the same point, and the
// nonzero state (MUMPS analyses again when it changes) stays the same.
PetscErrorCode check_newton_pattern(double mu) {
  TestScene s;
  SelfContactTerm* term = nullptr;
  Vec x0, x, xl;
  Mat H;
  PetscFunctionBeginUser;
  PetscCall(make_two_blocks("barrier", s, &term, 0, mu));
  PetscCall(VecDuplicate(s.step->layout(), &x0));
  PetscCall(VecDuplicate(x0, &x));
  PetscCall(test_scene::deformed_positions(s, x0, 0.01));
  PetscCall(s.body->begin_step(StepStart{0.05, 0.05, x0, x0}));
  PetscCall(VecCopy(x0, x));  // slid by 0.002 along the faces: within the list's cover (0.4 d)
  PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
  PetscCall(DMGlobalToLocal(s.mesh.dm, x0, INSERT_VALUES, xl));
  PetscScalar* a;
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
    if (s.mesh.local_dof[v] >= 0 && s.mesh.rest[3 * v] > kSize + kGap / 2) a[s.mesh.local_dof[v] + 2] += 0.002;
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));

  PetscCall(s.step->create_hessian(&H));
  MatInfo info;
  PetscCall(MatGetInfo(H, MAT_GLOBAL_SUM, &info));
  const double mesh_nonzeros = info.nz_used;
  PetscObjectState state = 0;
  int step = 0;
  for (Vec at : {x0, x, x0}) {
    PetscCall(s.step->assemble_hessian(at, H));
    PetscObjectState now;
    PetscCall(MatGetNonzeroState(H, &now));
    const std::string where = "Newton's pattern, mu " + std::to_string(mu) + ", assembly " + std::to_string(++step);
    CHECK_MSG(s.step->hessian_patterns() == 1, where + ": grown " + std::to_string(s.step->hessian_patterns()) + " times");
    CHECK_MSG(step == 1 || now == state, where + ": the nonzero state changed");
    state = now;
    Mat K;
    PetscReal diff, norm;
    PetscCall(test_scene::stiffness(s, at, true, &K));
    PetscCall(MatScale(K, 0.05 * 0.05));
    PetscCall(MatDiagonalSet(K, s.step->mass(), ADD_VALUES));
    PetscCall(MatNorm(K, NORM_FROBENIUS, &norm));
    PetscCall(MatAXPY(K, -1.0, H, DIFFERENT_NONZERO_PATTERN));
    PetscCall(MatNorm(K, NORM_FROBENIUS, &diff));
    PetscCall(MatDestroy(&K));
    CHECK_MSG(diff <= 1e-13 * norm, where + ": differs from the fresh matrix's by " + std::to_string(diff / norm));
  }
  PetscCall(MatGetInfo(H, MAT_GLOBAL_SUM, &info));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "Newton's pattern, mu %g: %.0f nonzeros of the mesh, %.0f with the couplings, grown %lld time(s)\n",
                        mu, mesh_nonzeros, info.nz_used, s.step->hessian_patterns()));
  CHECK_MSG(info.nz_used > mesh_nonzeros, "Newton's pattern took no couplings");
  PetscCall(MatDestroy(&H));
  for (Vec* w : {&x0, &x}) PetscCall(VecDestroy(w));
  PetscFunctionReturn(0);
}

// Every pair of the serial mesh's surface (its tets' faces that belong to one tet only) that shares
// no vertex and is closer than d at positions x: a search without any broad phase.
long pairs_within(const TetMesh& mesh, const std::vector<double>& x, double d) {
  static const int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<int, 3>, int> faces;
  for (int64_t t = 0; t < mesh.num_tets(); ++t)
    for (const auto& f : kFaces) {
      std::array<int, 3> face{mesh.tets[4 * t + f[0]], mesh.tets[4 * t + f[1]], mesh.tets[4 * t + f[2]]};
      std::sort(face.begin(), face.end());
      ++faces[face];
    }
  std::vector<std::array<int, 3>> triangles;
  std::set<std::array<int, 2>> edge_set;
  std::set<int> vertices;
  for (const auto& [face, count] : faces) {
    if (count != 1) continue;
    triangles.push_back(face);
    for (int k = 0; k < 3; ++k) {
      vertices.insert(face[k]);
      edge_set.insert({std::min(face[k], face[(k + 1) % 3]), std::max(face[k], face[(k + 1) % 3])});
    }
  }
  const std::vector<std::array<int, 2>> edges(edge_set.begin(), edge_set.end());
  const auto p = [&](int v) { return Vec3(&x[3 * v]); };
  long count = 0;
  for (int v : vertices)
    for (const auto& t : triangles)
      if (v != t[0] && v != t[1] && v != t[2])
        count += point_triangle_squared_distance(p(v), p(t[0]), p(t[1]), p(t[2])) < d * d;
  for (size_t e = 0; e < edges.size(); ++e)
    for (size_t f = e + 1; f < edges.size(); ++f) {
      const auto &a = edges[e], &b = edges[f];
      if (a[0] != b[0] && a[0] != b[1] && a[1] != b[0] && a[1] != b[1])
        count += edge_edge_squared_distance(p(a[0]), p(a[1]), p(b[0]), p(b[1])) < d * d;
    }
  return count;
}

// The candidate pairs kept between evaluations miss no pair within d (terms/self_contact.cpp,
// refresh_candidates): over random motions (every vertex jittered by up to 0.002 per coordinate,
// the second block driven 0.008 a time into the first and through it), the term finds within d
// exactly the pairs that a search of every pair finds, while its list is built again only when a
// vertex has moved more than 0.4 of the margin (d without a step) since. (With 1.5 instead of 0.4
// pairs are missed.) With drift, both blocks also move together by drift per evaluation and each
// step carries them by 3 drift more (a body in free fall): a translation moves no pair, so the list
// is kept as without it (built again at every evaluation when the moves counted the translation),
// and the step bound from the list stays the broad phase's, whose swept boxes do count it.
PetscErrorCode check_candidates_against_all_pairs(double drift) {
  TestScene s;
  SelfContactTerm* term = nullptr;
  Vec x, grad, xl, dir;
  PetscFunctionBeginUser;
  PetscCall(make_two_blocks("penalty", s, &term));
  const TetMesh serial = two_blocks();  // the same on every rank, positions by input id
  std::vector<double> at = serial.coords;
  const int64_t first_block = serial.num_vertices() / 2;
  PetscCall(VecDuplicate(s.step->layout(), &x));
  PetscCall(VecDuplicate(x, &grad));
  std::mt19937 random(11);
  std::uniform_real_distribution<double> jitter(-0.002, 0.002);
  const int trials = 60;
  const double kApproach = 0.16 * kDistance;  // per evaluation: through the first block by the end
  long mismatches = 0, total = 0, bound_mismatches = 0, bounded = 0;
  PetscRandom rng;
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rng));
  PetscCall(PetscRandomSetSeed(rng, 5));
  PetscCall(PetscRandomSeed(rng));
  PetscCall(VecDuplicate(x, &dir));
  for (int trial = 0; trial < trials; ++trial) {
    for (int64_t v = 0; v < serial.num_vertices(); ++v)
      for (int d = 0; d < 3; ++d)
        at[3 * v + d] += jitter(random) + (v >= first_block && d == 0 ? -kApproach : 0.0) + (d == 1 ? drift : 0.0);
    PetscScalar* a;
    PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
    PetscCall(VecGetArray(xl, &a));
    for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
      if (s.mesh.local_dof[v] >= 0)
        for (int d = 0; d < 3; ++d) a[s.mesh.local_dof[v] + d] = at[3 * s.mesh.vertex_ids[v] + d];
    PetscCall(VecRestoreArray(xl, &a));
    PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, x));
    PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
    PetscReal E;
    PetscCall(s.body->energy_gradient(x, &E, grad));
    // The step bound along a random step (the second block closing by 0.1 d, every vertex jittered
    // by up to 0.1 d per coordinate): the same alpha from the list (when it covers the step) as
    // from a broad phase of the step alone.
    PetscCall(VecSetRandom(dir, rng));
    PetscCall(VecShift(dir, -0.5));
    PetscCall(VecScale(dir, 0.2 * kDistance));
    PetscCall(DMGetLocalVector(s.mesh.dm, &xl));
    PetscCall(DMGlobalToLocal(s.mesh.dm, dir, INSERT_VALUES, xl));
    PetscCall(VecGetArray(xl, &a));
    for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
      if (s.mesh.local_dof[v] >= 0) {
        if (s.mesh.vertex_ids[v] >= first_block) a[s.mesh.local_dof[v]] -= 0.1 * kDistance;
        a[s.mesh.local_dof[v] + 1] += 3 * drift;
      }
    PetscCall(VecRestoreArray(xl, &a));
    PetscCall(DMLocalToGlobal(s.mesh.dm, xl, INSERT_VALUES, dir));
    PetscCall(DMRestoreLocalVector(s.mesh.dm, &xl));
    double by_list = 1, by_broad_phase = 1;
    PetscCall(term->limit_step(x, dir, &by_list));
    PetscCall(term->limit_step_without_list(x, dir, &by_broad_phase));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &by_list, 1, MPI_DOUBLE, MPI_MIN, PETSC_COMM_WORLD));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &by_broad_phase, 1, MPI_DOUBLE, MPI_MIN, PETSC_COMM_WORLD));
    bound_mismatches += by_list != by_broad_phase;
    bounded += by_list < 1;
    long found = (long)term->active_pairs();
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &found, 1, MPI_LONG, MPI_SUM, PETSC_COMM_WORLD));
    const long expected = pairs_within(serial, at, kDistance);
    mismatches += found != expected;
    total += expected;
  }
  const size_t builds = term->candidate_builds();
  PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                        "random motions with a drift of %.3g per evaluation: %d evaluations, %ld pairs within d in all, %ld "
                        "evaluations missing or adding pairs against every pair; the list built %zu times\n",
                        drift, trials, total, mismatches, builds));
  CHECK_MSG(mismatches == 0, "the candidates missed pairs within d in " + std::to_string(mismatches) + " evaluations");
  CHECK_MSG(total > 10 * trials, "the motions bring many pairs within d: " + std::to_string(total));
  CHECK_MSG(builds > 3 && builds < (size_t)trials / 2, "the list is kept between evaluations: built " + std::to_string(builds) + " times");
  const size_t from_list = term->step_bounds_from_list();
  PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                        "random steps: %ld of %d bounded, %zu from the list, %ld with another alpha without the list\n",
                        bounded, trials, from_list, bound_mismatches));
  CHECK_MSG(from_list > (size_t)trials / 4, "the list bounds the steps it covers: " + std::to_string(from_list));
  CHECK_MSG(bound_mismatches == 0, "the step bound depends on the candidate list in " + std::to_string(bound_mismatches) + " steps");
  CHECK_MSG(bounded > trials / 4, "the random steps are bounded: " + std::to_string(bounded));
  PetscCall(PetscRandomDestroy(&rng));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&grad));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscMPIInt rank;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  for (const std::string model : {"penalty", "barrier"}) {
    if (rank == 0) check_pairs(model);
    PetscCall(check_two_blocks(model));
  }
  PetscCall(check_step_bound_with_thickness());
  if (rank == 0) check_frictions();
  PetscCall(check_two_blocks_friction());
  for (double mu : {0.0, 0.5}) PetscCall(check_newton_pattern(mu));
  for (double drift : {0.0, 2 * kDistance}) PetscCall(check_candidates_against_all_pairs(drift));
  const int code = test_scene::tally("test_self_contact");
  PetscCall(PetscFinalize());
  return code;
}

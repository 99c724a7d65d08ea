#include "model/step_objective.hpp"

#include "io/log_events.hpp"
#include "mesh/vertex_matrix.hpp"
#include "model/ordered_assembly.hpp"
#include "solvers/stop_request.hpp"

#include <algorithm>
#include <cmath>

namespace hyperqn {

StepObjective::StepObjective(Body& body, double dt, const std::array<double, 3>& gravity, double damping,
                             WarmStart warm_start, bool upright_guess, double element_limit,
                             TimeIntegrator integrator, double pseudo_step)
    : body_(body), dt_(dt), life_(body, dt, damping, integrator), solve_dt_(life_.solve_dt()), pseudo_step_(pseudo_step),
      gravity_(gravity), warm_start_(warm_start), upright_guess_(upright_guess), element_limit_(element_limit) {}

StepObjective::~StepObjective() {
  for (Vec* v : {&work_, &end_x_, &end_v_, &kinetic_, &rest_, &rest_grad_}) VecDestroy(v);
}

PetscErrorCode StepObjective::setup() {
  PetscFunctionBeginUser;
  if (!has_inertia()) {
    if (pseudo_step_ > 0)
      solve_dt_ = pseudo_step_;
    else
      PetscCall(automatic_pseudo_step(&solve_dt_));
  }
  PetscCall(inertia_.setup(body_, solve_dt_, gravity_, has_inertia()));
  Vec mass = inertia_.mass();
  PetscCall(VecDuplicate(mass, &work_));
  PetscCall(life_.setup(mass));
  // W = h^2 g0 sqrt(sum of m_i^2 over free vertices) (force_scale); the mass vector repeats m_i
  // three times.
  constexpr double kStandardGravity = 9.80665;
  PetscReal mass_norm;
  PetscCall(VecNorm(mass, NORM_2, &mass_norm));
  weight_scale_ = solve_dt_ * solve_dt_ * kStandardGravity * mass_norm / std::sqrt(3.0);
  diagonal_ = rest_diagonal(body_.mesh());
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::create_substep(int parts, std::unique_ptr<StepObjective>& sub) const {
  PetscFunctionBeginUser;
  const double damping = 1.0 - std::pow(1.0 - life_.damping(), 1.0 / parts);
  // Static: the same s (a load increment changes no pseudo step).
  sub = std::make_unique<StepObjective>(body_, dt_ / parts, gravity_, damping, warm_start_, upright_guess_,
                                       element_limit_, life_.kind(), has_inertia() ? 0.0 : solve_dt_);
  sub->counts_ = counts_;
  sub->pattern_from_cells_ = pattern_from_cells_;  // a rebuilt scene's sub-steps: no DMPlex preallocation either
  sub->life_.set_substep();
  PetscCall(sub->setup());
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::begin_step(State& s) {
  PetscFunctionBeginUser;
  PetscCall(life_.begin(s));
  PetscCall(inertia_.set_target(life_.x_hat(), life_.v_hat()));
  PetscCall(body_.hold(inertia_.target()));  // rollers: y's held slots where their supports are
  // A static step spans h (contact's colliders and friction take the step's length from it).
  StepStart start{life_.solve_time(s), has_inertia() ? solve_dt_ : dt_, s.x, inertia_.target(), s.frame * dt_};
  start.quasi_static = !has_inertia();
  PetscCall(body_.begin_step(start));
  if (!has_inertia()) {
    PetscReal g;
    const PetscInt rejected_before = counts_->rejected;
    if (!rest_) PetscCall(VecDuplicate(work_, &rest_));
    if (!rest_grad_) PetscCall(VecDuplicate(work_, &rest_grad_));
    PetscCall(body_.rest_positions(rest_));
    // Without contact: a body started inside a contact layer is pushed out by forces that no load
    // balances; counted, they made S 4e4 times the 20 N load and a frame 36 times off equilibrium
    // was converged (docs/self-contact.md).
    PetscCall(evaluate(rest_, &g, rest_grad_, false));
    load_scale_ = 0;
    if (!rejected(g)) PetscCall(VecNorm(rest_grad_, NORM_2, &load_scale_));
    --evaluations_;  // neither the solver's evaluation nor its rejection
    counts_->rejected = rejected_before;
  }
  PetscCall(initial_guess(life_.x_n(), s.x));
  PetscCall(body_.hold(s.x));  // x_n's held slots are those of t_n (the lower warm start)
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::automatic_pseudo_step(double* s) const {
  Mat L;
  Vec d, mass;
  const PetscScalar *m, *l;
  PetscInt n;
  double local = 0, global;
  PetscFunctionBeginUser;
  PetscCall(DMCreateMatrix(body_.mesh().vertex_dm, &L));
  PetscCall(MatSetOption(L, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(add_in_rank_order(L, [&](Mat S) { return body_.add_laplacian(S, 1.0, 1); }));
  PetscCall(MatCreateVecs(L, &d, nullptr));
  PetscCall(MatGetDiagonal(L, d));
  PetscCall(DMCreateGlobalVector(body_.mesh().dm, &mass));
  PetscCall(body_.lumped_mass(mass));
  PetscCall(VecGetLocalSize(d, &n));
  PetscCall(VecGetArrayRead(d, &l));
  PetscCall(VecGetArrayRead(mass, &m));
  for (PetscInt i = 0; i < n; ++i)
    if (l[i] > 0) local = std::fmax(local, m[3 * i] / l[i]);
  PetscCall(VecRestoreArrayRead(mass, &m));
  PetscCall(VecRestoreArrayRead(d, &l));
  PetscCallMPI(MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, PetscObjectComm((PetscObject)d)));
  PetscCall(VecDestroy(&d));
  PetscCall(VecDestroy(&mass));
  PetscCall(MatDestroy(&L));
  // max m_i / L_ii ~ (l / c)^2 at the mesh spacing l; the body's slowest modes are slower by about
  // (D / l)^2 ~ N^(2/3) (N free vertices), a slender body's bending modes by its slenderness
  // squared again; s must outlast them, or M slows Newton there (L-BFGS's counts do not change):
  // on a 10 x 1 x 1 cantilever of 40 x 4 x 4 cubes under a tip load Newton took 13, 3, 2, 2
  // iterations at kPseudoStepFactor 1e4, 1e6, 1e8, 1e10 (docs/method.md#time-integrators).
  const double vertices = static_cast<double>(body_.mesh().global_dofs) / 3;
  *s = global > 0 ? std::sqrt(kPseudoStepFactor * global * std::cbrt(vertices * vertices)) : dt_;  // no stiffness: h
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::initial_guess(Vec from, Vec x) {
  PetscFunctionBeginUser;
  if (warm_start_ == WarmStart::previous) {
    PetscCall(VecCopy(from, x));
    PetscFunctionReturn(0);
  }
  PetscCall(upright_guess(from, x));
  if (body_.any_term(&EnergyTerm::couples_surfaces) && body_.any_term(&EnergyTerm::bounds_steps)) {
    // No surface may pass through another on the way from x_n (EnergyTerm::couples_surfaces).
    double alpha = 1;
    PetscCall(VecWAXPY(work_, -1.0, from, x));
    PetscCall(body_.limit_step(from, work_, &alpha));
    if (alpha < 1) PetscCall(VecWAXPY(x, alpha, work_, from));
  }
  if (warm_start_ == WarmStart::lower) {
    PetscReal g_y, g_n;
    PetscCall(objective(x, &g_y, nullptr));
    Vec at_n = from;
    if (body_.holds_components()) {  // x_n with its held slots where y has them: no inertia there in g
      PetscCall(VecCopy(from, work_));
      PetscCall(body_.hold(work_));
      at_n = work_;
    }
    PetscCall(objective(at_n, &g_n, nullptr));
    if (!rejected(g_n) && g_n < g_y) PetscCall(VecCopy(from, x));
  }
  PetscFunctionReturn(0);
}

// y - x_n is rigid where the body is free and zero where it is fixed (or whatever the velocities
// do at the scale of one tet), so the tets in between take all of the difference. A sliver there
// whose thin side spans it inverts or blows up: on the 0.4 x 2 x 0.4 m sliver mesh of
// tests/python/test_sliver_mesh.py, y puts 14 tets at det F down to -2953, where Neo-Hookean's
// quadratic extension of log J makes g(y) 3.7e11 (its curvature there is ~1e8 times L's), and
// no solver recovers within the frame. The answer has no such tet, so the guess stops short of
// y: t halves until no tet upright at x_n is inverted, nor past the element limit
// (-hyperqn_element_limit) unless it already was. Where y does neither, t = 1 and the guess is y,
// bit for bit.
PetscErrorCode StepObjective::upright_guess(Vec from, Vec x) {
  constexpr int kMaxHalvings = 30;
  const PetscInt cells = body_.mesh().num_cells;
  PetscFunctionBeginUser;
  PetscCall(VecCopy(inertia_.target(), x));
  // Only tets can invert (not cells == 0 alone: a rank may have none, the others some).
  if (!upright_guess_ || body_.mesh().global_cells == 0) PetscFunctionReturn(0);
  PetscCall(body_.local_positions(from, pos_));
  body_.cell_jacobians(pos_, J_n_);
  PetscCall(VecWAXPY(work_, -1.0, from, inertia_.target()));  // y - x_n
  double t = 1;
  for (int halvings = 0;; ++halvings, t *= 0.5) {
    if (halvings > kMaxHalvings) {
      t = 0;
      PetscCall(VecCopy(from, x));
      break;
    }
    if (halvings > 0) PetscCall(VecWAXPY(x, t, work_, from));
    PetscCall(body_.local_positions(x, pos_));
    body_.cell_jacobians(pos_, J_);
    int local = 0, any;
    for (PetscInt c = 0; c < cells && !local; ++c)
      local = J_n_[c] > 0 &&
              !(J_[c] > 0 && (element_limit_ <= 0 || J_[c] <= element_limit_ || J_n_[c] > element_limit_));
    PetscCallMPI(MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_LOR, PetscObjectComm((PetscObject)x)));
    if (!any) break;
  }
  if (t < 1) ++counts_->pulled_back;
  PetscFunctionReturn(0);
}

// The solver from the initial guess in s.x; if g is not finite there (e.g. y inverts elements of
// a material without an extension), once more from `from`.
PetscErrorCode StepObjective::solve_from(TimeStepSolver& solver, Vec from, Vec x, const IterationCallback& on_iteration,
                                         StepSolve& out) {
  PetscFunctionBeginUser;
  PetscCall(solver.solve(x, on_iteration, out.result));
  out.evaluations += evaluations_;
  out.iterations += out.result.iterations;
  if (warm_start_ != WarmStart::previous && out.result.reason == "REJECTED_INITIAL_GUESS" && !stop_agreed()) {
    out.restarted = true;
    PetscCall(VecCopy(from, x));
    PetscCall(solver.solve(x, on_iteration, out.result));
    out.evaluations += evaluations_;
    out.iterations += out.result.iterations;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::solve_step(TimeStepSolver& solver, State& s, const IterationCallback& on_iteration,
                                         StepSolve& out) {
  PetscFunctionBeginUser;
  out = StepSolve{};
  PetscCall(begin_step(s));
  const double before = event_seconds(log_events().step);
  PetscCall(event_begin(&LogEvents::step));
  PetscCall(solve_from(solver, life_.x_n(), s.x, on_iteration, out));
  if (life_.integrator().extrapolates() && !rejected(out.result.energy) && !stop_agreed()) {
    bool sound;
    PetscCall(end_is_sound(s, &sound));
    if (!sound) PetscCall(complete_by_euler(solver, s, on_iteration, out));
  }
  PetscCall(event_end(&LogEvents::step));
  out.seconds = event_seconds(log_events().step) - before;
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::end_is_sound(State& s, bool* sound) {
  const DistributedMesh& mesh = body_.mesh();
  const PetscInt cells = mesh.num_cells;
  PetscFunctionBeginUser;
  *sound = true;
  bool any_springs = false;  // springs_keep_energy's
  for (const auto& term : body_.terms()) any_springs = any_springs || term->has_midpoint_defect();
  if (mesh.global_cells == 0 && mesh.global_segments == 0 && !any_springs) PetscFunctionReturn(0);  // nothing to check
  if (!end_x_) PetscCall(VecDuplicate(inertia_.mass(), &end_x_));
  if (!end_v_) PetscCall(VecDuplicate(inertia_.mass(), &end_v_));
  PetscCall(body_.local_positions(s.x, pos_));  // z, the fixed vertices at the solve's time
  body_.cell_jacobians(pos_, J_n_);
  std::vector<double> z;  // z's positions, for the strand segments and the springs
  if (mesh.num_segments > 0 || any_springs) z = pos_;
  PetscCall(VecCopy(s.x, end_x_));
  PetscCall(life_.end_map(end_x_, end_v_));
  const double solve_time = body_.time();
  body_.set_time((s.frame + 1) * dt_);
  PetscCall(body_.local_positions(end_x_, pos_));
  body_.cell_jacobians(pos_, J_);
  body_.set_time(solve_time);  // back, so that the step goes on as if not looked at
  int local = 0, any;
  for (PetscInt c = 0; c < cells && !local; ++c) {
    const bool inverted = J_n_[c] > 0 && !(J_[c] > 0);
    const bool blown = element_limit_ > 0 && !(std::fabs(J_[c]) <= element_limit_) && std::fabs(J_n_[c]) <= element_limit_;
    local = inverted || blown;
  }
  // A strand segment's inversion: the end map turns it through 90 degrees or more from z, where
  // it points the other way (a rope that recoils after a snap overshoots so, gaining energy).
  for (PetscInt k = 0; k < mesh.num_segments && !local; ++k) {
    const PetscInt a = 3 * mesh.segments[2 * k], b = 3 * mesh.segments[2 * k + 1];
    double dot = 0;
    for (int i = 0; i < 3; ++i) dot += (z[b + i] - z[a + i]) * (pos_[b + i] - pos_[a + i]);
    local = !(dot > 0);
  }
  PetscCallMPI(MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_LOR, PetscObjectComm((PetscObject)s.x)));
  *sound = !any;
  if (*sound && any_springs) PetscCall(springs_keep_energy(s, z, sound));
  PetscFunctionReturn(0);
}

// The energy test of the springs and cloth (strands, cloth edges, membranes and bending: the terms
// with has_midpoint_defect): the midpoint keeps a quadratic energy, but a spring's k/2 (l - L)^2 is
// not quadratic in x where it turns (nor a membrane's where it folds), and where
// the step resolves none of its stiffness (h sqrt(k/m) >> 1) the end map 2z - x_n doubles a sag or
// a buckle that z took over half a step: a string between its supports that sags by d at z ends
// at 2d with its stretch energy 16 times z's (quartic in d), twice the work the forces at z did
// (EnergyTerm::add_midpoint_defect). The defect summed over the springs is what the step adds to
// the energy beyond the work of its forces (M(v_{n+1} - v_n) = h f(z) makes the kinetic energy's
// change exactly that work); the step ends by Euler where it exceeds kMidpointDefect of the springs'
// energies and works plus the kinetic energy at both ends. A sum over the ranks: its last bits,
// not the decision, depend on the rank count (a tie at the threshold aside).
PetscErrorCode StepObjective::springs_keep_energy(State& s, const std::vector<double>& z, bool* sound) {
  constexpr double kMidpointDefect = 1e-2;
  PetscFunctionBeginUser;
  // pos_ holds the end (end_is_sound); the start with the fixed vertices at t_n.
  const double solve_time = body_.time();
  body_.set_time(s.frame * dt_);
  PetscCall(body_.local_positions(life_.x_n(), start_pos_));
  body_.set_time(solve_time);
  double local[2] = {0, 0}, sum[2];
  for (const auto& term : body_.terms()) term->add_midpoint_defect(start_pos_, z, pos_, &local[0], &local[1]);
  PetscCallMPI(MPI_Allreduce(local, sum, 2, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)s.x)));
  // kinetic energies at both ends: 1/2 v.Mv over the free dofs
  if (!kinetic_) PetscCall(VecDuplicate(end_v_, &kinetic_));
  PetscReal Kn, Ke;
  PetscCall(VecPointwiseMult(kinetic_, inertia_.mass(), life_.v_n()));
  PetscCall(VecDot(kinetic_, life_.v_n(), &Kn));
  PetscCall(VecPointwiseMult(kinetic_, inertia_.mass(), end_v_));
  PetscCall(VecDot(kinetic_, end_v_, &Ke));
  const double scale = sum[1] + 0.5 * (Kn + Ke);
  *sound = std::isfinite(sum[0]) && !(sum[0] > kMidpointDefect * scale);  // an end of infinite energy: not sound
  PetscFunctionReturn(0);
}

// z is an implicit Euler step of h' from x_n, v_n to t_n + h' (Integrator::extrapolates); a second
// one from z, v' = (z - x_n) / h' reaches t_{n+1} with the same h', hence the same constant matrix.
PetscErrorCode StepObjective::complete_by_euler(TimeStepSolver& solver, State& s, const IterationCallback& on_iteration,
                                                StepSolve& out) {
  const double t = (s.frame + 1) * dt_;
  PetscFunctionBeginUser;
  const double t_z = body_.time();  // z's
  ++counts_->euler_completed;
  PetscCall(life_.complete_by_euler(s.x));  // x^ = z, v^ = (z - x_n) / h'
  body_.set_time(t);
  PetscCall(inertia_.set_target(life_.x_hat(), life_.v_hat()));
  PetscCall(body_.hold(inertia_.target()));
  PetscCall(body_.begin_step({t, solve_dt_, life_.x_hat(), inertia_.target(), t_z}));
  PetscCall(initial_guess(life_.x_hat(), s.x));
  PetscCall(body_.hold(s.x));
  PetscCall(solve_from(solver, life_.x_hat(), s.x, on_iteration, out));
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::objective(Vec x, PetscReal* g, Vec grad) { return evaluate(x, g, grad, true); }

PetscErrorCode StepObjective::evaluate(Vec x, PetscReal* g, Vec grad, bool with_contact) {
  PetscReal E, inertia;
  PetscFunctionBeginUser;
  PetscCall(event_begin(&LogEvents::objective));
  ++evaluations_;
  PetscCall(body_.energy_gradient(x, &E, grad, with_contact));
  // A non-finite entry of dE/dx on this rank poisons this rank's part of the inertia, so g
  // (reduced over all ranks) says on every rank that the point is rejected, without a reduction
  // of its own.
  bool finite = true;
  if (grad) {
    const PetscScalar* dE;
    PetscInt n;
    PetscCall(VecGetLocalSize(grad, &n));
    PetscCall(VecGetArrayRead(grad, &dE));
    for (PetscInt i = 0; i < n; ++i) finite = finite && std::isfinite(dE[i]);
    PetscCall(VecRestoreArrayRead(grad, &dE));
  }
  PetscCall(inertia_.evaluate(x, !finite, &inertia));
  *g = inertia + solve_dt_ * solve_dt_ * E;  // the sum's order decides its bits
  if (rejected(*g)) {
    ++counts_->rejected;
    *g = kRejectedEnergy;
    if (grad) PetscCall(VecSet(grad, 0.0));
  } else if (grad) {
    PetscCall(VecAYPX(grad, solve_dt_ * solve_dt_, inertia_.gradient()));  // M (x - y) + h'^2 dE/dx
    PetscCall(body_.zero_held(grad));  // rollers: no solver moves a held slot
  }
  PetscCall(event_end(&LogEvents::objective));
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::force_scale(Vec x, double* scale) {
  double norm;
  PetscFunctionBeginUser;
  if (!has_inertia()) {  // no M (x - y): the forces acting are the loads' (begin_step)
    *scale = std::fmax(load_scale_, weight_scale_);
    PetscFunctionReturn(0);
  }
  PetscCall(inertia_.gradient_norm(x, &norm));
  *scale = std::fmax(norm, weight_scale_);
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::momentum(Vec v, std::array<double, 3>& P, double* mass_speed) const {
  const PetscScalar *m, *a;
  PetscInt n;
  double local[4] = {0, 0, 0, 0}, global[4];
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(v, &n));
  PetscCall(VecGetArrayRead(inertia_.mass(), &m));
  PetscCall(VecGetArrayRead(v, &a));
  for (PetscInt i = 0; i + 2 < n; i += 3) {  // a rank holds whole vertices (x, y, z interleaved)
    for (int c = 0; c < 3; ++c) local[c] += m[i + c] * a[i + c];
    local[3] += m[i] * std::sqrt(a[i] * a[i] + a[i + 1] * a[i + 1] + a[i + 2] * a[i + 2]);
  }
  PetscCall(VecRestoreArrayRead(v, &a));
  PetscCall(VecRestoreArrayRead(inertia_.mass(), &m));
  PetscCallMPI(MPI_Allreduce(local, global, 4, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)v)));
  P = {global[0], global[1], global[2]};
  *mass_speed = global[3];
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::assemble_constant_matrix(Mat* A, int components, ConstantMatrix kind) const {
  PetscFunctionBeginUser;
  PetscCheck(components == 1 || components == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "components must be 1 or 3");
  PetscCheck(kind == ConstantMatrix::laplacian || components == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE,
             "the rest stiffness and the volumetric H0 couple x, y and z: components must be 3");
  if (pattern_from_cells_ && components == 1) {
    PetscCall(create_vertex_matrix(body_.mesh(), A));
  } else {
    PetscCall(DMCreateMatrix(components == 3 ? body_.mesh().dm : body_.mesh().vertex_dm, A));
    PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  }
  PetscCall(add_in_rank_order(*A, [&](Mat S) {
    const double h2 = solve_dt_ * solve_dt_;
    return kind == ConstantMatrix::laplacian  ? body_.add_laplacian(S, h2, components)
           : kind == ConstantMatrix::volumetric ? body_.add_volumetric_h0(S, h2)
                                                : body_.add_rest_hessian(S, h2);
  }));
  PetscCall(inertia_.add_to(*A, components));
  // Rollers: A's held rows and columns are the identity's, so A^{-1} is the inverse of A reduced to
  // the other slots and maps a vector that is 0 at the held slots to one that is 0 there. A1 (x) I3
  // then no longer holds: the factor is of the full matrix (FactoredSystem).
  if (body_.holds_components()) {
    PetscCheck(components == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "with rollers the constant matrix has 3 components");
    PetscCall(body_.identity_at_held(*A));
  }
  PetscCall(MatSetOption(*A, MAT_SPD, PETSC_TRUE));
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::create_hessian(Mat* H) const {
  PetscFunctionBeginUser;
  PetscCall(DMCreateMatrix(body_.mesh().dm, H));
  // Self-contact couples vertices of no common element: assemble_hessian makes room for its pairs
  // (HessianPattern); a caller that adds them itself (tests) takes them as they come.
  PetscCall(MatSetOption(*H, MAT_NEW_NONZERO_ALLOCATION_ERR, body_.any_term(&EnergyTerm::couples_surfaces) ? PETSC_FALSE : PETSC_TRUE));
  PetscFunctionReturn(0);
}

PetscErrorCode StepObjective::assemble_hessian(Vec x, Mat H, bool exact) {
  PetscFunctionBeginUser;
  PetscCall(event_begin(&LogEvents::hessian));
  if (body_.any_term(&EnergyTerm::couples_surfaces)) {
    PetscCall(pattern_.grow(body_, x, H, &counts_->hessian_patterns));
    // A coupling the terms did not announce is an error, not a reallocation at each row.
    PetscCall(MatSetOption(H, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  }
  PetscCall(MatZeroEntries(H));  // keeps the pattern
  PetscCall(add_in_rank_order(H, [&](Mat S) { return body_.add_hessian(x, S, solve_dt_ * solve_dt_, !exact); }));
  PetscCall(inertia_.add_to(H));
  PetscCall(body_.identity_at_held(H));  // rollers: Newton's step is 0 at the held slots
  // Set after every assembly (new values may clear the flags). SPD makes MUMPS use LL^T.
  PetscCall(MatSetOption(H, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(H, MAT_SPD, exact ? PETSC_FALSE : PETSC_TRUE));
  PetscCall(event_end(&LogEvents::hessian));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

// One time step as a minimization over the free positions (model/time_integrator.hpp):
//   g(z) = 1/2 (z - y)^T M (z - y) + h'^2 E(z),   y = x^ + h' v^ + h'^2 a_gravity
// (the paper's 1/(2h^2)||x - y||_M^2 + E(x) times h^2 for implicit Euler, so g and grad g are in
// units of M x). The integrator gives h' = h or a fraction of it, x^ and v^, the fixed vertices'
// time during the solve and the end map to x_{n+1}, v_{n+1}; damping scales v_{n+1} by
// 1 - damping. g is the sum of its terms: the inertia (InertiaTerm) and h'^2 times the body's
// energy terms; the solvers see it through the Objective interface. The step around the solve
// (x_n, v_n, x^, v^, the end map, accept, undo) is the StepLifecycle's (model/step_lifecycle.hpp);
// begin_step and solve_step start and solve it. The simulation and the study both step with it.
// The frame's step h advances frames and time whatever h' is.
// The static integrator (Integrator::has_inertia false): g(z) = s^2 (E(z) - W_gravity(z)), a load
// step to the loads and fixed vertices of t_{n+1}; h' is the pseudo step s, which weighs M against
// s^2 L in H0 = (M + s^2 L)^{-1} and Newton's H (M only regularizes there), and nothing else.
#pragma once
#include <petscvec.h>

#include <array>
#include <cmath>
#include <memory>

#include "model/body.hpp"
#include "model/hessian_pattern.hpp"
#include "model/inertia_term.hpp"
#include "model/step_lifecycle.hpp"
#include "model/time_integrator.hpp"
#include "model/state.hpp"
#include "solvers/objective.hpp"
#include "solvers/solver_spec.hpp"  // WarmStart
#include "solvers/time_step_solver.hpp"

namespace hyperqn {

// How a step's solve went (see StepObjective::solve_step).
struct StepSolve {
  FrameResult result;
  PetscInt evaluations = 0;      // of g / grad g, over both solves if there were two
  double seconds = 0;            // wall time of the solve(s)
  bool restarted = false;        // g was not finite at y: solved again from x_n
  // The fallback chain (model/fallback_chain.hpp): iterations over every attempt, and which
  // stage produced the step. With sub-steps, velocity is the last sub-step's (for
  // StepLifecycle::accept).
  PetscInt iterations = 0;
  bool extended = false;         // iterated past the budget
  int substeps = 1;              // solved in this many sub-steps
  bool kept_substeps = false;    // started at the sub-step size of the frames before
  bool newton = false;           // solved by the Newton fallback
  bool unresolved = false;       // the chain's stages ran and none made the frame acceptable: flagged
  // And of those, the Newton fallback ended non-finite or unsound (an element past the element
  // limit, or inverted where x_n had none): in a static step, no equilibrium near (app/frame_step.cpp).
  bool newton_ran_away = false;
  // A stop signal ended the solve (solvers/stop_request.hpp): the frame is given up, and the
  // caller undoes the step; iterations and seconds are then those of every stage so far.
  bool interrupted = false;
  Vec velocity = nullptr;
  double min_J = 0, max_abs_J = 0;  // of the tets at the end, if measured (FallbackChain measures them)
  bool measured = false;
  // ||grad g|| / S at the end of the kept solve, S its force scale (Objective::force_scale); of
  // sub-steps, the largest. Measured by FallbackChain (0 otherwise).
  double residual = 0;
};

class StepObjective : public Objective {
 public:
  StepObjective(Body& body, double dt, const std::array<double, 3>& gravity, double damping = 0,
                WarmStart warm_start = WarmStart::inertial, bool upright_guess = true,
                double element_limit = 0, TimeIntegrator integrator = TimeIntegrator::implicit_euler,
                double pseudo_step = 0);
  ~StepObjective() override;
  StepObjective(const StepObjective&) = delete;
  StepObjective& operator=(const StepObjective&) = delete;
  PetscErrorCode setup();  // mass vector, work vectors
  // The same body and settings with h / parts (damping per sub-step so that `parts` of them damp
  // as one step does), set up: for the fallback chain's sub-steps.
  PetscErrorCode create_substep(int parts, std::unique_ptr<StepObjective>& sub) const;

  Body& body() { return body_; }
  double dt() const { return dt_; }  // a frame's step h (the solve's is h' = solve_dt_)
  double solve_dt() const { return solve_dt_; }  // h', for the static integrator the pseudo step s
  bool has_inertia() const { return life_.integrator().has_inertia(); }
  // The static integrator's automatic pseudo step: s^2 = kPseudoStepFactor N^(2/3) max_i m_i / L_ii
  // over the N free vertices (collective): M is at most 1/kPseudoStepFactor of s^2 L on the
  // diagonal, and of the body's slowest modes too (docs/method.md#time-integrators).
  static constexpr double kPseudoStepFactor = 1e8;
  // The range of a deck's time.pseudo_step, as a factor of the automatic one (LiveScene::build
  // refuses others): both ends measured on the static cantilever, 129 and 84 lbfgs iterations a
  // frame (docs/method.md).
  static constexpr double kPseudoStepRange[2] = {1e-4, 1e4};
  PetscErrorCode automatic_pseudo_step(double* s) const;
  const Integrator& integrator() const { return life_.integrator(); }
  // The step's x_n, v_n, x^, v^ and its end: accept, undo, keep and restore are the caller's.
  StepLifecycle& lifecycle() { return life_; }
  Vec mass() const { return inertia_.mass(); }

  // Starts the step from s (at t_n = s.frame h) to t_{n+1}: the lifecycle begins it (x_n, v_n
  // kept, the fixed vertices at the solve's time, x^ and v^), y is formed, the energy terms update
  // for the step, and s.x becomes the initial guess (y, or x_n).
  PetscErrorCode begin_step(State& s);
  // begin_step, then the solver from the initial guess; if g is not finite at y (e.g. y inverts
  // elements of a material without an extension), once more from x_n. For an integrator whose
  // end map extrapolates (the midpoint), an end that would invert or blow up a tet is replaced
  // by a second implicit Euler step of h' from z (complete_by_euler). Then lifecycle().accept or
  // lifecycle().undo.
  PetscErrorCode solve_step(TimeStepSolver& solver, State& s, const IterationCallback& on_iteration, StepSolve& out);

  // Objective: g of the current step.
  Vec layout() const override { return inertia_.mass(); }
  PetscErrorCode objective(Vec x, PetscReal* g, Vec grad) override;
  PetscInt evaluations() const override { return evaluations_; }
  void reset_evaluations() override { evaluations_ = 0; }
  // Both over the whole run, and shared with the sub-step integrators made from this one
  // (create_substep), so that they count the fallback chain's sub-steps too.
  PetscInt rejected_evaluations() const override { return counts_->rejected; }
  // Steps whose initial guess was pulled back from y towards x_n (upright_guess).
  long long pulled_back_guesses() const { return counts_->pulled_back; }
  // Steps of an extrapolating integrator (the midpoint) completed by implicit Euler (complete_by_euler).
  long long euler_completed_steps() const { return counts_->euler_completed; }
  // The run's counters (shared with the sub-step integrators) as they stand, and back to them: a
  // frame given up counts for nothing.
  struct RunCounts {
    PetscInt rejected = 0;
    long long pulled_back = 0;
    long long euler_completed = 0;
    long long hessian_patterns = 0;
  };
  RunCounts counts() const { return *counts_; }
  void restore_counts(const RunCounts& c) { *counts_ = c; }
  PetscErrorCode force_scale(Vec x, double* scale) override;
  // The free vertices' linear momentum P = sum m v at velocity v and their sum m |v| (one
  // reduction; collective).
  PetscErrorCode momentum(Vec v, std::array<double, 3>& P, double* mass_speed) const;
  double length_scale() const override { return diagonal_; }
  bool seeks_equilibrium() const override { return !has_inertia(); }
  bool bounds_steps() const override { return body_.any_term(&EnergyTerm::bounds_steps); }
  unsigned long long active_set() const override { return body_.active_set(); }
  PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const override { return body_.limit_step(x, dir, alpha); }
  bool has_vertex_stiffness() const override { return body_.any_term(&EnergyTerm::has_vertex_stiffness); }
  PetscErrorCode vertex_stiffness(std::vector<VertexStiffness>& out, Vec at = nullptr) const override {
    return body_.vertex_stiffness(at ? at : life_.x_n(), solve_dt_ * solve_dt_, out);
  }
  Vec step_start() const override { return life_.x_n(); }
  void tet_laplacians(std::vector<TetLaplacian>& out, double min_weight) const override {
    body_.tet_laplacians(solve_dt_ * solve_dt_, min_weight, out);
  }
  void tet_weight_range(double& softest, double& stiffest) const override { body_.tet_weight_range(softest, stiffest); }
  PetscErrorCode assemble_constant_matrix(Mat* A, int components = 3,
                                          ConstantMatrix kind = ConstantMatrix::laplacian) const override;
  // A scene rebuilt after a cut on one rank: the 1-component constant matrix takes its pattern from
  // the mesh's cells (create_vertex_matrix, the same pattern) instead of the DMPlex's preallocation.
  // Its sub-step integrators (create_substep) inherit this.
  void pattern_from_cells() { pattern_from_cells_ = true; }
  PetscErrorCode create_hessian(Mat* H) const override;
  PetscErrorCode assemble_hessian(Vec x, Mat H, bool exact = false) override;
  // Times a Hessian was preallocated again for couplings new to its pattern (HessianPattern), over
  // the run (shared with the sub-step integrators, as the counts above).
  long long hessian_patterns() const { return counts_->hessian_patterns; }
  bool projective_dynamics_exact() const override { return body_.projective_dynamics_exact(); }
  bool holds_components() const override { return body_.holds_components(); }
  std::string energy_names() const override { return body_.material_names(); }
  std::string inexact_energy_names() const override { return body_.inexact_names(); }

 private:
  // x = x_n + t (y - x_n), t the largest of 1, 1/2, 1/4, ... that leaves no tet upright at x_n
  // inverted, nor past det F = 100 unless it was (x_n itself if none within 30 halvings).
  PetscErrorCode upright_guess(Vec from, Vec x);
  // x = the initial guess of a step from `from` (solver.warm_start: y pulled back, `from`, or the
  // lower of the two).
  PetscErrorCode initial_guess(Vec from, Vec x);
  PetscErrorCode solve_from(TimeStepSolver& solver, Vec from, Vec x, const IterationCallback& on_iteration,
                            StepSolve& out);
  // For an integrator whose end map extrapolates past z: false if x_{n+1} would invert a tet that
  // is upright at z, or blow one past the element limit that is within it at z.
  PetscErrorCode end_is_sound(State& s, bool* sound);
  // objective(), with or without the contact terms (Body::energy_gradient).
  PetscErrorCode evaluate(Vec x, PetscReal* g, Vec grad, bool with_contact);
  PetscErrorCode springs_keep_energy(State& s, const std::vector<double>& z, bool* sound);
  // Ends such a step by a second implicit Euler step of h' from z instead (docs/method.md#time-integrators).
  PetscErrorCode complete_by_euler(TimeStepSolver& solver, State& s, const IterationCallback& on_iteration,
                                   StepSolve& out);
  Body& body_;
  double dt_;
  StepLifecycle life_;
  double solve_dt_;  // h' of the minimization: the integrator's solve_fraction() h, or static's s
  double pseudo_step_;  // static: the deck's s (0: automatic_pseudo_step)
  // Static: ||grad g|| at the rest positions (the fixed vertices where they are) at the step's
  // start, the forces acting (the loads, gravity, supports' displacements) in force_scale.
  double load_scale_ = 0;
  std::array<double, 3> gravity_;
  WarmStart warm_start_;
  bool upright_guess_;
  double element_limit_;  // -hyperqn_element_limit: the guess blows no tet past it (<= 0: no such test)
  InertiaTerm inertia_;  // 1/2 (x - y)^T M (x - y): M, y
  Vec work_ = nullptr;    // the initial guess's step from x_n
  Vec end_x_ = nullptr, end_v_ = nullptr;  // end_is_sound's x_{n+1}, v_{n+1}
  Vec kinetic_ = nullptr;                  // springs_keep_energy's M v
  std::vector<double> start_pos_;          // springs_keep_energy's x_n (local, fixed vertices at t_n)
  Vec rest_ = nullptr, rest_grad_ = nullptr;  // static: the rest positions and grad g there (load_scale_)
  PetscInt evaluations_ = 0;
  std::shared_ptr<RunCounts> counts_ = std::make_shared<RunCounts>();
  HessianPattern pattern_;  // Newton's H holds the couplings of the terms' lists
  std::vector<double> pos_, J_n_, J_;  // upright_guess's work space
  double weight_scale_ = 0;  // W of force_scale()
  double diagonal_ = 0;      // length_scale()
  bool pattern_from_cells_ = false;
};

}  // namespace hyperqn

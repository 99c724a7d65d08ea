// What a time-step solver minimizes: the integrator's g(x) over the free dofs, with its gradient,
// its Hessian, and the constant matrix A = M + h^2 L of the quasi-Newton methods. The solvers see
// only this (model/step_objective.hpp implements it).
#pragma once
#include <petscmat.h>

#include <string>
#include <vector>

#include "terms/energy_term.hpp"  // VertexStiffness, TetLaplacian

namespace hyperqn {

// The constant SPD matrix A of the quasi-Newton methods (the deck's solver.h0, docs/method.md):
// M + h^2 L with L the weighted Laplacian, or M + h^2 K(x_rest) with K the energy's Hessian at the
// rest shape (per-element PSD fix), which also sees the volumetric modes, or M + h^2 K_vol: a
// shear-weighted L plus a share of the rest divergence's volumetric stiffness.
enum class ConstantMatrix { laplacian, rest_stiffness, volumetric };

class Objective {
 public:
  virtual ~Objective() = default;

  // A template global vector of free dofs.
  virtual Vec layout() const = 0;
  // g(x) and, if grad is not null, its gradient. Counts evaluations.
  // Guardrail: if g or any entry of grad g is not finite (NaN/Inf), the point is *rejected*: g is
  // reported as kRejectedEnergy and grad g as 0, and the rejection is counted. kRejectedEnergy is
  // finite (TAO raises an error on a NaN/Inf objective in its monitor and at the initial point)
  // and larger than any real energy, so every sufficient-decrease test (TAO's More-Thuente and
  // Armijo, ours) rejects the point; a line search that accepts without a test (unit) is caught
  // by the solvers with rejected().
  virtual PetscErrorCode objective(Vec x, PetscReal* g, Vec grad) = 0;
  static constexpr double kRejectedEnergy = PETSC_MAX_REAL / 4;  // = PETSC_INFINITY, TAO's own "inf"
  static bool rejected(double g) { return !(g < kRejectedEnergy); }  // true for NaN too
  virtual PetscInt evaluations() const = 0;           // since reset_evaluations()
  virtual void reset_evaluations() = 0;
  virtual PetscInt rejected_evaluations() const = 0;  // over the whole run
  // The force scale of the solvers' stopping tests (solvers/frame_budget.hpp) at x:
  // S = max(||M (x - y)||, W), the impulse over the step of the forces acting (at the answer the
  // elastic forces balance M (x - y)), at least W, the body's own weight's (standard gravity, even
  // where the scene has none, so that a free body at rest has a scale too). Collective.
  virtual PetscErrorCode force_scale(Vec x, double* scale) = 0;
  // The rest bounding-box diagonal D of the body: the length scale of the same tests.
  virtual double length_scale() const = 0;
  // A static step's answer is the equilibrium itself: its frame is judged by its residual alone
  // (FrameBudget::far), not by how little its last iterations changed.
  virtual bool seeks_equilibrium() const { return false; }

  // Largest alpha <= *alpha such that x + alpha dir is admissible (energy terms that bound steps,
  // e.g. contact); bounds_steps() is false when no term does, and then nothing need be asked.
  // Asked by solvers/line_search.cpp's backtracking.
  virtual bool bounds_steps() const = 0;
  // A signature of the contact set at the last evaluated point (collective; 0 without contact).
  virtual unsigned long long active_set() const { return 0; }
  virtual PetscErrorCode limit_step(Vec x, Vec dir, double* alpha) const = 0;
  // h'^2 times the 3 x 3 diagonal blocks of d2E/dx2 at free vertices (contact, self-contact and
  // their friction) at the step's start x_n (or at `at`): this rank's vertices, by global dof
  // (solver.h0_contact; collective).
  virtual bool has_vertex_stiffness() const { return false; }  // false: vertex_stiffness is always empty
  virtual PetscErrorCode vertex_stiffness(std::vector<VertexStiffness>& out, Vec at = nullptr) const {
    (void)at;
    out.clear();
    return 0;
  }

  // The step's start x_n (null where the objective has none), and this rank's tets' parts of h^2 L
  // in A (solver.h0_rigid, solvers/rigid_mode_h0.hpp) of the tets whose weight is at least
  // min_weight, and the range of this rank's weights (softest, stiffest; unchanged without tets).
  virtual Vec step_start() const { return nullptr; }
  virtual void tet_laplacians(std::vector<TetLaplacian>& out, double /*min_weight*/) const { out.clear(); }
  virtual void tet_weight_range(double& /*softest*/, double& /*stiffest*/) const {}

  // Assembles A = M + h^2 L on the free dofs into a new matrix (once per scene). Since
  // A = A1 (x) I3, components = 1 assembles only the vertex matrix A1 = M1 + h^2 L1 (in the
  // vertex layout): a third of the rows, a ninth of the nonzeros. kind = rest_stiffness assembles
  // A = M + h^2 K(x_rest) instead, volumetric M + h^2 K_vol (components must be 3: both couple x, y and z).
  virtual PetscErrorCode assemble_constant_matrix(Mat* A, int components,
                                                  ConstantMatrix kind = ConstantMatrix::laplacian) const = 0;
  // A new matrix with the Hessian's nonzero pattern (the mesh's dof graph); inserting outside it
  // is an error, so the pattern, and hence a direct solver's symbolic analysis, never changes.
  virtual PetscErrorCode create_hessian(Mat* H) const = 0;
  // H = M + h^2 K(x) in place (K with the per-element PSD fix; exact = true: the true,
  // possibly indefinite Hessian of g). Flags H SPD (or only symmetric if exact).
  virtual PetscErrorCode assemble_hessian(Vec x, Mat H, bool exact) = 0;

  // True if some dofs are held (rollers, model/body.hpp): g's gradient is 0 there and the constant
  // matrix (assembled with 3 components) and the Hessian have identity rows and columns there.
  virtual bool holds_components() const { return false; }
  // True if every energy term is a Projective Dynamics energy with its own L (PD is then exact).
  virtual bool projective_dynamics_exact() const = 0;
  // The energy terms' names, for messages, e.g. "corotated, strand".
  virtual std::string energy_names() const = 0;
  // Those of them that are not (projective_dynamics_exact), for pd's message.
  virtual std::string inexact_energy_names() const { return energy_names(); }
};

}  // namespace hyperqn

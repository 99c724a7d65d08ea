// L-BFGS's initial inverse Hessian with the contacts in it (solver.h0_contact):
//   H0 = (A + K_c)^{-1},
// A = M + h^2 L the scene's factored constant matrix (A1 (x) I3) and K_c = h'^2 times the 3 x 3
// diagonal blocks of d2E/dx2 of obstacle contact, self-contact and their friction, per vertex
// (Objective::vertex_stiffness; obstacle contact's whole Hessian, self-contact's pairs without the
// blocks between their vertices), taken once per step, at its start.
//
// woodbury: with K_c = U C U^T (a column e_v (x) q per eigenpair (c, q) of a vertex's block, c > 0),
//   (A + U C U^T)^{-1} = A^{-1} - W S^{-1} W^T,  W = A^{-1} U C^{1/2},  S = I + C^{1/2} U^T A^{-1} U C^{1/2},
// where A^{-1} (e_v (x) q) = (A1^{-1} e_v) (x) q: one scalar column z_v = A1^{-1} e_v per vertex in
// contact, three of them per solve of A (one in each of x, y, z), computed again only when the set of
// vertices changes; S (dense, one row per column of U) is factored every step. A solve is then A's
// and O(n k) more (k vertices in contact).
// refactor: A + D_c factored anew (FactoredSystem::setup) whenever D_c changes, D_c the diagonal of
// the blocks' mean eigenvalues (trace / 3, so that it stays D1 (x) I3) rounded to powers of 2, so
// that H0 is a function of x_n alone and a resting contact keeps its factor.
//
// Either way, a step whose vertices have no contact stiffness is solved by A^{-1} itself.
#pragma once
#include <petscmat.h>

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "solvers/factored_system.hpp"
#include "solvers/objective.hpp"
#include "solvers/solver_spec.hpp"

namespace hyperqn {

// What refactor puts on a vertex's diagonal: its block's mean eigenvalue (trace / 3) rounded to the
// nearest power of 2 in log scale (from 2^(k - 1/2) up: 2^k); 0 if it is not positive.
double rounded_mean_stiffness(const VertexStiffness& s);
// refactor leaves out a vertex whose rounded stiffness is below this fraction of A's diagonal there.
constexpr double kNegligibleStiffness = 1.0 / 64;

class ContactH0 {
 public:
  // h0: the scene's factored A of the Laplacian kind (A1 (x) I3).
  ContactH0(const Objective& step, const FactoredSystem& h0, H0Contact mode);
  ~ContactH0();
  ContactH0(const ContactH0&) = delete;
  ContactH0& operator=(const ContactH0&) = delete;
  PetscErrorCode setup();  // the shell matrix
  // Takes K_c at the step's start, or at `at` (a static step's resumed iterate; collective).
  PetscErrorCode update(Vec at = nullptr);
  // x = (A + K_c)^{-1} b; y = (A + K_c) x.
  PetscErrorCode solve(Vec b, Vec x) const;
  PetscErrorCode mult(Vec x, Vec y) const;
  // MatSolve: solve, MatMult: mult (the form TaoLMVMSetH0 takes).
  Mat inverse_operator() const { return shell_; }
  // Vertices with contact stiffness in H0 at the last update (over all ranks), and A's solves and
  // factorizations spent on the corrections so far.
  PetscInt vertices() const { return vertices_; }
  long long column_solves() const { return column_solves_; }
  int refactorizations() const { return refactorizations_; }

 private:
  PetscErrorCode gather(const std::vector<VertexStiffness>& local);  // blocks_ over all ranks
  PetscErrorCode update_woodbury(bool same_vertices);
  PetscErrorCode update_refactor(const std::vector<VertexStiffness>& local);
  PetscErrorCode compute_columns();  // Z_ and G_ for blocks_' vertices

  const Objective& step_;
  const FactoredSystem& h0_;
  H0Contact mode_;
  Mat shell_ = nullptr;
  Vec b_ = nullptr, x_ = nullptr;  // work
  PetscInt lo_ = 0, local_ = 0;     // this rank's first dof and its dofs
  std::vector<VertexStiffness> blocks_;  // woodbury: every rank's, by global dof
  PetscInt vertices_ = 0;                // with a block, over all ranks
  bool active_ = false;                  // blocks_ not empty: the correction applies
  // woodbury: Z_ (local vertices x k, by columns) = A1^{-1} e_v, G_ = its rows of the k vertices
  // (k x k, the same on every rank); per column of U its vertex, direction q and sqrt(c); S's factor.
  Eigen::MatrixXd Z_, G_;
  std::vector<int> column_vertex_;
  std::vector<Eigen::Vector3d> column_direction_;
  Eigen::VectorXd column_scale_;
  Eigen::LLT<Eigen::MatrixXd> S_;
  std::unique_ptr<FactoredSystem> refactored_;  // refactor
  CholeskyAnalysis analysis_;                   // refactor: the pattern of A + D_c, analysed once
  std::vector<std::pair<PetscInt, double>> factored_diagonal_;  // refactor: this rank's (dof, rounded stiffness)
  std::vector<double> a_diagonal_;                              // refactor: A's diagonal at this rank's dofs
  long long column_solves_ = 0;
  int refactorizations_ = 0;
};

}  // namespace hyperqn

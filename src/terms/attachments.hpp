// Soft attachments: zero-rest-length springs pulling vertices towards targets,
// E = sum_i k_i/2 |x_i - p_i(t)|^2, p_i(t) = moved(motion, X_i, t) with X_i the rest position.
// Quadratic with a constant Hessian k_i I, which is also its part of L: Projective Dynamics stays
// exact, and A = M + h^2 L holds the springs. No mass.
#pragma once
#include <vector>

#include "geometry/motion.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

// The springs of one attachment on this rank: the same stiffness and target motion for all.
struct AttachedVertices {
  std::vector<PetscInt> vertices;  // local vertices this rank owns and that are free
  double stiffness = 0;            // k per vertex (N/m)
  Motion motion;                   // of the targets (none: the rest positions)
};

class Attachments : public EnergyTerm {
 public:
  // groups: every vertex listed once per group, owned by this rank (each spring on one rank only,
  // since the body sums the ghosts' gradients) and free.
  Attachments(const DistributedMesh& mesh, std::vector<AttachedVertices> groups);
  std::string name() const override { return "attachments"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  bool projective_dynamics_exact() const override { return true; }
  // Targets at t, the end of the step.
  PetscErrorCode begin_step(const StepStart& step) override;

 private:
  const DistributedMesh& mesh_;
  std::vector<AttachedVertices> groups_;
  std::vector<std::vector<Eigen::Vector3d>> targets_;  // per group, per vertex: p_i(t)
  void move_targets(double t);
};

}  // namespace hyperqn

#include "terms/attachments.hpp"

#include "terms/element_kernels.hpp"

namespace hyperqn {

Attachments::Attachments(const DistributedMesh& mesh, std::vector<AttachedVertices> groups)
    : mesh_(mesh), groups_(std::move(groups)) {
  move_targets(0.0);
}

void Attachments::move_targets(double t) {
  targets_.resize(groups_.size());
  for (size_t g = 0; g < groups_.size(); ++g) {
    const AttachedVertices& group = groups_[g];
    targets_[g].resize(group.vertices.size());
    for (size_t i = 0; i < group.vertices.size(); ++i)
      targets_[g][i] = moved(group.motion, Vec3(&mesh_.rest[3 * group.vertices[i]]), t);
  }
}

PetscErrorCode Attachments::begin_step(const StepStart& step) {
  move_targets(step.t);
  return 0;
}

PetscErrorCode Attachments::add_energy(Vec, const std::vector<double>& pos, double* energy,
                                       PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e = *energy;
  for (size_t g = 0; g < groups_.size(); ++g) {
    const double k = groups_[g].stiffness;
    for (size_t i = 0; i < groups_[g].vertices.size(); ++i) {
      const PetscInt v = groups_[g].vertices[i];
      const Vec3 u = Vec3(&pos[3 * v]) - targets_[g][i];
      e += 0.5 * k * u.squaredNorm();
      if (gradient) add_vertex_vector(mesh_, v, k * u, gradient);
    }
  }
  *energy = e;
  PetscFunctionReturn(0);
}

// k I per vertex, whatever the positions: the same matrix as add_laplacian.
PetscErrorCode Attachments::add_hessian(const std::vector<double>&, Mat H, double scale, bool) const {
  PetscFunctionBeginUser;
  PetscCall(add_laplacian(H, scale, 3));
  PetscFunctionReturn(0);
}

PetscErrorCode Attachments::add_laplacian(Mat A, double scale, int components) const {
  PetscFunctionBeginUser;
  for (const AttachedVertices& group : groups_) {
    const Eigen::Matrix<double, 1, 1, Eigen::RowMajor> Le(scale * group.stiffness);
    for (PetscInt v : group.vertices) PetscCall(add_element_laplacian<1>(mesh_, A, &v, Le, components));
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "terms/strand_segments.hpp"

#include "materials/spring.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

StrandSegments::StrandSegments(const DistributedMesh& mesh, double axial_stiffness, double linear_density,
                               double laplacian_weight)
    : mesh_(mesh),
      axial_stiffness_(axial_stiffness),
      linear_density_(linear_density),
      weight_(laplacian_weight > 0 ? laplacian_weight : axial_stiffness),
      springs_(mesh) {
  for (PetscInt s = 0; s < mesh.num_segments; ++s) {
    const PetscInt* seg = &mesh.segments[2 * s];
    const double L = segment_edge(mesh.rest.data(), seg).norm();
    springs_.add(seg[0], seg[1], L, axial_stiffness / L);
  }
}

PetscErrorCode StrandSegments::add_energy(Vec, const std::vector<double>& pos, double* energy,
                                          PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  springs_.add_energy(pos.data(), energy, gradient);
  PetscFunctionReturn(0);
}

PetscErrorCode StrandSegments::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> Ks;  // d2E/dx2 for x = (x_a, x_b): [K -K; -K K]
  PetscInt idx[6];
  PetscFunctionBeginUser;
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const PetscInt* seg = &mesh_.segments[2 * s];
    const Mat3 K = scale * spring::stiffness(segment_edge(pos.data(), seg), springs_.rest_length(s), springs_.stiffness(s), psd);
    Ks << K, -K, -K, K;
    element_dofs<2>(mesh_, seg, idx);
    PetscCall(MatSetValues(H, 6, idx, 6, idx, Ks.data(), ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

// A segment's spring k = EA / L: its L is exact, as for the mass-spring tets.
PetscErrorCode StrandSegments::add_laplacian(Mat A, double scale, int components) const {
  PetscFunctionBeginUser;
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const double k = scale * weight_ / springs_.rest_length(s);
    Eigen::Matrix<double, 2, 2, Eigen::RowMajor> Le;
    Le << k, -k, -k, k;
    PetscCall(add_element_laplacian<2>(mesh_, A, &mesh_.segments[2 * s], Le, components));
  }
  PetscFunctionReturn(0);
}

void StrandSegments::add_lumped_mass(PetscScalar* mass) const {
  for (PetscInt s = 0; s < mesh_.num_segments; ++s)
    for (int j = 0; j < 2; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.segments[2 * s + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += 0.5 * linear_density_ * springs_.rest_length(s);
    }
}

double StrandSegments::local_mass() const {
  double m = 0;
  for (size_t s = 0; s < springs_.size(); ++s) m += linear_density_ * springs_.rest_length(s);
  return m;
}

}  // namespace hyperqn

#include "terms/strand_segments.hpp"

#include "materials/spring.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

StrandSegments::StrandSegments(const DistributedMesh& mesh, double axial_stiffness, double linear_density,
                               double laplacian_weight)
    : mesh_(mesh),
      axial_stiffness_(axial_stiffness),
      linear_density_(linear_density),
      weight_(laplacian_weight > 0 ? laplacian_weight : axial_stiffness) {
  length_.resize(mesh.num_segments);
  for (PetscInt s = 0; s < mesh.num_segments; ++s) length_[s] = segment_edge(mesh.rest.data(), &mesh.segments[2 * s]).norm();
}

PetscErrorCode StrandSegments::add_energy(Vec, const std::vector<double>& pos, double* energy,
                                          PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e = *energy;
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const PetscInt* seg = &mesh_.segments[2 * s];
    const Vec3 u = segment_edge(pos.data(), seg);
    const double L = length_[s], k = axial_stiffness_ / L;
    e += spring::energy(u, L, k);
    if (!gradient) continue;
    const Vec3 f = spring::gradient(u, L, k);  // dE/dx_b; dE/dx_a = -f
    add_vertex_vector(mesh_, seg[0], -f, gradient);
    add_vertex_vector(mesh_, seg[1], f, gradient);
  }
  *energy = e;
  PetscFunctionReturn(0);
}

PetscErrorCode StrandSegments::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> Ks;  // d2E/dx2 for x = (x_a, x_b): [K -K; -K K]
  PetscInt idx[6];
  PetscFunctionBeginUser;
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const PetscInt* seg = &mesh_.segments[2 * s];
    const double L = length_[s];
    const Mat3 K = scale * spring::stiffness(segment_edge(pos.data(), seg), L, axial_stiffness_ / L, psd);
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
    const double k = scale * weight_ / length_[s];
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
      for (int d = 0; d < 3; ++d) mass[off + d] += 0.5 * linear_density_ * length_[s];
    }
}

double StrandSegments::local_mass() const {
  double m = 0;
  for (double L : length_) m += linear_density_ * L;
  return m;
}

}  // namespace hyperqn

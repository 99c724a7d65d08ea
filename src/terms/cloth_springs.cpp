#include "terms/cloth_springs.hpp"

#include "materials/spring.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

ClothSprings::ClothSprings(const DistributedMesh& mesh, double stiffness)
    : mesh_(mesh), k_(stiffness), springs_(mesh) {
  for (PetscInt t = 0; t < mesh.num_triangles; ++t)
    for (int e = 0; e < 3; ++e)
      if (mesh.triangle_edges[t] & (1u << e)) {
        const PetscInt ab[2] = {mesh.triangles[3 * t + e], mesh.triangles[3 * t + (e + 1) % 3]};
        springs_.add(ab[0], ab[1], segment_edge(mesh.rest.data(), ab).norm(), stiffness);
      }
}

PetscErrorCode ClothSprings::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  springs_.add_energy(pos.data(), energy, gradient);
  PetscFunctionReturn(0);
}

PetscErrorCode ClothSprings::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 6, 6> Ks;
  PetscFunctionBeginUser;
  for (size_t s = 0; s < springs_.size(); ++s) {
    const std::array<PetscInt, 2> ab = springs_.ends(s);
    const Mat3 K = spring::stiffness(segment_edge(pos.data(), ab.data()), springs_.rest_length(s), k_, psd);
    Ks << K, -K, -K, K;
    PetscCall(add_element_hessian<2>(mesh_, H, ab.data(), Ks, scale));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ClothSprings::add_laplacian(Mat A, double scale, int components) const {
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> Le;
  Le << 1, -1, -1, 1;
  Le *= scale * k_;
  PetscFunctionBeginUser;
  for (size_t s = 0; s < springs_.size(); ++s)
    PetscCall(add_element_laplacian<2>(mesh_, A, springs_.ends(s).data(), Le, components));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

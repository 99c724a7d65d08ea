#include "terms/cloth_springs.hpp"

#include "materials/spring.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

ClothSprings::ClothSprings(const DistributedMesh& mesh, double stiffness) : mesh_(mesh), k_(stiffness) {
  for (PetscInt t = 0; t < mesh.num_triangles; ++t)
    for (int e = 0; e < 3; ++e)
      if (mesh.triangle_edges[t] & (1u << e)) {
        const std::array<PetscInt, 2> ab{mesh.triangles[3 * t + e], mesh.triangles[3 * t + (e + 1) % 3]};
        edges_.push_back(ab);
        length_.push_back(segment_edge(mesh.rest.data(), ab.data()).norm());
      }
}

PetscErrorCode ClothSprings::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e = *energy;
  for (size_t s = 0; s < edges_.size(); ++s) {
    const Vec3 u = segment_edge(pos.data(), edges_[s].data());
    e += spring::energy(u, length_[s], k_);
    if (!gradient) continue;
    const Vec3 f = spring::gradient(u, length_[s], k_);  // dE/dx_b; dE/dx_a = -f
    add_vertex_vector(mesh_, edges_[s][0], -f, gradient);
    add_vertex_vector(mesh_, edges_[s][1], f, gradient);
  }
  *energy = e;
  PetscFunctionReturn(0);
}

PetscErrorCode ClothSprings::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 6, 6> Ks;
  PetscFunctionBeginUser;
  for (size_t s = 0; s < edges_.size(); ++s) {
    const Mat3 K = spring::stiffness(segment_edge(pos.data(), edges_[s].data()), length_[s], k_, psd);
    Ks << K, -K, -K, K;
    PetscCall(add_element_hessian<2>(mesh_, H, edges_[s].data(), Ks, scale));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ClothSprings::add_laplacian(Mat A, double scale, int components) const {
  Eigen::Matrix<double, 2, 2, Eigen::RowMajor> Le;
  Le << 1, -1, -1, 1;
  Le *= scale * k_;
  PetscFunctionBeginUser;
  for (const auto& ab : edges_) PetscCall(add_element_laplacian<2>(mesh_, A, ab.data(), Le, components));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "terms/cloth_springs.hpp"

#include "terms/element_kernels.hpp"

namespace hyperqn {

ClothSprings::ClothSprings(const DistributedMesh& mesh, double stiffness, const std::vector<PetscInt>& triangles,
                           const SpringYield& yield, const std::string& state)
    : mesh_(mesh), k_(stiffness), springs_(mesh) {
  for (PetscInt t : triangles)
    for (int e = 0; e < 3; ++e)
      if (mesh.triangle_edges[t] & (1u << e)) {
        const PetscInt ab[2] = {mesh.triangles[3 * t + e], mesh.triangles[3 * t + (e + 1) % 3]};
        const bool torn = mesh.triangle_edges[t] & (1u << (kTornEdgeBit + e));  // one side of a torn edge: half
        springs_.add(ab[0], ab[1], segment_edge(mesh.rest.data(), ab).norm(), torn ? 0.5 * stiffness : stiffness,
                     edge_spring_id(mesh.triangle_ids[t], e));
      }
  springs_.arrange();
  if (yield.active()) {
    springs_.set_yield(yield, state);
    springs_.element_state()->set_inherited(yielding_spring::kInherited);  // a torn edge's second half
  }
}

PetscErrorCode ClothSprings::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  springs_.add_energy(pos.data(), energy, gradient);
  PetscFunctionReturn(0);
}

PetscErrorCode ClothSprings::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  return springs_.add_hessian(pos.data(), H, scale, psd);
}

PetscErrorCode ClothSprings::add_laplacian(Mat A, double scale, int components) const {
  return springs_.add_laplacian(A, scale, components);
}

}  // namespace hyperqn

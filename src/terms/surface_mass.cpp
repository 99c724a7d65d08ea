#include "terms/surface_mass.hpp"

#include "terms/element_kernels.hpp"

namespace hyperqn {

SurfaceMass::SurfaceMass(const DistributedMesh& mesh, double areal_density) : mesh_(mesh), density_(areal_density) {
  area_.resize(mesh.num_triangles);
  for (PetscInt t = 0; t < mesh.num_triangles; ++t) area_[t] = triangle_area(mesh.rest.data(), &mesh.triangles[3 * t]);
}

void SurfaceMass::add_lumped_mass(PetscScalar* mass) const {
  for (PetscInt t = 0; t < mesh_.num_triangles; ++t)
    for (int j = 0; j < 3; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.triangles[3 * t + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += density_ * area_[t] / 3.0;
    }
}

double SurfaceMass::local_mass() const {
  double m = 0;
  for (double a : area_) m += density_ * a;
  return m;
}

}  // namespace hyperqn

#include "terms/surface_mass.hpp"

#include "terms/element_kernels.hpp"

namespace hyperqn {

SurfaceMass::SurfaceMass(const DistributedMesh& mesh, double areal_density, std::vector<PetscInt> triangles)
    : mesh_(mesh), density_(areal_density), triangles_(std::move(triangles)) {
  // From the rest shape before any torn edge opened (mass_rest): the total mass stays the deck's.
  for (PetscInt t : triangles_) area_.push_back(triangle_area(mass_rest(mesh), &mesh.triangles[3 * t]));
}

void SurfaceMass::add_lumped_mass(PetscScalar* mass) const {
  for (size_t i = 0; i < triangles_.size(); ++i)
    for (int j = 0; j < 3; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.triangles[3 * triangles_[i] + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += density_ * area_[i] / 3.0;
    }
}

double SurfaceMass::local_mass() const {
  double m = 0;
  for (double a : area_) m += density_ * a;
  return m;
}

}  // namespace hyperqn

// The mass of a cloth: areal density x rest area of each triangle, lumped a third to each of its
// vertices. No energy: the cloth's stretching and bending terms carry that, so either model of
// each may be chosen without moving the mass. Over the triangles its builder hands it (a body's:
// body_elements; a scene of bodies gives each cloth its own terms).
#pragma once
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

class SurfaceMass : public EnergyTerm {
 public:
  SurfaceMass(const DistributedMesh& mesh, double areal_density, std::vector<PetscInt> triangles);
  std::string name() const override { return "cloth mass"; }
  PetscErrorCode add_energy(Vec, const std::vector<double>&, double*, PetscScalar*) const override { return 0; }
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  void add_lumped_mass(PetscScalar* mass) const override;
  double local_mass() const override;
  bool projective_dynamics_exact() const override { return true; }

 private:
  const DistributedMesh& mesh_;
  double density_;
  std::vector<PetscInt> triangles_;  // its local triangles
  std::vector<double> area_;         // per triangle of triangles_: rest area
};

}  // namespace hyperqn

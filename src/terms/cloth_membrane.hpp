// A cloth's in-plane elasticity as a triangle-FEM membrane: E = sum_t A_t psi(F_t), F the 3x2
// deformation gradient of the triangle, psi StVK, corotated or Neo-Hookean in the 2-D Lame
// constants (materials/membrane.hpp). Its weight in L is the rest stiffness of the in-plane modes
// (2 mu + lambda) times the triangle's cotangent Laplacian; not exact, so PD is not offered.
// Over the triangles its builder hands it (a body's: body_elements).
#pragma once
#include <string>
#include <vector>

#include "materials/membrane.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"
#include "terms/midpoint_defect.hpp"

namespace hyperqn {

class ClothMembrane : public EnergyTerm {
 public:
  ClothMembrane(const DistributedMesh& mesh, membrane::Model model, double mu, double lambda, std::vector<PetscInt> triangles);
  std::string name() const override { return "cloth membrane"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  bool projective_dynamics_exact() const override { return false; }
  // membrane_stress: each triangle's Cauchy stress (membrane::cauchy_stress), a force per length.
  std::vector<ElementField> element_fields() const override { return {ElementField::membrane_stress}; }
  void fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const override;
  // The implicit midpoint's energy test, from its energy (terms/midpoint_defect.hpp).
  bool has_midpoint_defect() const override { return true; }
  void add_midpoint_defect(const std::vector<double>& start, const std::vector<double>& z, const std::vector<double>& end,
                           double* defect, double* scale) const override {
    midpoint_defect_by_energy(*this, start, z, end, defect, scale);
  }

 private:
  const DistributedMesh& mesh_;
  membrane::Model model_;
  double mu_, lambda_;
  std::vector<PetscInt> triangles_;            // its local triangles
  std::vector<membrane::TriangleRest> rest_;  // per triangle of triangles_
};

}  // namespace hyperqn

// A cloth's bending, one element per hinge (an interior edge a-b with the vertices c, d opposite
// it; DistributedMesh::hinges), in one of three models:
//   springs    a spring k/2 (l - L)^2 between c and d (Liu et al. 2013); exact in L;
//   quadratic  E = k/2 |sum_i w_i x_i|^2 3/(A1 + A2), w the cotangent weights of the rest hinge
//              (Bergou et al. 2006): constant Hessian, so exact in L; for flat rest shapes;
//   dihedral   E = k (theta - theta0)^2 3|e|^2/(A1 + A2), theta the dihedral angle (Grinspun et
//              al. 2003): large folds and curved rest shapes; the quadratic model's matrix is its
//              weight in L (its Hessian at a flat rest state), not exact.
// materials/hinge_bending.hpp holds the per-hinge formulas. Over the hinges its builder hands it
// (a body's: body_elements).
#pragma once
#include <array>
#include <string>
#include <vector>

#include "materials/cloth_models.hpp"
#include "materials/hinge_bending.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"
#include "terms/midpoint_defect.hpp"
#include "terms/spring_set.hpp"

namespace hyperqn {

class ClothBending : public EnergyTerm {
 public:
  // model: not none (a cloth without bending has no bending term).
  ClothBending(const DistributedMesh& mesh, BendingModel model, double stiffness, std::vector<PetscInt> hinges,
               const SpringYield& yield = {}, const std::string& state = "");
  std::string name() const override;
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  // The springs' unflowed (their history at its start); the hinges' have none.
  PetscErrorCode add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const override;
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  bool projective_dynamics_exact() const override { return model_ != BendingModel::dihedral && !springs_.yields(); }
  ElementState* element_state() override { return springs_.element_state(); }
  PetscErrorCode update_state(const std::vector<double>& pos) override {
    springs_.update_state(pos.data());
    return 0;
  }
  double dissipated_energy() const override { return springs_.dissipated_energy(); }
  // The springs' in closed form, the hinges' from their energy (terms/midpoint_defect.hpp).
  bool has_midpoint_defect() const override { return true; }
  void add_midpoint_defect(const std::vector<double>& start, const std::vector<double>& z, const std::vector<double>& end,
                           double* defect, double* scale) const override {
    if (model_ == BendingModel::springs)
      springs_.add_midpoint_defect(start.data(), z.data(), end.data(), defect, scale);
    else
      midpoint_defect_by_energy(*this, start, z, end, defect, scale);
  }

 private:
  const DistributedMesh& mesh_;
  BendingModel model_;
  double k_;
  std::vector<PetscInt> hinges_;  // its local hinges
  // Per hinge of hinges_: springs: the spring c-d (spring i is hinge i's); quadratic and dihedral:
  // the cotangent weights and 3 / (A1 + A2); dihedral: its rest angle and weight.
  SpringSet springs_;
  std::vector<std::array<double, 4>> weights_;
  std::vector<double> coefficient_;
  std::vector<hinge::HingeRest> rest_;
};

}  // namespace hyperqn

// Volumetric mass-spring bodies: a spring of stiffness k_m along each of a tet's 6 edges
// (materials/tet_springs.hpp), as an energy per element of F. Its L is the springs' own
// (weight k_m), so with that weight Projective Dynamics is exact.
#pragma once
#include "terms/tet_elements.hpp"

namespace hyperqn {

class MassSpringTets : public TetElements {
 public:
  // stiffness[m] > 0 for the materials of this term (0 where another term holds the cells);
  // weight[m] its weight in L; density[m] its mass per rest volume.
  MassSpringTets(const DistributedMesh& mesh, std::vector<double> stiffness, std::vector<double> weight,
                 std::vector<double> density);
  std::string name() const override { return "mass-spring"; }
  bool projective_dynamics_exact() const override;

 private:
  double element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const override;
  Mat9 element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const override;
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> element_laplacian(PetscInt k, int m, double scale) const override;

  std::vector<double> stiffness_, weight_;
  std::vector<Mat3> Dm_;  // per element: rest edge matrix (the springs' rest lengths)
};

}  // namespace hyperqn

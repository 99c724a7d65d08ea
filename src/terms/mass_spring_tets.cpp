#include "terms/mass_spring_tets.hpp"

#include "materials/tet_springs.hpp"

namespace hyperqn {

MassSpringTets::MassSpringTets(const DistributedMesh& mesh, std::vector<double> stiffness, std::vector<double> weight,
                               std::vector<double> density)
    : TetElements(mesh, cells_where(mesh, [&](int m) { return stiffness[m] > 0; }), std::move(density), false),
      stiffness_(std::move(stiffness)),
      weight_(std::move(weight)) {
  Dm_.reserve(cells_.size());
  for (PetscInt c : cells_) Dm_.push_back(edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]));
}

bool MassSpringTets::projective_dynamics_exact() const {
  for (size_t m = 0; m < stiffness_.size(); ++m)
    if (stiffness_[m] > 0 && weight_[m] != stiffness_[m]) return false;
  return true;
}

double MassSpringTets::element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const {
  return P ? tet_springs::energy_and_stress(F, Dm_[k], stiffness_[m], *P) : tet_springs::energy(F, Dm_[k], stiffness_[m]);
}

Mat9 MassSpringTets::element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const {
  return tet_springs::stress_derivative(F, Dm_[k], stiffness_[m], psd);
}

Eigen::Matrix<double, 4, 4, Eigen::RowMajor> MassSpringTets::element_laplacian(PetscInt, int m, double scale) const {
  return (scale * tet_springs::laplacian(weight_[m])).eval();
}

}  // namespace hyperqn

#include "terms/cloth_bending.hpp"

#include <stdexcept>

#include "terms/element_kernels.hpp"

namespace hyperqn {

std::string ClothBending::name() const {
  switch (model_) {
    case BendingModel::springs: return "bending springs";
    case BendingModel::quadratic: return "quadratic bending";
    default: return "dihedral bending";  // (none builds no term)
  }
}

ClothBending::ClothBending(const DistributedMesh& mesh, BendingModel model, double stiffness, std::vector<PetscInt> hinges)
    : mesh_(mesh), model_(model), k_(stiffness), hinges_(std::move(hinges)), springs_(mesh) {
  const double* X = mesh.rest.data();
  for (PetscInt h : hinges_) {
    const PetscInt* v = &mesh.hinges[4 * h];
    if (model == BendingModel::springs) {
      const PetscInt cd[2] = {v[2], v[3]};
      springs_.add(cd[0], cd[1], segment_edge(X, cd).norm(), stiffness);
      continue;
    }
    const Vec3 x0(&X[3 * v[0]]), x1(&X[3 * v[1]]), x2(&X[3 * v[2]]), x3(&X[3 * v[3]]);
    weights_.push_back(hinge::quadratic_weights(x0, x1, x2, x3));
    coefficient_.push_back(hinge::quadratic_coefficient(x0, x1, x2, x3));
    if (model == BendingModel::dihedral) rest_.push_back(hinge::hinge_rest(x0, x1, x2, x3));
  }
  springs_.arrange();
}

PetscErrorCode ClothBending::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  if (model_ == BendingModel::springs) {
    springs_.add_energy(pos.data(), energy, gradient);
    PetscFunctionReturn(0);
  }
  double e = *energy;
  for (size_t h = 0; h < hinges_.size(); ++h) {
    const PetscInt* v = &mesh_.hinges[4 * hinges_[h]];
    if (model_ == BendingModel::quadratic) {
      const hinge::Vec12 x = element_positions<4>(pos.data(), v);
      if (!gradient) {
        e += hinge::quadratic_energy(k_, weights_[h], coefficient_[h], x);
        continue;
      }
      hinge::Vec12 g;
      e += hinge::quadratic_energy_gradient(k_, weights_[h], coefficient_[h], x, g);
      add_element_vector<4>(mesh_, v, g, gradient);
    } else {
      const hinge::Vec12 x = element_positions<4>(pos.data(), v);
      if (!gradient) {
        e += hinge::dihedral_energy(k_, rest_[h], x);
        continue;
      }
      hinge::Vec12 g;
      e += hinge::dihedral_energy_gradient(k_, rest_[h], x, g);
      add_element_vector<4>(mesh_, v, g, gradient);
    }
  }
  *energy = e;
  PetscFunctionReturn(0);
}

PetscErrorCode ClothBending::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  PetscFunctionBeginUser;
  if (model_ == BendingModel::springs) {
    PetscCall(springs_.add_hessian(pos.data(), H, scale, psd));
    PetscFunctionReturn(0);
  }
  for (size_t h = 0; h < hinges_.size(); ++h) {
    const PetscInt* v = &mesh_.hinges[4 * hinges_[h]];
    if (model_ == BendingModel::quadratic) {
      const hinge::Mat12 He = hinge::quadratic_hessian(k_, weights_[h], coefficient_[h]);
      PetscCall(add_element_hessian<4>(mesh_, H, v, He, scale));
    } else {
      const hinge::Mat12 He = hinge::dihedral_hessian(k_, rest_[h], element_positions<4>(pos.data(), v), psd);
      PetscCall(add_element_hessian<4>(mesh_, H, v, He, scale));
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ClothBending::add_laplacian(Mat A, double scale, int components) const {
  PetscFunctionBeginUser;
  if (model_ == BendingModel::springs) {
    PetscCall(springs_.add_laplacian(A, scale, components));
    PetscFunctionReturn(0);
  }
  for (size_t h = 0; h < hinges_.size(); ++h) {
    const PetscInt* v = &mesh_.hinges[4 * hinges_[h]];
    const Eigen::Map<const Eigen::Vector4d> w(weights_[h].data());
    const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> Le = scale * k_ * coefficient_[h] * w * w.transpose();
    PetscCall(add_element_laplacian<4>(mesh_, A, v, Le, components));
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

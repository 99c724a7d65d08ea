#include "terms/cloth_membrane.hpp"

#include <stdexcept>

#include "terms/element_kernels.hpp"

namespace hyperqn {

ClothMembrane::ClothMembrane(const DistributedMesh& mesh, membrane::Model model, double mu, double lambda,
                             std::vector<PetscInt> triangles)
    : mesh_(mesh), model_(model), mu_(mu), lambda_(lambda), triangles_(std::move(triangles)) {
  rest_.reserve(triangles_.size());
  for (PetscInt t : triangles_) {
    const PetscInt* tri = &mesh.triangles[3 * t];
    const double* X = mesh.rest.data();
    rest_.push_back(membrane::rest(Vec3(&X[3 * tri[0]]), Vec3(&X[3 * tri[1]]), Vec3(&X[3 * tri[2]])));
  }
}

PetscErrorCode ClothMembrane::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e = *energy;
  membrane::Vec9 g;
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const PetscInt* tri = &mesh_.triangles[3 * triangles_[i]];
    const membrane::Vec9 x = element_positions<3>(pos.data(), tri);
    if (!gradient) {
      e += membrane::energy(model_, mu_, lambda_, rest_[i], x);
      continue;
    }
    e += membrane::energy_gradient(model_, mu_, lambda_, rest_[i], x, g);
    add_element_vector<3>(mesh_, tri, g, gradient);
  }
  *energy = e;
  PetscFunctionReturn(0);
}

PetscErrorCode ClothMembrane::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  PetscFunctionBeginUser;
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const PetscInt* tri = &mesh_.triangles[3 * triangles_[i]];
    const Mat9 He = membrane::hessian(model_, mu_, lambda_, rest_[i], element_positions<3>(pos.data(), tri), psd);
    PetscCall(add_element_hessian<3>(mesh_, H, tri, He, scale));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ClothMembrane::add_laplacian(Mat A, double scale, int components) const {
  const double w = scale * membrane::laplacian_weight(model_, mu_, lambda_);
  PetscFunctionBeginUser;
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const std::array<double, 9> gram = membrane::basis_gram(rest_[i]);
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> Le = w * Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(gram.data());
    PetscCall(add_element_laplacian<3>(mesh_, A, &mesh_.triangles[3 * triangles_[i]], Le, components));
  }
  PetscFunctionReturn(0);
}

void ClothMembrane::fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const {
  const int sym = field_info(ElementField::membrane_stress).components;
  for (ElementFieldValues& f : fields)
    if (f.field == ElementField::membrane_stress)
      for (size_t i = 0; i < triangles_.size(); ++i) {
        const PetscInt t = triangles_[i];
        const membrane::Vec9 x = element_positions<3>(pos.data(), &mesh_.triangles[3 * t]);
        store_symmetric(membrane::cauchy_stress(model_, mu_, lambda_, rest_[i], x),
                        &f.values[sym * (mesh_.num_cells + mesh_.num_segments + t)]);
      }
}

}  // namespace hyperqn

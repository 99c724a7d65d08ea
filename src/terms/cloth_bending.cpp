#include "terms/cloth_bending.hpp"

#include <map>
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

// The global id 3 t + e of the edge a-b as its carrying local triangle t names it (-1: none here).
static std::map<std::pair<PetscInt, PetscInt>, int64_t> carried_edge_ids(const DistributedMesh& mesh) {
  std::map<std::pair<PetscInt, PetscInt>, int64_t> ids;
  for (PetscInt t = 0; t < mesh.num_triangles; ++t)
    for (int e = 0; e < 3; ++e)
      if (mesh.triangle_edges[t] & (1u << e)) {
        const PetscInt a = mesh.triangles[3 * t + e], b = mesh.triangles[3 * t + (e + 1) % 3];
        ids[{std::min(a, b), std::max(a, b)}] = 3 * mesh.triangle_ids[t] + e;
      }
  return ids;
}

ClothBending::ClothBending(const DistributedMesh& mesh, BendingModel model, double stiffness, std::vector<PetscInt> hinges,
                           const SpringYield& yield, const std::string& state)
    : mesh_(mesh), model_(model), k_(stiffness), hinges_(std::move(hinges)), springs_(mesh) {
  const double* X = mesh.rest.data();
  std::map<std::pair<PetscInt, PetscInt>, int64_t> edge_ids;
  if (yield.active()) edge_ids = carried_edge_ids(mesh);
  for (PetscInt h : hinges_) {
    const PetscInt* v = &mesh.hinges[4 * h];
    if (model == BendingModel::springs) {
      const PetscInt cd[2] = {v[2], v[3]};
      int64_t id = -1;
      if (yield.active()) {
        const auto it = edge_ids.find({std::min(v[0], v[1]), std::max(v[0], v[1])});
        if (it == edge_ids.end())
          throw std::runtime_error("a yielding bending spring's hinge has no triangle carrying its edge on its rank");
        id = it->second;
      }
      springs_.add(cd[0], cd[1], segment_edge(X, cd).norm(), stiffness, id);
      continue;
    }
    const Vec3 x0(&X[3 * v[0]]), x1(&X[3 * v[1]]), x2(&X[3 * v[2]]), x3(&X[3 * v[3]]);
    weights_.push_back(hinge::quadratic_weights(x0, x1, x2, x3));
    coefficient_.push_back(hinge::quadratic_coefficient(x0, x1, x2, x3));
    if (model == BendingModel::dihedral) rest_.push_back(hinge::hinge_rest(x0, x1, x2, x3));
  }
  springs_.arrange();
  if (yield.active()) springs_.set_yield(yield, state);
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

PetscErrorCode ClothBending::add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const {
  if (model_ == BendingModel::springs) return springs_.add_hessian(rest.data(), H, scale, true, true);
  return add_hessian(rest, H, scale, true);
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

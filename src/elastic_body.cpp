#include "elastic_body.hpp"

#include "materials/material_factory.hpp"

namespace hyperqn {

// Columns of Ds: x_k - x_0 for k = 1..3.
static Mat3 edge_matrix(const double* pos, const PetscInt* cell) {
  Mat3 D;
  const double* x0 = &pos[3 * cell[0]];
  for (int k = 1; k <= 3; ++k) {
    const double* xk = &pos[3 * cell[k]];
    for (int d = 0; d < 3; ++d) D(d, k - 1) = xk[d] - x0[d];
  }
  return D;
}

ElasticBody::ElasticBody(const DistributedMesh& mesh, const MaterialSpec& spec) : mesh_(mesh) {
  material_ = make_material(spec.model, spec.mu, spec.lambda, spec.J0);
  weight_ = spec.laplacian_weight > 0 ? spec.laplacian_weight : material_->laplacian_weight();

  Dm_inv_.resize(mesh.num_cells);
  volume_.resize(mesh.num_cells);
  double local_volume = 0;
  for (PetscInt c = 0; c < mesh.num_cells; ++c) {
    Mat3 Dm = edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]);
    Dm_inv_[c] = Dm.inverse();
    volume_[c] = Dm.determinant() / 6.0;  // cells are positively oriented by clean_mesh
    local_volume += volume_[c];
  }
  double volume = 0;
  MPI_Allreduce(&local_volume, &volume, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)mesh.dm));
  density_ = spec.has_density ? spec.density : spec.total_mass / volume;
  total_mass_ = density_ * volume;
}

PetscErrorCode ElasticBody::scatter_to_local(Vec global, const std::vector<double>& fixed_values,
                                             std::vector<double>& out) const {
  const PetscScalar* xl;
  PetscFunctionBeginUser;
  if (!local_) PetscCall(DMCreateLocalVector(mesh_.dm, &local_));
  PetscCall(DMGlobalToLocal(mesh_.dm, global, INSERT_VALUES, local_));
  PetscCall(VecGetArrayRead(local_, &xl));
  out = fixed_values;
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v) {
    const PetscInt off = mesh_.local_dof[v];
    if (off >= 0)
      for (int d = 0; d < 3; ++d) out[3 * v + d] = xl[off + d];
  }
  PetscCall(VecRestoreArrayRead(local_, &xl));
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::local_positions(Vec x, std::vector<double>& pos) const {
  PetscFunctionBeginUser;
  PetscCall(scatter_to_local(x, mesh_.rest, pos));  // fixed vertices stay at rest
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::local_velocities(Vec v, std::vector<double>& vel) const {
  PetscFunctionBeginUser;
  PetscCall(scatter_to_local(v, std::vector<double>(3 * mesh_.num_vertices, 0.0), vel));
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::energy_gradient(Vec x, PetscReal* energy, Vec grad) const {
  PetscScalar* gl = nullptr;
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  if (grad) {
    PetscCall(VecSet(local_, 0.0));
    PetscCall(VecGetArray(local_, &gl));
  }
  double e_local = 0;
  Mat3 P;
  for (PetscInt c = 0; c < mesh_.num_cells; ++c) {
    const PetscInt* cell = &mesh_.cells[4 * c];
    const Mat3 F = edge_matrix(pos_.data(), cell) * Dm_inv_[c];
    if (!grad) {
      e_local += volume_[c] * material_->energy(F);
      continue;
    }
    e_local += volume_[c] * material_->energy_and_stress(F, P);
    // dE/dx_k = V P Dm^{-T} e_k for k = 1..3; vertex 0 gets minus their sum.
    const Mat3 H = volume_[c] * P * Dm_inv_[c].transpose();
    const Vec3 f0 = -H.rowwise().sum();
    for (int k = 0; k < 4; ++k) {
      const PetscInt off = mesh_.local_dof[cell[k]];
      if (off < 0) continue;
      const Vec3 f = k == 0 ? f0 : Vec3(H.col(k - 1));
      for (int d = 0; d < 3; ++d) gl[off + d] += f[d];
    }
  }
  PetscCallMPI(MPI_Allreduce(&e_local, energy, 1, MPIU_REAL, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm)));
  if (grad) {
    PetscCall(VecRestoreArray(local_, &gl));
    PetscCall(VecSet(grad, 0.0));
    PetscCall(DMLocalToGlobal(mesh_.dm, local_, ADD_VALUES, grad));
  }
  PetscFunctionReturn(0);
}

void ElasticBody::cell_jacobians(const std::vector<double>& pos, std::vector<double>& J) const {
  J.resize(mesh_.num_cells);
  for (PetscInt c = 0; c < mesh_.num_cells; ++c)
    J[c] = (edge_matrix(pos.data(), &mesh_.cells[4 * c]) * Dm_inv_[c]).determinant();
}

PetscErrorCode ElasticBody::lumped_mass(Vec mass) const {
  Vec ml;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(mesh_.dm, &ml));
  PetscCall(VecSet(ml, 0.0));
  PetscCall(VecGetArray(ml, &a));
  for (PetscInt c = 0; c < mesh_.num_cells; ++c)
    for (int k = 0; k < 4; ++k) {
      const PetscInt off = mesh_.local_dof[mesh_.cells[4 * c + k]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) a[off + d] += 0.25 * density_ * volume_[c];
    }
  PetscCall(VecRestoreArray(ml, &a));
  PetscCall(VecSet(mass, 0.0));
  PetscCall(DMLocalToGlobal(mesh_.dm, ml, ADD_VALUES, mass));
  PetscCall(DMRestoreLocalVector(mesh_.dm, &ml));
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::add_laplacian(Mat A, PetscReal scale) const {
  PetscFunctionBeginUser;
  for (PetscInt c = 0; c < mesh_.num_cells; ++c) {
    const PetscInt* cell = &mesh_.cells[4 * c];
    // Gradients of the 4 barycentric shape functions: rows of Dm^{-1}, and minus their sum.
    Eigen::Matrix<double, 3, 4> G;
    G.rightCols<3>() = Dm_inv_[c].transpose();
    G.col(0) = -G.rightCols<3>().rowwise().sum();
    const Eigen::Matrix4d Le = (scale * weight_ * volume_[c]) * (G.transpose() * G);
    PetscInt idx[12];
    PetscScalar vals[144] = {0};
    for (int i = 0; i < 4; ++i)
      for (int d = 0; d < 3; ++d) {
        const PetscInt g = mesh_.global_dof[cell[i]];
        idx[3 * i + d] = g < 0 ? -1 : g + d;  // negative indices are ignored by MatSetValues
      }
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int d = 0; d < 3; ++d) vals[(3 * i + d) * 12 + 3 * j + d] = Le(i, j);
    PetscCall(MatSetValues(A, 12, idx, 12, idx, vals, ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::rest_positions(Vec x) const {
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(mesh_.dm, &xl));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v)
    if (mesh_.local_dof[v] >= 0)
      for (int d = 0; d < 3; ++d) a[mesh_.local_dof[v] + d] = mesh_.rest[3 * v + d];
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(mesh_.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(mesh_.dm, &xl));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

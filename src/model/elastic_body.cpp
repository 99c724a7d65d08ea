#include "model/elastic_body.hpp"

#include <algorithm>
#include <cmath>

#include "app/material_params.hpp"
#include "materials/spring.hpp"
#include "materials/tet_springs.hpp"

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

// Deformed edge x_b - x_a of a segment (a, b).
static Vec3 segment_edge(const double* pos, const PetscInt* seg) {
  return Vec3(&pos[3 * seg[1]]) - Vec3(&pos[3 * seg[0]]);
}

// dvec(F)/dx_e (9 x 12, vec column-major): F = sum_k x_k g_k^T, so entry (i + 3j, 3k + i) is
// g_k[j], with g_1..g_3 the rows of Dm^{-1} and g_0 = -(g_1 + g_2 + g_3) (the G of add_laplacian).
static Eigen::Matrix<double, 9, 12> deformation_jacobian(const Mat3& Dm_inv) {
  Eigen::Matrix<double, 9, 12> B = Eigen::Matrix<double, 9, 12>::Zero();
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 3; ++j) {
      const double g = k == 0 ? -Dm_inv.col(j).sum() : Dm_inv(k - 1, j);
      for (int i = 0; i < 3; ++i) B(i + 3 * j, 3 * k + i) = g;
    }
  return B;
}

// The symmetric C with its negative eigenvalues clamped to 0. Done on the 9x9 dP/dF rather than
// the 12x12 element Hessian: a smaller eigenproblem, and B^T C B is PSD whenever C is. (The
// mass term then makes M + h^2 K SPD.) Fixed-size Eigen types: no heap allocation.
static Mat9 project_psd(const Mat9& C) {
  if (Eigen::LLT<Mat9>(C).info() == Eigen::Success) return C;  // positive definite: cheap exit
  const Eigen::SelfAdjointEigenSolver<Mat9> eig(C);
  if (eig.eigenvalues()(0) >= 0) return C;  // sorted ascending; PSD already, keep it exact
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

ElasticBody::ElasticBody(const DistributedMesh& mesh, const std::vector<MaterialSpec>& specs,
                         const StrandMaterial& strands)
    : mesh_(mesh), strands_(strands) {
  for (const MaterialSpec& spec : specs) {
    const bool springs = spec.model == "mass-spring";
    materials_.push_back(springs ? nullptr : make_material(spec));
    spring_k_.push_back(springs ? spec.spring_stiffness : 0.0);
    // A spring's own weight in L is its stiffness k (see add_laplacian).
    const double own = springs ? spec.spring_stiffness : materials_.back()->laplacian_weight();
    weights_.push_back(spec.laplacian_weight > 0 ? spec.laplacian_weight : own);
  }

  Dm_inv_.resize(mesh.num_cells);
  Dm_.resize(mesh.num_cells);
  volume_.resize(mesh.num_cells);
  double local_volume = 0;
  for (PetscInt c = 0; c < mesh.num_cells; ++c) {
    Mat3 Dm = edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]);
    Dm_inv_[c] = Dm.inverse();
    Dm_[c] = Dm;
    volume_[c] = Dm.determinant() / 6.0;  // cells are positively oriented by clean_mesh
    local_volume += volume_[c];
  }
  double volume = 0;
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  MPI_Allreduce(&local_volume, &volume, 1, MPI_DOUBLE, MPI_SUM, comm);
  // A total mass (single-material bodies only) is spread evenly over the rest volume.
  for (const MaterialSpec& spec : specs)
    densities_.push_back(spec.has_density ? spec.density : volume > 0 ? spec.total_mass / volume : 0.0);
  double local_mass = 0;
  for (PetscInt c = 0; c < mesh.num_cells; ++c) local_mass += densities_[mesh.cell_material[c]] * volume_[c];
  segment_length_.resize(mesh.num_segments);
  for (PetscInt s = 0; s < mesh.num_segments; ++s) {
    segment_length_[s] = segment_edge(mesh.rest.data(), &mesh.segments[2 * s]).norm();
    local_mass += strands.linear_density * segment_length_[s];
  }
  MPI_Allreduce(&local_mass, &total_mass_, 1, MPI_DOUBLE, MPI_SUM, comm);
  fixed_pos_ = mesh.rest;
  fixed_vel_.assign(3 * mesh.num_vertices, 0.0);
}

bool ElasticBody::projective_dynamics_exact() const {
  // Springs are a Projective Dynamics energy whose L is their own (weight k, strands EA).
  if (mesh_.global_segments > 0 && strand_weight() != strands_.axial_stiffness) return false;
  if (mesh_.global_cells == 0) return true;
  for (size_t k = 0; k < materials_.size(); ++k) {
    if (spring_k_[k] > 0) {
      if (weights_[k] != spring_k_[k]) return false;
    } else if (!materials_[k]->projective_dynamics_exact() || weights_[k] != materials_[k]->laplacian_weight()) {
      return false;
    }
  }
  return true;
}

std::string ElasticBody::material_names() const {
  std::string s;
  if (mesh_.global_cells > 0)
    for (const auto& m : materials_) s += (s.empty() ? "" : ", ") + (m ? m->name() : std::string("mass-spring"));
  if (mesh_.global_segments > 0) s += std::string(s.empty() ? "" : ", ") + "strand";
  return s;
}

// Position at time t of a point X moved by the motion (see Motion in deck.hpp).
static Vec3 moved(const Motion& m, const Vec3& X, double t) {
  const double tau = std::min(std::max(t, m.start), m.end) - m.start;
  const Vec3 axis = Vec3(m.axis[0], m.axis[1], m.axis[2]).normalized();
  const Vec3 c(m.center[0], m.center[1], m.center[2]);
  const Eigen::AngleAxisd R(m.rate_deg * M_PI / 180.0 * tau, axis);
  return c + R * (X - c) + tau * Vec3(m.velocity[0], m.velocity[1], m.velocity[2]);
}

void ElasticBody::set_time(double t) {
  const double dt = t - time_;
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v) {
    const int32_t region = mesh_.fixed[v];
    if (region == 0 || !fixed_regions_[region - 1].motion.active) continue;
    const Vec3 X(&mesh_.rest[3 * v]);
    const Vec3 p = moved(fixed_regions_[region - 1].motion, X, t);
    for (int d = 0; d < 3; ++d) {
      fixed_vel_[3 * v + d] = dt > 0 ? (p[d] - fixed_pos_[3 * v + d]) / dt : 0.0;
      fixed_pos_[3 * v + d] = p[d];
    }
  }
  time_ = t;
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
  PetscCall(scatter_to_local(x, fixed_pos_, pos));
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::local_velocities(Vec v, std::vector<double>& vel) const {
  PetscFunctionBeginUser;
  PetscCall(scatter_to_local(v, fixed_vel_, vel));
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
    const int m = mesh_.cell_material[c];
    // Continuum materials give an energy density (times V); springs an element energy (times 1).
    const double k = spring_k_[m], w = k > 0 ? 1.0 : volume_[c];
    if (!grad) {
      e_local += w * (k > 0 ? tet_springs::energy(F, Dm_[c], k) : materials_[m]->energy(F));
      continue;
    }
    e_local += w * (k > 0 ? tet_springs::energy_and_stress(F, Dm_[c], k, P) : materials_[m]->energy_and_stress(F, P));
    // dE/dx_k = w P Dm^{-T} e_k for k = 1..3; vertex 0 gets minus their sum.
    const Mat3 H = w * P * Dm_inv_[c].transpose();
    const Vec3 f0 = -H.rowwise().sum();
    for (int k = 0; k < 4; ++k) {
      const PetscInt off = mesh_.local_dof[cell[k]];
      if (off < 0) continue;
      const Vec3 f = k == 0 ? f0 : Vec3(H.col(k - 1));
      for (int d = 0; d < 3; ++d) gl[off + d] += f[d];
    }
  }
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const PetscInt* seg = &mesh_.segments[2 * s];
    const Vec3 u = segment_edge(pos_.data(), seg);
    const double L = segment_length_[s], k = strands_.axial_stiffness / L;
    e_local += spring::energy(u, L, k);
    if (!grad) continue;
    const Vec3 f = spring::gradient(u, L, k);  // dE/dx_b; dE/dx_a = -f
    for (int j = 0; j < 2; ++j) {
      const PetscInt off = mesh_.local_dof[seg[j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) gl[off + d] += j == 0 ? -f[d] : f[d];
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
      for (int d = 0; d < 3; ++d) a[off + d] += 0.25 * densities_[mesh_.cell_material[c]] * volume_[c];
    }
  for (PetscInt s = 0; s < mesh_.num_segments; ++s)
    for (int j = 0; j < 2; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.segments[2 * s + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) a[off + d] += 0.5 * strands_.linear_density * segment_length_[s];
    }
  PetscCall(VecRestoreArray(ml, &a));
  PetscCall(VecSet(mass, 0.0));
  PetscCall(DMLocalToGlobal(mesh_.dm, ml, ADD_VALUES, mass));
  PetscCall(DMRestoreLocalVector(mesh_.dm, &ml));
  PetscFunctionReturn(0);
}

// A += Le (x) I3 (components = 3, dof layout) or A += Le (components = 1, vertex_dm layout) for
// the element matrix Le (n x n, row-major) on the local vertices verts; fixed vertices skipped.
template <int n>
static PetscErrorCode add_element_laplacian(const DistributedMesh& mesh, Mat A, const PetscInt* verts,
                                            const Eigen::Matrix<double, n, n, Eigen::RowMajor>& Le, int components) {
  PetscFunctionBeginUser;
  if (components == 1) {
    PetscInt vidx[n];
    for (int i = 0; i < n; ++i) {
      const PetscInt g = mesh.global_dof[verts[i]];
      vidx[i] = g < 0 ? -1 : g / 3;  // vertex index in vertex_dm's layout
    }
    PetscCall(MatSetValues(A, n, vidx, n, vidx, Le.data(), ADD_VALUES));
    PetscFunctionReturn(0);
  }
  PetscInt idx[3 * n];
  PetscScalar vals[9 * n * n] = {0};
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      const PetscInt g = mesh.global_dof[verts[i]];
      idx[3 * i + d] = g < 0 ? -1 : g + d;  // negative indices are ignored by MatSetValues
    }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int d = 0; d < 3; ++d) vals[(3 * i + d) * 3 * n + 3 * j + d] = Le(i, j);
  PetscCall(MatSetValues(A, 3 * n, idx, 3 * n, idx, vals, ADD_VALUES));
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::add_laplacian(Mat A, PetscReal scale, int components) const {
  PetscFunctionBeginUser;
  for (PetscInt c = 0; c < mesh_.num_cells; ++c) {
    // Gradients of the 4 barycentric shape functions: rows of Dm^{-1}, and minus their sum.
    Eigen::Matrix<double, 3, 4> G;
    G.rightCols<3>() = Dm_inv_[c].transpose();
    G.col(0) = -G.rightCols<3>().rowwise().sum();
    const int m = mesh_.cell_material[c];
    const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> Le =
        spring_k_[m] > 0 ? (scale * tet_springs::laplacian(weights_[m])).eval()
                         : ((scale * weights_[m] * volume_[c]) * (G.transpose() * G)).eval();
    PetscCall(add_element_laplacian<4>(mesh_, A, &mesh_.cells[4 * c], Le, components));
  }
  // A segment's spring k = EA / L: its L is exact, as for the mass-spring tets.
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const double k = scale * strand_weight() / segment_length_[s];
    Eigen::Matrix<double, 2, 2, Eigen::RowMajor> Le;
    Le << k, -k, -k, k;
    PetscCall(add_element_laplacian<2>(mesh_, A, &mesh_.segments[2 * s], Le, components));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ElasticBody::add_hessian(Vec x, Mat H, PetscReal scale, bool psd) const {
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> Ke;  // row-major: the layout MatSetValues reads
  PetscInt idx[12];
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  for (PetscInt c = 0; c < mesh_.num_cells; ++c) {
    const PetscInt* cell = &mesh_.cells[4 * c];
    const Mat3 F = edge_matrix(pos_.data(), cell) * Dm_inv_[c];
    const int m = mesh_.cell_material[c];
    const double k = spring_k_[m];
    const Mat9 C = k > 0 ? tet_springs::stress_derivative(F, Dm_[c], k, psd)
                         : psd ? project_psd(materials_[m]->stress_derivative(F)) : materials_[m]->stress_derivative(F);
    const Eigen::Matrix<double, 9, 12> B = deformation_jacobian(Dm_inv_[c]);
    Ke.noalias() = (scale * (k > 0 ? 1.0 : volume_[c])) * (B.transpose() * (C * B));
    // Average with the transpose so H is exactly symmetric whatever the rounding above.
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < i; ++j) Ke(i, j) = Ke(j, i) = 0.5 * (Ke(i, j) + Ke(j, i));
    for (int k = 0; k < 4; ++k) {
      const PetscInt g = mesh_.global_dof[cell[k]];
      for (int d = 0; d < 3; ++d) idx[3 * k + d] = g < 0 ? -1 : g + d;  // fixed dofs: ignored
    }
    PetscCall(MatSetValues(H, 12, idx, 12, idx, Ke.data(), ADD_VALUES));
  }
  for (PetscInt s = 0; s < mesh_.num_segments; ++s) {
    const PetscInt* seg = &mesh_.segments[2 * s];
    const double L = segment_length_[s];
    const Mat3 K = scale * spring::stiffness(segment_edge(pos_.data(), seg), L, strands_.axial_stiffness / L, psd);
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> Ks;  // d2E/dx2 for x = (x_a, x_b): [K -K; -K K]
    Ks << K, -K, -K, K;
    PetscInt sidx[6];
    for (int j = 0; j < 2; ++j) {
      const PetscInt g = mesh_.global_dof[seg[j]];
      for (int d = 0; d < 3; ++d) sidx[3 * j + d] = g < 0 ? -1 : g + d;
    }
    PetscCall(MatSetValues(H, 6, sidx, 6, sidx, Ks.data(), ADD_VALUES));
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

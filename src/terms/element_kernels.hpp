// Small dense pieces shared by the element terms: deformation gradients of tets, the map from
// vec(F) to element dofs, the definiteness fix, and scattering element vectors and matrices into
// the local gradient and the global matrices (fixed vertices skipped).
#pragma once
#include <petscmat.h>

#include <Eigen/Dense>

#include "materials/material.hpp"
#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

// Columns of Ds: x_k - x_0 for k = 1..3 of the tet cell (4 local vertex indices).
inline Mat3 edge_matrix(const double* pos, const PetscInt* cell) {
  Mat3 D;
  const double* x0 = &pos[3 * cell[0]];
  for (int k = 1; k <= 3; ++k) {
    const double* xk = &pos[3 * cell[k]];
    for (int d = 0; d < 3; ++d) D(d, k - 1) = xk[d] - x0[d];
  }
  return D;
}

// Deformed edge x_b - x_a of a segment (a, b).
inline Vec3 segment_edge(const double* pos, const PetscInt* seg) {
  return Vec3(&pos[3 * seg[1]]) - Vec3(&pos[3 * seg[0]]);
}

// Positions of an element's n local vertices, stacked (3n): a triangle's 9, a hinge's 12.
template <int n>
Eigen::Matrix<double, 3 * n, 1> element_positions(const double* pos, const PetscInt* verts) {
  Eigen::Matrix<double, 3 * n, 1> x;
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) x[3 * i + d] = pos[3 * verts[i] + d];
  return x;
}

// Area of the triangle (3 local vertex indices).
inline double triangle_area(const double* pos, const PetscInt* tri) {
  const Vec3 x0(&pos[3 * tri[0]]);
  return 0.5 * (Vec3(&pos[3 * tri[1]]) - x0).cross(Vec3(&pos[3 * tri[2]]) - x0).norm();
}

// dvec(F)/dx_e (9 x 12, vec column-major): F = sum_k x_k g_k^T, so entry (i + 3j, 3k + i) is
// g_k[j], with g_1..g_3 the rows of Dm^{-1} and g_0 = -(g_1 + g_2 + g_3).
Eigen::Matrix<double, 9, 12> deformation_jacobian(const Mat3& Dm_inv);

// The symmetric C with its negative eigenvalues clamped to 0. Done on the 9x9 dP/dF rather than
// the 12x12 element Hessian: a smaller eigenproblem, and B^T C B is PSD whenever C is.
Mat9 project_psd(const Mat9& C);

// Global dof indices of n local vertices, 3 each; -1 (ignored by MatSetValues) for fixed ones.
template <int n>
void element_dofs(const DistributedMesh& mesh, const PetscInt* verts, PetscInt idx[3 * n]) {
  for (int i = 0; i < n; ++i) {
    const PetscInt g = mesh.global_dof[verts[i]];
    for (int d = 0; d < 3; ++d) idx[3 * i + d] = g < 0 ? -1 : g + d;
  }
}

// Adds the element force f_i (3 per vertex) of n local vertices into the local gradient array.
inline void add_vertex_vector(const DistributedMesh& mesh, PetscInt vertex, const Vec3& f, PetscScalar* gradient) {
  const PetscInt off = mesh.local_dof[vertex];
  if (off < 0) return;
  for (int d = 0; d < 3; ++d) gradient[off + d] += f[d];
}

// Adds an element gradient (3 per vertex, stacked) of n local vertices into the local gradient array.
template <int n>
void add_element_vector(const DistributedMesh& mesh, const PetscInt* verts, const Eigen::Matrix<double, 3 * n, 1>& g,
                        PetscScalar* gradient) {
  for (int i = 0; i < n; ++i) add_vertex_vector(mesh, verts[i], g.template segment<3>(3 * i), gradient);
}

// H += scale * He (3n x 3n) at the global dofs of n local vertices; fixed vertices skipped.
template <int n>
PetscErrorCode add_element_hessian(const DistributedMesh& mesh, Mat H, const PetscInt* verts,
                                   const Eigen::Matrix<double, 3 * n, 3 * n>& He, double scale) {
  PetscInt idx[3 * n];
  const Eigen::Matrix<double, 3 * n, 3 * n, Eigen::RowMajor> vals = scale * He;
  PetscFunctionBeginUser;
  element_dofs<n>(mesh, verts, idx);
  PetscCall(MatSetValues(H, 3 * n, idx, 3 * n, idx, vals.data(), ADD_VALUES));
  PetscFunctionReturn(0);
}

// A += Le (x) I3 (components = 3, dof layout) or A += Le (components = 1, vertex_dm layout) for
// the element matrix Le (n x n, row-major) on the local vertices verts; fixed vertices skipped.
template <int n>
PetscErrorCode add_element_laplacian(const DistributedMesh& mesh, Mat A, const PetscInt* verts,
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
  element_dofs<n>(mesh, verts, idx);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int d = 0; d < 3; ++d) vals[(3 * i + d) * 3 * n + 3 * j + d] = Le(i, j);
  PetscCall(MatSetValues(A, 3 * n, idx, 3 * n, idx, vals, ADD_VALUES));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "mesh/vertex_matrix.hpp"

#include <algorithm>

namespace hyperqn {

PetscErrorCode create_vertex_matrix(const DistributedMesh& m, Mat* A) {
  MPI_Comm comm = PetscObjectComm((PetscObject)m.dm);
  PetscMPIInt size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCheck(size == 1, comm, PETSC_ERR_SUP, "create_vertex_matrix: one rank only");
  const PetscInt n = m.global_dofs / 3;
  auto row_of = [&](PetscInt v) { return m.global_dof[v] < 0 ? PetscInt(-1) : m.global_dof[v] / 3; };
  // Every (row, column) pair of free vertices in one cell, then sorted and made unique: CSR.
  std::vector<std::pair<PetscInt, PetscInt>> pairs;
  auto add_cells = [&](const std::vector<PetscInt>& vertices, int per_cell) {
    for (size_t c = 0; c + per_cell <= vertices.size(); c += per_cell)
      for (int i = 0; i < per_cell; ++i) {
        const PetscInt r = row_of(vertices[c + i]);
        if (r < 0) continue;
        for (int j = 0; j < per_cell; ++j) {
          const PetscInt col = row_of(vertices[c + j]);
          if (col >= 0) pairs.push_back({r, col});
        }
      }
  };
  pairs.reserve(16 * m.cells.size() / 4 + 4 * m.segments.size() / 2 + 9 * m.triangles.size() / 3 + 16 * m.hinges.size() / 4);
  add_cells(m.cells, 4);
  add_cells(m.segments, 2);
  add_cells(m.triangles, 3);
  add_cells(m.hinges, 4);
  for (PetscInt v = 0; v < m.num_vertices; ++v)  // a free vertex in no cell keeps its diagonal
    if (row_of(v) >= 0) pairs.push_back({row_of(v), row_of(v)});
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  std::vector<PetscInt> per_row(n, 0), columns(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    ++per_row[pairs[k].first];
    columns[k] = pairs[k].second;
  }
  PetscCall(MatCreate(comm, A));
  PetscCall(MatSetSizes(*A, n, n, n, n));
  PetscCall(MatSetType(*A, MATSEQAIJ));
  PetscCall(MatSeqAIJSetPreallocation(*A, 0, per_row.data()));
  const std::vector<PetscScalar> zeros(n > 0 ? *std::max_element(per_row.begin(), per_row.end()) : 0, 0.0);
  for (PetscInt r = 0, k = 0; r < n; k += per_row[r], ++r)
    PetscCall(MatSetValues(*A, 1, &r, per_row[r], &columns[k], zeros.data(), INSERT_VALUES));
  PetscCall(MatAssemblyBegin(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

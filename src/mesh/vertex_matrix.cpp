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
  // Per row, the columns of every cell through it (two passes over the cells: count, then fill),
  // then each row sorted and made unique: CSR. (Rows are short: one sort of all pairs took 1 ms.)
  const std::vector<PetscInt>* kinds[4] = {&m.cells, &m.segments, &m.triangles, &m.hinges};
  const int per_cell[4] = {4, 2, 3, 4};
  std::vector<PetscInt> start(n + 1, 0), columns;
  auto each_pair = [&](auto&& visit) {
    for (int k = 0; k < 4; ++k)
      for (size_t c = 0; c + per_cell[k] <= kinds[k]->size(); c += per_cell[k])
        for (int i = 0; i < per_cell[k]; ++i) {
          const PetscInt r = row_of((*kinds[k])[c + i]);
          if (r < 0) continue;
          for (int j = 0; j < per_cell[k]; ++j) {
            const PetscInt col = row_of((*kinds[k])[c + j]);
            if (col >= 0) visit(r, col);
          }
        }
    for (PetscInt v = 0; v < m.num_vertices; ++v)  // a free vertex in no cell keeps its diagonal
      if (row_of(v) >= 0) visit(row_of(v), row_of(v));
  };
  each_pair([&](PetscInt r, PetscInt) { ++start[r + 1]; });
  for (PetscInt r = 0; r < n; ++r) start[r + 1] += start[r];
  columns.resize(start[n]);
  std::vector<PetscInt> fill(start.begin(), start.end() - 1), per_row(n);
  each_pair([&](PetscInt r, PetscInt col) { columns[fill[r]++] = col; });
  for (PetscInt r = 0; r < n; ++r) {
    PetscInt* first = columns.data() + start[r];
    std::sort(first, columns.data() + start[r + 1]);
    per_row[r] = PetscInt(std::unique(first, columns.data() + start[r + 1]) - first);
  }
  PetscCall(MatCreate(comm, A));
  PetscCall(MatSetSizes(*A, n, n, n, n));
  PetscCall(MatSetType(*A, MATSEQAIJ));
  PetscCall(MatSeqAIJSetPreallocation(*A, 0, per_row.data()));
  const std::vector<PetscScalar> zeros(n > 0 ? *std::max_element(per_row.begin(), per_row.end()) : 0, 0.0);
  for (PetscInt r = 0; r < n; ++r)
    PetscCall(MatSetValues(*A, 1, &r, per_row[r], &columns[start[r]], zeros.data(), INSERT_VALUES));
  PetscCall(MatAssemblyBegin(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "model/ordered_assembly.hpp"

#include <algorithm>
#include <vector>

namespace hyperqn {

namespace {

// One value for another rank's row, in the order the terms gave it.
struct Entry {
  PetscInt row, column;
  PetscScalar value;
};

// What the stand-in matrix holds: A, its own rows' range, and the values for other ranks' rows.
struct Collector {
  Mat A;
  PetscInt rstart, rend;
  std::vector<Entry> others;
};

PetscErrorCode collect(Mat S, PetscInt m, const PetscInt rows[], PetscInt n, const PetscInt columns[],
                       const PetscScalar values[], InsertMode mode) {
  Collector* c;
  PetscFunctionBeginUser;
  PetscCheck(mode == ADD_VALUES, PETSC_COMM_SELF, PETSC_ERR_SUP, "add_in_rank_order takes ADD_VALUES only");
  PetscCall(MatShellGetContext(S, &c));
  for (PetscInt i = 0; i < m; ++i) {
    const PetscInt row = rows[i];
    if (row < 0) continue;
    if (row >= c->rstart && row < c->rend) {  // its own row: in A at once (no message)
      PetscCall(MatSetValues(c->A, 1, &row, n, columns, values + i * n, ADD_VALUES));
      continue;
    }
    for (PetscInt j = 0; j < n; ++j)
      if (columns[j] >= 0) c->others.push_back({row, columns[j], values[i * n + j]});
  }
  PetscFunctionReturn(0);
}

}  // namespace

PetscErrorCode add_in_rank_order(Mat A, const std::function<PetscErrorCode(Mat)>& add) {
  Collector c;
  Mat S;
  PetscInt m, n, M, N;
  PetscMPIInt size;
  MPI_Comm comm = PetscObjectComm((PetscObject)A);
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  c.A = A;
  PetscCall(MatGetOwnershipRange(A, &c.rstart, &c.rend));
  PetscCall(MatGetLocalSize(A, &m, &n));
  PetscCall(MatGetSize(A, &M, &N));
  PetscCall(MatCreateShell(comm, m, n, M, N, &c, &S));
  PetscCall(MatShellSetOperation(S, MATOP_SET_VALUES, (void (*)(void))collect));
  const PetscErrorCode ierr = add(S);
  PetscCall(MatDestroy(&S));
  PetscCall(ierr);

  // One (row, column, value) per entry to each owner, in increasing order: the values of an entry
  // summed in the order the terms gave them (a stable sort keeps it); received in the order of the
  // sending ranks (MPI_Alltoallv places them so).
  std::stable_sort(c.others.begin(), c.others.end(), [](const Entry& a, const Entry& b) {
    return a.row < b.row || (a.row == b.row && a.column < b.column);
  });
  const PetscInt* ranges;
  PetscCall(MatGetOwnershipRanges(A, &ranges));
  std::vector<PetscMPIInt> send_counts(size, 0), recv_counts(size), send_offsets(size + 1, 0), recv_offsets(size + 1, 0);
  std::vector<PetscInt> send_rows, send_columns;
  std::vector<PetscScalar> send_values;
  int owner = 0;
  for (size_t e = 0; e < c.others.size(); ++e) {
    const Entry& entry = c.others[e];
    if (e > 0 && entry.row == send_rows.back() && entry.column == send_columns.back()) {
      send_values.back() += entry.value;
      continue;
    }
    while (entry.row >= ranges[owner + 1]) ++owner;
    ++send_counts[owner];
    send_rows.push_back(entry.row);
    send_columns.push_back(entry.column);
    send_values.push_back(entry.value);
  }
  PetscCallMPI(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, comm));
  for (int r = 0; r < size; ++r) {
    send_offsets[r + 1] = send_offsets[r] + send_counts[r];
    recv_offsets[r + 1] = recv_offsets[r] + recv_counts[r];
  }
  std::vector<PetscInt> rows(recv_offsets[size]), columns(recv_offsets[size]);
  std::vector<PetscScalar> values(recv_offsets[size]);
  PetscCallMPI(MPI_Alltoallv(send_rows.data(), send_counts.data(), send_offsets.data(), MPIU_INT, rows.data(),
                             recv_counts.data(), recv_offsets.data(), MPIU_INT, comm));
  PetscCallMPI(MPI_Alltoallv(send_columns.data(), send_counts.data(), send_offsets.data(), MPIU_INT, columns.data(),
                             recv_counts.data(), recv_offsets.data(), MPIU_INT, comm));
  PetscCallMPI(MPI_Alltoallv(send_values.data(), send_counts.data(), send_offsets.data(), MPIU_SCALAR, values.data(),
                             recv_counts.data(), recv_offsets.data(), MPIU_SCALAR, comm));
  for (size_t e = 0; e < rows.size(); ++e) PetscCall(MatSetValues(A, 1, &rows[e], 1, &columns[e], &values[e], ADD_VALUES));
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

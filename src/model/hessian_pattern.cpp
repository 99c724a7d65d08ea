#include "model/hessian_pattern.hpp"

#include <algorithm>
#include <array>
#include <vector>

namespace hyperqn {

// Inserting each coupling new to H as it came reallocated the whole matrix for every row that
// overflowed (the 81 x 81 cloth pile's Newton frame: 591 s, 70% in memmove), and preallocating
// each assembly's own pattern made MUMPS analyse it again at every iteration. So H holds the
// couplings of the terms' lists (self-contact's candidates: all an assembly may add until the
// lists are built again) as explicit zeros, which MatZeroEntries keeps, and is preallocated again
// only when a list built again holds other couplings: for the mesh's pattern and that list's
// couplings (not every coupling it ever had, whose fill-in would slow every factorization). A
// vertex's three dofs are on one rank and a coupling adds the whole 3 x 3 block, so a vertex pair
// is in H's pattern iff its first entry is.
PetscErrorCode HessianPattern::grow(const Body& body, Vec x, Mat H, long long* grown) {
  MPI_Comm comm = PetscObjectComm((PetscObject)H);
  PetscMPIInt size;
  std::vector<std::array<PetscInt, 2>> couplings;
  unsigned long long generation;
  PetscObjectId id;
  PetscObjectState state;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(body.hessian_couplings(x, nullptr, &generation));
  PetscCall(PetscObjectGetId((PetscObject)H, &id));
  PetscCall(MatGetNonzeroState(H, &state));
  int changed = id != seen_.id || state != seen_.state || generation != seen_.generation;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_LOR, comm));
  if (!changed) PetscFunctionReturn(0);
  PetscCall(body.hessian_couplings(x, &couplings, &generation));
  // Both orders, each to the owner of its row.
  const size_t n = couplings.size();
  couplings.resize(2 * n);
  for (size_t k = 0; k < n; ++k) couplings[n + k] = {couplings[k][1], couplings[k][0]};
  std::sort(couplings.begin(), couplings.end());
  couplings.erase(std::unique(couplings.begin(), couplings.end()), couplings.end());
  const PetscInt* ranges;
  PetscCall(MatGetOwnershipRanges(H, &ranges));
  std::vector<PetscMPIInt> send_counts(size, 0), recv_counts(size), send_offsets(size + 1, 0), recv_offsets(size + 1, 0);
  int owner = 0;
  for (const auto& c : couplings) {
    while (c[0] >= ranges[owner + 1]) ++owner;
    send_counts[owner] += 2;
  }
  PetscCallMPI(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, comm));
  for (int r = 0; r < size; ++r) {
    send_offsets[r + 1] = send_offsets[r] + send_counts[r];
    recv_offsets[r + 1] = recv_offsets[r] + recv_counts[r];
  }
  std::vector<std::array<PetscInt, 2>> mine(recv_offsets[size] / 2);
  PetscCallMPI(MPI_Alltoallv(couplings.data(), send_counts.data(), send_offsets.data(), MPIU_INT, mine.data(),
                             recv_counts.data(), recv_offsets.data(), MPIU_INT, comm));
  std::sort(mine.begin(), mine.end());
  mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
  // A new H has the mesh's pattern alone (create_hessian). H is made again whenever the list's
  // couplings are not the ones it was made for, fewer as well as more: its pattern is then a
  // function of the list, which a step builds from its start alone, so a restart (a new H) factors
  // the same pattern as the run not stopped, whose explicit zeros would otherwise be those of an
  // older list (a different fill and ordering: round-off apart).
  if (id != seen_.id) made_for_.clear();
  for (const auto& c : mine)
    PetscCheck(c[0] % 3 == 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "a coupling's dof %" PetscInt_FMT " is not a vertex's x dof", c[0]);
  int differ = mine != made_for_;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &differ, 1, MPI_INT, MPI_LOR, comm));
  if (differ) {
    // The mesh's pattern (a matrix made as create_hessian makes it) and the couplings, row by row.
    PetscBool aij;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)H, &aij, MATSEQAIJ, MATMPIAIJ, ""));
    PetscCheck(aij, comm, PETSC_ERR_SUP, "Newton with self-contact needs an AIJ Hessian");
    Mat mesh;
    PetscCall(DMCreateMatrix(body.mesh().dm, &mesh));
    PetscInt rstart, rend, cstart, cend;
    PetscCall(MatGetOwnershipRange(H, &rstart, &rend));
    PetscCall(MatGetOwnershipRangeColumn(H, &cstart, &cend));
    std::vector<PetscInt> offsets(1, 0), columns, diagonal, off_diagonal;
    size_t f = 0;
    for (PetscInt row = rstart; row < rend; ++row) {
      PetscInt count;
      const PetscInt* have;
      PetscCall(MatGetRow(mesh, row, &count, &have, nullptr));
      const size_t begin = columns.size();
      columns.insert(columns.end(), have, have + count);
      PetscCall(MatRestoreRow(mesh, row, &count, &have, nullptr));
      const PetscInt vertex = row - row % 3;
      while (f < mine.size() && mine[f][0] < vertex) ++f;
      for (size_t g = f; g < mine.size() && mine[g][0] == vertex; ++g)
        for (int d = 0; d < 3; ++d) columns.push_back(mine[g][1] + d);
      std::sort(columns.begin() + begin, columns.end());
      columns.erase(std::unique(columns.begin() + begin, columns.end()), columns.end());
      const PetscInt inside =
          std::count_if(columns.begin() + begin, columns.end(), [&](PetscInt c) { return c >= cstart && c < cend; });
      diagonal.push_back(inside);
      off_diagonal.push_back((PetscInt)(columns.size() - begin) - inside);
      offsets.push_back((PetscInt)columns.size());
    }
    PetscCall(MatDestroy(&mesh));
    PetscCall(MatSeqAIJSetPreallocation(H, 0, diagonal.data()));  // whichever H is, the other does nothing
    PetscCall(MatMPIAIJSetPreallocation(H, 0, diagonal.data(), 0, off_diagonal.data()));
    const std::vector<PetscScalar> zeros(columns.size(), 0.0);
    for (PetscInt row = rstart; row < rend; ++row) {
      const PetscInt k = row - rstart;
      PetscCall(MatSetValues(H, 1, &row, offsets[k + 1] - offsets[k], &columns[offsets[k]], zeros.data(), INSERT_VALUES));
    }
    PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
    ++*grown;
    PetscCall(PetscInfo(H, "Hessian pattern made again for %zu vertex couplings on this rank (%lld times in the run)\n",
                        mine.size(), *grown));
    PetscCall(MatGetNonzeroState(H, &state));
    made_for_ = std::move(mine);
  }
  seen_ = {id, state, generation};
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

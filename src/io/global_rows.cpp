#include "io/global_rows.hpp"

namespace hyperqn {

// A PETSc error here is a programming error (a row out of range): it aborts with PETSc's trace.

GlobalRows::GlobalRows(MPI_Comm comm, PetscInt rows, const std::vector<PetscInt>& row)
    : comm_(comm), rows_(rows), items_((PetscInt)row.size()) {
  PetscLayout layout;
  PetscCallAbort(comm_, PetscLayoutCreate(comm, &layout));
  PetscCallAbort(comm_, PetscLayoutSetSize(layout, rows));
  PetscCallAbort(comm_, PetscLayoutSetUp(layout));  // PETSc's default split, as a Vec of `rows` entries
  PetscCallAbort(comm_, PetscLayoutGetRange(layout, &first_, nullptr));
  PetscCallAbort(comm_, PetscLayoutGetLocalSize(layout, &count_));
  std::vector<PetscInt> local, remote;
  for (PetscInt i = 0; i < items_; ++i)
    if (row[i] >= 0) {
      local.push_back(i);
      remote.push_back(row[i]);
    }
  PetscCallAbort(comm_, PetscSFCreate(comm, &sf_));
  PetscCallAbort(comm_, PetscSFSetGraphLayout(sf_, layout, (PetscInt)local.size(), local.data(), PETSC_COPY_VALUES, remote.data()));
  PetscCallAbort(comm_, PetscSFSetUp(sf_));
  PetscCallAbort(comm_, PetscLayoutDestroy(&layout));
}

template <typename T>
std::vector<T> GlobalRows::move(const std::vector<T>& values, int width, MPI_Datatype type) const {
  MPI_Datatype unit = type;
  if (width > 1) {
    MPI_Type_contiguous(width, type, &unit);
    MPI_Type_commit(&unit);
  }
  std::vector<T> block((size_t)count_ * width, T(0));
  PetscCallAbort(comm_, PetscSFReduceBegin(sf_, unit, values.data(), block.data(), MPI_REPLACE));
  PetscCallAbort(comm_, PetscSFReduceEnd(sf_, unit, values.data(), block.data(), MPI_REPLACE));
  if (width > 1) MPI_Type_free(&unit);
  return block;
}

std::vector<double> GlobalRows::gather(const std::vector<double>& values, int width) const {
  return move(values, width, MPI_DOUBLE);
}
std::vector<int64_t> GlobalRows::gather(const std::vector<int64_t>& values, int width) const {
  return move(values, width, MPI_INT64_T);
}
std::vector<float> GlobalRows::gather(const std::vector<float>& values, int width) const {
  return move(values, width, MPI_FLOAT);
}

std::vector<int64_t> GlobalRows::scatter(const std::vector<int64_t>& block) const {
  std::vector<int64_t> values(items_, -1);
  PetscCallAbort(comm_, PetscSFBcastBegin(sf_, MPI_INT64_T, block.data(), values.data(), MPI_REPLACE));
  PetscCallAbort(comm_, PetscSFBcastEnd(sf_, MPI_INT64_T, block.data(), values.data(), MPI_REPLACE));
  return values;
}

}  // namespace hyperqn

// Values of items spread over the ranks (vertices, elements), moved to a global order in which
// rank r holds one contiguous block of rows: what a collective write of one dataset by every rank
// needs (io/xdmf_writer.hpp), without any rank holding more than its block.
#pragma once
#include <petscsf.h>

#include <cstdint>
#include <vector>

namespace hyperqn {

class GlobalRows {
 public:
  // rows: how many in all; row[i]: the global row of local item i, or -1 if another rank sends
  // it (a ghost vertex). A row that no rank sends stays 0. Collective.
  GlobalRows(MPI_Comm comm, PetscInt rows, const std::vector<PetscInt>& row);
  GlobalRows(const GlobalRows&) = delete;
  GlobalRows& operator=(const GlobalRows&) = delete;
  ~GlobalRows() { PetscSFDestroy(&sf_); }

  // This rank's block: rows [first(), first() + count()) of rows().
  PetscInt rows() const { return rows_; }
  PetscInt first() const { return first_; }
  PetscInt count() const { return count_; }

  // `width` values per local item in, `width` values per row of this rank's block out. Collective.
  std::vector<double> gather(const std::vector<double>& values, int width) const;
  std::vector<int64_t> gather(const std::vector<int64_t>& values, int width) const;
  std::vector<float> gather(const std::vector<float>& values, int width) const;
  // The reverse for one value per row: each local item (ghosts too, given their row) gets its row's
  // value from the block that holds it. Collective.
  std::vector<int64_t> scatter(const std::vector<int64_t>& block) const;

 private:
  template <typename T>
  std::vector<T> move(const std::vector<T>& values, int width, MPI_Datatype type) const;
  MPI_Comm comm_;
  PetscSF sf_ = nullptr;  // leaves: local items with a row; roots: this rank's rows
  PetscInt rows_ = 0, first_ = 0, count_ = 0, items_ = 0;
};

}  // namespace hyperqn

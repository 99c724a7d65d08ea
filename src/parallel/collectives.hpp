// Collectives over vectors whose length differs from rank to rank: the exchange of counts and the
// matching MPI "v" call, spelled out once; and the ranks' meeting after an error.
#pragma once
#include <mpi.h>

#include <ctime>

#include <vector>

namespace hyperqn {

// Every rank's items to every rank, in rank order; counts_out: each rank's number of items.
// Collective.
template <class T>
std::vector<T> all_gathered(MPI_Comm comm, const std::vector<T>& mine, MPI_Datatype type,
                            std::vector<int>* counts_out = nullptr) {
  int size;
  MPI_Comm_size(comm, &size);
  int count = (int)mine.size();
  std::vector<int> counts(size), offsets(size + 1, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  for (int r = 0; r < size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<T> all(offsets[size]);
  MPI_Allgatherv(mine.data(), count, type, all.data(), counts.data(), offsets.data(), type, comm);
  if (counts_out) *counts_out = counts;
  return all;
}

// Every rank's items for each rank (mine[offsets[r], offsets[r + 1]) to rank r), received in rank
// order; counts_out: how many from each rank. Collective.
inline std::vector<int> all_to_all(MPI_Comm comm, const std::vector<int>& mine, const std::vector<int>& counts,
                                   const std::vector<int>& offsets, std::vector<int>* counts_out = nullptr) {
  const int size = (int)counts.size();
  std::vector<int> in_counts(size), in_offsets(size + 1, 0);
  MPI_Alltoall(counts.data(), 1, MPI_INT, in_counts.data(), 1, MPI_INT, comm);
  for (int r = 0; r < size; ++r) in_offsets[r + 1] = in_offsets[r] + in_counts[r];
  std::vector<int> in(in_offsets[size]);
  MPI_Alltoallv(mine.data(), counts.data(), offsets.data(), MPI_INT, in.data(), in_counts.data(), in_offsets.data(),
                MPI_INT, comm);
  if (counts_out) *counts_out = in_counts;
  return in;
}

// After an error that may be one rank's alone (a check on PETSC_COMM_SELF, an exception): whether
// every rank came here within `seconds`. If not, the others wait in a collective this rank left,
// and the run can only be aborted (else it would hang). Collective if all ranks call it.
inline bool all_ranks_arrive(MPI_Comm comm, double seconds) {
  MPI_Request all_here;
  MPI_Ibarrier(comm, &all_here);
  const double until = MPI_Wtime() + seconds;
  int done = 0;
  while (!done) {
    MPI_Test(&all_here, &done, MPI_STATUS_IGNORE);
    if (!done && MPI_Wtime() > until) return false;  // the request is left: the caller aborts
    if (!done) {
      timespec nap{0, 1000000};  // 1 ms
      nanosleep(&nap, nullptr);
    }
  }
  return true;
}

}  // namespace hyperqn

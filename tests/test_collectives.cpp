// Unit test of parallel/collectives.hpp at any rank count: all_gathered and all_to_all with vectors of
// a different length on every rank, one rank with none, and the counts they report.
#include <mpi.h>

#include <cstdint>
#include <vector>

#include "check.hpp"
#include "parallel/collectives.hpp"

using namespace hyperqn;

namespace {

// Rank r holds r items (rank 0 none): r * 100 + i.
std::vector<int64_t> items_of(int rank) {
  std::vector<int64_t> v;
  for (int i = 0; i < rank; ++i) v.push_back(rank * 100 + i);
  return v;
}

void test_all_gathered(int rank, int size) {
  std::vector<int> counts;
  const std::vector<int64_t> all = all_gathered(MPI_COMM_WORLD, items_of(rank), MPI_INT64_T, &counts);
  std::vector<int64_t> expected;
  for (int r = 0; r < size; ++r) {
    const std::vector<int64_t> of_r = items_of(r);
    expected.insert(expected.end(), of_r.begin(), of_r.end());
  }
  CHECK(all == expected);  // every rank's items, in rank order, on every rank
  CHECK((int)counts.size() == size);
  for (int r = 0; r < size; ++r) CHECK(counts[r] == r);
  // Doubles, and no counts asked for.
  const std::vector<double> one = all_gathered(MPI_COMM_WORLD, std::vector<double>{0.5 + rank}, MPI_DOUBLE);
  CHECK((int)one.size() == size);
  for (int r = 0; r < size; ++r) CHECK(one[r] == 0.5 + r);
}

void test_all_to_all(int rank, int size) {
  // Rank r sends rank s (s + 1) items r * 1000 + s, none to itself.
  std::vector<int> mine, counts(size), offsets(size + 1, 0);
  for (int s = 0; s < size; ++s) {
    counts[s] = s == rank ? 0 : s + 1;
    for (int k = 0; k < counts[s]; ++k) mine.push_back(rank * 1000 + s);
    offsets[s + 1] = offsets[s] + counts[s];
  }
  std::vector<int> received_counts;
  const std::vector<int> in = all_to_all(MPI_COMM_WORLD, mine, counts, offsets, &received_counts);
  std::vector<int> expected;
  for (int r = 0; r < size; ++r)
    for (int k = 0; k < (r == rank ? 0 : rank + 1); ++k) expected.push_back(r * 1000 + rank);
  CHECK(in == expected);  // what each rank sent this one, in the senders' order
  for (int r = 0; r < size; ++r) CHECK(received_counts[r] == (r == rank ? 0 : rank + 1));
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  test_all_gathered(rank, size);
  test_all_to_all(rank, size);
  const int code = check::summary(rank == 0 ? "test_collectives" : "test_collectives (rank > 0)");
  MPI_Finalize();
  return code;
}

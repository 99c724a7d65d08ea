/* The machine's message costs for the scaling model (docs/performance.md#scaling-model), between
 * ranks 0 and 1 of `mpiexec -n 2 pingpong` (more ranks: the others join the Allreduces only):
 *   - ping-pong: rank 0 sends m bytes, rank 1 sends them back; one way = half the round trip,
 *     the best of several rounds of many repetitions (other jobs only ever add time);
 *   - alpha (s per message) = the one-way time of an 8-byte message, beta (s per byte) = the
 *     slope of the one-way time between the two largest sizes (where alpha no longer matters);
 *   - MPI_Allreduce (MPI_SUM) of n doubles, the best of several rounds, for a few n (the split
 *     solve's one Allreduce carries 3 s doubles, s the interface's vertices).
 * Prints one JSON object on rank 0's stdout (bench/scaling.py reads it). Not a test.
 * Options: --quick (fewer repetitions, for a check that it runs). */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { kRounds = 5 };

/* Best over kRounds of the mean one-way time of `repetitions` ping-pongs of `bytes` bytes. */
static double one_way_seconds(char* buffer, int bytes, int repetitions, int rank) {
  double best = 1e300;
  for (int round = 0; round < kRounds; ++round) {
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    for (int k = 0; k < repetitions; ++k) {
      if (rank == 0) {
        MPI_Send(buffer, bytes, MPI_BYTE, 1, 0, MPI_COMM_WORLD);
        MPI_Recv(buffer, bytes, MPI_BYTE, 1, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      } else if (rank == 1) {
        MPI_Recv(buffer, bytes, MPI_BYTE, 0, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        MPI_Send(buffer, bytes, MPI_BYTE, 0, 0, MPI_COMM_WORLD);
      }
    }
    const double t = (MPI_Wtime() - t0) / (2.0 * repetitions);
    if (t < best) best = t;
  }
  MPI_Bcast(&best, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);  /* rank 0's clock is the one reported */
  return best;
}

/* Best over kRounds of the mean time of `repetitions` MPI_Allreduce of n doubles. */
static double allreduce_seconds(double* in, double* out, int n, int repetitions) {
  double best = 1e300;
  for (int round = 0; round < kRounds; ++round) {
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    for (int k = 0; k < repetitions; ++k) MPI_Allreduce(in, out, n, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    const double t = (MPI_Wtime() - t0) / repetitions;
    if (t < best) best = t;
  }
  MPI_Bcast(&best, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  return best;
}

/* Repetitions that keep one round near a few milliseconds whatever the size. */
static int repetitions_for(double bytes, int quick) {
  const double budget = quick ? 2e5 : 4e7;  /* bytes moved per round, about */
  const int r = (int)(budget / (bytes + 1024.0));
  const int low = quick ? 2 : 20, high = quick ? 50 : 5000;
  return r < low ? low : r > high ? high : r;
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const int quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
  if (size < 2) {
    if (rank == 0) fprintf(stderr, "pingpong: needs at least 2 ranks (mpiexec -n 2 pingpong)\n");
    MPI_Finalize();
    return 1;
  }
  static const int sizes[] = {8, 64, 512, 4096, 32768, 262144, 1048576, 4194304};
  static const int doubles[] = {1, 3, 300, 3000, 24000, 100000, 1000000};
  const int n_sizes = sizeof sizes / sizeof sizes[0], n_doubles = sizeof doubles / sizeof doubles[0];
  char* buffer = calloc((size_t)sizes[n_sizes - 1], 1);
  double* in = calloc((size_t)doubles[n_doubles - 1], sizeof(double));
  double* out = calloc((size_t)doubles[n_doubles - 1], sizeof(double));
  if (!buffer || !in || !out) MPI_Abort(MPI_COMM_WORLD, 2);

  double one_way[sizeof sizes / sizeof sizes[0]], reduce[sizeof doubles / sizeof doubles[0]];
  one_way_seconds(buffer, sizes[0], repetitions_for(sizes[0], quick), rank);  /* warm-up: connections */
  for (int i = 0; i < n_sizes; ++i) one_way[i] = one_way_seconds(buffer, sizes[i], repetitions_for(sizes[i], quick), rank);
  for (int i = 0; i < n_doubles; ++i)
    reduce[i] = allreduce_seconds(in, out, doubles[i], repetitions_for(8.0 * doubles[i], quick));

  if (rank == 0) {
    const double alpha = one_way[0];
    const double beta = (one_way[n_sizes - 1] - one_way[n_sizes - 2]) / (sizes[n_sizes - 1] - sizes[n_sizes - 2]);
    printf("{\"ranks\": %d, \"alpha_s\": %.4e, \"beta_s_per_byte\": %.4e,\n \"one_way_s\": {", size, alpha, beta);
    for (int i = 0; i < n_sizes; ++i) printf("%s\"%d\": %.4e", i ? ", " : "", sizes[i], one_way[i]);
    printf("},\n \"allreduce_s\": {");
    for (int i = 0; i < n_doubles; ++i) printf("%s\"%d\": %.4e", i ? ", " : "", doubles[i], reduce[i]);
    printf("}}\n");
  }
  free(buffer);
  free(in);
  free(out);
  MPI_Finalize();
  return 0;
}

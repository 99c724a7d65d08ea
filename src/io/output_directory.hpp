// A run's output directory: created collectively, and cleared of an earlier run's files so that
// the frames of two runs never mix (docs/outputs.md, "A directory that holds an earlier run").
#pragma once
#include <mpi.h>

#include <string>

namespace hyperqn {

// Creates dir (and its parents) on rank 0; collective: on failure every rank throws
// std::runtime_error naming the directory.
void create_output_directory(MPI_Comm comm, const std::string& dir);

// Whether the file `name` in `dir` is one a run writes: summary.json, iterations.csv,
// contact.csv, NAME_NNNNN.vtu, NAME_NNNNN.pvtu, NAME_NNNNN_RANK.vtu, a NAME.pvd that lists
// NAME_ frames, and the temporaries of an interrupted write of any of these.
bool is_run_output(const std::string& dir, const std::string& name);

// Removes every file of dir for which is_run_output holds, and nothing else; returns how many.
// Call on one rank. Throws std::runtime_error naming a file that cannot be removed. A restart
// that continues an earlier run's series would skip this.
int clear_previous_run(const std::string& dir);

}  // namespace hyperqn

// The checkpoints of a run's output directory (OUTDIR/checkpoints) and the run each belongs to:
// which one `--restart latest|auto|PATH` continues, and which files a run keeps and removes
// (docs/outputs.md#checkpoints). The file format is io/checkpoint.hpp's.
//
// Every run has an id, kept by its restarts, in summary.json (written when the run starts) and in
// each checkpoint. The run that last wrote a directory is the one its summary.json names; a
// restart continues only that run, so a checkpoint left by an earlier run (or copied in, or
// damaged) is passed over with a warning, never resumed.
#pragma once
#include <mpi.h>

#include <string>
#include <vector>

#include "io/checkpoint.hpp"

namespace hyperqn {

// A new run's id: 32 hex digits from the system's random source (rank 0's, on every rank).
std::string new_run_id(MPI_Comm comm);
// The time now, UTC, ISO 8601 (rank 0's, on every rank).
std::string utc_now(MPI_Comm comm);

// The checkpoint a restart continues from.
struct RestartChoice {
  std::string path;         // "" and error "": none (--restart auto then starts the deck afresh)
  CheckpointHeader header;  // its header, on every rank
  std::string error;        // why the restart cannot go on (exit 1)
};

// For --restart `restart` ("latest", "auto" or a checkpoint's path) into outdir: the newest whole
// checkpoint of the run that last wrote outdir (latest, auto), or the file given if it is one of
// that run. Prints a warning for every file passed over (damaged, another run's, a name that is
// not a checkpoint's). Collective; rank 0 reads the files.
RestartChoice choose_restart(MPI_Comm comm, const std::string& restart, const std::string& outdir);

// The checkpoints one run writes into dir, of which it keeps the newest `keep`.
class CheckpointStore {
 public:
  CheckpointStore(MPI_Comm comm, std::string dir, int keep) : comm_(comm), dir_(std::move(dir)), keep_(keep) {}
  // A restart of run `run_id` from `frame`: its checkpoints of later frames (that future is
  // abandoned) and damaged ones of later frames go, with the temporaries of interrupted writes;
  // the others count towards `keep`. Collective; throws std::runtime_error on every rank.
  void resume(const std::string& run_id, int frame);
  // Writes the checkpoint of h.frame, then removes this run's oldest beyond `keep`. Collective;
  // throws std::runtime_error on every rank ("cannot write PATH: <reason>"). Returns its path.
  std::string write(const CheckpointHeader& h, const DistributedMesh& mesh, const VertexRows& rows,
                    const std::vector<ElementRows>& elements = {});

 private:
  MPI_Comm comm_;
  std::string dir_;
  int keep_;
  std::vector<int> frames_;  // rank 0: this run's checkpoints on disk, oldest first
};

}  // namespace hyperqn

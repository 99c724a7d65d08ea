// A run's output directory: created collectively, and cleared of an earlier run's files so that
// the frames of two runs never mix (docs/outputs.md, "A directory that holds an earlier run").
#pragma once
#include <mpi.h>

#include <string>

namespace hyperqn {

// Creates dir (and its parents) on rank 0; collective: on failure every rank throws
// std::runtime_error naming the directory.
void create_output_directory(MPI_Comm comm, const std::string& dir);

// An advisory lock on an output directory, held by rank 0 for the run's life, so that
// two runs never write one directory at once: flock(2) on DIR/.hyperqn.lock, which says who holds it
// (pid, host, start time, deck). The kernel releases it when the process ends, however it ends
// (kill -9 included): nothing stale is left, and a restart of a dead run takes it again. The file
// is removed as the lock is released (a run that opened it just before locks it, sees it unlinked and
// opens the next); after a kill it stays, unlocked, and the next run takes it.
// On NFS, flock is carried by the server's lock manager (NLM, or NFSv4's own locks) and holds between
// hosts; a mount with `nolock` or `local_lock=flock`, or Lustre's `localflock`, makes it hold on one
// host only; where the file system refuses locks (ENOLCK, EOPNOTSUPP) the run warns and goes on
// unlocked. docs/outputs.md, "One run at a time".
class OutputLock {
 public:
  static constexpr const char* kFileName = ".hyperqn.lock";
  OutputLock() = default;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();  // releases it, and removes its file
  // Collective; dir exists. Takes the lock and notes in it who holds it (`what`: "deck D"); "" on
  // every rank, or on every rank the refusal, naming dir and the run that holds it.
  std::string take(MPI_Comm comm, const std::string& dir, const std::string& what);

 private:
  int fd_ = -1;
  std::string path_;
};

// Collective: "" if no other process holds dir's lock now, else the refusal take() would give. Reads
// only (creates nothing): for a check before a run's setup, which can take minutes.
std::string output_directory_in_use(MPI_Comm comm, const std::string& dir);

// Whether the file `name` in `dir` is one a run writes: summary.json, iterations.csv,
// contact.csv, config.yaml, NAME_NNNNN.vtu, NAME_NNNNN.pvtu, NAME_NNNNN_RANK.vtu, a NAME.pvd that lists
// NAME_ frames, a NAME.xdmf whose data are in NAME.h5 and that NAME.h5, and the temporaries of an
// interrupted write of any of these.
bool is_run_output(const std::string& dir, const std::string& name);

// Where a run's file comes in clearing an earlier run (lower first): a series' index before what it
// lists (a .pvd its frames, a .xdmf its .h5, a .pvtu its pieces), so that a run killed while it
// clears leaves no index listing a file already gone.
inline int removal_order(const std::string& name) {
  const auto ends = [&](const char* e) {
    const std::string s(e);
    return name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0;
  };
  return ends(".pvd") ? 0 : ends(".xdmf") ? 1 : ends(".pvtu") ? 2 : 3;
}

// What clear_previous_run removed.
struct Cleared {
  int files = 0, checkpoints = 0;
};

// Removes an earlier run's files from dir: first the checkpoints of dir/checkpoints (with the
// temporaries of interrupted checkpoint writes), so that no checkpoint outlives the frames it
// refers to, then every file of dir for which is_run_output holds but summary.json (the caller
// has already replaced it with the new run's, which names the new run: from then on no restart
// takes the earlier run's leftovers for the directory's run). Nothing else. Call on one rank.
// Throws std::runtime_error naming a file that cannot be removed.
Cleared clear_previous_run(const std::string& dir);

// A restart from a checkpoint that holds no state of the frame series of `format` ("vtu" or
// "xdmf"): such a series in dir began after the checkpoint, on the trajectory the restart leaves,
// and its files go (its index first). Call on one rank; returns how many. Throws std::runtime_error.
int remove_series_begun_later(const std::string& dir, const std::string& format);

// A restart: removes the temporaries that interrupted writes of run outputs left in dir (a
// killed run's .NAME_00010.vtu.tmp-PID). Call on one rank; returns how many.
int remove_interrupted_writes(const std::string& dir);

}  // namespace hyperqn

// The run's logs: iterations.csv (one row per solver iteration), the terms' own logs (e.g.
// contact.csv: EnergyTerm::log) and summary.json.
// Written by rank 0; the values they hold are already global. The CSVs are flushed a frame at a
// time, in whole lines; summary.json is replaced atomically (io/atomic_file.hpp).
#pragma once
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/records.hpp"

namespace hyperqn {

class IterationLog {
 public:
  // Opens path for writing on rank 0 (other ranks: no-op). Throws std::runtime_error on failure.
  void open(const std::string& path, int rank);
  void append(int frame, const IterationRecord& r);
  // A restart: keeps the rows of frames <= frame of an existing file at path and appends to it.
  void resume(const std::string& path, int rank, int frame);
  // Writes the rows appended so far (at the end of every frame). Throws std::runtime_error.
  void flush() { file_.flush(); }

 private:
  LineFile file_;
};

// A log of rows per frame, "frame,time," then `columns` (a term's own log; rank 0 writes).
class FrameLog {
 public:
  void open(const std::string& path, const std::string& columns, int rank);
  // rows: the values after frame,time, one row each.
  void append(int frame, double time, const std::vector<std::string>& rows);
  // As IterationLog::resume; pad: a kept row with fewer cells than the header (a file written before a
  // column was added at the end) gets 0 in each missing one.
  void resume(const std::string& path, const std::string& columns, int rank, int frame, bool pad = false);
  void flush() { file_.flush(); }

 private:
  LineFile file_;
};

// A restart whose deck no longer writes the log at path: its rows of frames after `frame` (of the
// trajectory the restart leaves) are removed, the header and the others kept as they are; no file,
// nothing done. Rank 0 (other ranks: no-op). Throws std::runtime_error.
void cut_log_back(const std::string& path, int frame, int rank);

// Raises the summary's field `name` (a maximum over the run's frames that a term reports:
// max_penetration, max_active_contacts, max_self_crossings) to value if it is larger. Throws std::logic_error for a
// name summary.json does not have.
void raise_summary_maximum(RunSummary& s, const std::string& name, double value);
// Counts `frame` under the summary's field `name` (a flag a term reports: collider_intrusions,
// self_crossing_frames), keeping what the first flagged frame said. Throws std::logic_error for a name summary.json
// does not have.
void count_summary_flag(RunSummary& s, const std::string& name, int frame, const std::string& what);

// Writes summary.json (rank 0 only), atomically: the file on disk is always a whole one. Throws
// std::runtime_error naming the path on failure, leaving the previous file as it was.
void write_summary(const std::string& path, const RunSummary& s);

// The run_id of the summary.json at path, or "" if there is none (no file, no such field).
std::string summary_run_id(const std::string& path);

// Peak resident set size of this process in MB.
double peak_rss_mb();

}  // namespace hyperqn

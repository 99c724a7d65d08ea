// The run's logs: iterations.csv (one row per solver iteration) and summary.json.
// Written by rank 0; the values they hold are already global.
#pragma once
#include <cstdio>
#include <string>

#include "io/records.hpp"
#include "terms/contact.hpp"

namespace hyperqn {

class IterationLog {
 public:
  // Opens path for writing on rank 0 (other ranks: no-op). Throws std::runtime_error on failure.
  void open(const std::string& path, int rank);
  void append(int frame, const IterationRecord& r);
  // A restart: keeps the rows of frames <= frame of an existing file at path and appends to it.
  void resume(const std::string& path, int rank, int frame);
  void flush();
  ~IterationLog();

 private:
  std::FILE* file_ = nullptr;
};

// contact.csv: per frame and collider, the total normal and friction force on the body, the
// deepest penetration and the vertices within the activation distance (rank 0 writes).
class ContactLog {
 public:
  void open(const std::string& path, int rank);
  void append(int frame, double time, const ContactMeasure& m);
  void resume(const std::string& path, int rank, int frame);  // as IterationLog::resume
  ~ContactLog();

 private:
  std::FILE* file_ = nullptr;
};

// Writes summary.json (rank 0 only). Throws std::runtime_error on failure.
void write_summary(const std::string& path, const RunSummary& s);

// Peak resident set size of this process in MB.
double peak_rss_mb();

}  // namespace hyperqn

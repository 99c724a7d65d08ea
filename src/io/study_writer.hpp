// Writes the study's results (rank 0): study.csv and trajectory.csv (whole rows, as each curve is
// added), and the same data in study.h5 (HDF5: /frames/frame_NNNNN/<solver>/...,
// /trajectory/<solver>/...; a trajectory point's status only in the CSV), which appears under its
// name only once finish() has closed it.
#pragma once
#include <hdf5.h>

#include <cstdio>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/records.hpp"

namespace hyperqn {

// One solver's iterations at one study frame, with the errors relative to the reference.
struct StudyCurve {
  std::string solver;
  int frame = 0;
  std::vector<IterationRecord> iterations;
  double g0 = 0, g_star = 0;  // g at the common start, reference minimum
  // 0 where the frame starts at its answer (g0 = g*: every iterate is, and e would be 0/0).
  double rel_error(const IterationRecord& r) const { return g0 > g_star ? (r.energy - g_star) / (g0 - g_star) : 0.0; }
};

struct TrajectoryPoint {
  std::string solver;
  int frame = 0;
  double time_s = 0;         // cumulative solve time up to and including this frame
  long long iterations = 0;  // cumulative
  double rms_error = 0;      // RMS over free vertices of |x - x_ref|
  double rel_rms_error = 0;  // rms_error / rest bounding-box diagonal
  // "ok", or why the trajectory stopped at this frame (a guardrail, app/frame_step.hpp; the errors
  // are then NaN and the solver's trajectory has no later point)
  std::string status = "ok";
};

class StudyWriter {
 public:
  // Opens the files (rank 0 only; other ranks: no-op). Throws std::runtime_error.
  StudyWriter(const std::string& outdir, int rank);
  ~StudyWriter();
  StudyWriter(const StudyWriter&) = delete;
  StudyWriter& operator=(const StudyWriter&) = delete;
  // Each records its failure rather than throwing: rank 0 alone writes, so every rank must learn
  // of it together (check).
  void add(const StudyCurve& c);
  void add(const TrajectoryPoint& p);
  // Writes the trajectory datasets and closes everything.
  void finish();
  // Collective: if rank 0 failed to write, every rank throws std::runtime_error ("cannot write
  // PATH: <reason>").
  void check(MPI_Comm comm) const;

 private:
  void add_curve(const StudyCurve& c);
  void finish_file();
  std::string error_;  // the first failure
  bool active_ = false;
  LineFile study_csv_, trajectory_csv_;
  hid_t h5_ = -1;
  std::string h5_path_;  // study.h5, held in memory until finish()
  std::vector<TrajectoryPoint> trajectory_;
};

}  // namespace hyperqn

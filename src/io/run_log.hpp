// The run's logs: iterations.csv (one row per solver iteration) and summary.json.
// Written by rank 0; the values they hold are already global.
#pragma once
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "solvers/time_step_solver.hpp"

namespace hyperqn {

class IterationLog {
 public:
  // Opens path for writing on rank 0 (other ranks: no-op). Throws std::runtime_error on failure.
  void open(const std::string& path, int rank);
  void append(int frame, const IterationRecord& r);
  ~IterationLog();

 private:
  std::FILE* file_ = nullptr;
};

struct RunSummary {
  std::string deck, solver;
  // "ok"; "flagged: N of M frames could not decrease g (first: frame K)" (completed, exit 0); or
  // "error: ..." (the run stopped, exit 1).
  std::string status = "ok";
  int ranks = 0;
  long long vertices = 0, tets = 0, segments = 0, dofs = 0, fixed_vertices = 0;
  int frames = 0, factorizations = 0;
  double dt = 0;
  double setup_s = 0, assembly_s = 0, factor_s = 0, solve_s = 0, wall_s = 0;
  double ms_per_frame = 0, ms_per_iteration = 0, mean_iterations = 0;
  long long iterations = 0, evaluations = 0, h0_solves = 0;
  double objective_s = 0, h0_solve_s = 0;     // time in g / grad g evaluations and in A^{-1} solves
  double hessian_s = 0;                       // newton: time assembling M + h^2 K
  long long converged_frames = 0, failed_frames = 0;
  // Guardrails: line searches that failed (each followed by a retry), evaluations rejected for a
  // non-finite g or grad g, and the frames that could not decrease g (or stopped the run), with
  // the solver's reason.
  long long ls_failures = 0, rejected_evaluations = 0;
  std::vector<std::pair<int, std::string>> flagged_frames;
  double final_energy = 0, final_grad_norm = 0, min_J = 0;
  double peak_rss_mb = 0, peak_rss_mb_total = 0;  // max over ranks, sum over ranks
};

// Writes summary.json (rank 0 only). Throws std::runtime_error on failure.
void write_summary(const std::string& path, const RunSummary& s);

// Peak resident set size of this process in MB.
double peak_rss_mb();

}  // namespace hyperqn

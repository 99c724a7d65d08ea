#include "io/run_log.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hyperqn {

namespace {

const char kIterationHeader[] = "frame,iteration,time_s,energy,grad_norm,step,evaluations\n";

// A restart's CSV: the header and the rows of frames <= frame of the file at path (rows start
// with their frame; a missing file keeps none).
std::string rows_up_to(const std::string& path, int frame, const std::string& header, bool pad = false) {
  std::ifstream in(path);
  std::string kept = header, line;
  const auto cells = [](const std::string& s) { return std::count(s.begin(), s.end(), ',') + 1; };
  const auto wanted = cells(header.substr(0, header.find('\n')));
  if (in && std::getline(in, line))  // the header
    while (std::getline(in, line))
      if (!line.empty() && std::atoi(line.c_str()) <= frame) {
        if (pad)
          for (auto k = cells(line); k < wanted; ++k) line += ",0";
        kept += line + "\n";
      }
  return kept;
}

}  // namespace

void IterationLog::open(const std::string& path, int rank) {
  if (rank != 0) return;
  file_.open(path);
  file_.add(kIterationHeader);
  file_.flush();
}

void IterationLog::resume(const std::string& path, int rank, int frame) {
  if (rank == 0) file_.reopen(path, rows_up_to(path, frame, kIterationHeader));
}

void IterationLog::append(int frame, const IterationRecord& r) {
  if (!file_.is_open()) return;
  char line[256];
  std::snprintf(line, sizeof line, "%d,%d,%.9e,%.17g,%.17g,%.17g,%d\n", frame, (int)r.iteration, r.time_s, r.energy,
                r.grad_norm, r.step, (int)r.evaluations);
  file_.add(line);
}

void FrameLog::open(const std::string& path, const std::string& columns, int rank) {
  if (rank != 0) return;
  file_.open(path);
  file_.add("frame,time," + columns + "\n");
  file_.flush();
}

void FrameLog::resume(const std::string& path, const std::string& columns, int rank, int frame, bool pad) {
  if (rank == 0) file_.reopen(path, rows_up_to(path, frame, "frame,time," + columns + "\n", pad));
}

void FrameLog::append(int frame, double time, const std::vector<std::string>& rows) {
  if (!file_.is_open()) return;
  char head[64];
  std::snprintf(head, sizeof head, "%d,%.17g,", frame, time);
  for (const std::string& row : rows) file_.add(head + row + "\n");
}

void cut_log_back(const std::string& path, int frame, int rank) {
  if (rank != 0) return;
  std::ifstream in(path);
  std::string header;
  if (!in || !std::getline(in, header)) return;
  in.close();
  write_file_atomically(path, rows_up_to(path, frame, header + "\n"));
}

void raise_summary_maximum(RunSummary& s, const std::string& name, double value) {
  if (name == "max_penetration") {
    s.max_penetration = std::fmax(s.max_penetration, value);
  } else if (name == "max_active_contacts") {
    s.max_active_contacts = std::max(s.max_active_contacts, (long long)value);
  } else if (name == "max_self_crossings") {
    s.max_self_crossings = std::max(s.max_self_crossings, (long long)value);
  } else {
    throw std::logic_error("summary.json has no maximum named " + name);
  }
}

void count_summary_flag(RunSummary& s, const std::string& name, int frame, const std::string& what) {
  if (name == "collider_intrusions") {
    if (s.collider_intrusions++ == 0) {
      s.first_intrusion_frame = frame;
      s.first_intrusion = what;
    }
  } else if (name == "self_crossing_frames") {
    if (s.self_crossing_frames++ == 0) {
      s.first_self_crossing_frame = frame;
      s.first_self_crossing = what;
    }
  } else {
    throw std::logic_error("summary.json has no flag named " + name);
  }
}

// JSON has no NaN or Inf: write null for them.
static std::string number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);  // full precision: the numbers are read back
  return buf;
}

static std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    if (c == '\n') {
      q += "\\n";
      continue;
    }
    q += c;
  }
  return q + "\"";
}

// summary.json's "reactions" line and its comma, or nothing for a run that did not ask for them.
static std::string reactions_entry(const std::vector<SupportReaction>& reactions) {
  if (reactions.empty()) return "";
  const auto vec = [](const std::array<double, 3>& a) {
    return "[" + number(a[0]) + ", " + number(a[1]) + ", " + number(a[2]) + "]";
  };
  std::string out = "  \"reactions\": [";
  for (size_t k = 0; k < reactions.size(); ++k) {
    const SupportReaction& r = reactions[k];
    out += std::string(k ? ", " : "") + "{\"name\": " + quoted(r.name) + ", \"line\": " + std::to_string(r.line) +
           ", \"force\": " + vec(r.force) + ", \"moment\": " + vec(r.moment) + ", \"point\": " + vec(r.point) +
           ", \"max_force\": " + number(r.max_force) + ", \"max_force_frame\": " + std::to_string(r.max_force_frame) +
           "}";
  }
  return out + "],\n";
}

void write_summary(const std::string& path, const RunSummary& s) {
  std::string flagged = "[";
  for (const auto& [frame, reason] : s.flagged_frames)
    flagged += std::string(flagged.size() > 1 ? ", " : "") + "{\"frame\": " + std::to_string(frame) +
               ", \"reason\": " + quoted(reason) + "}";
  flagged += "]";
  const std::string first_intrusion =
      s.collider_intrusions ? "{\"frame\": " + std::to_string(s.first_intrusion_frame) + ", \"what\": " + quoted(s.first_intrusion) + "}"
                            : std::string("null");
  const std::string first_self_crossing =
      s.self_crossing_frames ? "{\"frame\": " + std::to_string(s.first_self_crossing_frame) + ", \"what\": " +
                                   quoted(s.first_self_crossing) + "}"
                             : std::string("null");
  // A free scene's |P_n - P_0| over its scale (0 for a scene that never moved); null otherwise.
  const std::string momentum_change =
      !s.free_scene ? "null" : number(s.momentum_scale > 0 ? s.momentum_drift / s.momentum_scale : s.momentum_drift);
  std::ostringstream out;
  out << "{\n"
      << "  \"deck\": " << quoted(s.deck) << ",\n"
      << "  \"run_id\": " << quoted(s.run_id) << ",\n"
      << "  \"status\": " << quoted(s.status) << ",\n"
      << "  \"signal\": " << (s.signal.empty() ? std::string("null") : quoted(s.signal)) << ",\n"
      << "  \"solver\": " << quoted(s.solver) << ",\n"
      << "  \"ranks\": " << s.ranks << ",\n"
      << "  \"vertices\": " << s.vertices << ",\n"
      << "  \"tets\": " << s.tets << ",\n"
      << "  \"segments\": " << s.segments << ",\n"
      << "  \"triangles\": " << s.triangles << ",\n"
      << "  \"dofs\": " << s.dofs << ",\n"
      << "  \"fixed_vertices\": " << s.fixed_vertices << ",\n"
      << "  \"dropped_vertices\": " << s.dropped_vertices << ",\n"
      << "  \"reoriented_tets\": " << s.reoriented_tets << ",\n"
      << "  \"frames\": " << s.frames << ",\n"
      << "  \"dt\": " << number(s.dt) << ",\n"
      << "  \"factorizations\": " << s.factorizations << ",\n"
      << "  \"h0_package\": " << (s.h0_package.empty() ? std::string("null") : quoted(s.h0_package)) << ",\n"
      << "  \"h0_factor_nonzeros\": " << number(s.h0_factor_nonzeros) << ",\n"
      << "  \"h0_interface\": " << s.h0_interface << ",\n"
      << "  \"setup_s\": " << number(s.setup_s) << ",\n"
      << "  \"assembly_s\": " << number(s.assembly_s) << ",\n"
      << "  \"factor_s\": " << number(s.factor_s) << ",\n"
      << "  \"solve_s\": " << number(s.solve_s) << ",\n"
      << "  \"wall_s\": " << number(s.wall_s) << ",\n"
      << "  \"ms_per_frame\": " << number(s.ms_per_frame) << ",\n"
      << "  \"ms_per_iteration\": " << number(s.ms_per_iteration) << ",\n"
      << "  \"iterations\": " << s.iterations << ",\n"
      << "  \"mean_iterations\": " << number(s.mean_iterations) << ",\n"
      << "  \"evaluations\": " << s.evaluations << ",\n"
      << "  \"objective_s\": " << number(s.objective_s) << ",\n"
      << "  \"h0_solves\": " << s.h0_solves << ",\n"
      << "  \"h0_solve_s\": " << number(s.h0_solve_s) << ",\n"
      << "  \"hessian_s\": " << number(s.hessian_s) << ",\n"
      << "  \"hessian_assemblies\": " << s.hessian_assemblies << ",\n"
      << "  \"converged_frames\": " << s.converged_frames << ",\n"
      << "  \"failed_frames\": " << s.failed_frames << ",\n"
      << "  \"flagged_frames\": " << flagged << ",\n"
      << "  \"ls_failures\": " << s.ls_failures << ",\n"
      << "  \"extended_frames\": " << s.extended_frames << ",\n"
      << "  \"substepped_frames\": " << s.substepped_frames << ",\n"
      << "  \"kept_substep_frames\": " << s.kept_substep_frames << ",\n"
      << "  \"newton_frames\": " << s.newton_frames << ",\n"
      << "  \"inverted_frames\": " << s.inverted_frames.size() << ",\n"
      << "  \"rejected_evaluations\": " << s.rejected_evaluations << ",\n"
      << "  \"pulled_back_guesses\": " << s.pulled_back_guesses << ",\n"
      << "  \"euler_completed_steps\": " << s.euler_completed_steps << ",\n"
      << "  \"final_energy\": " << number(s.final_energy) << ",\n"
      << "  \"final_grad_norm\": " << number(s.final_grad_norm) << ",\n"
      << "  \"max_residual\": " << number(s.max_residual) << ",\n"
      << "  \"max_residual_frame\": " << s.max_residual_frame << ",\n"
      << "  \"momentum_change\": " << momentum_change << ",\n"
      << "  \"momentum_change_frame\": " << (s.free_scene ? std::to_string(s.momentum_drift_frame) : "null") << ",\n"
      << "  \"min_J\": " << number(s.min_J) << ",\n"
      << "  \"max_penetration\": " << number(s.max_penetration) << ",\n"
      << "  \"max_active_contacts\": " << s.max_active_contacts << ",\n"
      << "  \"collider_intrusions\": " << s.collider_intrusions << ",\n"
      << "  \"first_intrusion\": " << first_intrusion << ",\n"
      << "  \"max_self_crossings\": " << s.max_self_crossings << ",\n"
      << "  \"self_crossing_frames\": " << s.self_crossing_frames << ",\n"
      << "  \"first_self_crossing\": " << first_self_crossing << ",\n"
      << "  \"contact_s\": " << number(s.contact_s) << ",\n"
      << "  \"contact_evaluations\": " << s.contact_evaluations << ",\n"
      << reactions_entry(s.reactions)
      << (std::isnan(s.dissipated_energy) ? "" : "  \"dissipated_energy\": " + number(s.dissipated_energy) + ",\n")
      << (std::isnan(s.small_strain_reach) ? "" : "  \"prony_largest_strain\": " + number(s.small_strain_reach) + ",\n")
      << (!s.cuts ? "" : "  \"cuts\": {\"faces_separated\": " + std::to_string(s.faces_separated - s.faces_broken) +
                             ", \"vertices_added\": " + std::to_string(s.cut_vertices) +
                             ", \"tets_removed\": " + std::to_string(s.tets_removed) +
                             ", \"h0_corrections\": " + std::to_string(s.cut_h0_corrections) +
                             ", \"refactorizations\": " + std::to_string(s.cut_refactorizations) +
                             ", \"topology_s\": " + number(s.topology_s) + "},\n")
      << (!s.fracture ? "" : "  \"fracture\": {\"faces_broken\": " + std::to_string(s.faces_broken) +
                                 ", \"vertices_added\": " + std::to_string(s.cut_vertices) +
                                 ", \"first_break_frame\": " +
                                 (s.first_break_frame < 0 ? std::string("null") : std::to_string(s.first_break_frame)) +
                                 ", \"h0_corrections\": " + std::to_string(s.cut_h0_corrections) +
                                 ", \"refactorizations\": " + std::to_string(s.cut_refactorizations) +
                                 ", \"topology_s\": " + number(s.topology_s) + "},\n")
      << (!s.breaks ? "" : "  \"breaks\": {\"segments_snapped\": " + std::to_string(s.segments_snapped) +
                               ", \"edges_torn\": " + std::to_string(s.edges_torn) +
                               ", \"vertices_added\": " + std::to_string(s.break_vertices) +
                               ", \"h0_corrections\": " + std::to_string(s.break_h0_corrections) +
                               ", \"refactorizations\": " + std::to_string(s.break_refactorizations) +
                               ", \"topology_s\": " + number(s.topology_s) + "},\n")
      << "  \"peak_rss_mb\": " << number(s.peak_rss_mb) << ",\n"
      << "  \"peak_rss_mb_total\": " << number(s.peak_rss_mb_total) << ",\n"
      << "  \"peak_rss_mb_by_rank\": [";
  for (size_t r = 0; r < s.peak_rss_mb_by_rank.size(); ++r) out << (r ? ", " : "") << number(s.peak_rss_mb_by_rank[r]);
  out << "]\n}\n";
  write_file_atomically(path, out.str());
}

std::string summary_run_id(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return "";  // (a directory cannot be read as one)
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string key = "\n  \"run_id\": \"";  // as write_summary writes it
  const size_t at = text.find(key);
  if (at == std::string::npos) return "";
  const size_t end = text.find('"', at + key.size());
  return end == std::string::npos ? "" : text.substr(at + key.size(), end - at - key.size());
}

double peak_rss_mb() {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;  // Linux reports KiB
}

}  // namespace hyperqn

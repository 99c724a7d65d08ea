#include "io/checkpoint.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/fnv_hash.hpp"
#include "io/hdf5_file.hpp"

namespace fs = std::filesystem;

namespace hyperqn {

namespace {

constexpr const char* kPrefix = "checkpoint_";
constexpr const char* kSuffix = ".h5";
constexpr int kTagRows = 7031;  // the messages that carry a rank's rows to or from rank 0
const std::string kElementPrefix = "elements_";  // an element set's dataset: elements_<name>

// The summary's counters, each stored as summary_<name>. Frame counters describe frames
// 1..frame and are restored; work counters (times, factorizations, solves) are added to the
// restarted run's own.
struct LongField { const char* name; long long RunSummary::*member; bool work; };
struct IntField { const char* name; int RunSummary::*member; bool work; };
struct RealField { const char* name; double RunSummary::*member; bool work; };
const LongField kLongFields[] = {
    {"iterations", &RunSummary::iterations, false},
    {"evaluations", &RunSummary::evaluations, false},
    {"converged_frames", &RunSummary::converged_frames, false},
    {"failed_frames", &RunSummary::failed_frames, false},
    {"ls_failures", &RunSummary::ls_failures, false},
    {"rejected_evaluations", &RunSummary::rejected_evaluations, false},
    {"pulled_back_guesses", &RunSummary::pulled_back_guesses, false},
    {"euler_completed_steps", &RunSummary::euler_completed_steps, false},
    {"extended_frames", &RunSummary::extended_frames, false},
    {"substepped_frames", &RunSummary::substepped_frames, false},
    {"kept_substep_frames", &RunSummary::kept_substep_frames, false},
    {"newton_frames", &RunSummary::newton_frames, false},
    {"max_active_contacts", &RunSummary::max_active_contacts, false},
    {"collider_intrusions", &RunSummary::collider_intrusions, false},
    {"first_intrusion_frame", &RunSummary::first_intrusion_frame, false},
    {"max_self_crossings", &RunSummary::max_self_crossings, false},
    {"self_crossing_frames", &RunSummary::self_crossing_frames, false},
    {"first_self_crossing_frame", &RunSummary::first_self_crossing_frame, false},
    {"max_residual_frame", &RunSummary::max_residual_frame, false},
    {"momentum_drift_frame", &RunSummary::momentum_drift_frame, false},
    {"h0_solves", &RunSummary::h0_solves, true},
    {"hessian_assemblies", &RunSummary::hessian_assemblies, true},
    {"contact_evaluations", &RunSummary::contact_evaluations, true},
    {"cut_h0_corrections", &RunSummary::cut_h0_corrections, true},
    {"cut_refactorizations", &RunSummary::cut_refactorizations, true},
    {"break_h0_corrections", &RunSummary::break_h0_corrections, true},
    {"break_refactorizations", &RunSummary::break_refactorizations, true},
    {"faces_broken", &RunSummary::faces_broken, true},  // a deck with cuts and fracture: of this run's faces
    {"first_break_frame", &RunSummary::first_break_frame, false},
};
const IntField kIntFields[] = {
    {"frames", &RunSummary::frames, false},
    {"factorizations", &RunSummary::factorizations, true},
};
const RealField kRealFields[] = {
    {"min_J", &RunSummary::min_J, false},
    {"max_penetration", &RunSummary::max_penetration, false},
    {"final_energy", &RunSummary::final_energy, false},
    {"final_grad_norm", &RunSummary::final_grad_norm, false},
    {"max_residual", &RunSummary::max_residual, false},
    {"momentum_drift", &RunSummary::momentum_drift, false},
    {"momentum_scale", &RunSummary::momentum_scale, false},
    {"dissipated_removed", &RunSummary::dissipated_removed, false},
    {"assembly_s", &RunSummary::assembly_s, true},
    {"factor_s", &RunSummary::factor_s, true},
    {"solve_s", &RunSummary::solve_s, true},
    {"objective_s", &RunSummary::objective_s, true},
    {"h0_solve_s", &RunSummary::h0_solve_s, true},
    {"hessian_s", &RunSummary::hessian_s, true},
    {"contact_s", &RunSummary::contact_s, true},
    {"wall_s", &RunSummary::wall_s, true},
};

std::string flags_text(const std::vector<char>& flags) {
  std::string s;
  for (char f : flags) s += f ? '1' : '0';
  return s;
}
std::vector<char> parse_flags(const std::string& s) {
  std::vector<char> flags;
  for (char c : s) flags.push_back(c == '1');
  return flags;
}

// The header as "key value" lines (values on one line; doubles with 17 digits, read back exactly).
class HeaderLines {
 public:
  void put(const std::string& key, const std::string& value) {
    std::string one_line = value;
    std::replace(one_line.begin(), one_line.end(), '\n', ' ');
    text_ += key + " " + one_line + "\n";
  }
  void put(const std::string& key, long long x) { put(key, std::to_string(x)); }
  void put(const std::string& key, double x) {
    char text[40];
    std::snprintf(text, sizeof text, "%.17g", x);
    put(key, std::string(text));
  }
  const std::string& text() const { return text_; }

  // Parses text; get* throw std::runtime_error naming a missing or malformed key.
  explicit HeaderLines(const std::string& text = "") {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t space = line.find(' ');
      if (space != std::string::npos) values_[line.substr(0, space)] = line.substr(space + 1);
    }
  }
  bool has(const std::string& key) const { return values_.count(key) > 0; }
  std::string get(const std::string& key) const {
    const auto it = values_.find(key);
    if (it == values_.end()) throw std::runtime_error("its header has no " + key);
    return it->second;
  }
  long long get_long(const std::string& key) const {
    const std::string v = get(key);
    char* end = nullptr;
    const long long x = std::strtoll(v.c_str(), &end, 10);
    if (v.empty() || *end) throw std::runtime_error("its header's " + key + " is not an integer");
    return x;
  }
  double get_real(const std::string& key) const {
    const std::string v = get(key);
    char* end = nullptr;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end) throw std::runtime_error("its header's " + key + " is not a number");
    return x;
  }

 private:
  std::string text_;
  std::map<std::string, std::string> values_;
};

// Every text item of a checkpoint: "header" and the texts that grow with the run.
std::map<std::string, std::string> texts_of(const CheckpointHeader& h) {
  HeaderLines head;
  head.put("format_version", (long long)h.version);
  head.put("run_id", h.run_id);
  head.put("run_started", h.run_started);
  head.put("deck", h.deck);
  head.put("mesh_hash", h.mesh_hash);
  head.put("vertices", h.vertices);
  head.put("dofs", h.dofs);
  head.put("vertex_slots", h.vertex_slots);
  head.put("ranks", (long long)h.ranks);
  head.put("frame", (long long)h.frame);
  head.put("time", h.time);
  head.put("body_time", h.body_time);
  head.put("released", flags_text(h.released));
  head.put("released_attachments", flags_text(h.released_attachments));
  if (!h.cuts.empty()) {
    std::string cuts;
    for (const auto& f : h.cuts)
      for (int64_t x : f) cuts += (cuts.empty() ? "" : " ") + std::to_string(x);
    head.put("cuts", cuts);
    head.put("cuts_factored", h.cuts_factored);
    std::string sizes;
    for (int64_t n : h.cut_batches) sizes += (sizes.empty() ? "" : " ") + std::to_string(n);
    head.put("cut_batches", sizes);
  }
  if (h.cuts_resolved) head.put("cuts_resolved", h.cuts_resolved);
  if (h.changes_decided) head.put("changes_decided", 1LL);
  if (!h.breaks.empty()) {
    std::string breaks;
    for (const auto& b : h.breaks)
      for (int64_t x : b) breaks += (breaks.empty() ? "" : " ") + std::to_string(x);
    head.put("breaks", breaks);
    head.put("breaks_factored", h.breaks_factored);
    std::string sizes;
    for (int64_t n : h.break_batches) sizes += (sizes.empty() ? "" : " ") + std::to_string(n);
    head.put("break_batches", sizes);
  }
  head.put("started_inverted", (long long)h.started_inverted);
  const RunSummary& s = h.summary;
  for (const auto& f : kLongFields) head.put(std::string("summary_") + f.name, s.*f.member);
  for (const auto& f : kIntFields) head.put(std::string("summary_") + f.name, (long long)(s.*f.member));
  for (const auto& f : kRealFields) head.put(std::string("summary_") + f.name, s.*f.member);
  // NaN (no viscoelastic_prony tets) kept as -1: a header's values compare equal.
  head.put("summary_small_strain_reach", std::isnan(s.small_strain_reach) ? -1.0 : s.small_strain_reach);
  head.put("summary_first_intrusion", s.first_intrusion);
  head.put("summary_first_self_crossing", s.first_self_crossing);
  char momentum0[80];
  std::snprintf(momentum0, sizeof momentum0, "%.17g %.17g %.17g", s.momentum0[0], s.momentum0[1], s.momentum0[2]);
  head.put("summary_momentum0", std::string(momentum0));
  std::string keys;
  for (const auto& w : h.writers) keys += (keys.empty() ? "" : " ") + w.first;
  head.put("writers", keys);
  head.put("history", (long long)h.history);
  head.put("substep_halvings", (long long)h.substep_halvings);
  head.put("substep_kept", (long long)h.substep_kept);
  head.put("substep_hold", (long long)h.substep_hold);
  head.put("substep_trying", (long long)h.substep_trying);
  for (size_t k = 0; k < h.hashes.size(); ++k) head.put(std::string(kVertexSets[k]) + "_hash", h.hashes[k]);
  if (!h.element_sets.empty()) {
    std::string sets;
    for (const ElementSetInfo& e : h.element_sets)
      sets += (sets.empty() ? "" : " ") + e.name + " " + std::to_string(e.width) + " " + std::to_string(e.slots) + " " + e.hash;
    head.put("element_sets", sets);
  }

  std::map<std::string, std::string> texts;
  texts["header"] = head.text();
  texts["physics"] = h.physics;
  std::string flagged, inverted;
  for (const auto& [frame, reason] : s.flagged_frames) {
    std::string one_line = reason;
    std::replace(one_line.begin(), one_line.end(), '\n', ' ');
    flagged += std::to_string(frame) + "\t" + one_line + "\n";
  }
  for (int frame : s.inverted_frames) inverted += std::to_string(frame) + "\n";
  texts["flagged_frames"] = flagged;
  texts["inverted_frames"] = inverted;
  for (const auto& [key, state] : h.writers) texts["writer_" + key] = state;
  return texts;
}

// A checksum of a checkpoint's texts (names and contents), stored beside them as "checksum".
std::string texts_checksum(const std::map<std::string, std::string>& texts) {
  std::string all;
  for (const auto& [name, text] : texts) all += name + "\n" + std::to_string(text.size()) + "\n" + text;
  return text_hash(all);
}

// Every text of a checkpoint file, checked against its stored checksum; throws
// std::runtime_error saying what is missing or damaged.
std::map<std::string, std::string> read_texts(const Hdf5File& file) {
  std::map<std::string, std::string> texts;
  for (const char* name : {"header", "physics", "flagged_frames", "inverted_frames", "checksum"})
    if (!file.has(name)) throw std::runtime_error("not a hyperqn checkpoint (no " + std::string(name) + ")");
  for (const char* name : {"header", "physics", "flagged_frames", "inverted_frames"}) texts[name] = file.read_text(name);
  const HeaderLines head(texts["header"]);
  std::istringstream keys(head.get("writers"));
  for (std::string key; keys >> key;) texts["writer_" + key] = file.read_text("writer_" + key);
  const std::string stored = file.read_text("checksum"), computed = texts_checksum(texts);
  if (stored != computed)
    throw std::runtime_error("its texts: checksum " + computed + " of the texts read, " + stored + " stored");
  return texts;
}

// The header from a checkpoint's texts; throws std::runtime_error saying what is missing.
CheckpointHeader header_of(const std::function<std::string(const std::string&)>& text) {
  CheckpointHeader h;
  const HeaderLines head(text("header"));
  h.version = (int)head.get_long("format_version");
  if (h.version != CheckpointHeader::kVersion)
    throw std::runtime_error("it is of format version " + std::to_string(h.version) + ", this hyperqn reads version " +
                             std::to_string(CheckpointHeader::kVersion));
  h.run_id = head.get("run_id");
  h.run_started = head.get("run_started");
  h.deck = head.get("deck");
  h.mesh_hash = head.get("mesh_hash");
  h.vertices = head.get_long("vertices");
  h.dofs = head.get_long("dofs");
  h.vertex_slots = head.get_long("vertex_slots");
  h.ranks = (int)head.get_long("ranks");
  h.frame = (int)head.get_long("frame");
  h.time = head.get_real("time");
  h.body_time = head.get_real("body_time");
  h.released = parse_flags(head.get("released"));
  h.released_attachments = parse_flags(head.get("released_attachments"));
  if (head.has("cuts")) {
    std::istringstream in(head.get("cuts"));
    std::array<int64_t, 3> f;
    while (in >> f[0] >> f[1] >> f[2]) h.cuts.push_back(f);
    if (!in.eof()) throw std::runtime_error("its header's cuts are malformed");
    h.cuts_factored = head.has("cuts_factored") ? head.get_long("cuts_factored") : -1;
    if (head.has("cut_batches")) {
      std::istringstream sizes(head.get("cut_batches"));
      int64_t n;
      while (sizes >> n) h.cut_batches.push_back(n);
      if (!sizes.eof()) throw std::runtime_error("its header's cut_batches are malformed");
    }
  }
  h.cuts_resolved = head.has("cuts_resolved") ? head.get_long("cuts_resolved") : 0;
  h.changes_decided = head.has("changes_decided") && head.get_long("changes_decided") != 0;
  if (head.has("breaks")) {
    std::istringstream in(head.get("breaks"));
    std::array<int64_t, 3> b;
    while (in >> b[0] >> b[1] >> b[2]) h.breaks.push_back(b);
    if (!in.eof()) throw std::runtime_error("its header's breaks are malformed");
    h.breaks_factored = head.has("breaks_factored") ? head.get_long("breaks_factored") : -1;
    if (head.has("break_batches")) {
      std::istringstream sizes(head.get("break_batches"));
      int64_t n;
      while (sizes >> n) h.break_batches.push_back(n);
      if (!sizes.eof()) throw std::runtime_error("its header's break_batches are malformed");
    }
  }
  h.started_inverted = (int)head.get_long("started_inverted");
  RunSummary& s = h.summary;
  // A counter newer than the file reads as 0 (euler_completed_steps came after format version 3).
  for (const auto& f : kLongFields) {
    const std::string key = std::string("summary_") + f.name;
    s.*f.member = head.has(key) ? head.get_long(key) : 0;
  }
  for (const auto& f : kIntFields) s.*f.member = (int)head.get_long(std::string("summary_") + f.name);
  // A counter newer than the file reads as 0 (max_residual and the momentum's came after format
  // version 3); without P_0 the momentum's drift is unknown (NaN).
  for (const auto& f : kRealFields) {
    const std::string key = std::string("summary_") + f.name;
    s.*f.member = head.has(key) ? head.get_real(key) : 0;
  }
  s.small_strain_reach = head.has("summary_small_strain_reach") ? head.get_real("summary_small_strain_reach") : -1.0;
  if (s.small_strain_reach < 0) s.small_strain_reach = NAN;
  if (head.has("summary_first_intrusion")) s.first_intrusion = head.get("summary_first_intrusion");
  if (head.has("summary_first_self_crossing")) s.first_self_crossing = head.get("summary_first_self_crossing");
  if (head.has("summary_momentum0")) {
    std::istringstream in(head.get("summary_momentum0"));
    for (double& p : s.momentum0)
      if (!(in >> p)) throw std::runtime_error("its header's summary_momentum0 is not three numbers");
  } else {
    s.momentum_drift = NAN;
  }
  h.physics = text("physics");
  std::istringstream flagged(text("flagged_frames"));
  for (std::string line; std::getline(flagged, line);) {
    const size_t tab = line.find('\t');
    s.flagged_frames.emplace_back(std::atoi(line.substr(0, tab).c_str()), tab == std::string::npos ? "" : line.substr(tab + 1));
  }
  std::istringstream inverted(text("inverted_frames"));
  for (int frame; inverted >> frame;) s.inverted_frames.push_back(frame);
  std::istringstream keys(head.get("writers"));
  for (std::string key; keys >> key;) h.writers.emplace_back(key, text("writer_" + key));
  h.history = head.has("history") ? (int)head.get_long("history") : 0;  // absent before the history was
  // Absent before the chain kept sub-step sizes: the full step, as that build started every frame.
  if (head.has("substep_halvings")) {
    h.substep_halvings = (int)head.get_long("substep_halvings");
    h.substep_kept = (int)head.get_long("substep_kept");
    h.substep_hold = (int)head.get_long("substep_hold");
    h.substep_trying = (int)head.get_long("substep_trying");
  }
  for (size_t k = 0; k < h.vertex_sets(); ++k) h.hashes.push_back(head.get(std::string(kVertexSets[k]) + "_hash"));
  if (head.has("element_sets")) {  // absent: no term keeps element state
    std::istringstream in(head.get("element_sets"));
    for (ElementSetInfo e; in >> e.name;) {
      if (!(in >> e.width >> e.slots >> e.hash) || e.width < 1 || e.slots < 0)
        throw std::runtime_error("its header's element_sets is not \"name width slots hash\" items");
      h.element_sets.push_back(e);
    }
  }
  return h;
}

// A vector of `width` entries per slot (vertex or element) in PETSc's default layout (the natural
// order): rank r holds a contiguous block of rows, which it sends to or receives from rank 0.
PetscErrorCode create_natural(MPI_Comm comm, long long slots, int width, Vec* v) {
  PetscFunctionBeginUser;
  PetscCall(VecCreate(comm, v));
  PetscCall(VecSetSizes(*v, PETSC_DECIDE, (PetscInt)(width * slots)));
  PetscCall(VecSetBlockSize(*v, width));
  PetscCall(VecSetType(*v, VECSTANDARD));
  PetscFunctionReturn(0);
}

// Rank 0 receives every rank's rows of `natural` in rank order and hands each block to
// `write(first_row, rows, data)` (which must not throw).
using RowsOut = std::function<void(hsize_t, hsize_t, const double*)>;
PetscErrorCode gather_rows(MPI_Comm comm, Vec natural, int width, const RowsOut& write) {
  int rank, size;
  const PetscInt* ranges;
  const PetscScalar* a;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  PetscCall(VecGetOwnershipRanges(natural, &ranges));
  PetscCall(VecGetArrayRead(natural, &a));
  if (rank == 0) {
    std::vector<double> block;
    for (int r = 0; r < size; ++r) {
      const PetscInt n = ranges[r + 1] - ranges[r];
      const double* data = a;
      if (r > 0) {
        block.resize(n);
        PetscCallMPI(MPI_Recv(block.data(), (int)n, MPI_DOUBLE, r, kTagRows, comm, MPI_STATUS_IGNORE));
        data = block.data();
      }
      write((hsize_t)ranges[r] / width, (hsize_t)n / width, data);
    }
  } else {
    PetscCallMPI(MPI_Send(a, (int)(ranges[rank + 1] - ranges[rank]), MPI_DOUBLE, 0, kTagRows, comm));
  }
  PetscCall(VecRestoreArrayRead(natural, &a));
  PetscFunctionReturn(0);
}

// The reverse: rank 0 fills each rank's block with `read(first_row, rows, data)` (which must
// not throw, and fills the block even when it fails) and sends it.
using RowsIn = std::function<void(hsize_t, hsize_t, double*)>;
PetscErrorCode scatter_rows(MPI_Comm comm, Vec natural, int width, const RowsIn& read) {
  int rank, size;
  const PetscInt* ranges;
  PetscScalar* a;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  PetscCall(VecGetOwnershipRanges(natural, &ranges));
  PetscCall(VecGetArray(natural, &a));
  if (rank == 0) {
    std::vector<double> block;
    for (int r = 0; r < size; ++r) {
      const PetscInt n = ranges[r + 1] - ranges[r];
      block.assign(n, 0.0);
      read((hsize_t)ranges[r] / width, (hsize_t)n / width, r == 0 ? a : block.data());
      if (r > 0) PetscCallMPI(MPI_Send(block.data(), (int)n, MPI_DOUBLE, r, kTagRows, comm));
    }
  } else {
    PetscCallMPI(MPI_Recv(a, (int)(ranges[rank + 1] - ranges[rank]), MPI_DOUBLE, 0, kTagRows, comm, MPI_STATUS_IGNORE));
  }
  PetscCall(VecRestoreArray(natural, &a));
  PetscFunctionReturn(0);
}

// Local items' values (`width` each, item i at slot ids[i]; ids[i] < 0: another rank sends it)
// in a natural vector.
PetscErrorCode to_natural(MPI_Comm comm, long long slots, int width, const std::vector<int64_t>& ids,
                          const std::vector<double>& values, Vec* natural) {
  PetscFunctionBeginUser;
  PetscCall(create_natural(comm, slots, width, natural));
  std::vector<PetscInt> rows;
  std::vector<PetscScalar> data;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (ids[i] < 0) continue;
    for (int d = 0; d < width; ++d) {
      rows.push_back((PetscInt)(width * ids[i] + d));
      data.push_back(values[width * i + d]);
    }
  }
  PetscCall(VecSet(*natural, 0.0));
  PetscCall(VecSetValues(*natural, (PetscInt)rows.size(), rows.data(), data.data(), INSERT_VALUES));
  PetscCall(VecAssemblyBegin(*natural));
  PetscCall(VecAssemblyEnd(*natural));
  PetscFunctionReturn(0);
}

// The slot of each owned local vertex (its vertex id), -1 for a ghost: to_natural's ids.
std::vector<int64_t> owned_vertex_ids(const DistributedMesh& mesh) {
  std::vector<int64_t> ids(mesh.num_vertices, -1);
  for (PetscInt i = 0; i < mesh.num_vertices; ++i)
    if (mesh.owned[i]) ids[i] = mesh.vertex_ids[i];
  return ids;
}

// Values (`width` each) for local items from their slots ids (vertices: ghosts included).
PetscErrorCode from_natural(Vec natural, int width, const std::vector<int64_t>& ids, std::vector<double>& values) {
  Vec local;
  IS rows;
  VecScatter scatter;
  PetscFunctionBeginUser;
  std::vector<PetscInt> idx(width * ids.size());
  for (size_t i = 0; i < ids.size(); ++i)
    for (int d = 0; d < width; ++d) idx[width * i + d] = (PetscInt)(width * ids[i] + d);
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, (PetscInt)idx.size(), idx.data(), PETSC_COPY_VALUES, &rows));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, (PetscInt)idx.size(), &local));
  PetscCall(VecScatterCreate(natural, rows, local, nullptr, &scatter));
  PetscCall(VecScatterBegin(scatter, natural, local, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(scatter, natural, local, INSERT_VALUES, SCATTER_FORWARD));
  const PetscScalar* a;
  PetscCall(VecGetArrayRead(local, &a));
  values.assign(a, a + idx.size());
  PetscCall(VecRestoreArrayRead(local, &a));
  PetscCall(VecScatterDestroy(&scatter));
  PetscCall(ISDestroy(&rows));
  PetscCall(VecDestroy(&local));
  PetscFunctionReturn(0);
}

// A checksum of doubles in order: FNV-1a over their 64-bit words. Each word's step is a bijection
// of the state, so a single changed value always changes it; the same however the rows come in blocks.
class DataHash {
 public:
  void add(const double* x, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      uint64_t w;
      std::memcpy(&w, x + i, sizeof w);
      h_ = (h_ ^ w) * 1099511628211ull;
    }
  }
  std::string hex() const {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", (unsigned long long)h_);
    return text;
  }

 private:
  uint64_t h_ = 1469598103934665603ull;
};

// Why the values of dataset k read do not match the header's checksum, or "".
std::string hash_mismatch(int k, const DataHash& read, const CheckpointHeader& h) {
  const std::string stored = (size_t)k < h.hashes.size() ? h.hashes[k] : "none";
  if (read.hex() == stored) return "";
  return std::string(kVertexSets[k]) + ": checksum " + read.hex() + " of the values read, " + stored + " in the header";
}

// The checkpoint file, opened on rank 0 alone (empty elsewhere, and where it cannot be opened: then
// error says why).
std::optional<Hdf5File> open_on_rank0(int rank, const std::string& path, std::string& error) {
  std::optional<Hdf5File> file;
  if (rank != 0) return file;
  try {
    file.emplace(Hdf5File::open(path));
  } catch (const std::exception& e) {
    error = e.what();
  }
  return file;
}

// One dataset of `slots` rows of `width` from the file rank 0 holds open (null elsewhere) into each
// rank's items at rows ids, its checksum checked against `stored` (collective). The first failure
// goes into error on rank 0; nothing is read once there is one.
PetscErrorCode read_set(MPI_Comm comm, std::optional<Hdf5File>& file, const std::string& path, const std::string& name,
                        long long slots, int width, const std::string& stored, const std::vector<int64_t>& ids,
                        std::vector<double>& values, std::string& error) {
  int rank;
  Vec natural;
  DataHash hash;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  PetscCall(create_natural(comm, slots, width, &natural));
  PetscCall(scatter_rows(comm, natural, width, [&](hsize_t first, hsize_t count, double* data) {
    if (!error.empty()) return;
    try {
      file->read_rows(name, first, count, width, data);
      hash.add(data, width * count);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }));
  if (rank == 0 && error.empty() && hash.hex() != stored)
    error = "cannot read " + path + ": " + name + ": checksum " + hash.hex() + " of the values read, " + stored +
            " in the header";
  PetscCall(from_natural(natural, width, ids, values));
  PetscCall(VecDestroy(&natural));
  PetscFunctionReturn(0);
}

}  // namespace

std::string text_hash(const std::string& text) {
  Fnv1a h;
  h.add(text.data(), text.size());
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h.value);
  return hex;
}

std::string physics_fingerprint(const std::vector<std::pair<std::string, std::string>>& sections) {
  std::string s;
  for (const auto& [name, text] : sections) s += name + " " + text_hash(text) + "\n";
  return s;
}

std::string checkpoint_mismatch(const CheckpointHeader& saved, const CheckpointHeader& now) {
  if (saved.physics != now.physics) {
    // Name the sections whose hash differs (or that only one of the two has).
    std::vector<std::string> a, b, differ;
    std::istringstream sa(saved.physics), sb(now.physics);
    for (std::string line; std::getline(sa, line);) a.push_back(line);
    for (std::string line; std::getline(sb, line);) b.push_back(line);
    auto section = [](const std::string& line) { return line.substr(0, line.find(' ')); };
    for (const auto& line : a)
      if (std::find(b.begin(), b.end(), line) == b.end()) differ.push_back(section(line));
    for (const auto& line : b)
      if (std::find(a.begin(), a.end(), line) == a.end() &&
          std::find(differ.begin(), differ.end(), section(line)) == differ.end())
        differ.push_back(section(line));
    std::string names;
    for (const auto& d : differ) names += (names.empty() ? "" : ", ") + d;
    return "the deck's physics differ from the checkpoint's (hash " + text_hash(now.physics) + " here, " +
           text_hash(saved.physics) + " in the checkpoint): section(s) " + names;
  }
  if (saved.mesh_hash != now.mesh_hash)
    return "the mesh differs from the checkpoint's (hash " + now.mesh_hash + " here, " + saved.mesh_hash +
           " in the checkpoint)";
  if (now.vertices > 0 && (saved.vertices != now.vertices || saved.vertex_slots != now.vertex_slots))
    return "the mesh has " + std::to_string(now.vertices) + " vertices, the checkpoint's " +
           std::to_string(saved.vertices);
  return "";
}

PetscErrorCode write_checkpoint(MPI_Comm comm, const std::string& path, const CheckpointHeader& h,
                                const DistributedMesh& mesh, const VertexRows& rows,
                                const std::vector<ElementRows>& elements) {
  const size_t sets = h.vertex_sets();
  int rank;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  PetscCheck(rows.size() == sets, comm, PETSC_ERR_ARG_SIZ, "%zu vertex datasets for a header of %zu", rows.size(), sets);
  // Each element set's rows: one past its largest global id over the ranks.
  std::vector<long long> element_slots;
  for (const ElementRows& e : elements) {
    long long top = 0;
    for (int64_t id : e.ids) top = std::max(top, (long long)id + 1);
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &top, 1, MPI_LONG_LONG, MPI_MAX, comm));
    element_slots.push_back(top);
  }
  std::string error;  // rank 0's first failure; it goes on receiving so that no rank waits
  std::optional<Hdf5File> file;
  if (rank == 0) {
    try {
      file.emplace(Hdf5File::create(path));
      for (size_t k = 0; k < sets; ++k) file->create_rows(kVertexSets[k], (hsize_t)h.vertex_slots, 3);
      for (size_t k = 0; k < elements.size(); ++k)
        file->create_rows(kElementPrefix + elements[k].name, (hsize_t)element_slots[k], (hsize_t)elements[k].width);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  // One dataset from every rank's items (width values each, at slots ids) through rank 0.
  const auto write_set = [&](const std::string& name, long long slots, int width, const std::vector<int64_t>& ids,
                             const std::vector<double>& values, DataHash& hash) -> PetscErrorCode {
    Vec natural;
    PetscFunctionBeginUser;
    PetscCall(to_natural(comm, slots, width, ids, values, &natural));
    PetscCall(gather_rows(comm, natural, width, [&](hsize_t first, hsize_t count, const double* data) {
      if (!error.empty()) return;
      hash.add(data, width * count);
      try {
        file->write_rows(name, first, count, width, data);
      } catch (const std::exception& e) {
        error = e.what();
      }
    }));
    PetscCall(VecDestroy(&natural));
    PetscFunctionReturn(0);
  };
  const std::vector<int64_t> vertex_slots_of = owned_vertex_ids(mesh);
  std::vector<DataHash> hashes(sets), element_hashes(elements.size());
  for (size_t k = 0; k < sets; ++k)
    PetscCall(write_set(kVertexSets[k], h.vertex_slots, 3, vertex_slots_of, rows[k], hashes[k]));
  for (size_t k = 0; k < elements.size(); ++k)
    PetscCall(write_set(kElementPrefix + elements[k].name, element_slots[k], elements[k].width, elements[k].ids,
                        elements[k].values, element_hashes[k]));
  if (rank == 0 && error.empty()) {
    try {
      CheckpointHeader with_hashes = h;
      with_hashes.hashes.clear();
      for (const DataHash& hash : hashes) with_hashes.hashes.push_back(hash.hex());
      with_hashes.element_sets.clear();
      for (size_t k = 0; k < elements.size(); ++k)
        with_hashes.element_sets.push_back(
            {elements[k].name, elements[k].width, element_slots[k], element_hashes[k].hex()});
      const std::map<std::string, std::string> texts = texts_of(with_hashes);
      for (const auto& [name, text] : texts) file->write_text(name, text);
      file->write_text("checksum", texts_checksum(texts));
      file->close();  // writes the file: a full disk shows here
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  file.reset();
  throw_if_any_failed(comm, error);
  PetscFunctionReturn(0);
}

std::string inspect_checkpoint(const std::string& path, CheckpointHeader* header, bool data) {
  try {
    const Hdf5File file = Hdf5File::open(path);
    const std::map<std::string, std::string> texts = read_texts(file);
    *header = header_of([&](const std::string& name) { return texts.at(name); });
    const int named = checkpoint_frame(fs::path(path).filename().string());
    if (named >= 0 && named != header->frame)
      return "its name says frame " + std::to_string(named) + ", its header frame " + std::to_string(header->frame);
    if (!data) return "";
    const hsize_t slots = (hsize_t)header->vertex_slots, block = 65536;
    std::vector<double> rows;
    for (size_t k = 0; k < header->vertex_sets(); ++k) {
      const char* name = kVertexSets[k];
      if (file.rows(name) != slots)
        return std::string(name) + " has " + std::to_string(file.rows(name)) + " rows, its header " +
               std::to_string(slots) + " vertex slots";
      DataHash hash;
      for (hsize_t first = 0; first < slots; first += block) {  // every chunk read: every checksum checked
        const hsize_t n = std::min(block, slots - first);
        rows.resize(3 * n);
        file.read_rows(name, first, n, 3, rows.data());
        hash.add(rows.data(), rows.size());
      }
      const std::string mismatch = hash_mismatch((int)k, hash, *header);
      if (!mismatch.empty()) return mismatch;
    }
    for (const ElementSetInfo& e : header->element_sets) {
      const std::string name = kElementPrefix + e.name;
      if (!file.has(name) || file.rows(name) != (hsize_t)e.slots)
        return name + " is missing or not of the " + std::to_string(e.slots) + " rows its header says";
      DataHash hash;
      for (hsize_t first = 0; first < (hsize_t)e.slots; first += block) {
        const hsize_t n = std::min(block, (hsize_t)e.slots - first);
        rows.resize(e.width * n);
        file.read_rows(name, first, n, e.width, rows.data());
        hash.add(rows.data(), rows.size());
      }
      if (hash.hex() != e.hash)
        return name + ": checksum " + hash.hex() + " of the values read, " + e.hash + " in the header";
    }
  } catch (const std::exception& e) {
    const std::string prefix = "cannot read " + path + ": ";
    const std::string what = e.what();
    return what.compare(0, prefix.size(), prefix) == 0 ? what.substr(prefix.size()) : what;
  }
  return "";
}

CheckpointHeader broadcast_header(MPI_Comm comm, const CheckpointHeader& header) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  // Each text as its length and bytes, in the order of texts_of.
  std::string packed;
  if (rank == 0)
    for (const auto& [name, text] : texts_of(header)) packed += std::to_string(name.size()) + " " + name +
                                                                std::to_string(text.size()) + " " + text;
  packed = broadcast_text(comm, packed);
  if (rank == 0) return header;
  std::map<std::string, std::string> texts;
  size_t at = 0;
  const auto next = [&]() {
    const size_t space = packed.find(' ', at);
    const size_t len = std::stoul(packed.substr(at, space - at));
    std::string s = packed.substr(space + 1, len);
    at = space + 1 + len;
    return s;
  };
  while (at < packed.size()) {
    std::string name = next();
    texts[name] = next();
  }
  return header_of([&](const std::string& name) { return texts.at(name); });
}

PetscErrorCode read_checkpoint_vertices(MPI_Comm comm, const std::string& path, const DistributedMesh& mesh,
                                        const CheckpointHeader& h, VertexRows& rows) {
  int rank;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  std::optional<Hdf5File> file = open_on_rank0(rank, path, error);
  rows.assign(h.vertex_sets(), {});
  const std::vector<int64_t>& vertex_ids = mesh.vertex_ids;
  for (size_t k = 0; k < rows.size(); ++k) {
    const std::string stored = k < h.hashes.size() ? h.hashes[k] : "none";
    PetscCall(read_set(comm, file, path, kVertexSets[k], h.vertex_slots, 3, stored, vertex_ids, rows[k], error));
  }
  file.reset();
  throw_if_any_failed(comm, error);
  PetscFunctionReturn(0);
}

PetscErrorCode read_checkpoint_elements(MPI_Comm comm, const std::string& path, const CheckpointHeader& h,
                                        std::vector<ElementRows>& elements) {
  int rank;
  PetscFunctionBeginUser;
  MPI_Comm_rank(comm, &rank);
  // The same sets in the same order as the scene's terms have them, each id within its rows.
  std::string error, saved, scene;
  for (const ElementSetInfo& e : h.element_sets) saved += (saved.empty() ? "" : ", ") + e.name + " (" + std::to_string(e.width) + ")";
  for (const ElementRows& e : elements) scene += (scene.empty() ? "" : ", ") + e.name + " (" + std::to_string(e.width) + ")";
  if (saved != scene)
    error = "cannot read " + path + ": it holds the element state " + (saved.empty() ? "none" : saved) +
            ", the scene's terms keep " + (scene.empty() ? "none" : scene);
  int beyond = 0;
  for (size_t k = 0; error.empty() && k < elements.size(); ++k)
    for (int64_t id : elements[k].ids) beyond = beyond || id < 0 || id >= h.element_sets[k].slots;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &beyond, 1, MPI_INT, MPI_LOR, comm));
  if (beyond) error = "cannot read " + path + ": the scene has elements beyond its element state's rows";
  throw_if_any_failed(comm, error);
  std::optional<Hdf5File> file = open_on_rank0(rank, path, error);
  for (size_t k = 0; k < elements.size(); ++k) {
    const ElementSetInfo& info = h.element_sets[k];
    PetscCall(read_set(comm, file, path, kElementPrefix + info.name, info.slots, info.width, info.hash, elements[k].ids,
                       elements[k].values, error));
  }
  file.reset();
  throw_if_any_failed(comm, error);
  PetscFunctionReturn(0);
}

int checkpoint_frame(const std::string& filename) {
  const std::string prefix = kPrefix, suffix = kSuffix;
  if (filename.size() <= prefix.size() + suffix.size() || filename.compare(0, prefix.size(), prefix) != 0 ||
      filename.compare(filename.size() - suffix.size(), suffix.size(), suffix) != 0)
    return -1;
  const std::string digits = filename.substr(prefix.size(), filename.size() - prefix.size() - suffix.size());
  if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::atoi(digits.c_str());
}

std::string checkpoint_name(int frame) { return kPrefix + std::to_string(frame) + kSuffix; }

void restore_frame_counters(RunSummary& s, const RunSummary& saved) {
  for (const auto& f : kLongFields)
    if (!f.work) s.*f.member = saved.*f.member;
  for (const auto& f : kIntFields)
    if (!f.work) s.*f.member = saved.*f.member;
  for (const auto& f : kRealFields)
    if (!f.work) s.*f.member = saved.*f.member;
  s.flagged_frames = saved.flagged_frames;
  s.inverted_frames = saved.inverted_frames;
  s.first_intrusion = saved.first_intrusion;
  s.first_self_crossing = saved.first_self_crossing;
  s.momentum0 = saved.momentum0;
  s.small_strain_reach = saved.small_strain_reach;
}

void add_earlier_work(RunSummary& s, const RunSummary& earlier) {
  for (const auto& f : kLongFields)
    if (f.work) s.*f.member += earlier.*f.member;
  for (const auto& f : kIntFields)
    if (f.work) s.*f.member += earlier.*f.member;
  for (const auto& f : kRealFields)
    if (f.work) s.*f.member += earlier.*f.member;
}

}  // namespace hyperqn

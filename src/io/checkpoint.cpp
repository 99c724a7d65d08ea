#include "io/checkpoint.hpp"

#include <petscviewerhdf5.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"

namespace fs = std::filesystem;

namespace hyperqn {

namespace {

constexpr const char* kRoot = "/";
constexpr const char* kPrefix = "checkpoint_";
constexpr const char* kSuffix = ".h5";
constexpr const char* kTemporary = ".h5.tmp";

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
    {"extended_frames", &RunSummary::extended_frames, false},
    {"substepped_frames", &RunSummary::substepped_frames, false},
    {"newton_frames", &RunSummary::newton_frames, false},
    {"max_active_contacts", &RunSummary::max_active_contacts, false},
    {"h0_solves", &RunSummary::h0_solves, true},
    {"hessian_assemblies", &RunSummary::hessian_assemblies, true},
    {"contact_evaluations", &RunSummary::contact_evaluations, true},
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

// Attribute writers and readers on the root group. Strings are never empty in the file (HDF5
// refuses a string type of size 0 in some versions): "-" stands for "".
PetscErrorCode put_text(PetscViewer v, const std::string& name, const std::string& text) {
  PetscFunctionBeginUser;
  const std::string stored = "-" + text;
  PetscCall(PetscViewerHDF5WriteAttribute(v, kRoot, name.c_str(), PETSC_STRING, stored.c_str()));
  PetscFunctionReturn(0);
}
PetscErrorCode get_text(PetscViewer v, const std::string& name, std::string& text) {
  char* value = nullptr;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5ReadAttribute(v, kRoot, name.c_str(), PETSC_STRING, nullptr, &value));
  text = value && value[0] ? std::string(value + 1) : std::string();
  PetscCall(PetscFree(value));
  PetscFunctionReturn(0);
}
PetscErrorCode put_long(PetscViewer v, const std::string& name, long long x) {
  PetscFunctionBeginUser;
  long value = (long)x;
  PetscCall(PetscViewerHDF5WriteAttribute(v, kRoot, name.c_str(), PETSC_LONG, &value));
  PetscFunctionReturn(0);
}
PetscErrorCode get_long(PetscViewer v, const std::string& name, long long& x) {
  long value = 0;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5ReadAttribute(v, kRoot, name.c_str(), PETSC_LONG, nullptr, &value));
  x = value;
  PetscFunctionReturn(0);
}
PetscErrorCode get_int(PetscViewer v, const std::string& name, int& x) {
  long long value = 0;
  PetscFunctionBeginUser;
  PetscCall(get_long(v, name, value));
  x = (int)value;
  PetscFunctionReturn(0);
}
PetscErrorCode put_real(PetscViewer v, const std::string& name, double x) {
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5WriteAttribute(v, kRoot, name.c_str(), PETSC_DOUBLE, &x));
  PetscFunctionReturn(0);
}
PetscErrorCode get_real(PetscViewer v, const std::string& name, double& x) {
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5ReadAttribute(v, kRoot, name.c_str(), PETSC_DOUBLE, nullptr, &x));
  PetscFunctionReturn(0);
}

// A vector of 3 entries per vertex slot, in PETSc's default layout (the natural order).
PetscErrorCode create_natural(MPI_Comm comm, long long slots, const char* name, Vec* v) {
  PetscFunctionBeginUser;
  PetscCall(VecCreate(comm, v));
  PetscCall(VecSetSizes(*v, PETSC_DECIDE, (PetscInt)(3 * slots)));
  PetscCall(VecSetBlockSize(*v, 3));
  PetscCall(VecSetType(*v, VECSTANDARD));
  PetscCall(PetscObjectSetName((PetscObject)*v, name));
  PetscFunctionReturn(0);
}

// Writes local per-vertex values (owned vertices) at their vertex ids.
PetscErrorCode view_by_vertex_id(PetscViewer viewer, MPI_Comm comm, const DistributedMesh& mesh, long long slots,
                                 const char* name, const std::vector<double>& values) {
  Vec natural;
  PetscFunctionBeginUser;
  PetscCall(create_natural(comm, slots, name, &natural));
  std::vector<PetscInt> rows;
  std::vector<PetscScalar> data;
  for (PetscInt i = 0; i < mesh.num_vertices; ++i) {
    if (!mesh.owned[i]) continue;
    for (int d = 0; d < 3; ++d) {
      rows.push_back((PetscInt)(3 * mesh.vertex_ids[i] + d));
      data.push_back(values[3 * i + d]);
    }
  }
  PetscCall(VecSet(natural, 0.0));
  PetscCall(VecSetValues(natural, (PetscInt)rows.size(), rows.data(), data.data(), INSERT_VALUES));
  PetscCall(VecAssemblyBegin(natural));
  PetscCall(VecAssemblyEnd(natural));
  PetscCall(VecView(natural, viewer));
  PetscCall(VecDestroy(&natural));
  PetscFunctionReturn(0);
}

// Reads per-vertex values for every local vertex (ghosts included) from their vertex ids.
PetscErrorCode load_by_vertex_id(PetscViewer viewer, MPI_Comm comm, const DistributedMesh& mesh, long long slots,
                                 const char* name, std::vector<double>& values) {
  Vec natural, local;
  IS rows;
  VecScatter scatter;
  PetscFunctionBeginUser;
  PetscCall(create_natural(comm, slots, name, &natural));
  PetscCall(VecLoad(natural, viewer));
  std::vector<PetscInt> idx(3 * mesh.num_vertices);
  for (PetscInt i = 0; i < mesh.num_vertices; ++i)
    for (int d = 0; d < 3; ++d) idx[3 * i + d] = (PetscInt)(3 * mesh.vertex_ids[i] + d);
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
  PetscCall(VecDestroy(&natural));
  PetscFunctionReturn(0);
}

PetscErrorCode write_file(MPI_Comm comm, const std::string& path, const CheckpointHeader& h, const DistributedMesh& mesh,
                          const std::vector<double>& pos, const std::vector<double>& vel) {
  PetscViewer v;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5Open(comm, path.c_str(), FILE_MODE_WRITE, &v));
  PetscCall(view_by_vertex_id(v, comm, mesh, h.vertex_slots, "positions", pos));
  PetscCall(view_by_vertex_id(v, comm, mesh, h.vertex_slots, "velocities", vel));
  PetscCall(put_long(v, "format_version", h.version));
  PetscCall(put_text(v, "physics", h.physics));
  PetscCall(put_text(v, "mesh_hash", h.mesh_hash));
  PetscCall(put_long(v, "vertices", h.vertices));
  PetscCall(put_long(v, "dofs", h.dofs));
  PetscCall(put_long(v, "vertex_slots", h.vertex_slots));
  PetscCall(put_long(v, "ranks", h.ranks));
  PetscCall(put_long(v, "frame", h.frame));
  PetscCall(put_real(v, "time", h.time));
  PetscCall(put_real(v, "body_time", h.body_time));
  PetscCall(put_text(v, "released", flags_text(h.released)));
  PetscCall(put_text(v, "released_attachments", flags_text(h.released_attachments)));
  PetscCall(put_long(v, "started_inverted", h.started_inverted));
  const RunSummary& s = h.summary;
  for (const auto& f : kLongFields) PetscCall(put_long(v, std::string("summary_") + f.name, s.*f.member));
  for (const auto& f : kIntFields) PetscCall(put_long(v, std::string("summary_") + f.name, s.*f.member));
  for (const auto& f : kRealFields) PetscCall(put_real(v, std::string("summary_") + f.name, s.*f.member));
  std::string flagged, inverted;
  for (const auto& [frame, reason] : s.flagged_frames) {
    std::string one_line = reason;
    std::replace(one_line.begin(), one_line.end(), '\n', ' ');
    flagged += std::to_string(frame) + "\t" + one_line + "\n";
  }
  for (int frame : s.inverted_frames) inverted += std::to_string(frame) + "\n";
  PetscCall(put_text(v, "summary_flagged_frames", flagged));
  PetscCall(put_text(v, "summary_inverted_frames", inverted));
  std::string keys;
  for (const auto& [key, state] : h.writers) {
    keys += key + "\n";
    PetscCall(put_text(v, "writer_" + key, state));
  }
  PetscCall(put_text(v, "writers", keys));
  PetscCall(PetscViewerDestroy(&v));  // closes the file on every rank
  PetscFunctionReturn(0);
}

PetscErrorCode read_header(MPI_Comm comm, const std::string& path, CheckpointHeader& h) {
  PetscViewer v;
  long long x = 0;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5Open(comm, path.c_str(), FILE_MODE_READ, &v));
  PetscCall(get_int(v, "format_version", h.version));
  if (h.version != CheckpointHeader::kVersion) {
    PetscCall(PetscViewerDestroy(&v));
    PetscFunctionReturn(0);  // the caller says so
  }
  PetscCall(get_text(v, "physics", h.physics));
  PetscCall(get_text(v, "mesh_hash", h.mesh_hash));
  PetscCall(get_long(v, "vertices", h.vertices));
  PetscCall(get_long(v, "dofs", h.dofs));
  PetscCall(get_long(v, "vertex_slots", h.vertex_slots));
  PetscCall(get_int(v, "ranks", h.ranks));
  PetscCall(get_int(v, "frame", h.frame));
  PetscCall(get_real(v, "time", h.time));
  PetscCall(get_real(v, "body_time", h.body_time));
  std::string text;
  PetscCall(get_text(v, "released", text));
  h.released = parse_flags(text);
  PetscCall(get_text(v, "released_attachments", text));
  h.released_attachments = parse_flags(text);
  PetscCall(get_int(v, "started_inverted", h.started_inverted));
  RunSummary& s = h.summary;
  for (const auto& f : kLongFields) {
    const std::string name = std::string("summary_") + f.name;
    PetscBool has = PETSC_TRUE;
    // Added after format version 1: a checkpoint written before has none (0).
    if (f.member == &RunSummary::pulled_back_guesses)
      PetscCall(PetscViewerHDF5HasAttribute(v, kRoot, name.c_str(), &has));
    if (has) PetscCall(get_long(v, name, s.*f.member));
  }
  for (const auto& f : kIntFields) {
    PetscCall(get_long(v, std::string("summary_") + f.name, x));
    s.*f.member = (int)x;
  }
  for (const auto& f : kRealFields) PetscCall(get_real(v, std::string("summary_") + f.name, s.*f.member));
  PetscCall(get_text(v, "summary_flagged_frames", text));
  std::istringstream flagged(text);
  for (std::string line; std::getline(flagged, line);) {
    const size_t tab = line.find('\t');
    s.flagged_frames.emplace_back(std::atoi(line.substr(0, tab).c_str()), tab == std::string::npos ? "" : line.substr(tab + 1));
  }
  PetscCall(get_text(v, "summary_inverted_frames", text));
  std::istringstream inverted(text);
  for (int frame; inverted >> frame;) s.inverted_frames.push_back(frame);
  PetscCall(get_text(v, "writers", text));
  std::istringstream keys(text);
  for (std::string key; std::getline(keys, key);) {
    std::string state;
    PetscCall(get_text(v, "writer_" + key, state));
    h.writers.emplace_back(key, state);
  }
  PetscCall(PetscViewerDestroy(&v));
  PetscFunctionReturn(0);
}

// Runs fn on rank 0; an exception there is thrown on every rank (throw_if_any_failed).
void on_rank0(MPI_Comm comm, const std::function<void()>& fn) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  if (rank == 0) {
    try {
      fn();
    } catch (const std::exception& e) {
      error = *e.what() ? e.what() : "checkpoint error";
    }
  }
  throw_if_any_failed(comm, error);
}

}  // namespace

std::string text_hash(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h);
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

PetscErrorCode write_checkpoint(MPI_Comm comm, const std::string& dir, const CheckpointHeader& h,
                                const DistributedMesh& mesh, const std::vector<double>& pos,
                                const std::vector<double>& vel, int keep, std::string* path) {
  PetscFunctionBeginUser;
  const std::string name = kPrefix + std::to_string(h.frame);
  const std::string tmp = dir + "/" + name + kTemporary;
  *path = dir + "/" + name + kSuffix;
  on_rank0(comm, [&] { fs::create_directories(dir); });
  PetscCall(write_file(comm, tmp, h, mesh, pos, vel));
  PetscCallMPI(MPI_Barrier(comm));  // every rank has closed the file
  on_rank0(comm, [&] {
    fs::rename(tmp, *path);  // atomic on one file system: the name appears complete
    std::vector<std::pair<int, fs::path>> all;
    for (const auto& e : fs::directory_iterator(dir)) {
      const int frame = checkpoint_frame(e.path().filename().string());
      if (frame >= 0) all.emplace_back(frame, e.path());
    }
    std::sort(all.begin(), all.end());
    for (size_t k = 0; k + keep < all.size(); ++k) fs::remove(all[k].second);
  });
  PetscFunctionReturn(0);
}

CheckpointHeader read_checkpoint_header(MPI_Comm comm, const std::string& path) {
  on_rank0(comm, [&] {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) throw std::runtime_error("no checkpoint file " + path);
  });
  CheckpointHeader h;
  h.version = -1;
  PetscPushErrorHandler(PetscIgnoreErrorHandler, nullptr);  // a bad file is said once, below
  const PetscErrorCode ierr = read_header(comm, path, h);
  PetscPopErrorHandler();
  int bad = ierr != 0 || h.version != CheckpointHeader::kVersion, any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, comm);
  if (any)
    throw std::runtime_error(path + " is not a hyperqn checkpoint of format version " +
                             std::to_string(CheckpointHeader::kVersion) + " (or cannot be read)");
  return h;
}

PetscErrorCode read_checkpoint_vertices(MPI_Comm comm, const std::string& path, const DistributedMesh& mesh,
                                        long long vertex_slots, std::vector<double>& pos, std::vector<double>& vel) {
  PetscViewer v;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5Open(comm, path.c_str(), FILE_MODE_READ, &v));
  PetscCall(load_by_vertex_id(v, comm, mesh, vertex_slots, "positions", pos));
  PetscCall(load_by_vertex_id(v, comm, mesh, vertex_slots, "velocities", vel));
  PetscCall(PetscViewerDestroy(&v));
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

std::string latest_checkpoint(MPI_Comm comm, const std::string& dir) {
  std::string found;
  on_rank0(comm, [&] {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return;
    int best = -1;
    for (const auto& e : fs::directory_iterator(dir)) {
      const int frame = checkpoint_frame(e.path().filename().string());
      if (frame > best) {
        best = frame;
        found = e.path().string();
      }
    }
  });
  int n = (int)found.size();
  MPI_Bcast(&n, 1, MPI_INT, 0, comm);
  found.resize(n);
  MPI_Bcast(found.data(), n, MPI_CHAR, 0, comm);
  return found;
}

void remove_checkpoints_after(MPI_Comm comm, const std::string& dir, int frame) {
  on_rank0(comm, [&] {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return;
    std::vector<fs::path> gone;
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      const bool temporary = name.size() > 4 && name.compare(name.size() - 4, 4, ".tmp") == 0;
      if (checkpoint_frame(name) > frame || (temporary && name.rfind(kPrefix, 0) == 0)) gone.push_back(e.path());
    }
    for (const auto& p : gone) fs::remove(p);
  });
}

void restore_frame_counters(RunSummary& s, const RunSummary& saved) {
  for (const auto& f : kLongFields)
    if (!f.work) s.*f.member = saved.*f.member;
  for (const auto& f : kIntFields)
    if (!f.work) s.*f.member = saved.*f.member;
  for (const auto& f : kRealFields)
    if (!f.work) s.*f.member = saved.*f.member;
  s.flagged_frames = saved.flagged_frames;
  s.inverted_frames = saved.inverted_frames;
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

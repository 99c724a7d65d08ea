#include "io/checkpoint_store.hpp"

#include <petscsys.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <system_error>

#include "io/atomic_file.hpp"
#include "io/run_log.hpp"

namespace fs = std::filesystem;

namespace hyperqn {

namespace {

int rank_of(MPI_Comm comm) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  return rank;
}

void warn(const std::string& text) { PetscPrintf(PETSC_COMM_SELF, "hyperqn: warning: %s\n", text.c_str()); }

// "run R (deck D, started T)": whose a checkpoint is, for messages.
std::string whose(const CheckpointHeader& h) {
  return "run " + h.run_id + " (deck " + h.deck + ", started " + h.run_started + ")";
}

// A temporary of an interrupted checkpoint write: .checkpoint_<frame>.h5.tmp-<pid>.
bool is_checkpoint_temporary(const std::string& name) {
  return is_atomic_temporary(name) && checkpoint_frame(temporary_target(name)) >= 0;
}

// The checkpoint files of dir by frame, newest first; a warning for each other file that is not a
// temporary of ours (rank 0). Only regular files (or links to one) count: opening a FIFO would
// block forever, and a directory or device is no checkpoint either.
std::vector<std::pair<int, std::string>> checkpoint_files(const std::string& dir, bool warn_others) {
  std::vector<std::pair<int, std::string>> files;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const int frame = checkpoint_frame(name);
    std::error_code type;
    if (frame >= 0 && !it->is_regular_file(type)) {
      if (warn_others) warn(it->path().string() + " is not a regular file: passed over");
    } else if (frame >= 0) {
      files.emplace_back(frame, it->path().string());
    } else if (warn_others && !is_checkpoint_temporary(name))
      warn(it->path().string() + " is not named as a checkpoint (checkpoint_<frame>.h5): ignored");
  }
  std::sort(files.rbegin(), files.rend());
  return files;
}

// Rank 0's part of choose_restart: the path, or an error ("" and "" for none).
void choose_on_rank0(const std::string& restart, const std::string& outdir, std::string& path, std::string& error) {
  const std::string run = summary_run_id(outdir + "/summary.json");
  CheckpointHeader h;
  if (restart != "latest" && restart != "auto") {  // a path
    std::error_code ec;
    if (fs::exists(restart, ec) && !fs::is_regular_file(restart, ec)) {  // a FIFO would block the open
      error = "cannot restart from " + restart + ": not a regular file";
      return;
    }
    const std::string damage = inspect_checkpoint(restart, &h);
    if (!damage.empty())
      error = "cannot restart from " + restart + ": " + damage;
    else if (h.run_id != run)
      error = "cannot restart from " + restart + " into " + outdir + ": it is a checkpoint of " + whose(h) +
              " at frame " + std::to_string(h.frame) + ", and " + outdir + " holds " +
              (run.empty() ? std::string("no run (no summary.json)") : "the output of run " + run) +
              "; restart into the checkpoint's own output directory (-o)";
    else
      path = restart;
    return;
  }
  const std::string dir = outdir + "/checkpoints";
  if (run.empty()) {
    if (restart == "latest")
      error = "--restart latest: " + outdir + " holds no run to continue (no summary.json with a run_id)";
    return;
  }
  bool passed_over_damaged = false;
  for (const auto& [frame, file] : checkpoint_files(dir, true)) {
    const std::string header_damage = inspect_checkpoint(file, &h, false);
    if (header_damage.empty() && h.run_id != run) {
      warn(file + " is a checkpoint of " + whose(h) + ", not of run " + run + " that last wrote " + outdir +
           ": passed over");
      continue;
    }
    const std::string damage = header_damage.empty() ? inspect_checkpoint(file, &h) : header_damage;
    if (!damage.empty()) {
      warn(file + " is damaged or not a checkpoint (" + damage + "): passed over");
      passed_over_damaged = true;
      continue;
    }
    if (passed_over_damaged) warn("falling back to " + file + ", the newest whole checkpoint of run " + run);
    path = file;
    return;
  }
  if (restart == "latest")
    error = "--restart latest: no whole checkpoint of run " + run + " (the run that last wrote " + outdir + ") in " + dir;
}

}  // namespace

std::string new_run_id(MPI_Comm comm) {
  std::string id;
  if (rank_of(comm) == 0) {
    std::random_device source;
    char hex[9];
    for (int k = 0; k < 4; ++k) {
      std::snprintf(hex, sizeof hex, "%08x", (unsigned)source());
      id += hex;
    }
  }
  return broadcast_text(comm, id);
}

std::string utc_now(MPI_Comm comm) {
  std::string now;
  if (rank_of(comm) == 0) {
    const std::time_t t = std::time(nullptr);
    std::tm utc;
    gmtime_r(&t, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    now = text;
  }
  return broadcast_text(comm, now);
}

RestartChoice choose_restart(MPI_Comm comm, const std::string& restart, const std::string& outdir) {
  RestartChoice choice;
  CheckpointHeader header;
  if (rank_of(comm) == 0) {
    choose_on_rank0(restart, outdir, choice.path, choice.error);
    if (!choice.path.empty()) inspect_checkpoint(choice.path, &header, false);
  }
  choice.path = broadcast_text(comm, choice.path);
  choice.error = broadcast_text(comm, choice.error);
  if (!choice.path.empty()) choice.header = broadcast_header(comm, header);
  return choice;
}

void CheckpointStore::resume(const std::string& run_id, int frame) {
  std::string error;
  if (rank_of(comm_) == 0) {
    std::error_code ec;
    for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec))
      if (is_checkpoint_temporary(it->path().filename().string())) fs::remove(it->path(), ec);
    for (const auto& [f, file] : checkpoint_files(dir_, false)) {
      CheckpointHeader h;
      const std::string damage = inspect_checkpoint(file, &h, false);
      if (!damage.empty() && f <= frame) continue;  // not ours to judge; latest passes over it
      if (damage.empty() && h.run_id != run_id) continue;
      if (f > frame) {
        std::error_code rm;
        fs::remove(file, rm);
        if (rm) error = "cannot remove " + file + " (a checkpoint after the restart's frame): " + rm.message();
      } else {
        frames_.push_back(f);
      }
    }
    std::sort(frames_.begin(), frames_.end());
  }
  throw_if_any_failed(comm_, error);
}

std::string CheckpointStore::write(const CheckpointHeader& h, const DistributedMesh& mesh, const VertexRows& rows,
                                   const std::vector<ElementRows>& elements) {
  const std::string path = dir_ + "/" + checkpoint_name(h.frame);
  std::string error;
  if (rank_of(comm_) == 0) {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) error = "cannot create the checkpoint directory " + dir_ + ": " + ec.message();
  }
  throw_if_any_failed(comm_, error);
  if (write_checkpoint(comm_, path, h, mesh, rows, elements))
    throw std::runtime_error("cannot write " + path + ": PETSc error while gathering the rows");
  if (rank_of(comm_) == 0) {
    if (std::find(frames_.begin(), frames_.end(), h.frame) == frames_.end()) frames_.push_back(h.frame);
    while ((int)frames_.size() > keep_) {
      const std::string old = dir_ + "/" + checkpoint_name(frames_.front());
      std::error_code rm;
      fs::remove(old, rm);
      if (rm && error.empty()) error = "cannot remove " + old + " (beyond checkpoint.keep): " + rm.message();
      frames_.erase(frames_.begin());
    }
  }
  throw_if_any_failed(comm_, error);
  return path;
}

}  // namespace hyperqn

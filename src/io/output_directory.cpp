#include "io/output_directory.hpp"

#include <algorithm>
#include <filesystem>
#include <functional>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <system_error>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"

namespace hyperqn {

namespace fs = std::filesystem;

void create_output_directory(MPI_Comm comm, const std::string& dir) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  if (rank == 0) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) error = "cannot create the output directory " + dir + ": " + ec.message();
    else if (!fs::is_directory(dir, ec)) error = "cannot create the output directory " + dir + ": not a directory";
  }
  throw_if_any_failed(comm, error);
}

bool is_run_output(const std::string& dir, const std::string& name) {
  if (is_atomic_temporary(name)) return is_run_output(dir, temporary_target(name));
  if (name == "summary.json" || name == "iterations.csv" || name == "contact.csv" || name == "self-contact.csv" ||
      name == "reactions.csv" || name == "energy.csv" || name == "topology.csv" ||
      name == "config.yaml")
    return true;
  // Frames: the frame number of at least five digits (%05d; time.frames goes to 1e8), and the
  // rank of a piece, is what marks them as ours.
  static const std::regex frame(R"(.+_\d{5,9}(\.p?vtu|_\d+\.vtu))");
  if (std::regex_match(name, frame)) return true;
  // A .pvd only if it lists frames of its own name: a user's collection of other files stays.
  if (name.size() > 4 && name.compare(name.size() - 4, 4, ".pvd") == 0) {
    std::ifstream in(dir + "/" + name);
    std::string head(4096, '\0');
    in.read(&head[0], (std::streamsize)head.size());
    head.resize((size_t)in.gcount());
    return head.find("file=\"" + name.substr(0, name.size() - 4) + "_") != std::string::npos;
  }
  // The XDMF series: an index that names its own NAME.h5, and that file while such an index is beside it.
  const auto ends_with = [&](const std::string& suffix) {
    return name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (ends_with(".xdmf")) {
    std::ifstream in(dir + "/" + name);
    std::string head(4096, '\0');
    in.read(&head[0], (std::streamsize)head.size());
    head.resize((size_t)in.gcount());
    return head.find(">" + name.substr(0, name.size() - 5) + ".h5:/") != std::string::npos;
  }
  if (ends_with(".h5")) {
    const std::string index = name.substr(0, name.size() - 3) + ".xdmf";
    std::error_code ec;
    return fs::is_regular_file(dir + "/" + index, ec) && is_run_output(dir, index);
  }
  return false;
}

namespace {

// The regular files of dir whose names satisfy `ours` (listed first: removing while listing may
// skip entries), removed; returns how many. A directory that does not exist holds none.
int remove_files(const std::string& dir, const std::function<bool(const std::string&)>& ours) {
  std::vector<fs::path> old;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return 0;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (it->is_regular_file(type_ec) && ours(it->path().filename().string())) old.push_back(it->path());
  }
  if (ec) throw std::runtime_error("cannot list the output directory " + dir + ": " + ec.message());
  std::stable_sort(old.begin(), old.end(), [](const fs::path& a, const fs::path& b) {
    return removal_order(a.filename().string()) < removal_order(b.filename().string());
  });
  for (const fs::path& p : old) {
    std::error_code rm;
    fs::remove(p, rm);
    if (rm) throw std::runtime_error("cannot remove " + p.string() + " (a previous run's output): " + rm.message());
  }
  return (int)old.size();
}

bool is_checkpoint_file(const std::string& name) {
  const std::string base = is_atomic_temporary(name) ? temporary_target(name) : name;
  return checkpoint_frame(base) >= 0 || (base.rfind("checkpoint_", 0) == 0 && base.size() > 4 &&
                                         base.compare(base.size() - 4, 4, ".tmp") == 0);  // format 1's temporaries
}

}  // namespace

Cleared clear_previous_run(const std::string& dir) {
  Cleared cleared;
  cleared.checkpoints = remove_files(dir + "/checkpoints", is_checkpoint_file);
  cleared.files = remove_files(dir, [&](const std::string& name) { return name != "summary.json" && is_run_output(dir, name); });
  return cleared;
}

int remove_series_begun_later(const std::string& dir, const std::string& format) {
  const std::vector<std::string> ends = format == "vtu" ? std::vector<std::string>{".pvd", ".vtu", ".pvtu"}
                                                        : std::vector<std::string>{".xdmf", ".h5"};
  return remove_files(dir, [&](const std::string& name) {
    const std::string base = is_atomic_temporary(name) ? temporary_target(name) : name;
    const bool of_format = std::any_of(ends.begin(), ends.end(), [&](const std::string& e) {
      return base.size() > e.size() && base.compare(base.size() - e.size(), e.size(), e) == 0;
    });
    return of_format && is_run_output(dir, name);
  });
}

int remove_interrupted_writes(const std::string& dir) {
  return remove_files(dir, [&](const std::string& name) { return is_atomic_temporary(name) && is_run_output(dir, name); });
}

}  // namespace hyperqn

#include "io/output_directory.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <thread>
#include <ctime>
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

namespace {

// The refusal for a lock held by another process, from what its file says (fd open on it).
std::string held_by(int fd, const std::string& dir) {
  std::string text(512, '\0');
  const ssize_t n = pread(fd, &text[0], text.size(), 0);
  text.resize(n > 0 ? size_t(n) : 0);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ' || text.back() == '\0')) text.pop_back();
  for (char& c : text)
    if (c == '\n' || (unsigned char)c < 32) c = ' ';
  return "the output directory " + dir + " is in use by another run (" +
         (text.empty() ? std::string("its lock file ") + OutputLock::kFileName + " says nothing yet" : text) +
         "): two runs in one directory would remove and mix each other's files; wait for it to end, or choose "
         "another -o";
}

// The lock's text: who holds it.
std::string holder_text(const std::string& what) {
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char when[32] = "";
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return "pid " + std::to_string((long long)getpid()) + " on host " + host + ", started " + when +
         (what.empty() ? std::string() : ", " + what) + "\n";
}

}  // namespace

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  unlink(path_.c_str());  // while held: a run that opened it before must find it gone (take)
  close(fd_);             // releases the flock
}

std::string OutputLock::take(MPI_Comm comm, const std::string& dir, const std::string& what) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string refusal;
  const std::string path = dir + "/" + kFileName;
  for (int attempt = 0; rank == 0 && fd_ < 0 && refusal.empty() && attempt < 20; ++attempt) {
    const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
    if (fd < 0) break;  // a directory where the file cannot be made: the run's first write fails there, naming it
    // A starting run's look (output_directory_in_use) holds a shared lock for a moment: a few tries.
    int locked = -1;
    for (int wait = 0; wait < 5; ++wait) {
      if ((locked = flock(fd, LOCK_EX | LOCK_NB)) == 0 || errno != EWOULDBLOCK) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (locked != 0 && errno == EWOULDBLOCK) {
      refusal = held_by(fd, dir);
      close(fd);
      break;
    }
    if (locked != 0) {
      std::fprintf(stderr, "hyperqn: warning: cannot lock the output directory %s (%s: %s): another run writing "
                           "into it at once would not be noticed\n", dir.c_str(), path.c_str(), std::strerror(errno));
      close(fd);
      break;
    }
    // The file locked must still be the one named: a run that ended unlinked it after this one opened it.
    struct stat held {}, named {};
    if (fstat(fd, &held) != 0 || stat(path.c_str(), &named) != 0 || held.st_dev != named.st_dev ||
        held.st_ino != named.st_ino) {
      close(fd);
      continue;
    }
    fd_ = fd;
    path_ = path;
    const std::string text = holder_text(what);
    if (ftruncate(fd_, 0) != 0 || pwrite(fd_, text.data(), text.size(), 0) != (ssize_t)text.size()) {
      // A full disk: the lock holds all the same, only its note is missing.
    }
  }
  return broadcast_text(comm, refusal);
}

std::string output_directory_in_use(MPI_Comm comm, const std::string& dir) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string refusal;
  if (rank == 0) {
    const int fd = open((dir + "/" + OutputLock::kFileName).c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd >= 0) {
      if (flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK) refusal = held_by(fd, dir);
      close(fd);  // a shared lock taken here goes with it
    }
  }
  return broadcast_text(comm, refusal);
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

#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace hyperqn {

namespace {

std::string failure(const std::string& path, int err) { return "cannot write " + path + ": " + std::strerror(err); }

// write(2) until everything is written; false with errno set on failure.
bool write_all(int fd, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += w;
    n -= (size_t)w;
  }
  return true;
}

}  // namespace

std::string atomic_temporary(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  return dir + "." + name + ".tmp-" + std::to_string(::getpid());
}

void commit_temporary(const std::string& tmp, const std::string& path) {
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error(failure(path, err));
  }
}

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(std::move(path)), tmp_(atomic_temporary(path_)) {
  fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(failure(path_, errno));
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) {  // not committed
    ::close(fd_);
    ::unlink(tmp_.c_str());
  }
}

void AtomicFileWriter::fail(int err) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(tmp_.c_str());  // frees the space a full disk needs for summary.json
  throw std::runtime_error(failure(path_, err));
}

void AtomicFileWriter::write(const char* data, size_t n) {
  if (!write_all(fd_, data, n)) fail(errno);
}

// A full disk may only show at close (NFS, Lustre): both are checked. No fsync: this guards
// against the process dying, not the machine, and fsync per frame is slow on cluster file systems.
void AtomicFileWriter::commit() {
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp_.c_str());
    throw std::runtime_error(failure(path_, err));
  }
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp_.c_str());
    throw std::runtime_error(failure(path_, err));
  }
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  AtomicFileWriter file(path);
  file.write(contents.data(), contents.size());
  file.commit();
}

bool is_atomic_temporary(const std::string& name) {
  const size_t at = name.rfind(".tmp-");
  if (name.size() < 2 || name[0] != '.' || at == std::string::npos || at + 5 == name.size()) return false;
  for (size_t i = at + 5; i < name.size(); ++i)
    if (name[i] < '0' || name[i] > '9') return false;
  return true;
}

std::string temporary_target(const std::string& name) { return name.substr(1, name.rfind(".tmp-") - 1); }

void throw_if_any_failed(MPI_Comm comm, const std::string& error) {
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const int mine = error.empty() ? size : rank;
  int first = size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return;
  throw std::runtime_error(broadcast_text(comm, error, first));
}

std::string broadcast_text(MPI_Comm comm, std::string text, int root) {
  long long n = (long long)text.size();
  MPI_Bcast(&n, 1, MPI_LONG_LONG, root, comm);
  text.resize((size_t)n);
  MPI_Bcast(&text[0], (int)n, MPI_CHAR, root, comm);
  return text;
}

LineFile::~LineFile() {
  if (fd_ >= 0) {
    try {
      flush();
    } catch (...) {  // the run has already said what went wrong, or ends with it
    }
    ::close(fd_);
  }
}

void LineFile::open(const std::string& path) {
  path_ = path;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(failure(path, errno));
}

void LineFile::reopen(const std::string& path, const std::string& contents) {
  write_file_atomically(path, contents);
  path_ = path;
  fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(failure(path, errno));
}

void LineFile::add(const std::string& line) {
  if (fd_ >= 0) pending_ += line;
}

void LineFile::flush() {
  if (fd_ < 0 || pending_.empty()) return;
  std::string lines;
  lines.swap(pending_);  // written or not, they are not written twice
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (!write_all(fd_, lines.data(), lines.size())) {
    const int err = errno;
    // A full disk may have taken part of the lines: cut the file back to its last whole row.
    if (end >= 0 && ::ftruncate(fd_, end) == 0) ::lseek(fd_, end, SEEK_SET);
    throw std::runtime_error(failure(path_, err));
  }
}

}  // namespace hyperqn

// Output files that are never seen half-written, and write errors that every rank learns of.
// Every writer of src/io goes through these (docs/outputs.md, "Guarantees").
#pragma once
#include <mpi.h>

#include <string>

namespace hyperqn {

// Writes `contents` to `path` as a whole: into a temporary file beside it (.NAME.tmp-PID, in
// the same directory so that the rename cannot cross file systems), closed with every error
// checked, then renamed over `path`. A reader, or a kill at any moment, finds the old file or the
// new one, never a part of one. On failure throws std::runtime_error naming `path` and the
// system's reason; the temporary is removed and `path` is left as it was.
void write_file_atomically(const std::string& path, const std::string& contents);

// The same for a file written in parts (a .vtu piece of tens of MB, never whole in memory): the
// constructor opens the temporary, write() appends, commit() closes and renames. Each throws as
// write_file_atomically does, removing the temporary; so does the destructor of one not committed
// (an exception on the way), silently.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();
  void write(const char* data, size_t n);
  void commit();

 private:
  [[noreturn]] void fail(int err);  // removes the temporary, throws naming path_
  std::string path_, tmp_;
  int fd_ = -1;
};

// For a file another library writes (HDF5): the temporary name beside `path` to write it under,
// and the rename that puts it in place once it is closed (throws naming `path`, removing the
// temporary).
std::string atomic_temporary(const std::string& path);
void commit_temporary(const std::string& tmp, const std::string& path);

// Whether a file name (no directory) is a temporary of write_file_atomically: what an
// interrupted write leaves behind.
bool is_atomic_temporary(const std::string& name);
// The name of the file such a temporary was to become (.NAME.tmp-PID -> NAME).
std::string temporary_target(const std::string& name);

// Collective over comm: rank `root`'s text on every rank (the others' text is ignored).
std::string broadcast_text(MPI_Comm comm, std::string text, int root = 0);

// Collective over comm: every rank passes its error ("" if none). If any rank has one, every
// rank throws std::runtime_error with the message of the lowest such rank, so no rank goes on to
// wait for another that has failed, and rank 0 (which prints) can name the path.
void throw_if_any_failed(MPI_Comm comm, const std::string& error);

// A log appended one whole line at a time (iterations.csv, contact.csv): lines are held in
// memory until flush(), which hands them to the kernel in one write, so a kill leaves only
// complete lines (unless it lands inside that one write call); a failed write (a full disk) cuts
// the file back to the lines before it. Only the rank that opened it
// writes. Errors throw std::runtime_error naming the path.
class LineFile {
 public:
  LineFile() = default;
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;
  ~LineFile();
  // Creates (truncates) path.
  void open(const std::string& path);
  // Replaces path by `contents` (atomically) and appends from there on (a restart's logs).
  void reopen(const std::string& path, const std::string& contents);
  bool is_open() const { return fd_ >= 0; }
  void add(const std::string& line);  // a complete line, with its '\n'
  void flush();

 private:
  int fd_ = -1;
  std::string path_, pending_;
};

}  // namespace hyperqn

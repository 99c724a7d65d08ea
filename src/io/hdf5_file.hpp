// One HDF5 file written or read by a single process (checkpoints: rank 0 alone touches the file,
// so an error on a full disk is one process's error, which throw_if_any_failed then spreads; no
// collective HDF5 call exists that a failed rank could leave the others waiting in).
//
// Every HDF5 failure throws std::runtime_error "cannot write PATH: <reason>" or "cannot read
// PATH: <reason>", the reason taken from HDF5's error stack (for a full disk, the system's
// "No space left on device"); HDF5 prints nothing itself. Integrity: every dataset is chunked with
// HDF5's Fletcher32 checksum filter, so a damaged chunk fails to read, and the file's metadata
// (superblock, object headers) are in the 1.8+ format that carries HDF5's own checksums.
#pragma once
#include <hdf5.h>

#include <string>

namespace hyperqn {

class Hdf5File {
 public:
  // Creates (truncates) path for writing.
  static Hdf5File create(const std::string& path);
  // Opens path read-only.
  static Hdf5File open(const std::string& path);
  Hdf5File(Hdf5File&& other) noexcept;
  Hdf5File(const Hdf5File&) = delete;
  Hdf5File& operator=(const Hdf5File&) = delete;
  ~Hdf5File();  // closes without checking: close() is the checked way

  // Flushes and closes; a write that failed only now (a full disk) throws here.
  void close();

  // A text as a 1-D byte dataset (any length: datasets, not attributes, have no 64 KiB limit).
  void write_text(const std::string& name, const std::string& text);
  std::string read_text(const std::string& name) const;
  bool has(const std::string& name) const;

  // A (rows, cols) float64 dataset written and read a block of rows at a time.
  void create_rows(const std::string& name, hsize_t rows, hsize_t cols);
  void write_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, const double* data);
  void read_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, double* data) const;
  hsize_t rows(const std::string& name) const;

 private:
  Hdf5File(hid_t id, std::string path, bool writing) : id_(id), path_(std::move(path)), writing_(writing) {}
  [[noreturn]] void fail(const std::string& what) const;
  hid_t id_ = -1;
  std::string path_;
  bool writing_ = false;
};

}  // namespace hyperqn

// One HDF5 file written or read by a single process (checkpoints: rank 0 alone touches the file,
// so an error on a full disk is one process's error, which throw_if_any_failed then spreads; no
// collective HDF5 call exists that a failed rank could leave the others waiting in).
//
// A file is written in memory (HDF5's core driver) and its bytes are then written by
// write_file_atomically: HDF5 itself never writes to disk, because HDF5 1.10 cannot give up a file
// it failed to close (a full disk): it crashes closing it again at exit. The cost is the file's
// size in memory on the writing process, twice for a moment (the image and its copy).
//
// Every failure throws std::runtime_error "cannot write PATH: <reason>" or "cannot read PATH:
// <reason>", the reason from the system (for a full disk "No space left on device") or from
// HDF5's error stack; HDF5 prints nothing itself. Integrity: every dataset is chunked with HDF5's
// Fletcher32 checksum filter, so a damaged chunk fails to read. The file's metadata (in HDF5's
// earliest format, see create) carry no checksums: a damaged chunk index can make HDF5 read
// zeros without an error, so users of this class keep checksums of what they read as well.
#pragma once
#include <hdf5.h>

#include <string>

namespace hyperqn {

// Why the last HDF5 call failed, from HDF5's error stack (which it then clears), and HDF5's own
// printing of that stack turned off: for code that calls HDF5 itself (io/study_writer.cpp).
std::string hdf5_error_reason();
void silence_hdf5();

class Hdf5File {
 public:
  // A new file for path, in memory until close() writes it (replacing path whole).
  static Hdf5File create(const std::string& path);
  // Opens path read-only.
  static Hdf5File open(const std::string& path);
  Hdf5File(Hdf5File&& other) noexcept;
  Hdf5File(const Hdf5File&) = delete;
  Hdf5File& operator=(const Hdf5File&) = delete;
  ~Hdf5File();  // closes without checking: close() is the checked way

  // Closes; a file being written is then written to its path (atomically: path is the old file or
  // the whole new one), which is where a full disk shows.
  void close();

  // A text as a 1-D byte dataset (any length: datasets, not attributes, have no 64 KiB limit).
  void write_text(const std::string& name, const std::string& text);
  std::string read_text(const std::string& name) const;
  bool has(const std::string& name) const;

  // A (rows, cols) dataset written and read a block of rows at a time. T, its element type, is one
  // of double (float64), int64_t, int32_t and uint8_t; reading checks that the dataset holds
  // numbers of that kind (integers or floating point) and size, so a file never reads as another type.
  template <typename T = double>
  void create_rows(const std::string& name, hsize_t rows, hsize_t cols);
  template <typename T>
  void write_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, const T* data);
  template <typename T>
  void read_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, T* data) const;
  // Rows added at the end of a dataset that grows (created by the first call, even with count 0,
  // in chunks of chunk_rows rows, at most 8192): for data that comes in pieces.
  template <typename T>
  void append_rows(const std::string& name, hsize_t count, hsize_t cols, const T* data, hsize_t chunk_rows);
  hsize_t rows(const std::string& name) const;
  hsize_t cols(const std::string& name) const;

 private:
  Hdf5File(hid_t id, std::string path, bool writing) : id_(id), path_(std::move(path)), writing_(writing) {}
  [[noreturn]] void fail(const std::string& what) const;
  hid_t id_ = -1;
  std::string path_;
  bool writing_ = false;
};

}  // namespace hyperqn

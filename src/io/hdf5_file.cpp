#include "io/hdf5_file.hpp"

#include "io/atomic_file.hpp"


#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace hyperqn {

namespace {

// Rows (or bytes) per chunk: each chunk carries its own checksum and is read whole.
constexpr hsize_t kChunkRows = 8192;
constexpr hsize_t kChunkBytes = 65536;

herr_t collect(unsigned n, const H5E_error2_t* e, void* out) {
  auto& descriptions = *static_cast<std::vector<std::string>*>(out);
  (void)n;
  descriptions.push_back(e->desc ? e->desc : "");
  return 0;
}

// The reason of the last failure: the system's message if a file operation failed (HDF5 quotes
// it as "error message = '...'"), else the innermost description ("Fletcher32 checksum error ...").
std::string reason_from_stack() {
  std::vector<std::string> descriptions;  // innermost first
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, collect, &descriptions);
  H5Eclear2(H5E_DEFAULT);
  const std::string quote = "error message = '";
  for (const std::string& d : descriptions) {
    const size_t at = d.find(quote);
    if (at != std::string::npos) {
      const size_t end = d.find('\'', at + quote.size());
      return d.substr(at + quote.size(), end == std::string::npos ? std::string::npos : end - at - quote.size());
    }
  }
  for (const std::string& d : descriptions)
    if (!d.empty()) return d;
  return "HDF5 error";
}

// Closes an HDF5 identifier when it goes out of scope.
struct Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Handle() {
    if (id >= 0) close(id);
  }
};

}  // namespace

// HDF5 prints its error stack to stderr unless told not to; we turn it into the message.
void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
std::string hdf5_error_reason() { return reason_from_stack(); }

Hdf5File Hdf5File::create(const std::string& path) {
  silence_hdf5();
  Handle fapl{H5Pcreate(H5P_FILE_ACCESS), H5Pclose};
  // In memory, grown 4 MiB at a time, never backed by the file. The library's earliest format:
  // HDF5 1.10.8 gives a broken image (a superblock checksum that does not match) of a file in the
  // 1.8 format or later, whose metadata would carry checksums (measured 2026-11-25).
  if (fapl.id < 0 || H5Pset_fapl_core(fapl.id, 4 << 20, false) < 0)
    throw std::runtime_error("cannot write " + path + ": " + reason_from_stack());
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id);
  if (id < 0) throw std::runtime_error("cannot write " + path + ": " + reason_from_stack());
  return Hdf5File(id, path, true);
}

Hdf5File Hdf5File::open(const std::string& path) {
  silence_hdf5();
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) throw std::runtime_error("cannot read " + path + ": " + reason_from_stack());
  return Hdf5File(id, path, false);
}

Hdf5File::Hdf5File(Hdf5File&& other) noexcept : id_(other.id_), path_(std::move(other.path_)), writing_(other.writing_) {
  other.id_ = -1;
}

Hdf5File::~Hdf5File() {
  if (id_ >= 0) {
    H5Fclose(id_);
    H5Eclear2(H5E_DEFAULT);
  }
}

void Hdf5File::fail(const std::string& what) const {
  throw std::runtime_error(std::string(writing_ ? "cannot write " : "cannot read ") + path_ + ": " + what + ": " +
                           reason_from_stack());
}

void Hdf5File::close() {
  const hid_t id = id_;
  id_ = -1;
  if (id < 0) return;
  std::string image;
  if (writing_) {
    const ssize_t size = H5Fflush(id, H5F_SCOPE_GLOBAL) < 0 ? -1 : H5Fget_file_image(id, nullptr, 0);
    if (size >= 0) image.resize((size_t)size);
    if (size < 0 || (size > 0 && H5Fget_file_image(id, &image[0], image.size()) != size)) {
      const std::string reason = reason_from_stack();
      H5Fclose(id);  // in memory: nothing to write, so it cannot fail for want of space
      throw std::runtime_error("cannot write " + path_ + ": " + reason);
    }
  }
  if (H5Fclose(id) < 0) fail("closing the file");
  if (writing_) write_file_atomically(path_, image);
}

void Hdf5File::write_text(const std::string& name, const std::string& text) {
  const hsize_t n = text.size(), unlimited = H5S_UNLIMITED;
  const hsize_t chunk = std::max<hsize_t>(1, std::min(n, kChunkBytes));
  Handle space{H5Screate_simple(1, &n, &unlimited), H5Sclose};
  Handle dcpl{H5Pcreate(H5P_DATASET_CREATE), H5Pclose};
  if (space.id < 0 || dcpl.id < 0 || H5Pset_chunk(dcpl.id, 1, &chunk) < 0 || H5Pset_fletcher32(dcpl.id) < 0)
    fail(name);
  Handle set{H5Dcreate2(id_, name.c_str(), H5T_NATIVE_UCHAR, space.id, H5P_DEFAULT, dcpl.id, H5P_DEFAULT), H5Dclose};
  if (set.id < 0) fail(name);
  if (n > 0 && H5Dwrite(set.id, H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()) < 0) fail(name);
}

bool Hdf5File::has(const std::string& name) const { return H5Lexists(id_, name.c_str(), H5P_DEFAULT) > 0; }

std::string Hdf5File::read_text(const std::string& name) const {
  if (!has(name)) fail("no dataset " + name);
  Handle set{H5Dopen2(id_, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (set.id < 0) fail(name);
  Handle space{H5Dget_space(set.id), H5Sclose};
  hsize_t n = 0;
  if (space.id < 0 || H5Sget_simple_extent_ndims(space.id) != 1 || H5Sget_simple_extent_dims(space.id, &n, nullptr) < 0)
    fail(name + " is not a text");
  std::string text(n, '\0');
  if (n > 0 && H5Dread(set.id, H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, &text[0]) < 0) fail(name);
  return text;
}

namespace {

// The HDF5 type, and the name, of each element type of a table.
template <typename T>
hid_t native_type();
template <>
hid_t native_type<double>() { return H5T_NATIVE_DOUBLE; }
template <>
hid_t native_type<int64_t>() { return H5T_NATIVE_INT64; }
template <>
hid_t native_type<int32_t>() { return H5T_NATIVE_INT32; }
template <>
hid_t native_type<uint8_t>() { return H5T_NATIVE_UINT8; }

template <typename T>
const char* type_name() {
  return std::is_floating_point<T>::value ? "float64" : sizeof(T) == 8 ? "int64" : sizeof(T) == 4 ? "int32" : "uint8";
}

// A chunked dataset with checksums: `rows` rows now, at most `max_rows` (H5S_UNLIMITED: grows).
hid_t create_table(hid_t file, const std::string& name, hid_t type, hsize_t rows, hsize_t max_rows, hsize_t chunk_rows,
                   hsize_t cols) {
  const hsize_t dims[2] = {rows, cols}, max_dims[2] = {max_rows, cols};
  const hsize_t chunk[2] = {std::max<hsize_t>(1, std::min(chunk_rows, kChunkRows)), std::max<hsize_t>(1, cols)};
  Handle space{H5Screate_simple(2, dims, max_dims), H5Sclose};
  Handle dcpl{H5Pcreate(H5P_DATASET_CREATE), H5Pclose};
  if (space.id < 0 || dcpl.id < 0 || H5Pset_chunk(dcpl.id, 2, chunk) < 0 || H5Pset_fletcher32(dcpl.id) < 0) return -1;
  return H5Dcreate2(file, name.c_str(), type, space.id, H5P_DEFAULT, dcpl.id, H5P_DEFAULT);
}

// The rows [first, first + count) of a dataset of `cols` columns, as a selection in the file and
// the matching memory space.
bool select_rows(hid_t set, hsize_t first, hsize_t count, hsize_t cols, hid_t* file_space, hid_t* mem_space) {
  const hsize_t start[2] = {first, 0}, size[2] = {count, cols};
  *file_space = H5Dget_space(set);
  *mem_space = H5Screate_simple(2, size, nullptr);
  return *file_space >= 0 && *mem_space >= 0 &&
         H5Sselect_hyperslab(*file_space, H5S_SELECT_SET, start, nullptr, size, nullptr) >= 0;
}

// Whether a dataset holds numbers of T's kind and size (a table of int32 is not read as float64).
template <typename T>
bool holds(hid_t set) {
  Handle type{H5Dget_type(set), H5Tclose};
  if (type.id < 0) return false;
  const H5T_class_t kind = H5Tget_class(type.id);
  return kind == (std::is_floating_point<T>::value ? H5T_FLOAT : H5T_INTEGER) && H5Tget_size(type.id) == sizeof(T) &&
         (kind == H5T_FLOAT || (H5Tget_sign(type.id) == H5T_SGN_NONE) == std::is_unsigned<T>::value);
}

// The (rows, cols) of a 2-D dataset; false if it is not one.
bool table_dims(hid_t file, const std::string& name, hsize_t dims[2]) {
  Handle set{H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose};
  Handle space{set.id >= 0 ? H5Dget_space(set.id) : -1, H5Sclose};
  return space.id >= 0 && H5Sget_simple_extent_ndims(space.id) == 2 && H5Sget_simple_extent_dims(space.id, dims, nullptr) >= 0;
}

}  // namespace

template <typename T>
void Hdf5File::create_rows(const std::string& name, hsize_t rows, hsize_t cols) {
  Handle set{create_table(id_, name, native_type<T>(), rows, rows, rows, cols), H5Dclose};
  if (set.id < 0) fail(name);
}

template <typename T>
void Hdf5File::write_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, const T* data) {
  if (count == 0) return;
  Handle set{H5Dopen2(id_, name.c_str(), H5P_DEFAULT), H5Dclose};
  Handle file_space{-1, H5Sclose}, mem_space{-1, H5Sclose};
  if (set.id < 0 || !select_rows(set.id, first, count, cols, &file_space.id, &mem_space.id) ||
      H5Dwrite(set.id, native_type<T>(), mem_space.id, file_space.id, H5P_DEFAULT, data) < 0)
    fail(name);
}

template <typename T>
void Hdf5File::append_rows(const std::string& name, hsize_t count, hsize_t cols, const T* data, hsize_t chunk_rows) {
  if (!has(name)) {
    Handle set{create_table(id_, name, native_type<T>(), 0, H5S_UNLIMITED, chunk_rows, cols), H5Dclose};
    if (set.id < 0) fail(name);
  }
  if (count == 0) return;
  const hsize_t first = rows(name), dims[2] = {first + count, cols};
  Handle set{H5Dopen2(id_, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (set.id < 0 || H5Dset_extent(set.id, dims) < 0) fail(name);
  write_rows(name, first, count, cols, data);
}

template <typename T>
void Hdf5File::read_rows(const std::string& name, hsize_t first, hsize_t count, hsize_t cols, T* data) const {
  if (count == 0) return;
  if (!has(name)) fail("no dataset " + name);
  Handle set{H5Dopen2(id_, name.c_str(), H5P_DEFAULT), H5Dclose};
  if (set.id >= 0 && !holds<T>(set.id)) fail(name + " does not hold " + type_name<T>() + " values");
  Handle file_space{-1, H5Sclose}, mem_space{-1, H5Sclose};
  if (set.id < 0 || !select_rows(set.id, first, count, cols, &file_space.id, &mem_space.id) ||
      H5Dread(set.id, native_type<T>(), mem_space.id, file_space.id, H5P_DEFAULT, data) < 0)
    fail(name);
}

#define HYPERQN_HDF5_TABLE(T)                                                                                  \
  template void Hdf5File::create_rows<T>(const std::string&, hsize_t, hsize_t);                               \
  template void Hdf5File::write_rows<T>(const std::string&, hsize_t, hsize_t, hsize_t, const T*);             \
  template void Hdf5File::append_rows<T>(const std::string&, hsize_t, hsize_t, const T*, hsize_t);            \
  template void Hdf5File::read_rows<T>(const std::string&, hsize_t, hsize_t, hsize_t, T*) const;
HYPERQN_HDF5_TABLE(double)
HYPERQN_HDF5_TABLE(int64_t)
HYPERQN_HDF5_TABLE(int32_t)
HYPERQN_HDF5_TABLE(uint8_t)
#undef HYPERQN_HDF5_TABLE

hsize_t Hdf5File::rows(const std::string& name) const {
  if (!has(name)) fail("no dataset " + name);
  hsize_t dims[2] = {0, 0};
  if (!table_dims(id_, name, dims)) fail(name + " is not a table");
  return dims[0];
}

hsize_t Hdf5File::cols(const std::string& name) const {
  if (!has(name)) fail("no dataset " + name);
  hsize_t dims[2] = {0, 0};
  if (!table_dims(id_, name, dims)) fail(name + " is not a table");
  return dims[1];
}

}  // namespace hyperqn

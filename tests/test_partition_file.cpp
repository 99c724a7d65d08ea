// The partition file (io/partition_file.hpp) at 1, 2 and 3 ranks, on a box, a cloth sheet, a box
// with strands and a shared mesh file, each written for 1, 2 and 3 parts: read at the file's rank
// count, each rank's piece is pieces_of_serial_mesh's bit for bit; at another, the merged pieces
// hold every element exactly once with the whole mesh's vertices, coordinates and tags. Damaged
// files (missing, truncated, another format version, offsets out of range, a vertex index out of
// range under a valid checksum, not a partition file) are the same InputError naming the file on
// every rank. A file of bodies keeps its stamp (count and hash) and refuses a tag that is no body.
#include <hdf5.h>
#include <mpi.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unistd.h>

#include "check.hpp"
#include "io/hdf5_file.hpp"
#include "io/partition_file.hpp"
#include "mesh/input_error.hpp"

using namespace hyperqn;

namespace {

int rank_, size_;
std::string dir_;  // a directory of this run's files (rank 0's pid)

TetMesh cleaned(TetMesh m) {
  clean_mesh(m, "test");
  return m;
}

std::map<std::string, TetMesh> test_meshes() {
  std::map<std::string, TetMesh> meshes;
  meshes["box"] = cleaned(generate_box({2, 1, 1}, {4, 3, 2}));
  meshes["sheet"] = cleaned(generate_sheet({1, 1}, {8, 6}));
  TetMesh roped = generate_box({0.2, 0.2, 0.2}, {2, 2, 2});
  StrandLine rope, free_strand;
  rope.from = {0.2, 0.2, 0.2};
  rope.to = {0.2, 1.2, 0.2};
  rope.segments = 7;
  free_strand.from = {1, 0, 0};
  free_strand.to = {1, 0, 1};
  free_strand.segments = 5;
  add_strand(roped, rope);
  add_strand(roped, free_strand);
  meshes["box_with_strands"] = cleaned(roped);
  meshes["torus_file"] = cleaned(read_medit(std::string(HYPERQN_SHARED_MESHES) + "/torus.mesh"));
  return meshes;
}

// Every array of two pieces equal, bit for bit.
bool same_piece(MeshPiece& a, MeshPiece& b, std::string& what) {
  PieceArrays x = piece_arrays(a), y = piece_arrays(b);
  const auto compare = [&](auto& xs, auto& ys) {
    for (size_t k = 0; k < xs.size(); ++k)
      if (*xs[k].second != *ys[k].second) what += std::string(xs[k].first) + " ";
  };
  compare(x.doubles, y.doubles);
  compare(x.ints, y.ints);
  compare(x.longs, y.longs);
  compare(x.bytes, y.bytes);
  if (a.global_vertices != b.global_vertices) what += "global_vertices ";
  return what.empty();
}

std::vector<int64_t> gather_all(const std::vector<int64_t>& mine) {
  int n = int(mine.size());
  std::vector<int> counts(size_), starts(size_, 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  for (int r = 1; r < size_; ++r) starts[r] = starts[r - 1] + counts[r - 1];
  std::vector<int64_t> all(size_t(starts.back() + counts.back()));
  MPI_Allgatherv(mine.data(), n, MPI_INT64_T, all.data(), counts.data(), starts.data(), MPI_INT64_T, MPI_COMM_WORLD);
  return all;
}

// A piece that is a chunk of `serial` (not this rank's part of a partition): its elements are the
// whole mesh's (vertices, tags, coordinates), and over all ranks every element is held once.
void check_chunk(const MeshPiece& piece, const TetMesh& serial, const std::string& name) {
  const TetMesh& m = piece.mesh;
  CHECK_MSG(piece.global_vertices == serial.num_vertices(), name);
  bool vertices_ok = m.num_vertices() == (int64_t)piece.vertex_numbers.size();
  for (size_t v = 0; vertices_ok && v < piece.vertex_numbers.size(); ++v) {
    const int64_t g = piece.vertex_numbers[v];
    vertices_ok = (v == 0 || g > piece.vertex_numbers[v - 1]) && m.vertex_ids[v] == serial.vertex_ids[g];
    for (int d = 0; d < 3; ++d) vertices_ok = vertices_ok && m.coords[3 * v + d] == serial.coords[3 * g + d];
  }
  CHECK_MSG(vertices_ok, name + ": vertices and coordinates are the whole mesh's");
  const std::vector<int32_t>* local[3] = {&m.tets, &m.segments, &m.triangles};
  const std::vector<int32_t>* whole[3] = {&serial.tets, &serial.segments, &serial.triangles};
  const std::vector<int32_t>* local_tags[3] = {&m.tet_tags, &m.segment_tags, &m.triangle_tags};
  const std::vector<int32_t>* whole_tags[3] = {&serial.tet_tags, &serial.segment_tags, &serial.triangle_tags};
  const int width[3] = {4, 2, 3};
  size_t e = 0;
  for (int k = 0; k < 3; ++k) {
    std::vector<int64_t> numbers;
    bool elements_ok = true;
    for (size_t i = 0; i < local[k]->size() / width[k]; ++i, ++e) {
      const int64_t n = piece.element_numbers[e];
      numbers.push_back(n);
      for (int j = 0; j < width[k]; ++j)
        elements_ok = elements_ok && piece.vertex_numbers[(*local[k])[width[k] * i + j]] == (*whole[k])[width[k] * n + j];
      elements_ok = elements_ok && (*local_tags[k])[i] == (*whole_tags[k])[n];
      if (k == 2) elements_ok = elements_ok && m.triangle_edges[i] == serial.triangle_edges[n];
    }
    CHECK_MSG(elements_ok, name + ": kind " + std::to_string(k) + ": elements are the whole mesh's");
    std::vector<int64_t> all = gather_all(numbers);
    std::vector<int> held(whole[k]->size() / width[k], 0);
    bool in_range = true;
    for (int64_t n : all) in_range = in_range && n >= 0 && n < (int64_t)held.size() && ++held[n] > 0;
    bool once = in_range;
    for (int h : held) once = once && h == 1;
    CHECK_MSG(once, name + ": kind " + std::to_string(k) + ": every element held exactly once");
  }
  // Hinges carry no number: the same set of (global) vertex quadruples, in all.
  std::vector<int64_t> hinges;
  for (int32_t v : m.hinges) hinges.push_back(piece.vertex_numbers[v]);
  std::vector<int64_t> all = gather_all(hinges);
  std::multiset<std::vector<int64_t>> held, expected;
  for (size_t i = 0; i + 4 <= all.size(); i += 4) held.insert({all.begin() + i, all.begin() + i + 4});
  for (size_t i = 0; i + 4 <= serial.hinges.size(); i += 4) expected.insert({serial.hinges.begin() + i, serial.hinges.begin() + i + 4});
  CHECK_MSG(held == expected, name + ": hinges");
}

void check_round_trip(const std::string& mesh_name, const TetMesh& serial, int nparts) {
  const std::string path = dir_ + "/" + mesh_name + "_" + std::to_string(nparts) + ".h5";
  const std::string name = mesh_name + " in " + std::to_string(nparts) + " parts at " + std::to_string(size_) + " ranks";
  int written = 1;
  if (rank_ == 0) {
    try {
      write_partition_file(path, serial, nparts, "test " + mesh_name);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
      written = 0;
    }
  }
  MPI_Bcast(&written, 1, MPI_INT, 0, MPI_COMM_WORLD);
  CHECK_MSG(written, name);
  if (!written) return;
  const PartitionFileInfo info = read_partition_info(path);
  CHECK_MSG(info.parts == nparts && info.version == kPartitionFileVersion && info.source == "test " + mesh_name, name);
  CHECK_MSG(info.vertices == serial.num_vertices() && info.tets == serial.num_tets() &&
                info.segments == serial.num_segments() && info.triangles == serial.num_triangles() &&
                info.hinges == serial.num_hinges(),
            name + ": counts");
  MeshPiece piece = read_partition_piece(MPI_COMM_WORLD, path);
  if (nparts == size_) {
    bool found = false;
    pieces_of_serial_mesh(serial, nparts, [&](int part, MeshPiece& expected) {
      if (part != rank_) return;
      found = true;
      std::string what;
      CHECK_MSG(same_piece(piece, expected, what), name + ": part " + std::to_string(part) + " differs in " + what);
    });
    CHECK_MSG(found, name);
  }
  check_chunk(piece, serial, name);  // every rank count: the pieces cover the mesh once
}

// Overwrites one value of a dataset of a file in place (the file stays a valid HDF5 file: its
// chunk checksums are recomputed).
template <typename T>
void overwrite(const std::string& path, const std::string& name, hsize_t row, hsize_t col, T value, hid_t type) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  const hsize_t start[2] = {row, col}, count[2] = {1, 1};
  H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr);
  const hid_t mem = H5Screate_simple(2, count, nullptr);
  CHECK_MSG(H5Dwrite(set, type, mem, space, H5P_DEFAULT, &value) >= 0, path + ": " + name);
  H5Sclose(mem);
  H5Sclose(space);
  H5Dclose(set);
  H5Fclose(file);
}

void copy_file(const std::string& from, const std::string& to, double fraction = 1) {
  std::ifstream in(from, std::ios::binary);
  std::stringstream all;
  all << in.rdbuf();
  const std::string bytes = all.str();
  std::ofstream(to, std::ios::binary) << bytes.substr(0, size_t(bytes.size() * fraction));
}

// Reading `path` fails with the same InputError naming it on every rank, saying `expected`; and
// reading its header alone too, if the header is what is wrong.
void check_refused(const std::string& path, const std::string& expected, const std::string& name, bool header = true) {
  std::string message;
  try {
    read_partition_piece(MPI_COMM_WORLD, path);
  } catch (const InputError& e) {
    message = e.what();
  }
  CHECK_MSG(message.find(path) != std::string::npos && message.find(expected) != std::string::npos,
            name + ": '" + message + "'");
  std::vector<int64_t> length = gather_all({int64_t(message.size())});
  bool same = true;
  for (int64_t n : length) same = same && n == length[0];
  CHECK_MSG(same, name + ": the same message on every rank");
  if (rank_ == 0 && header) {  // the header alone is read by the deck reader
    std::string info_message;
    try {
      read_partition_info(path);
    } catch (const InputError& e) {
      info_message = e.what();
    }
    CHECK_MSG(info_message.find(path) != std::string::npos, name + ": read_partition_info: '" + info_message + "'");
  }
}

void check_damaged_files(const TetMesh& serial) {
  const std::string good = dir_ + "/good.h5";
  const std::string truncated = dir_ + "/truncated.h5", version = dir_ + "/version.h5", offsets = dir_ + "/offsets.h5",
                    index = dir_ + "/index.h5", other = dir_ + "/other.h5", damaged = dir_ + "/damaged.h5";
  if (rank_ == 0) {
    write_partition_file(good, serial, 2, "test");
    copy_file(good, truncated, 0.5);
    copy_file(good, version);
    overwrite<int64_t>(version, "format_version", 0, 0, 99, H5T_NATIVE_INT64);
    copy_file(good, offsets);
    overwrite<int64_t>(offsets, "tets_offsets", 1, 0, 1 << 30, H5T_NATIVE_INT64);
    copy_file(good, damaged);
    overwrite<double>(damaged, "coords", 0, 0, 12345.0, H5T_NATIVE_DOUBLE);
    // A vertex index out of the part's range, with the part's checksum made to match.
    copy_file(good, index);
    pieces_of_serial_mesh(serial, 2, [&](int part, MeshPiece& piece) {
      if (part != 0) return;
      piece.mesh.tets[1] = int32_t(piece.mesh.num_vertices() + 5);
      overwrite<int32_t>(index, "tets", 0, 1, piece.mesh.tets[1], H5T_NATIVE_INT32);
      overwrite<int64_t>(index, "part_checksums", 0, 0, int64_t(piece_checksum(piece)), H5T_NATIVE_INT64);
    });
    Hdf5File f = Hdf5File::create(other);
    f.write_text("something", "else");
    f.close();
    // Typed tables: an int32 table is not read as float64.
    const Hdf5File g = Hdf5File::open(good);
    double x;
    bool refused = false;
    try {
      g.read_rows("tets", 0, 1, 1, &x);
    } catch (const std::runtime_error& e) {
      refused = std::string(e.what()).find("does not hold float64") != std::string::npos;
    }
    CHECK(refused);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  check_refused(dir_ + "/missing.h5", "not found", "missing file");
  check_refused(truncated, "cannot read", "truncated file");
  check_refused(version, "format version 99", "another version");
  check_refused(offsets, "tets_offsets", "offsets out of range");
  check_refused(damaged, "checksum", "a changed coordinate", false);
  check_refused(other, "not a partition file", "another HDF5 file");
  MPI_Barrier(MPI_COMM_WORLD);
  // Only the rank that reads part 0 sees the bad index; every rank must say it.
  check_refused(index, "outside the part's", "vertex index out of range", false);
}

// A file of bodies: its stamp read back; a tag that is no body (under a valid checksum) refused on
// every rank; mesh_sources_hash changes with a transform or a mesh file's bytes, not its path.
void check_bodies(const TetMesh& serial) {
  const std::string good = dir_ + "/bodies.h5", bad_tag = dir_ + "/bad_tag.h5";
  const BodiesStamp stamp{2, 0x8000000000000123ull};  // a hash with the top bit set survives the int64 table
  TetMesh two = serial;  // two bodies: the first tets body 0, the rest body 1
  for (size_t t = 0; t < two.tet_tags.size(); ++t) two.tet_tags[t] = t < two.tet_tags.size() / 2 ? 0 : 1;
  if (rank_ == 0) {
    write_partition_file(good, two, 2, "test bodies", CleanReport(), stamp);
    copy_file(good, bad_tag);
    pieces_of_serial_mesh(two, 2, [&](int part, MeshPiece& piece) {
      if (part != 0) return;
      piece.mesh.tet_tags[0] = 2;
      overwrite<int32_t>(bad_tag, "tet_tags", 0, 0, 2, H5T_NATIVE_INT32);
      overwrite<int64_t>(bad_tag, "part_checksums", 0, 0, int64_t(piece_checksum(piece)), H5T_NATIVE_INT64);
    });
  }
  MPI_Barrier(MPI_COMM_WORLD);
  const PartitionFileInfo info = read_partition_info(good);
  CHECK_MSG(info.bodies.count == 2 && info.bodies.hash == stamp.hash, "bodies: the stamp read back");
  CHECK_MSG(read_partition_info(dir_ + "/box_2.h5").bodies.count == 0, "one mesh: no bodies");
  MeshPiece piece = read_partition_piece(MPI_COMM_WORLD, good);
  check_chunk(piece, two, "bodies");
  check_refused(bad_tag, "body 2 of 2 bodies", "a tag that is no body", false);

  const std::string medit = dir_ + "/one_tet.mesh", moved = dir_ + "/moved_tet.mesh";
  const std::string text = "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
                           "Tetrahedra\n1\n1 2 3 4 0\nEnd\n";
  if (rank_ == 0) {
    std::ofstream(medit) << text;
    std::ofstream(moved) << text;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  MeshSpec box, file;
  box.is_box = true;
  file.file = medit;
  const uint64_t h = mesh_sources_hash({box, file});
  MeshSpec file_elsewhere = file;
  file_elsewhere.file = moved;  // the same bytes under another name
  CHECK_MSG(mesh_sources_hash({box, file_elsewhere}) == h, "bodies hash: not the file's path");
  MeshSpec turned = box;
  turned.transform.rotate_deg[2] = 90;
  CHECK_MSG(mesh_sources_hash({turned, file}) != h, "bodies hash: a transform");
  CHECK_MSG(mesh_sources_hash({file, box}) != h && mesh_sources_hash({box}) != h, "bodies hash: the order and count");
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank_ == 0) std::ofstream(moved) << text << "\n";
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK_MSG(mesh_sources_hash({box, file_elsewhere}) != h, "bodies hash: the file's bytes");
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  long pid = rank_ == 0 ? long(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_LONG, 0, MPI_COMM_WORLD);
  dir_ = "/tmp/hyperqn_test_partition_" + std::to_string(pid);
  if (rank_ == 0) std::filesystem::create_directories(dir_);
  MPI_Barrier(MPI_COMM_WORLD);
  const std::map<std::string, TetMesh> meshes = test_meshes();
  for (const auto& [name, mesh] : meshes)
    for (int nparts : {1, 2, 3}) check_round_trip(name, mesh, nparts);
  check_damaged_files(meshes.at("box"));
  check_bodies(meshes.at("box"));
  int local = check::failures(), total = 0;
  MPI_Allreduce(&local, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  MPI_Barrier(MPI_COMM_WORLD);
  if (rank_ == 0) std::filesystem::remove_all(dir_);
  check::failures() = total;
  const int code = rank_ == 0 ? check::summary(("test_partition_file (" + std::to_string(size_) + " ranks)").c_str())
                              : (total == 0 ? 0 : 1);
  MPI_Finalize();
  return code;
}

#include "io/partition_file.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <new>
#include <stdexcept>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/fnv_hash.hpp"
#include "io/hdf5_file.hpp"
#include "mesh/distributed_mesh.hpp"
#include "mesh/input_error.hpp"

namespace hyperqn {

namespace {

const char kFormat[] = "hyperqn partition file";
// The 1 x 1 int64 tables of the header, in PartitionFileInfo's order.
const char* const kHeader[] = {"format_version", "parts", "global_vertices", "total_tets", "total_segments",
                               "total_triangles", "total_hinges", "dropped_vertices", "reoriented_tets"};

// Columns of each array's table: one row per vertex or element.
hsize_t width_of(const std::string& name) {
  if (name == "coords" || name == "triangles") return 3;
  if (name == "tets" || name == "hinges") return 4;
  if (name == "segments") return 2;
  return 1;
}

// Rows of an array over the whole mesh (about: a vertex on an interface is in several pieces).
int64_t serial_rows(const std::string& name, const TetMesh& m) {
  if (name == "coords" || name == "vertex_ids" || name == "vertex_numbers") return m.num_vertices();
  if (name == "tets" || name == "tet_tags") return m.num_tets();
  if (name == "segments" || name == "segment_tags") return m.num_segments();
  if (name == "triangles" || name == "triangle_tags" || name == "triangle_edges") return m.num_triangles();
  if (name == "hinges") return m.num_hinges();
  return m.num_tets() + m.num_segments() + m.num_triangles();  // element_numbers
}

int64_t read_scalar(const Hdf5File& file, const std::string& name) {
  if (file.rows(name) != 1 || file.cols(name) != 1) throw std::runtime_error(name + " is not a single value");
  int64_t value = 0;
  file.read_rows(name, 0, 1, 1, &value);
  return value;
}

void write_scalar(Hdf5File& file, const std::string& name, int64_t value) {
  file.create_rows<int64_t>(name, 1, 1);
  file.write_rows(name, 0, 1, 1, &value);
}

// The file's header and every array's offsets, checked.
struct Layout {
  PartitionFileInfo info;
  std::map<std::string, std::vector<int64_t>> offsets;  // per array: parts + 1 row offsets
  std::vector<int64_t> checksums;                       // per part
  // Part p's rows of array `name`.
  int64_t rows(const std::string& name, int p) const {
    const std::vector<int64_t>& o = offsets.at(name);
    return o[p + 1] - o[p];
  }
};

// Reads and checks the layout; throws std::runtime_error saying what is wrong (without the path).
Layout read_layout(const Hdf5File& file) {
  if (!file.has("format") || file.read_text("format") != kFormat)
    throw std::runtime_error("not a partition file of hyperqn (write one with hyperqn partition DECK -n N -o FILE.h5)");
  for (const char* name : kHeader)
    if (!file.has(name)) throw std::runtime_error("not a whole partition file: no " + std::string(name));
  Layout l;
  PartitionFileInfo& info = l.info;
  const int64_t version = read_scalar(file, "format_version");
  if (version != kPartitionFileVersion)
    throw std::runtime_error("format version " + std::to_string(version) + "; this hyperqn reads version " +
                             std::to_string(kPartitionFileVersion) + " (write the file again with hyperqn partition)");
  info.version = int(version);
  const int64_t parts = read_scalar(file, "parts");
  if (parts < 1 || parts > std::numeric_limits<int>::max())
    throw std::runtime_error("parts: " + std::to_string(parts) + " (expected at least 1)");
  info.parts = int(parts);
  int64_t* counts[] = {&info.vertices, &info.tets, &info.segments, &info.triangles, &info.hinges,
                       &info.repaired.dropped_vertices, &info.repaired.reoriented_tets};
  for (int k = 0; k < 7; ++k) {
    *counts[k] = read_scalar(file, kHeader[k + 2]);
    if (*counts[k] < 0) throw std::runtime_error(std::string(kHeader[k + 2]) + ": negative count " + std::to_string(*counts[k]));
  }
  info.source = file.has("source") ? file.read_text("source") : "";
  if (file.has("bodies")) {  // a file of bodies
    info.bodies.count = read_scalar(file, "bodies");
    if (info.bodies.count < 1) throw std::runtime_error("bodies: " + std::to_string(info.bodies.count) + " (expected at least 1)");
    if (!file.has("bodies_hash")) throw std::runtime_error("not a whole partition file: bodies without bodies_hash");
    info.bodies.hash = uint64_t(read_scalar(file, "bodies_hash"));
  }

  MeshPiece names;
  for_each_array(names, [&](const std::string& name, auto&) {
    const std::string offsets = name + "_offsets";
    if (!file.has(name) || !file.has(offsets)) throw std::runtime_error("not a whole partition file: no " + name + " or " + offsets);
    if (file.cols(name) != width_of(name))
      throw std::runtime_error(name + " has " + std::to_string(file.cols(name)) + " columns, not " + std::to_string(width_of(name)));
    if (file.rows(offsets) != hsize_t(parts) + 1 || file.cols(offsets) != 1)
      throw std::runtime_error(offsets + " has " + std::to_string(file.rows(offsets)) + " rows for " + std::to_string(parts) +
                               " parts (expected parts + 1)");
    std::vector<int64_t>& o = l.offsets[name];
    o.resize(size_t(parts) + 1);
    file.read_rows(offsets, 0, o.size(), 1, o.data());
    const int64_t total = int64_t(file.rows(name));
    if (o[0] != 0) throw std::runtime_error(offsets + " starts at " + std::to_string(o[0]) + ", not 0");
    for (int64_t p = 0; p < parts; ++p)
      if (o[p + 1] < o[p] || o[p + 1] > total)
        throw std::runtime_error(offsets + ": part " + std::to_string(p) + " ends at row " + std::to_string(o[p + 1]) +
                                 ", outside [" + std::to_string(o[p]) + ", " + std::to_string(total) + "] of " + name);
    if (o[parts] != total)
      throw std::runtime_error(offsets + " ends at row " + std::to_string(o[parts]) + " of the " + std::to_string(total) +
                               " of " + name);
  });
  const std::pair<const char*, int64_t> totals[] = {{"tets", info.tets},         {"tet_tags", info.tets},
                                                    {"segments", info.segments}, {"segment_tags", info.segments},
                                                    {"triangles", info.triangles}, {"triangle_tags", info.triangles},
                                                    {"triangle_edges", info.triangles}, {"hinges", info.hinges},
                                                    {"element_numbers", info.tets + info.segments + info.triangles}};
  for (const auto& [name, count] : totals)
    if (l.offsets[name][parts] != count)
      throw std::runtime_error(std::string(name) + " has " + std::to_string(l.offsets[name][parts]) + " rows; the header says " +
                               std::to_string(count));
  for (int p = 0; p < parts; ++p) {
    const auto same = [&](const char* a, const char* b) {
      if (l.rows(a, p) != l.rows(b, p))
        throw std::runtime_error("part " + std::to_string(p) + ": " + std::to_string(l.rows(a, p)) + " rows of " + a + " but " +
                                 std::to_string(l.rows(b, p)) + " of " + b);
    };
    same("vertex_ids", "coords");
    same("vertex_numbers", "coords");
    same("tet_tags", "tets");
    same("segment_tags", "segments");
    same("triangle_tags", "triangles");
    same("triangle_edges", "triangles");
    if (l.rows("element_numbers", p) != l.rows("tets", p) + l.rows("segments", p) + l.rows("triangles", p))
      throw std::runtime_error("part " + std::to_string(p) + ": element_numbers does not number its tets, segments and triangles");
    if (l.rows("coords", p) > info.vertices)
      throw std::runtime_error("part " + std::to_string(p) + " has more vertices than the whole mesh");
  }
  if (!file.has("part_checksums") || file.rows("part_checksums") != hsize_t(parts) || file.cols("part_checksums") != 1)
    throw std::runtime_error("part_checksums missing or not of one row per part");
  l.checksums.resize(size_t(parts));
  file.read_rows("part_checksums", 0, l.checksums.size(), 1, l.checksums.data());
  return l;
}

// What is wrong with a piece read as part p, or "" (indices, numbers and values in range).
std::string check_piece(const MeshPiece& piece, const PartitionFileInfo& info, int p) {
  const TetMesh& m = piece.mesh;
  const std::string part = "part " + std::to_string(p) + ": ";
  const int64_t nv = m.num_vertices();
  for (const auto& [name, v] : {std::pair<const char*, const std::vector<int32_t>*>{"tets", &m.tets},
                                {"segments", &m.segments}, {"triangles", &m.triangles}, {"hinges", &m.hinges}})
    for (size_t i = 0; i < v->size(); ++i)
      if ((*v)[i] < 0 || (*v)[i] >= nv)
        return part + name + " row " + std::to_string(i / width_of(name)) + ": vertex " + std::to_string((*v)[i]) +
               " outside the part's " + std::to_string(nv) + " vertices";
  for (size_t i = 0; i < piece.vertex_numbers.size(); ++i) {
    const int64_t n = piece.vertex_numbers[i];
    if (n < 0 || n >= info.vertices || (i > 0 && n <= piece.vertex_numbers[i - 1]))
      return part + "vertex_numbers row " + std::to_string(i) + ": " + std::to_string(n) +
             " is not ascending within [0, " + std::to_string(info.vertices) + ")";
  }
  for (size_t i = 0; i < m.coords.size(); ++i)
    if (!std::isfinite(m.coords[i])) return part + "coords row " + std::to_string(i / 3) + ": not a finite number";
  const int64_t kinds[3] = {m.num_tets(), m.num_segments(), m.num_triangles()};
  const int64_t counts[3] = {info.tets, info.segments, info.triangles};
  size_t e = 0;
  for (int k = 0; k < 3; ++k)
    for (int64_t i = 0; i < kinds[k]; ++i, ++e)
      if (piece.element_numbers[e] < 0 || piece.element_numbers[e] >= counts[k])
        return part + "element_numbers row " + std::to_string(e) + ": " + std::to_string(piece.element_numbers[e]) +
               " outside the whole mesh's " + std::to_string(counts[k]) + " elements of its kind";
  for (size_t i = 0; i < m.triangle_edges.size(); ++i)
    if (m.triangle_edges[i] > 7) return part + "triangle_edges row " + std::to_string(i) + ": not 3 bits";
  if (info.bodies.count > 0)  // a file of bodies: every element's tag is its body
    for (const auto& [name, tags] : {std::pair<const char*, const std::vector<int32_t>*>{"tet_tags", &m.tet_tags},
                                     {"segment_tags", &m.segment_tags}, {"triangle_tags", &m.triangle_tags}})
      for (size_t i = 0; i < tags->size(); ++i)
        if ((*tags)[i] < 0 || (*tags)[i] >= info.bodies.count)
          return part + name + " row " + std::to_string(i) + ": body " + std::to_string((*tags)[i]) + " of " +
                 std::to_string(info.bodies.count) + " bodies";
  return "";
}

// Part p, read and checked; throws std::runtime_error.
MeshPiece read_part(const Hdf5File& file, const Layout& l, int p) {
  MeshPiece piece;
  piece.global_vertices = l.info.vertices;
  for_each_array(piece, [&](const std::string& name, auto& v) {
    const int64_t first = l.offsets.at(name)[p], rows = l.rows(name, p);
    v.resize(size_t(rows) * width_of(name));
    file.read_rows(name, hsize_t(first), hsize_t(rows), width_of(name), v.data());
  });
  const uint64_t sum = piece_checksum(piece);
  if (int64_t(sum) != l.checksums[p])
    throw std::runtime_error("part " + std::to_string(p) + ": its arrays do not match their checksum (a damaged file)");
  const std::string wrong = check_piece(piece, l.info, p);
  if (!wrong.empty()) throw std::runtime_error(wrong);
  return piece;
}

void check_readable(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "", "partition file not found");
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "", "is a directory, not a partition file");
}

// A failure reading `path` as the InputError naming it: Hdf5File's messages ("cannot read PATH:
// ...") name it already.
InputError read_error(const std::string& path, const std::exception& e) {
  const std::string what = e.what();
  if (what.rfind("cannot read " + path, 0) == 0) return InputError(what);
  return InputError(path, 0, "", what);
}

}  // namespace

uint64_t piece_checksum(MeshPiece& piece) {
  Fnv1a h;
  for_each_array(piece, [&](const std::string& name, auto& v) {
    const uint64_t n = v.size();
    h.add(name.data(), name.size());
    h.add(&n, sizeof n);
    h.add(v.data(), v.size() * sizeof(v[0]));
  });
  return h.value;
}

void write_partition_file(const std::string& path, const TetMesh& serial, int nparts, const std::string& source,
                          const CleanReport& repaired, const BodiesStamp& bodies) {
  if (nparts < 1) throw std::invalid_argument("write_partition_file: nparts must be at least 1");
  try {
    Hdf5File file = Hdf5File::create(path);
    file.write_text("format", kFormat);
    std::map<std::string, std::vector<int64_t>> offsets;
    std::vector<int64_t> checksums;
    pieces_of_serial_mesh(serial, nparts, [&](int, MeshPiece& piece) {
      for_each_array(piece, [&](const std::string& name, auto& v) {
        const hsize_t width = width_of(name), rows = v.size() / width;
        // A chunk about a part's rows: a rank reads little beyond its own.
        file.append_rows(name, rows, width, v.data(), hsize_t(serial_rows(name, serial) / nparts + 1));
        std::vector<int64_t>& o = offsets[name];
        if (o.empty()) o.push_back(0);
        o.push_back(o.back() + int64_t(rows));
      });
      checksums.push_back(int64_t(piece_checksum(piece)));
    });
    for (const auto& [name, o] : offsets) {
      file.create_rows<int64_t>(name + "_offsets", o.size(), 1);
      file.write_rows(name + "_offsets", 0, o.size(), 1, o.data());
    }
    file.create_rows<int64_t>("part_checksums", checksums.size(), 1);
    file.write_rows("part_checksums", 0, checksums.size(), 1, checksums.data());
    const int64_t header[] = {kPartitionFileVersion, nparts, serial.num_vertices(), serial.num_tets(),
                              serial.num_segments(), serial.num_triangles(), serial.num_hinges(),
                              repaired.dropped_vertices, repaired.reoriented_tets};
    for (size_t k = 0; k < std::size(kHeader); ++k) write_scalar(file, kHeader[k], header[k]);
    if (bodies.count > 0) {
      write_scalar(file, "bodies", bodies.count);
      write_scalar(file, "bodies_hash", int64_t(bodies.hash));
    }
    file.write_text("source", source);
    file.close();
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("cannot write " + path + ": out of memory");
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind("cannot write " + path, 0) == 0) throw;
    throw std::runtime_error("cannot write " + path + ": " + e.what());  // METIS
  }
}

uint64_t mesh_sources_hash(const std::vector<MeshSpec>& meshes) {
  Fnv1a h;
  const auto add = [&](const auto& value) { h.add(&value, sizeof value); };
  add(meshes.size());
  for (const MeshSpec& m : meshes) {
    add(m.is_box);
    add(m.box_size);
    add(m.box_cells);
    add(m.is_sheet);
    add(m.sheet_size);
    add(m.sheet_cells);
    add(m.surface_as_cloth);
    add(m.edges_as_strands);
    add(m.transform.scale);
    add(m.transform.rotate_deg);
    add(m.transform.translate);
    add(m.strands.size());
    for (const StrandLine& s : m.strands) {
      add(s.from);
      add(s.to);
      add(s.segments);
    }
    uint64_t bytes = 0;
    if (!m.file.empty()) {
      std::ifstream in(m.file, std::ios::binary);
      std::vector<char> block(1 << 20);
      while (in) {
        in.read(block.data(), std::streamsize(block.size()));
        h.add(block.data(), size_t(in.gcount()));
        bytes += uint64_t(in.gcount());
      }
      if (!in.eof()) throw InputError(m.file, 0, "", "cannot read the file to check it against the partition file");
    }
    add(bytes);
  }
  return h.value;
}

PartitionFileInfo read_partition_info(const std::string& path) {
  check_readable(path);
  try {
    const Hdf5File file = Hdf5File::open(path);
    return read_layout(file).info;
  } catch (const std::bad_alloc&) {
    throw InputError(path, 0, "", "out of memory reading the partition file's header");
  } catch (const std::exception& e) {
    throw read_error(path, e);
  }
}

// More ranks (M) than parts (P): part p goes to the ranks [ceil(p M / P), ceil((p + 1) M / P)).
static int first_rank_of_part(int p, int parts, int size) { return int((int64_t(p) * size + parts - 1) / parts); }
static int part_of(int rank, int parts, int size) {
  int p = 0;
  while (p + 1 < parts && first_rank_of_part(p + 1, parts, size) <= rank) ++p;
  return p;
}
// The first rank and the number of ranks of rank's group.
static std::pair<int, int> group_of(int rank, int parts, int size) {
  const int p = part_of(rank, parts, size), first = first_rank_of_part(p, parts, size);
  return {first, first_rank_of_part(p + 1, parts, size) - first};
}

MeshPiece read_partition_piece(MPI_Comm comm, const std::string& path) {
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  MeshPiece piece;
  std::string error;
  auto failed = [&](const std::exception& e) {
    if (const auto* input = dynamic_cast<const InputError*>(&e)) return std::string(input->what());
    if (dynamic_cast<const std::bad_alloc*>(&e))
      return std::string(InputError(path, 0, "", "out of memory reading this rank's parts of the partition file").what());
    return std::string(read_error(path, e).what());
  };
  int parts = 0;
  try {
    check_readable(path);
    const Hdf5File file = Hdf5File::open(path);
    const Layout layout = read_layout(file);
    parts = layout.info.parts;
    if (parts >= size) {  // rank r takes the parts [r P / M, (r + 1) P / M), merged
      const int first = int(int64_t(rank) * parts / size), last = int(int64_t(rank + 1) * parts / size);
      std::vector<MeshPiece> mine;
      for (int p = first; p < last; ++p) mine.push_back(read_part(file, layout, p));
      piece = mine.size() == 1 ? std::move(mine[0]) : merge_pieces(mine);
      piece.global_vertices = layout.info.vertices;
    } else if (rank == group_of(rank, parts, size).first) {  // more ranks than parts: the group's first reads
      piece = read_part(file, layout, part_of(rank, parts, size));
    }
  } catch (const std::exception& e) {
    error = failed(e);
  }
  // Every rank knows the file's part count before a group shares its part.
  int agreed_parts = error.empty() ? parts : -1, smallest = 0;
  MPI_Allreduce(&agreed_parts, &smallest, 1, MPI_INT, MPI_MIN, comm);
  if (smallest > 0 && parts < size) {  // part p cut by METIS for its group of ranks
    const auto [root, count] = group_of(rank, parts, size);
    try {
      piece = share_piece(comm, root, count, rank == root ? &piece : nullptr);
    } catch (const std::exception& e) {
      if (error.empty()) error = failed(e);
    }
  }
  try {
    throw_if_any_failed(comm, error);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  return piece;
}

}  // namespace hyperqn

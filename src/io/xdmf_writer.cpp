#include "io/xdmf_writer.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "io/atomic_file.hpp"
#include "io/frame_fields.hpp"
#include "io/hdf5_file.hpp"

namespace hyperqn {

namespace {

// Element kinds in the order of the topology: XDMF's Mixed code, and its vertices.
constexpr int kKinds = 3;
constexpr int kVertices[kKinds] = {4, 2, 3};
constexpr int kMixedCode[kKinds] = {6, 2, 4};          // Tetrahedron, Polyline, Triangle
constexpr int kMixedPrefix[kKinds] = {1, 2, 1};        // the code, and a polyline's vertex count
constexpr const char* kTopology[kKinds] = {"Tetrahedron", "Polyline", "Triangle"};

// XDMF's Tensor6 holds a symmetric tensor's values as xx, xy, xz, yy, yz, zz (the upper triangle
// row by row; ParaView's XDMF reader expands it so); value i of it is value kTensor6[i] of the
// frame's (terms/element_fields.hpp's kSymmetricRow order).
int tensor6_source(int i) {
  static const int row[6] = {0, 0, 0, 1, 1, 2}, col[6] = {0, 1, 2, 1, 2, 2};
  for (int j = 0; j < 6; ++j)
    if (kSymmetricRow[j] == row[i] && kSymmetricCol[j] == col[i]) return j;
  return -1;
}
const int kTensor6[6] = {tensor6_source(0), tensor6_source(1), tensor6_source(2),
                         tensor6_source(3), tensor6_source(4), tensor6_source(5)};

// In a restart state, an element field is NAME@COMPONENTS, NAME@COMPONENTS/4 if written as floats
// (a point field is its name alone).
constexpr char kElementFieldMark = '@';
constexpr const char* kSingleMark = "/4";

// Mesh block K's group: /mesh (the first mesh), /mesh/K after the Kth topology change.
std::string mesh_group(size_t block) { return block == 0 ? "/mesh" : "/mesh/" + std::to_string(block); }

// In a restart state, a frame of mesh block K > 0 ends with mesh=K; block K is a line "mesh K POINTS".
constexpr const char* kBlockMark = "mesh=";
constexpr const char* kBlockLine = "mesh ";

std::string frame_group(int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "/frames/%05d", frame);
  return buf;
}

// Closes an HDF5 identifier when it goes out of scope.
struct Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Handle() {
    if (id >= 0) close(id);
  }
};

// NAME.h5 opened by every rank through MPI-IO. Every call is collective (HDF5's metadata
// operations are, in parallel); a failure throws std::runtime_error "cannot write PATH: ...".
class ParallelFile {
 public:
  ParallelFile(MPI_Comm comm, const std::string& path, bool create) : path_(path) {
    silence_hdf5();
#ifdef H5_HAVE_PARALLEL
    Handle fapl{H5Pcreate(H5P_FILE_ACCESS), H5Pclose};
    if (fapl.id < 0 || H5Pset_fapl_mpio(fapl.id, comm, MPI_INFO_NULL) < 0) fail("MPI-IO");
    id_ = create ? H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id)
                 : H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.id);
    if (id_ < 0) fail(create ? "creating the file" : "opening the file");
    dxpl_ = H5Pcreate(H5P_DATASET_XFER);
    if (dxpl_ < 0 || H5Pset_dxpl_mpio(dxpl_, H5FD_MPIO_COLLECTIVE) < 0) fail("collective transfers");
#else
    (void)comm;
    (void)create;
    throw std::runtime_error("cannot write " + path + ": output.format xdmf needs an HDF5 built for MPI (parallel)");
#endif
  }
  ParallelFile(const ParallelFile&) = delete;
  ParallelFile& operator=(const ParallelFile&) = delete;
  ~ParallelFile() {
    if (dxpl_ >= 0) H5Pclose(dxpl_);
    if (id_ >= 0) H5Fclose(id_);
    H5Eclear2(H5E_DEFAULT);
  }
  void close() {
    const hid_t id = id_;
    id_ = -1;
    if (H5Fclose(id) < 0) fail("closing the file");
  }

  void group(const std::string& name) {
    if (H5Lexists(id_, name.c_str(), H5P_DEFAULT) > 0 && H5Ldelete(id_, name.c_str(), H5P_DEFAULT) < 0) fail(name);
    Handle g{H5Gcreate2(id_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
    if (g.id < 0) fail(name);
  }

  // A dataset of `rows` rows of `width` values (width 0: a 1-D dataset of `rows` values), and
  // the blocks of it that this rank writes. A block of a 2-D dataset: `rows` rows from row
  // `start`; of a 1-D one: `rows` rows of `width` values from value `start`.
  struct Block {
    hsize_t start, rows, width;
    const void* data;
  };
  // Values are int64 (integer), double, or float (single: an element field of output.field_precision single).
  void dataset(const std::string& name, bool integer, hsize_t rows, hsize_t width, const std::vector<Block>& blocks,
               bool single = false) {
    const int rank = width > 0 ? 2 : 1;
    const hsize_t dims[2] = {rows, width};
    Handle space{H5Screate_simple(rank, dims, nullptr), H5Sclose};
    const hid_t file_type = integer ? H5T_STD_I64LE : single ? H5T_IEEE_F32LE : H5T_IEEE_F64LE;
    const hid_t mem_type = integer ? H5T_NATIVE_INT64 : single ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
    Handle set{space.id < 0 ? -1 : H5Dcreate2(id_, name.c_str(), file_type, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose};
    if (set.id < 0) fail(name);
    // Every rank writes as many blocks as the others (collective transfers), an empty one as none.
    for (const Block& b : blocks) {
      const hsize_t values = b.rows * (width > 0 ? width : b.width), one = 1;
      const hsize_t start[2] = {b.start, 0}, count[2] = {width > 0 ? b.rows : values, width};
      Handle file_space{H5Dget_space(set.id), H5Sclose};
      Handle mem_space{H5Screate_simple(1, values > 0 ? &values : &one, nullptr), H5Sclose};
      if (file_space.id < 0 || mem_space.id < 0) fail(name);
      const bool selected =
          values == 0 ? H5Sselect_none(file_space.id) >= 0 && H5Sselect_none(mem_space.id) >= 0
                      : H5Sselect_hyperslab(file_space.id, H5S_SELECT_SET, start, nullptr, count, nullptr) >= 0;
      if (!selected || H5Dwrite(set.id, mem_type, mem_space.id, file_space.id, dxpl_, b.data) < 0) fail(name);
    }
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("cannot write " + path_ + ": " + what + ": " + hdf5_error_reason());
  }
  std::string path_;
  hid_t id_ = -1, dxpl_ = -1;
};

herr_t collect_name(hid_t, const char* name, const H5L_info_t*, void* names) {
  static_cast<std::vector<std::string>*>(names)->push_back(name);
  return 0;
}

std::vector<PetscInt> as_rows(const std::vector<int64_t>& ids) { return std::vector<PetscInt>(ids.begin(), ids.end()); }

// The ids in use (of local items, ghosts too), numbered in order: each local item's number, and
// how many ids are in use. Every local item marks its id's row; each block counts its marked
// rows; a prefix sum over the ranks makes the numbers. Collective.
std::pair<std::vector<int64_t>, PetscInt> number_in_use(MPI_Comm comm, const std::vector<int64_t>& ids) {
  long long slots = 0;
  for (int64_t id : ids) slots = std::max<long long>(slots, id + 1);
  MPI_Allreduce(MPI_IN_PLACE, &slots, 1, MPI_LONG_LONG, MPI_MAX, comm);
  const GlobalRows by_id(comm, (PetscInt)slots, as_rows(ids));
  std::vector<int64_t> number = by_id.gather(std::vector<int64_t>(ids.size(), 1), 1);
  long long used = 0, before = 0;
  for (int64_t marked : number) used += marked;
  MPI_Exscan(&used, &before, 1, MPI_LONG_LONG, MPI_SUM, comm);
  int rank;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) before = 0;  // MPI_Exscan leaves rank 0's undefined
  for (int64_t& n : number) n = n ? before++ : -1;
  MPI_Allreduce(MPI_IN_PLACE, &used, 1, MPI_LONG_LONG, MPI_SUM, comm);
  return {by_id.scatter(number), (PetscInt)used};
}

}  // namespace

// Where this rank's vertices and elements go: points numbered by vertex_id (the ids in use, in
// order), elements by kind and their index in the input mesh (the indices in use, in order, after
// a removal).
struct XdmfSeries::Layout {
  PetscInt points = 0;
  std::vector<int64_t> point_of;          // per local vertex (ghosts too): its point
  std::unique_ptr<GlobalRows> vertices;   // owned vertices -> points
  std::unique_ptr<GlobalRows> kinds[kKinds];  // local elements of a kind -> their rows
  PetscInt count[kKinds] = {0, 0, 0}, base[kKinds] = {0, 0, 0};  // elements per kind, first element's index
  std::vector<double> rest;                // this rank's block of points
  std::vector<int64_t> vertex_id;

  Layout(MPI_Comm comm, const DistributedMesh& m) {
    // Points: the ids in use, numbered in order.
    std::tie(point_of, points) = number_in_use(comm, m.vertex_ids);
    std::vector<PetscInt> owned_rows(m.num_vertices, -1);
    for (PetscInt v = 0; v < m.num_vertices; ++v)
      if (m.owned[v]) owned_rows[v] = (PetscInt)point_of[v];
    vertices = std::make_unique<GlobalRows>(comm, points, owned_rows);
    rest = vertices->gather(m.rest, 3);
    vertex_id = vertices->gather(m.vertex_ids, 1);

    const std::vector<int64_t>* ids[kKinds] = {&m.cell_ids, &m.segment_ids, &m.triangle_ids};
    const PetscInt totals[kKinds] = {m.global_cells, m.global_segments, m.global_triangles};
    for (int k = 0; k < kKinds; ++k) {
      // After a removal (remove_tets, mesh/separation.hpp) the ids in use have gaps: numbered in order too.
      long long slots = 0;
      for (int64_t id : *ids[k]) slots = std::max<long long>(slots, id + 1);
      MPI_Allreduce(MPI_IN_PLACE, &slots, 1, MPI_LONG_LONG, MPI_MAX, comm);
      const std::vector<PetscInt> rows =
          slots > totals[k] ? as_rows(number_in_use(comm, *ids[k]).first) : as_rows(*ids[k]);
      kinds[k] = std::make_unique<GlobalRows>(comm, totals[k], rows);
      count[k] = totals[k];
      if (k > 0) base[k] = base[k - 1] + count[k - 1];
    }
  }
  int kinds_present() const { return (count[0] > 0) + (count[1] > 0) + (count[2] > 0); }
  // `width` values per local element (element_J's order: tets, segments, triangles) gathered into
  // each kind's rows (in `gathered`), and the blocks of the list of all elements they fill. With
  // `order`, value i of a row is value order[i] of the element's.
  template <typename T>
  std::vector<ParallelFile::Block> element_blocks(const DistributedMesh& m, const std::vector<T>& values,
                                                  std::vector<T> (&gathered)[kKinds], int width = 1,
                                                  const int* order = nullptr) const {
    std::vector<ParallelFile::Block> blocks;
    const PetscInt local[kKinds] = {m.num_cells, m.num_segments, m.num_triangles};
    PetscInt at = 0;
    for (int k = 0; k < kKinds; ++k) {
      std::vector<T> mine(values.begin() + width * at, values.begin() + width * (at + local[k]));
      if (order)
        for (PetscInt e = 0; e < local[k]; ++e)
          for (int i = 0; i < width; ++i) mine[width * e + i] = values[width * (at + e) + order[i]];
      gathered[k] = kinds[k]->gather(mine, width);
      at += local[k];
      blocks.push_back(
          {(hsize_t)(base[k] + kinds[k]->first()), (hsize_t)kinds[k]->count(), (hsize_t)width, gathered[k].data()});
    }
    return blocks;
  }
  PetscInt elements() const { return count[0] + count[1] + count[2]; }
};

XdmfSeries::XdmfSeries(MPI_Comm comm, std::string directory, std::string name)
    : comm_(comm), dir_(std::move(directory)), name_(std::move(name)) {}

XdmfSeries::~XdmfSeries() = default;

void XdmfSeries::begin_run(const DistributedMesh& mesh) {
#ifndef H5_HAVE_PARALLEL
  throw std::runtime_error("output.format xdmf needs an HDF5 built for MPI (parallel); this hyperqn's is serial");
#endif
  set_mesh(mesh);
}

void XdmfSeries::set_mesh(const DistributedMesh& mesh) {
  layout_ = std::make_unique<Layout>(comm_, mesh);
  mesh_ = &mesh;
  // A topology change (mesh/separation.hpp, snaps, tears) moves elements to copies of vertices,
  // new points; a removal (remove_tets, mesh/separation.hpp) drops elements, and the points no element uses.
  // The same number of points and of elements is the same mesh (a release).
  block_current_ = block_current_ && current_block() == blocks_.back();
}

XdmfSeries::MeshBlock XdmfSeries::current_block() const {
  return {layout_->points, {layout_->count[0], layout_->count[1], layout_->count[2]}};
}

bool XdmfSeries::own_cells(const MeshBlock& b) const {
  const MeshBlock& first = blocks_.front();
  return b.cells[0] != first.cells[0] || b.cells[1] != first.cells[1] || b.cells[2] != first.cells[2];
}

// The topology of the frames of mesh block `block`: each kind's elements with their points, in
// each rank's block of rows.
void XdmfSeries::write_mesh(size_t block) const {
  const Layout& L = *layout_;
  const bool mixed = L.kinds_present() > 1;
  const std::vector<PetscInt>* local[kKinds] = {&mesh_->cells, &mesh_->segments, &mesh_->triangles};
  std::vector<int64_t> blocks[kKinds];
  std::vector<ParallelFile::Block> topology;
  PetscInt mixed_length = 0;
  for (int k = 0; k < kKinds; ++k) {
    const int n = kVertices[k], width = n + (mixed ? kMixedPrefix[k] : 0);
    std::vector<int64_t> rows;
    for (size_t e = 0; e < local[k]->size() / n; ++e) {
      if (mixed) rows.push_back(kMixedCode[k]);
      if (mixed && k == 1) rows.push_back(2);  // a polyline's vertex count
      for (int i = 0; i < n; ++i) rows.push_back(L.point_of[(*local[k])[n * e + i]]);
    }
    blocks[k] = L.kinds[k]->gather(rows, width);
    if (mixed) {  // one list: each kind's elements after the earlier kinds'
      topology.push_back({(hsize_t)(mixed_length + L.kinds[k]->first() * width), (hsize_t)L.kinds[k]->count(),
                          (hsize_t)width, blocks[k].data()});
      mixed_length += L.count[k] * width;
    } else if (L.count[k] > 0) {
      topology.push_back({(hsize_t)L.kinds[k]->first(), (hsize_t)L.kinds[k]->count(), 0, blocks[k].data()});
    }
  }
  const std::string group = mesh_group(block);
  ParallelFile file(comm_, h5_path(), block == 0);
  file.group(group);
  if (mixed) {
    file.dataset(group + "/topology", true, (hsize_t)mixed_length, 0, topology);
  } else {
    int k = 0;
    while (L.count[k] == 0) ++k;
    file.dataset(group + "/topology", true, (hsize_t)L.count[k], (hsize_t)kVertices[k], topology);
  }
  const ParallelFile::Block points{(hsize_t)L.vertices->first(), (hsize_t)L.vertices->count(), 0, nullptr};
  ParallelFile::Block rest = points, ids = points;
  rest.data = L.rest.data();
  ids.width = 1;
  ids.data = L.vertex_id.data();
  file.dataset(group + "/rest", false, (hsize_t)L.points, 3, {rest});
  file.dataset(group + "/vertex_id", true, (hsize_t)L.points, 0, {ids});
  // Each element's body (its index in the deck's bodies list) is the first block's, but for a
  // block of other elements (after a removal); /frames is the first block's.
  if (mesh_->num_bodies > 0 && (block == 0 || own_cells(current_block()))) {
    const std::vector<int32_t> tags = element_bodies(*mesh_);
    std::vector<int64_t> body_blocks[kKinds];
    file.dataset(group + "/body", true, (hsize_t)L.elements(), 0,
                 L.element_blocks(*mesh_, std::vector<int64_t>(tags.begin(), tags.end()), body_blocks));
  }
  if (block == 0) file.group("/frames");
  file.close();
}

void XdmfSeries::write_frame(const FrameData& f) {
  const Layout& L = *layout_;
  std::string error;
  try {
    if (!block_current_) {  // the first frame, or the first after a topology change
      write_mesh(blocks_.size());
      blocks_.push_back(current_block());
      block_current_ = true;
    }
    // Point fields, in this rank's block of points.
    const PetscInt nv = mesh_->num_vertices;
    std::vector<double> disp(3 * nv);
    for (PetscInt i = 0; i < 3 * nv; ++i) disp[i] = (*f.positions)[i] - mesh_->rest[i];
    std::vector<std::pair<std::string, std::vector<double>>> point_fields = {
        {"positions", L.vertices->gather(*f.positions, 3)},
        {"displacement", L.vertices->gather(disp, 3)},
        {"velocity", L.vertices->gather(*f.velocities, 3)}};
    for (const auto& [name, values] : f.point_fields) point_fields.emplace_back(name, L.vertices->gather(*values, 3));
    // Element fields: each kind's block at its place in the list of all elements.
    std::vector<double> J_blocks[kKinds];
    const std::vector<ParallelFile::Block> J_writes = L.element_blocks(*mesh_, element_J(*mesh_, f), J_blocks);
    const bool cloth = L.count[2] > 0 && L.count[2] == L.elements();
    std::vector<double> stretch;
    if (cloth) stretch = L.kinds[2]->gather(triangle_stretch(*mesh_, *f.positions), 1);
    // The deck's element fields: a dataset of E rows of `components` values each (E values for one).
    // A field of single precision is rounded to float first: half the bytes to move and to write.
    struct Gathered {
      std::vector<double> kind[kKinds];
      std::vector<float> single[kKinds];
    };
    std::vector<Gathered> field_blocks(f.element_fields.size());
    std::vector<std::vector<ParallelFile::Block>> field_writes;
    for (size_t i = 0; i < f.element_fields.size(); ++i) {
      const FrameElementField& field = f.element_fields[i];
      const int* order = field.components == 6 ? kTensor6 : nullptr;
      field_writes.push_back(
          field.single ? L.element_blocks(*mesh_, std::vector<float>(field.values->begin(), field.values->end()),
                                          field_blocks[i].single, field.components, order)
                       : L.element_blocks(*mesh_, *field.values, field_blocks[i].kind, field.components, order));
    }

    const std::string group = frame_group(f.frame);
    ParallelFile file(comm_, h5_path(), false);
    file.group(group);
    for (const auto& [name, block] : point_fields)
      file.dataset(group + "/" + name, false, (hsize_t)L.points, 3,
                   {{(hsize_t)L.vertices->first(), (hsize_t)L.vertices->count(), 0, block.data()}});
    file.dataset(group + "/J", false, (hsize_t)L.elements(), 0, J_writes);
    if (cloth)
      file.dataset(group + "/stretch", false, (hsize_t)L.count[2], 0,
                   {{(hsize_t)L.kinds[2]->first(), (hsize_t)L.kinds[2]->count(), 1, stretch.data()}});
    for (size_t i = 0; i < f.element_fields.size(); ++i) {
      const int c = f.element_fields[i].components;
      file.dataset(group + "/" + f.element_fields[i].name, false, (hsize_t)L.elements(), c > 1 ? (hsize_t)c : 0,
                   field_writes[i], f.element_fields[i].single);
    }
    file.close();
  } catch (const std::exception& e) {
    error = e.what();
  }
  throw_if_any_failed(comm_, error);
  // Listed once written: a frame written again (the last good frame of a run that stops) once.
  if (!written_.empty() && written_.back().frame == f.frame) written_.pop_back();
  std::vector<std::string> fields;
  for (const auto& field : f.point_fields) fields.push_back(field.first);
  std::vector<ListedField> element_fields;
  for (const FrameElementField& field : f.element_fields) element_fields.push_back({field.name, field.components, field.single});
  written_.push_back({f.time, f.frame, fields, element_fields, blocks_.size() - 1});
  int rank;
  MPI_Comm_rank(comm_, &rank);
  try {
    if (rank == 0) write_index();
  } catch (const std::exception& e) {
    error = e.what();
    written_.pop_back();
  }
  throw_if_any_failed(comm_, error);
}

// XDMF 3: one uniform grid per frame in a temporal collection; all data in NAME.h5.
bool XdmfSeries::holds_a_series_alone(const std::string& path) {
  silence_hdf5();
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) return false;
  hsize_t count = 0;
  bool only_ours = H5Gget_num_objs(file, &count) >= 0 && count > 0;
  for (hsize_t i = 0; only_ours && i < count; ++i) {
    char name[16] = {};
    const ssize_t n = H5Gget_objname_by_idx(file, i, name, sizeof name);
    only_ours = n > 0 && n < (ssize_t)sizeof name && (std::strcmp(name, "mesh") == 0 || std::strcmp(name, "frames") == 0);
  }
  H5Fclose(file);
  return only_ours;
}

void XdmfSeries::write_index() const {
  const std::string h5 = name_ + ".h5:";
  const auto item = [&](const std::string& dims, bool integer, const std::string& path, bool single = false) {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"" + (integer ? "Int" : "Float") + "\" Precision=\"" +
           (single ? "4" : "8") + "\" Format=\"HDF\">" + h5 + path + "</DataItem>";
  };
  const auto topology = [&](const std::string& mesh, const PetscInt* count, const std::string& E) {  // a block's
    if ((count[0] > 0) + (count[1] > 0) + (count[2] > 0) > 1) {
      PetscInt length = 0;
      for (int k = 0; k < kKinds; ++k) length += count[k] * (kVertices[k] + kMixedPrefix[k]);
      return "<Topology TopologyType=\"Mixed\" NumberOfElements=\"" + E + "\">" +
             item(std::to_string(length), true, mesh + "/topology") + "</Topology>";
    }
    int k = 0;
    while (k < kKinds - 1 && count[k] == 0) ++k;
    return std::string("<Topology TopologyType=\"") + kTopology[k] + "\" NumberOfElements=\"" + E + "\"" +
           (k == 1 ? " NodesPerElement=\"2\"" : "") + ">" +
           item(E + " " + std::to_string(kVertices[k]), true, mesh + "/topology") + "</Topology>";
  };
  std::ostringstream out;
  out.precision(17);
  out << "<?xml version=\"1.0\"?>\n<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n<Domain>\n"
      << "<Grid Name=\"" << name_ << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const auto& [t, frame, fields, element_fields, block] : written_) {
    const std::string group = frame_group(frame), mesh = mesh_group(block);
    const MeshBlock& B = blocks_.at(block);
    const PetscInt* count = B.cells;
    const std::string V = std::to_string(B.points), E = std::to_string(count[0] + count[1] + count[2]);
    out << "<Grid Name=\"frame_" << group.substr(group.rfind('/') + 1) << "\" GridType=\"Uniform\">\n<Time Value=\"" << t
        << "\"/>\n"
        << topology(mesh, count, E) << "\n<Geometry GeometryType=\"XYZ\">" << item(V + " 3", false, group + "/positions") << "</Geometry>\n";
    const auto attribute = [&](const char* name, const char* type, const char* center, const std::string& data) {
      out << "<Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\"" << center << "\">" << data
          << "</Attribute>\n";
    };
    for (const char* name : {"displacement", "velocity"}) attribute(name, "Vector", "Node", item(V + " 3", false, group + "/" + name));
    attribute("vertex_id", "Scalar", "Node", item(V, true, mesh + "/vertex_id"));
    for (const std::string& name : fields) attribute(name.c_str(), "Vector", "Node", item(V + " 3", false, group + "/" + name));
    attribute("J", "Scalar", "Cell", item(E, false, group + "/J"));
    if (mesh_->num_bodies > 0) attribute("body", "Scalar", "Cell", item(E, true, (own_cells(B) ? mesh : "/mesh") + "/body"));
    if (count[2] > 0 && count[0] + count[1] == 0) attribute("stretch", "Scalar", "Cell", item(E, false, group + "/stretch"));
    for (const auto& [name, c, single] : element_fields)  // a symmetric tensor: Tensor6 (a run before it: Tensor, 9 values)
      attribute(name.c_str(), c == 1 ? "Scalar" : c == 3 ? "Vector" : c == 6 ? "Tensor6" : "Tensor", "Cell",
                item(c == 1 ? E : E + " " + std::to_string(c), false, group + "/" + name, single));
    out << "</Grid>\n";
  }
  out << "</Grid>\n</Domain>\n</Xdmf>\n";
  write_file_atomically(dir_ + "/" + name_ + ".xdmf", out.str());
}

std::string XdmfSeries::restart_state() const {
  std::string s = "xdmf " + name_ + "\n";
  char line[64];
  for (const auto& [t, frame, fields, element_fields, block] : written_) {
    std::snprintf(line, sizeof line, "%.17g %d", t, frame);  // read back exactly
    s += line;
    for (const std::string& name : fields) s += " " + name;
    for (const auto& [name, c, single] : element_fields)
      s += " " + name + kElementFieldMark + std::to_string(c) + (single ? kSingleMark : "");
    if (block > 0) s += std::string(" ") + kBlockMark + std::to_string(block);
    s += "\n";
  }
  // The blocks, once the topology changed (a state without them: one block, the mesh's).
  // A block's counts of elements follow its points when they are not the mesh's (after a removal).
  if (blocks_.size() > 1 || !block_current_)
    for (size_t k = 0; k < blocks_.size(); ++k) {
      const MeshBlock& b = blocks_[k];
      s += kBlockLine + std::to_string(k) + " " + std::to_string(b.points);
      if (b.cells[0] != layout_->count[0] || b.cells[1] != layout_->count[1] || b.cells[2] != layout_->count[2])
        for (PetscInt c : b.cells) s += " " + std::to_string(c);
      s += "\n";
    }
  return s;
}

std::string XdmfSeries::series_name(const std::string& state) {
  const std::string head = "xdmf ";
  if (state.compare(0, head.size(), head) != 0) return "";
  return state.substr(head.size(), state.find('\n') - head.size());
}

void XdmfSeries::resume(const std::string& state, int frame) {
  written_.clear();
  std::istringstream lines(state);
  std::string line;
  std::getline(lines, line);  // xdmf NAME
  std::vector<MeshBlock> blocks;
  const MeshBlock mesh = current_block();
  for (double t; std::getline(lines, line);) {
    std::istringstream words(line);
    if (line.compare(0, std::strlen(kBlockLine), kBlockLine) == 0) {  // mesh K POINTS [TETS SEGMENTS TRIANGLES]
      std::string word;
      size_t k;
      long long points, cells[3];
      if (!(words >> word >> k >> points) || k != blocks.size()) continue;
      MeshBlock b = mesh;  // without counts, the mesh's elements
      b.points = (PetscInt)points;
      if (words >> cells[0] >> cells[1] >> cells[2])
        for (int i = 0; i < 3; ++i) b.cells[i] = (PetscInt)cells[i];
      blocks.push_back(b);
      continue;
    }
    int k;
    if (!(words >> t >> k) || k > frame) continue;
    std::vector<std::string> fields;
    std::vector<ListedField> element_fields;
    size_t block = 0;
    for (std::string name; words >> name;)
      if (name.compare(0, std::strlen(kBlockMark), kBlockMark) == 0) {
        block = (size_t)std::atoll(name.c_str() + std::strlen(kBlockMark));
      } else if (const size_t mark = name.find(kElementFieldMark); mark != std::string::npos) {
        const bool single = name.size() > mark + 1 && name.find(kSingleMark, mark) != std::string::npos;
        element_fields.push_back({name.substr(0, mark), std::atoi(name.c_str() + mark + 1), single});
      } else if (name == "1") {
        fields.push_back("contact_force");  // the state of a run written before the fields had names
      } else if (name != "0") {
        fields.push_back(name);
      }
    written_.push_back({t, k, fields, element_fields, block});
  }
  // The kept frames' blocks; without blocks listed, the one block is the mesh's (no change since).
  size_t kept = 1;
  for (const Listed& l : written_) kept = std::max(kept, l.block + 1);
  if (blocks.empty()) blocks.push_back(mesh);
  if (blocks.size() < kept) throw std::runtime_error("cannot continue " + h5_path() + ": the checkpoint lists fewer mesh blocks than its frames use");
  blocks.resize(std::min(blocks.size(), kept));
  blocks_ = blocks;
  block_current_ = mesh == blocks_.back();
  int rank;
  MPI_Comm_rank(comm_, &rank);
  std::string error;
  if (rank == 0) {  // the later frames' groups go (HDF5 does not give their space back)
    try {
      silence_hdf5();
      Handle file{H5Fopen(h5_path().c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose};
      if (file.id < 0) throw std::runtime_error("cannot continue " + h5_path() + ": " + hdf5_error_reason());
      std::vector<std::string> names, later;
      Handle frames{H5Gopen2(file.id, "/frames", H5P_DEFAULT), H5Gclose};
      if (frames.id < 0 || H5Literate(frames.id, H5_INDEX_NAME, H5_ITER_NATIVE, nullptr, collect_name, &names) < 0)
        throw std::runtime_error("cannot continue " + h5_path() + ": its /frames: " + hdf5_error_reason());
      for (const std::string& g : names)
        if (std::atoi(g.c_str()) > frame) later.push_back(g);
      for (const std::string& g : later)
        if (H5Ldelete(frames.id, g.c_str(), H5P_DEFAULT) < 0)
          throw std::runtime_error("cannot continue " + h5_path() + ": removing frame " + g + ": " + hdf5_error_reason());
      // and the later mesh blocks (/mesh/K, K >= the kept blocks)
      for (size_t k = blocks_.size();; ++k) {
        const std::string group = mesh_group(k);
        if (H5Lexists(file.id, group.c_str(), H5P_DEFAULT) <= 0) break;
        if (H5Ldelete(file.id, group.c_str(), H5P_DEFAULT) < 0)
          throw std::runtime_error("cannot continue " + h5_path() + ": removing " + group + ": " + hdf5_error_reason());
      }
      write_index();
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  throw_if_any_failed(comm_, error);
}

}  // namespace hyperqn

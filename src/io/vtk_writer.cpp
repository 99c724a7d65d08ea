#include "io/vtk_writer.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/base64.hpp"
#include "io/frame_fields.hpp"

namespace hyperqn {

namespace {

// One data array: its XML attributes and its raw bytes, read where they are (no copy: the frame's
// arrays are most of its output time, docs/records/2026-12-02-field-output-cost.md).
struct Array {
  std::string type, name;
  int components;
  const char* bytes;
  size_t size;
  std::string* encoded = nullptr;  // an array of the mesh: its inline element, encoded at its first frame
};

template <typename T>
Array make_array(const std::string& type, const std::string& name, int components, const std::vector<T>& v,
                 std::string* encoded = nullptr) {
  return {type, name, components, reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T), encoded};
}

// Where a piece's text goes: a buffer handed to the file whenever it holds kFlush bytes, so a
// piece of tens of MB is never whole in memory and the bytes the kernel copies are still in cache;
// or, without a file, the buffer alone (an array's element encoded whole for MeshArrays).
struct Sink {
  static constexpr size_t kFlush = size_t(1) << 20;
  static constexpr size_t kChunk = 3 * (size_t(1) << 18);  // bytes encoded at a time: a multiple of 3,
                                                           // so the characters are those of the whole
  std::string& buf;
  AtomicFileWriter* file = nullptr;

  void flush() {
    if (!file) return;
    file->write(buf.data(), buf.size());
    buf.clear();
  }
  void full() {
    if (file && buf.size() >= kFlush) flush();
  }
  Sink& operator+=(const std::string& text) {
    buf += text;
    full();
    return *this;
  }
  void bytes(const char* p, size_t n) {  // large ones straight to the file
    if (file && n >= kFlush) {
      flush();
      file->write(p, n);
    } else {
      buf.append(p, n);
      full();
    }
  }
  void base64(const char* p, size_t n) {
    do {
      const size_t m = file ? std::min(n, kChunk) : n;
      append_base64(buf, p, m);
      p += m;
      n -= m;
      full();
    } while (n > 0);
  }
};

// A DataArray, appended to xml. Inline (the default): base64 of the UInt64 byte count, then base64
// of the bytes, encoded separately as VTK does. Raw (output.vtu_encoding raw, `appended` not null):
// the element says where in the <AppendedData> block its bytes will be (the count and the bytes as
// they are, appended by the caller in the same order: a quarter fewer bytes than base64 and no
// encoding); `appended` collects the arrays. (Raw is not the default: readers that strip whitespace
// around the appended block corrupt arrays that start or end with bytes 9-13 or 32, such as the
// tetra cell type 10.)
void append_data_array(Sink& xml, const Array& a, std::vector<const Array*>* appended = nullptr,
                       uint64_t* offset = nullptr) {
  if (a.encoded && !appended) {  // the same text at every frame of the mesh
    if (a.encoded->empty()) {
      Sink whole{*a.encoded};
      append_data_array(whole, Array{a.type, a.name, a.components, a.bytes, a.size});
      a.encoded->shrink_to_fit();
    }
    xml.bytes(a.encoded->data(), a.encoded->size());
    return;
  }
  xml += "<DataArray type=\"" + a.type + "\"";
  if (!a.name.empty()) xml += " Name=\"" + a.name + "\"";
  const uint64_t n = a.size;
  xml += " NumberOfComponents=\"" + std::to_string(a.components) + "\"";
  if (appended) {
    xml += " format=\"appended\" offset=\"" + std::to_string(*offset) + "\"/>\n";
    appended->push_back(&a);
    *offset += sizeof n + n;
    return;
  }
  xml += " format=\"binary\">\n";
  xml.base64(reinterpret_cast<const char*>(&n), sizeof n);
  xml.base64(a.bytes, n);
  xml += "\n</DataArray>\n";
}

std::string frame_stem(const std::string& name, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "_%05d", frame);
  return name + buf;
}

}  // namespace

VtkSeries::VtkSeries(MPI_Comm comm, std::string directory, std::string name, bool raw)
    : comm_(comm), dir_(std::move(directory)), name_(std::move(name)), raw_(raw) {}

void VtkSeries::write_piece(const std::string& path, const FrameData& f) const {
  const PetscInt nv = mesh_->num_vertices, nt = mesh_->num_cells, ns = mesh_->num_segments, nf = mesh_->num_triangles;
  const PetscInt nc = nt + ns + nf;
  int rank;
  MPI_Comm_rank(comm_, &rank);
  std::vector<double>& disp = disp_;
  disp.resize(3 * nv);
  for (PetscInt i = 0; i < 3 * nv; ++i) disp[i] = (*f.positions)[i] - mesh_->rest[i];
  if (!mesh_arrays_) {  // the mesh's own arrays: built (and, inline, encoded) at its first frame
    mesh_arrays_ = std::make_unique<MeshArrays>();
    MeshArrays& m = *mesh_arrays_;
    // Tets, then strand segments as lines, then cloth triangles.
    m.conn.assign(mesh_->cells.begin(), mesh_->cells.end());
    m.conn.insert(m.conn.end(), mesh_->segments.begin(), mesh_->segments.end());
    m.conn.insert(m.conn.end(), mesh_->triangles.begin(), mesh_->triangles.end());
    m.offsets.resize(nc);
    for (PetscInt c = 0; c < nc; ++c)
      m.offsets[c] = c < nt ? 4 * (c + 1) : c < nt + ns ? 4 * nt + 2 * (c - nt + 1) : 4 * nt + 2 * ns + 3 * (c - nt - ns + 1);
    m.types.assign(nc, 10);                                         // VTK_TETRA
    std::fill(m.types.begin() + nt, m.types.begin() + nt + ns, 3);  // VTK_LINE
    std::fill(m.types.begin() + nt + ns, m.types.end(), 5);         // VTK_TRIANGLE
    m.ranks.assign(nc, rank);
    if (mesh_->num_bodies > 0) m.body = element_bodies(*mesh_);
  }
  MeshArrays& m = *mesh_arrays_;
  // Cell field J: det F of a tet, l / L of a segment, the area ratio of a triangle.
  const std::vector<double> J = element_J(*mesh_, f);
  const std::vector<double> stretch = cloth() ? triangle_stretch(*mesh_, *f.positions) : std::vector<double>();

  std::vector<Array> point_data = {make_array("Float64", "displacement", 3, disp),
                                   make_array("Float64", "velocity", 3, *f.velocities),
                                   make_array("Int64", "vertex_id", 1, mesh_->vertex_ids, &m.encoded[0])};
  for (const auto& [name, values] : f.point_fields) point_data.push_back(make_array("Float64", name, 3, *values));
  std::vector<Array> cell_data = {make_array("Int32", "rank", 1, m.ranks, &m.encoded[1]), make_array("Float64", "J", 1, J)};
  if (cloth())  // the largest principal stretch of each triangle
    cell_data.push_back(make_array("Float64", "stretch", 1, stretch));
  if (mesh_->num_bodies > 0)  // each element's body: its index in the deck's bodies list
    cell_data.push_back(make_array("Int32", "body", 1, m.body, &m.encoded[2]));
  single_.resize(f.element_fields.size());
  for (size_t i = 0; i < f.element_fields.size(); ++i) {  // 6 components: a symmetric tensor to ParaView
    const FrameElementField& field = f.element_fields[i];
    if (field.single) {
      single_[i].assign(field.values->begin(), field.values->end());  // rounded to nearest
      cell_data.push_back(make_array("Float32", field.name, field.components, single_[i]));
    } else {
      cell_data.push_back(make_array("Float64", field.name, field.components, *field.values));
    }
  }
  const Array points = make_array("Float64", "", 3, *f.positions);
  const std::vector<Array> cells = {make_array("Int64", "connectivity", 1, m.conn, &m.encoded[3]),
                                    make_array("Int64", "offsets", 1, m.offsets, &m.encoded[4]),
                                    make_array("UInt8", "types", 1, m.types, &m.encoded[5])};

  // The text of the piece, through a buffer kept from frame to frame (a fresh one would be new
  // pages from the kernel, faulted in and zeroed, at every frame).
  xml_.clear();
  AtomicFileWriter file(path);
  Sink xml{xml_, &file};
  std::vector<const Array*> raw_arrays;  // raw: the arrays whose bytes follow the XML, in order
  std::vector<const Array*>* appended = raw_ ? &raw_arrays : nullptr;
  uint64_t offset = 0;
  xml += "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n";
  xml += "<Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfCells=\"" + std::to_string(nc) + "\">\n";
  xml += "<PointData>\n";
  for (const Array& a : point_data) append_data_array(xml, a, appended, &offset);
  xml += "</PointData>\n<CellData>\n";
  for (const Array& a : cell_data) append_data_array(xml, a, appended, &offset);
  xml += "</CellData>\n<Points>\n";
  append_data_array(xml, points, appended, &offset);
  xml += "</Points>\n<Cells>\n";
  for (const Array& a : cells) append_data_array(xml, a, appended, &offset);
  xml += "</Cells>\n</Piece>\n</UnstructuredGrid>\n";
  if (raw_) {  // '_' starts the data, as the format says; the newline before the closing tag ends it
    xml += "<AppendedData encoding=\"raw\">\n_";
    for (const Array* a : raw_arrays) {
      const uint64_t n = a->size;
      xml.bytes(reinterpret_cast<const char*>(&n), sizeof n);
      xml.bytes(a->bytes, n);
    }
    xml += "\n</AppendedData>\n";
  }
  xml += "</VTKFile>\n";
  xml.flush();
  file.commit();
  if (!raw_) {  // inline, the next frames take the mesh's arrays from their encoded elements alone
    m.conn = {};
    m.offsets = {};
    m.types = {};
    m.ranks = {};
    m.body = {};
  }
}

void VtkSeries::write_pvtu(const std::string& path, const std::string& stem, const std::vector<int>& pieces,
                           const FrameData& f) const {
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<PUnstructuredGrid GhostLevel=\"0\">\n"
         "<PPointData>\n"
         "<PDataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\"/>\n"
         "<PDataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\"/>\n"
         "<PDataArray type=\"Int64\" Name=\"vertex_id\" NumberOfComponents=\"1\"/>\n";
  for (const auto& field : f.point_fields)
    out << "<PDataArray type=\"Float64\" Name=\"" << field.first << "\" NumberOfComponents=\"3\"/>\n";
  out << "</PPointData>\n<PCellData>\n"
         "<PDataArray type=\"Int32\" Name=\"rank\" NumberOfComponents=\"1\"/>\n"
         "<PDataArray type=\"Float64\" Name=\"J\" NumberOfComponents=\"1\"/>\n"
      << (cloth() ? "<PDataArray type=\"Float64\" Name=\"stretch\" NumberOfComponents=\"1\"/>\n" : "")
      << (mesh_->num_bodies > 0 ? "<PDataArray type=\"Int32\" Name=\"body\" NumberOfComponents=\"1\"/>\n" : "");
  for (const FrameElementField& field : f.element_fields)
    out << "<PDataArray type=\"" << (field.single ? "Float32" : "Float64") << "\" Name=\"" << field.name
        << "\" NumberOfComponents=\"" << field.components << "\"/>\n";
  out << "</PCellData>\n<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n";
  for (int r : pieces) out << "<Piece Source=\"" << stem << "_" << r << ".vtu\"/>\n";
  out << "</PUnstructuredGrid>\n</VTKFile>\n";
  write_file_atomically(path, out.str());
}

void VtkSeries::write_pvd() const {
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n<Collection>\n";
  out.precision(17);
  for (const auto& [t, file] : written_) out << "<DataSet timestep=\"" << t << "\" part=\"0\" file=\"" << file << "\"/>\n";
  out << "</Collection>\n</VTKFile>\n";
  write_file_atomically(dir_ + "/" + name_ + ".pvd", out.str());
}

void VtkSeries::write_frame(const FrameData& f) {
  int rank, size;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &size);
  const std::string stem = frame_stem(name_, f.frame);
  const std::string file = stem + (size == 1 ? ".vtu" : ".pvtu");
  // Pieces first; then, once every rank's piece is in place, the .pvtu and the .pvd that list
  // them: so the .pvd never names a frame with a missing or partial file, even after a kill.
  std::string error;
  std::vector<int> pieces;
  try {
    if (size == 1) {
      write_piece(dir_ + "/" + file, f);
    } else {
      // A rank without elements (a mesh smaller than the rank count) writes no piece: readers
      // such as meshio cannot read an empty one.
      const int mine = mesh_->num_cells + mesh_->num_segments + mesh_->num_triangles > 0;
      std::vector<int> has(size);
      MPI_Allgather(&mine, 1, MPI_INT, has.data(), 1, MPI_INT, comm_);
      for (int r = 0; r < size; ++r)
        if (has[r]) pieces.push_back(r);
      if (mine) write_piece(dir_ + "/" + stem + "_" + std::to_string(rank) + ".vtu", f);
    }
  } catch (const std::exception& e) {
    error = e.what();
  }
  // Every rank must learn of a failure on any rank, or the others would wait forever later.
  throw_if_any_failed(comm_, error);
  written_.emplace_back(f.time, file);
  try {
    if (rank == 0 && size > 1) write_pvtu(dir_ + "/" + file, stem, pieces, f);
    if (rank == 0) write_pvd();
  } catch (const std::exception& e) {
    error = e.what();
    written_.pop_back();  // not listed: a later .pvd must not name it
  }
  throw_if_any_failed(comm_, error);
}

bool VtkSeries::lists_frame(int frame) const {
  const std::string stem = frame_stem(name_, frame);
  for (const auto& entry : written_)
    if (entry.second.compare(0, stem.size() + 1, stem + ".") == 0) return true;
  return false;
}

std::string VtkSeries::restart_state() const {
  std::string s;
  char time[40];
  for (const auto& [t, file] : written_) {
    std::snprintf(time, sizeof time, "%.17g", t);  // read back exactly
    s += std::string(time) + " " + file + "\n";
  }
  return s;
}

std::string VtkSeries::series_name(const std::string& state) {
  const size_t space = state.find(' '), end = state.find('\n');
  if (space == std::string::npos || end == std::string::npos || end < space) return "";
  const std::string file = state.substr(space + 1, end - space - 1);  // NAME_NNNNN.vtu or .pvtu
  const size_t underscore = file.rfind('_');
  return underscore == std::string::npos ? "" : file.substr(0, underscore);
}

void VtkSeries::resume(const std::string& state, int frame) {
  written_.clear();
  std::istringstream lines(state);
  for (std::string line; std::getline(lines, line);) {
    const size_t space = line.find(' ');
    if (space != std::string::npos) written_.emplace_back(std::strtod(line.c_str(), nullptr), line.substr(space + 1));
  }
  int rank;
  MPI_Comm_rank(comm_, &rank);
  if (rank != 0) return;
  // Files of frames after `frame`: <name>_<5+ digits> then '.' or '_' (.vtu, .pvtu, per-rank pieces).
  const std::string prefix = name_ + "_";
  std::vector<std::filesystem::path> later;
  for (const auto& e : std::filesystem::directory_iterator(dir_)) {
    const std::string file = e.path().filename().string();
    if (file.compare(0, prefix.size(), prefix) != 0) continue;
    size_t end = prefix.size();
    while (end < file.size() && std::isdigit((unsigned char)file[end])) ++end;
    if (end - prefix.size() < 5 || end == file.size() || (file[end] != '.' && file[end] != '_')) continue;
    if (std::atoi(file.substr(prefix.size(), end - prefix.size()).c_str()) > frame) later.push_back(e.path());
  }
  for (const auto& p : later) std::filesystem::remove(p);
  write_pvd();
}

}  // namespace hyperqn

#include "vtk_writer.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hyperqn {

namespace {

// One array of the appended-data block: its XML declaration and its raw bytes.
struct Array {
  std::string type, name;
  int components;
  std::string bytes;
};

template <typename T>
Array make_array(const std::string& type, const std::string& name, int components, const std::vector<T>& v) {
  return {type, name, components, std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T))};
}

std::string declaration(const Array& a, uint64_t offset) {
  std::ostringstream s;
  s << "<DataArray type=\"" << a.type << "\"";
  if (!a.name.empty()) s << " Name=\"" << a.name << "\"";
  s << " NumberOfComponents=\"" << a.components << "\" format=\"appended\" offset=\"" << offset << "\"/>\n";
  return s.str();
}

std::string frame_stem(const std::string& name, int frame) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "_%05d", frame);
  return name + buf;
}

void check_stream(const std::ofstream& out, const std::string& path) {
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

VtkWriter::VtkWriter(MPI_Comm comm, const DistributedMesh& mesh, std::string directory, std::string name)
    : comm_(comm), mesh_(mesh), dir_(std::move(directory)), name_(std::move(name)) {}

void VtkWriter::write_piece(const std::string& path, const VtkFrame& f) const {
  const PetscInt nv = mesh_.num_vertices, nc = mesh_.num_cells;
  int rank;
  MPI_Comm_rank(comm_, &rank);
  std::vector<double> disp(3 * nv);
  for (PetscInt i = 0; i < 3 * nv; ++i) disp[i] = (*f.positions)[i] - mesh_.rest[i];
  std::vector<int64_t> conn(mesh_.cells.begin(), mesh_.cells.end()), offsets(nc);
  for (PetscInt c = 0; c < nc; ++c) offsets[c] = 4 * (c + 1);
  std::vector<uint8_t> types(nc, 10);  // VTK_TETRA
  std::vector<int32_t> ranks(nc, rank);

  const std::vector<Array> point_data = {make_array("Float64", "displacement", 3, disp),
                                         make_array("Float64", "velocity", 3, *f.velocities),
                                         make_array("Int64", "vertex_id", 1, mesh_.vertex_ids)};
  const std::vector<Array> cell_data = {make_array("Int32", "rank", 1, ranks), make_array("Float64", "J", 1, *f.J)};
  const Array points = make_array("Float64", "", 3, *f.positions);
  const std::vector<Array> cells = {make_array("Int64", "connectivity", 1, conn),
                                    make_array("Int64", "offsets", 1, offsets),
                                    make_array("UInt8", "types", 1, types)};

  uint64_t offset = 0;
  std::string xml;
  auto declare = [&](const Array& a) {
    xml += declaration(a, offset);
    offset += sizeof(uint64_t) + a.bytes.size();
  };
  xml += "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n";
  xml += "<Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfCells=\"" + std::to_string(nc) + "\">\n";
  xml += "<PointData>\n";
  for (const Array& a : point_data) declare(a);
  xml += "</PointData>\n<CellData>\n";
  for (const Array& a : cell_data) declare(a);
  xml += "</CellData>\n<Points>\n";
  declare(points);
  xml += "</Points>\n<Cells>\n";
  for (const Array& a : cells) declare(a);
  xml += "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";

  std::ofstream out(path, std::ios::binary);
  out << xml;
  auto append = [&](const Array& a) {
    const uint64_t n = a.bytes.size();
    out.write(reinterpret_cast<const char*>(&n), sizeof n);
    out.write(a.bytes.data(), (std::streamsize)n);
  };
  for (const Array& a : point_data) append(a);
  for (const Array& a : cell_data) append(a);
  append(points);
  for (const Array& a : cells) append(a);
  out << "\n</AppendedData>\n</VTKFile>\n";
  out.close();
  check_stream(out, path);
}

void VtkWriter::write_pvtu(const std::string& path, const std::string& stem, int nranks) const {
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<PUnstructuredGrid GhostLevel=\"0\">\n"
         "<PPointData>\n"
         "<PDataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\"/>\n"
         "<PDataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\"/>\n"
         "<PDataArray type=\"Int64\" Name=\"vertex_id\" NumberOfComponents=\"1\"/>\n"
         "</PPointData>\n<PCellData>\n"
         "<PDataArray type=\"Int32\" Name=\"rank\" NumberOfComponents=\"1\"/>\n"
         "<PDataArray type=\"Float64\" Name=\"J\" NumberOfComponents=\"1\"/>\n"
         "</PCellData>\n<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n";
  for (int r = 0; r < nranks; ++r) out << "<Piece Source=\"" << stem << "_" << r << ".vtu\"/>\n";
  out << "</PUnstructuredGrid>\n</VTKFile>\n";
  out.close();
  check_stream(out, path);
}

void VtkWriter::write_pvd() const {
  const std::string path = dir_ + "/" + name_ + ".pvd";
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n<Collection>\n";
  out.precision(17);
  for (const auto& [t, file] : written_) out << "<DataSet timestep=\"" << t << "\" part=\"0\" file=\"" << file << "\"/>\n";
  out << "</Collection>\n</VTKFile>\n";
  out.close();
  check_stream(out, path);
}

void VtkWriter::write(const VtkFrame& f) {
  int rank, size;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &size);
  const std::string stem = frame_stem(name_, f.frame);
  const std::string file = stem + (size == 1 ? ".vtu" : ".pvtu");
  std::string error;
  try {
    if (size == 1) {
      write_piece(dir_ + "/" + file, f);
    } else {
      write_piece(dir_ + "/" + stem + "_" + std::to_string(rank) + ".vtu", f);
      if (rank == 0) write_pvtu(dir_ + "/" + file, stem, size);
    }
    written_.emplace_back(f.time, file);
    if (rank == 0) write_pvd();
  } catch (const std::exception& e) {
    error = e.what();
  }
  // Every rank must learn of a failure on any rank, or the others would wait forever later.
  int bad = !error.empty(), any_bad = 0;
  MPI_Allreduce(&bad, &any_bad, 1, MPI_INT, MPI_MAX, comm_);
  if (any_bad) throw std::runtime_error(error.empty() ? "VTK output failed on another rank" : error);
}

}  // namespace hyperqn

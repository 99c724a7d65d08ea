#include "app/partition_command.hpp"

#include <petscsys.h>

#include <filesystem>
#include <new>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/partition_file.hpp"
#include "mesh/input_error.hpp"
#include "model/scene.hpp"

namespace hyperqn {

namespace {

// What a mesh was made from, for the file's source text.
std::string describe(const MeshSpec& m) {
  std::string s;
  if (m.is_box)
    s += "box cells " + std::to_string(m.box_cells[0]) + " " + std::to_string(m.box_cells[1]) + " " +
         std::to_string(m.box_cells[2]);
  else if (m.is_sheet)
    s += "sheet cells " + std::to_string(m.sheet_cells[0]) + " " + std::to_string(m.sheet_cells[1]);
  else
    s += m.file;
  const size_t strands = m.strands.size();
  if (strands > 0) s += (s.empty() ? "" : " with ") + std::to_string(strands) + (strands == 1 ? " strand" : " strands");
  return s;
}

std::string mesh_source(const Deck& deck) {
  if (deck.bodies.empty()) return "deck " + deck.path + ", mesh " + describe(deck.mesh);
  std::string s = "deck " + deck.path + ", bodies";
  for (const BodySpec& body : deck.bodies)
    s += (&body == &deck.bodies[0] ? ": " : ", ") + body.name + " (" + describe(body.mesh) + ")";
  return s;
}

}  // namespace

void run_partition(MPI_Comm comm, const Deck& deck, int parts, const std::string& output) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  if (deck.mesh.is_partition_file)
    throw InputError(deck.path, deck.mesh.line, "mesh.file",
                     "is already a partition file: give hyperqn partition the deck of the mesh it was made from");
  const std::string file = output.empty() ? deck.partition_file : output;  // -o, or the deck's partition:
  if (file.empty())
    throw InputError("", 0, "-o", "missing: the partition file to write (or name it as partition: in a deck of bodies): "
                                  "hyperqn partition DECK.yaml -n N -o FILE.h5");
  std::string error, summary;
  if (rank == 0) {
    try {
      CleanReport repaired;
      const TetMesh mesh = read_serial_mesh(deck, &repaired);
      const int64_t elements = mesh.num_tets() + mesh.num_segments() + mesh.num_triangles();
      if (parts > elements)
        throw InputError("", 0, "-n", std::to_string(parts) + " parts for a mesh of " + std::to_string(elements) +
                                          " elements: give at most that many");
      write_partition_file(file, mesh, parts, mesh_source(deck), repaired, bodies_stamp(deck));
      std::error_code ec;
      const auto bytes = std::filesystem::file_size(file, ec);
      summary = "hyperqn partition: " + file + ": " + std::to_string(parts) + " parts, " +
                (deck.bodies.empty() ? "" : std::to_string(deck.bodies.size()) + " bodies, ") +
                std::to_string(mesh.num_vertices()) + " vertices, " + std::to_string(mesh.num_tets()) + " tets, " +
                std::to_string(mesh.num_segments()) + " segments, " + std::to_string(mesh.num_triangles()) +
                " triangles, " + std::to_string(ec ? 0 : (unsigned long long)bytes) + " bytes\n";
    } catch (const InputError& e) {
      error = e.what();
    } catch (const std::bad_alloc&) {
      error = "out of memory reading and cutting the mesh on rank 0";
    } catch (const std::exception& e) {  // "cannot write PATH: <reason>"
      error = e.what();
    }
  }
  try {
    throw_if_any_failed(comm, error);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  PetscPrintf(comm, "%s", summary.c_str());
}

}  // namespace hyperqn

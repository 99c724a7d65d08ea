// Gmsh .msh files, read through PETSc's reader (DMPlexCreateFromFile) on one process.
#pragma once
#include <string>

#include "mesh/mesh.hpp"

namespace hyperqn {

// Reads the tetrahedra of a Gmsh file (2.2 or 4.1 ASCII/binary). Element tags come from the
// physical groups ("Cell Sets"). Throws InputError naming the file on failure.
TetMesh read_gmsh(const std::string& path);

}  // namespace hyperqn

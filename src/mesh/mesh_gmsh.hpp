// Gmsh .msh files: MSH 4.1 (with or without $Entities) and 2.2, ASCII.
#pragma once
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace hyperqn {

// Reads the nodes and the 4-node tetrahedra (type 4) of a Gmsh file; points, lines and
// triangles (boundaries) are skipped, any other 3-D element is an error. A tet's tag is the
// first physical tag of its element (2.2) or of its volume (4.1 with $Entities), else its volume
// tag (4.1 without $Entities, as meshio writes). Vertex ids are the nodes' 0-based positions in
// the file. Throws InputError naming the file, line and section for anything malformed,
// binary files and MSH versions other than 2.x and 4.1 included. With triangles_as_cloth the
// 3-node triangles (type 2) are read as a cloth surface instead (tag: the first physical tag in
// 2.2, the surface entity's tag in 4.1) and the tets are skipped. With face_tags (ascending), the
// triangles of those physical groups are kept in tagged_faces (a tet mesh's boundary faces): in
// 2.2 a triangle's first tag, in 4.1 every physical tag of its surface in $Entities (without
// $Entities, the surface's own tag, as for tets).
TetMesh read_gmsh(const std::string& path, bool triangles_as_cloth = false, const std::vector<int32_t>& face_tags = {});

}  // namespace hyperqn

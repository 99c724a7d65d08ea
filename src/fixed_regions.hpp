// Fixed (Dirichlet) vertices: those inside the deck's axis-aligned boxes.
#pragma once
#include <vector>

#include "deck.hpp"
#include "mesh.hpp"

namespace hyperqn {

// One flag per vertex. A box that selects no vertex is an input error naming the deck line.
// Boxes are inclusive, widened by 1e-9 of the mesh's bounding-box diagonal against round-off.
std::vector<char> select_fixed_vertices(const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                        const std::string& deck_path);

}  // namespace hyperqn

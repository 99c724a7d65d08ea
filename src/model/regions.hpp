// Parts of the mesh selected by the deck's regions: fixed (Dirichlet) vertices and the elements
// of each material region, and how fixed regions move. Decided once, on the serial mesh (rank 0), before distribution.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/motion.hpp"
#include "mesh/mesh.hpp"
#include "model/material_spec.hpp"

namespace hyperqn {

struct BoxRegion {
  std::array<double, 3> min{0, 0, 0}, max{0, 0, 0};
  int line = 0;                      // deck line, for error messages
  Motion motion;                     // fixed regions only
  double release = -1;               // fixed regions: time at which its vertices become free (< 0: never)
};

// Elements with a material other than the deck's default one: those whose centroid lies in a
// box, or whose mesh element tag is listed. Later regions override earlier ones.
struct MaterialRegion {
  bool by_box = true;
  BoxRegion box;
  std::vector<int> tags;
  MaterialSpec material;
  int line = 0;
};


// Per vertex: 0 if free, k + 1 if fixed by boxes[k] (the last box containing it wins).
// A box that selects no vertex is an input error naming the deck line. Boxes are inclusive,
// widened by 1e-9 of the mesh's bounding-box diagonal against round-off.
std::vector<int32_t> select_fixed_vertices(const TetMesh& mesh, const std::vector<BoxRegion>& boxes,
                                           const std::string& deck_path);

// Per tet: 0 for the default material, k + 1 for regions[k] (by centroid in its box, or by
// element tag; later regions win). A region that selects no element is an input error.
std::vector<int32_t> select_material_regions(const TetMesh& mesh, const std::vector<MaterialRegion>& regions,
                                             const std::string& deck_path);

}  // namespace hyperqn

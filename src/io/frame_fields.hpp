// The element fields of an output frame, the same in every output format (io/vtk_writer.hpp,
// io/xdmf_writer.hpp).
#pragma once
#include <vector>

#include "io/output_writer.hpp"

namespace hyperqn {

// J of each local element, tets then strand segments then cloth triangles: det F of a tet, the
// stretch l / L of a segment, the area ratio of a triangle.
std::vector<double> element_J(const DistributedMesh& mesh, const FrameData& f);

// The body of each local element of a scene of bodies (its tag, DistributedMesh::cell_tags), in
// element_J's order: the `body` cell field.
std::vector<int32_t> element_bodies(const DistributedMesh& mesh);

// The largest principal stretch of each local cloth triangle.
std::vector<double> triangle_stretch(const DistributedMesh& mesh, const std::vector<double>& positions);

}  // namespace hyperqn

#include "io/frame_fields.hpp"

#include <cmath>

#include "materials/membrane.hpp"

namespace hyperqn {

std::vector<double> element_J(const DistributedMesh& mesh, const FrameData& f) {
  const PetscInt nt = mesh.num_cells, nf = mesh.num_triangles;
  auto length = [](const double* p, PetscInt a, PetscInt b) {
    double s = 0;
    for (int d = 0; d < 3; ++d) s += (p[3 * b + d] - p[3 * a + d]) * (p[3 * b + d] - p[3 * a + d]);
    return std::sqrt(s);
  };
  std::vector<double> J(f.J->begin(), f.J->begin() + nt);  // f.J: the tets', then the triangles'
  for (PetscInt s = 0; s < mesh.num_segments; ++s) {
    const PetscInt a = mesh.segments[2 * s], b = mesh.segments[2 * s + 1];
    J.push_back(length(f.positions->data(), a, b) / length(mesh.rest.data(), a, b));
  }
  J.insert(J.end(), f.J->begin() + nt, f.J->begin() + nt + nf);
  return J;
}

std::vector<int32_t> element_bodies(const DistributedMesh& mesh) {
  std::vector<int32_t> body(mesh.cell_tags);
  body.insert(body.end(), mesh.segment_tags.begin(), mesh.segment_tags.end());
  body.insert(body.end(), mesh.triangle_tags.begin(), mesh.triangle_tags.end());
  return body;
}

std::vector<double> triangle_stretch(const DistributedMesh& mesh, const std::vector<double>& positions) {
  std::vector<double> stretch(mesh.num_triangles);
  for (PetscInt t = 0; t < mesh.num_triangles; ++t) {
    const PetscInt* tri = &mesh.triangles[3 * t];
    const auto X = [&](const std::vector<double>& p, int k) { return Vec3(&p[3 * tri[k]]); };
    membrane::Vec9 x;
    x << X(positions, 0), X(positions, 1), X(positions, 2);
    stretch[t] = membrane::max_stretch(membrane::rest(X(mesh.rest, 0), X(mesh.rest, 1), X(mesh.rest, 2)), x);
  }
  return stretch;
}

}  // namespace hyperqn

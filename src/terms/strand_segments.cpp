#include "terms/strand_segments.hpp"

#include "terms/element_kernels.hpp"

namespace hyperqn {

StrandSegments::StrandSegments(const DistributedMesh& mesh, double axial_stiffness, double linear_density,
                               double laplacian_weight, std::vector<PetscInt> segments, const SpringYield& yield,
                               const std::string& state)
    : mesh_(mesh),
      axial_stiffness_(axial_stiffness),
      linear_density_(linear_density),
      weight_(laplacian_weight > 0 ? laplacian_weight : axial_stiffness),
      segments_(std::move(segments)),
      springs_(mesh) {
  for (PetscInt s : segments_) {
    const PetscInt* seg = &mesh.segments[2 * s];
    const double L = segment_edge(mesh.rest.data(), seg).norm();
    springs_.add(seg[0], seg[1], L, axial_stiffness / L, mesh.segment_ids[s]);
  }
  if (yield.active()) springs_.set_yield(yield, state);
}

PetscErrorCode StrandSegments::add_energy(Vec, const std::vector<double>& pos, double* energy,
                                          PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  springs_.add_energy(pos.data(), energy, gradient);
  PetscFunctionReturn(0);
}

PetscErrorCode StrandSegments::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  return springs_.add_hessian(pos.data(), H, scale, psd);
}

// A segment's spring k = EA / L: its L is exact, as for the mass-spring tets. A deck's own weight
// W makes it W / L, i.e. the springs' k scaled by W / EA.
PetscErrorCode StrandSegments::add_laplacian(Mat A, double scale, int components) const {
  return springs_.add_laplacian(A, scale * (weight_ / axial_stiffness_), components);
}

void StrandSegments::add_lumped_mass(PetscScalar* mass) const {
  for (size_t s = 0; s < segments_.size(); ++s)
    for (int j = 0; j < 2; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.segments[2 * segments_[s] + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += 0.5 * linear_density_ * springs_.rest_length(s);
    }
}

double StrandSegments::local_mass() const {
  double m = 0;
  for (size_t s = 0; s < springs_.size(); ++s) m += linear_density_ * springs_.rest_length(s);
  return m;
}

void StrandSegments::fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const {
  for (ElementFieldValues& f : fields)
    if (f.field == ElementField::axial_force)
      for (size_t s = 0; s < segments_.size(); ++s)  // spring s is segment segments_[s] (never arranged)
        f.values[mesh_.num_cells + segments_[s]] = springs_.tension(s, pos.data());
}

}  // namespace hyperqn

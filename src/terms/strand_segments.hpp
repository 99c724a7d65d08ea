// Strand segments: one axial spring per two-vertex segment of rest length L,
// E = EA/(2L) (l - L)^2, mass linear_density * L lumped half to each end, and weight EA/L in L
// (exact for springs, so Projective Dynamics is exact unless the deck overrides the weight).
// With a yield (strand_material.yield_strain) the segments' rest lengths flow (SpringSet::set_yield,
// docs/yielding-springs.md): their history is the ElementState `state`, by segment id.
#pragma once
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"
#include "terms/spring_set.hpp"

namespace hyperqn {

class StrandSegments : public EnergyTerm {
 public:
  // axial_stiffness EA, linear_density, laplacian_weight (0: EA) as in the deck's strand_material;
  // segments: its local segments (indices into mesh.segments' pairs), as its builder selects them.
  StrandSegments(const DistributedMesh& mesh, double axial_stiffness, double linear_density, double laplacian_weight,
                 std::vector<PetscInt> segments, const SpringYield& yield = {}, const std::string& state = "");
  std::string name() const override { return "strand"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  PetscErrorCode add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const override {
    return springs_.add_hessian(rest.data(), H, scale, true, true);  // unflowed
  }
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  void add_lumped_mass(PetscScalar* mass) const override;
  double local_mass() const override;
  bool projective_dynamics_exact() const override { return weight_ == axial_stiffness_ && !springs_.yields(); }
  ElementState* element_state() override { return springs_.element_state(); }
  PetscErrorCode update_state(const std::vector<double>& pos) override {
    springs_.update_state(pos.data());
    return 0;
  }
  double dissipated_energy() const override { return springs_.dissipated_energy(); }
  bool has_midpoint_defect() const override { return true; }
  void add_midpoint_defect(const std::vector<double>& start, const std::vector<double>& z, const std::vector<double>& end,
                           double* defect, double* scale) const override {
    springs_.add_midpoint_defect(start.data(), z.data(), end.data(), defect, scale);
  }
  // axial_force: each segment's tension EA (l/L - 1) (yielding: EA (l/L - 1 - eps_p)).
  std::vector<ElementField> element_fields() const override { return {ElementField::axial_force}; }
  void fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const override;

 private:
  const DistributedMesh& mesh_;
  double axial_stiffness_, linear_density_, weight_;
  std::vector<PetscInt> segments_;  // its local segments
  SpringSet springs_;               // spring s is segment segments_[s]: rest length L, stiffness EA / L
};

}  // namespace hyperqn

// Mass-spring cloth (Liu, Bao, Ladislav, Kavan 2013): a spring E = k/2 (l - L)^2 on every edge of
// the surface, L its rest length, the same k for all. Each edge is carried by one of its
// triangles (DistributedMesh::triangle_edges), so a spring is counted once on one rank; a torn
// edge's two sides carry k/2 each (kTornEdgeBit, mesh/cloth_separation.hpp). Its
// weight in L is k: exact, so Projective Dynamics is the paper's local-global solver. Over the
// triangles its builder hands it (a body's: body_elements). With a yield (cloth.yield_strain) the
// rest lengths flow (SpringSet::set_yield, docs/yielding-springs.md): the history is
// the ElementState `state`, an edge's id 3 t + e (t the global id of the triangle carrying it;
// edge_spring_id); a torn edge's second half, on the other triangle, carries on the edge's flow
// (yielding_spring::kInherited, Body::carry_element_states).
#pragma once
#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"
#include "terms/spring_set.hpp"

namespace hyperqn {

class ClothSprings : public EnergyTerm {
 public:
  ClothSprings(const DistributedMesh& mesh, double stiffness, const std::vector<PetscInt>& triangles,
               const SpringYield& yield = {}, const std::string& state = "");
  std::string name() const override { return "cloth springs"; }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  PetscErrorCode add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const override {
    return springs_.add_hessian(rest.data(), H, scale, true, true);  // unflowed
  }
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  bool projective_dynamics_exact() const override { return !springs_.yields(); }
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

 private:
  const DistributedMesh& mesh_;
  double k_;
  SpringSet springs_;  // the springs this rank carries, between local vertices
};

}  // namespace hyperqn

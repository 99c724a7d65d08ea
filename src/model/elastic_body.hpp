// The elastic body on this rank: per-element rest shape, the material, the lumped mass and the
// constant matrix L. Evaluates the elastic energy E(x) and its gradient over the local cells:
// tets (continuum materials or mass-spring tets) and strand segments (one axial spring each).
#pragma once
#include <petscdmplex.h>

#include <memory>
#include <vector>

#include "app/deck.hpp"
#include "mesh/distributed_mesh.hpp"
#include "materials/material.hpp"

namespace hyperqn {

class ElasticBody {
 public:
  // materials[0] is the default material, materials[k + 1] that of material region k
  // (mesh.cell_material says which tet has which); strands is the material of every segment.
  ElasticBody(const DistributedMesh& mesh, const std::vector<MaterialSpec>& materials,
              const StrandMaterial& strands = StrandMaterial());
  ElasticBody(const DistributedMesh& mesh, const MaterialSpec& material)
      : ElasticBody(mesh, std::vector<MaterialSpec>{material}) {}
  ~ElasticBody() { VecDestroy(&local_); }
  ElasticBody(const ElasticBody&) = delete;
  ElasticBody& operator=(const ElasticBody&) = delete;

  const DistributedMesh& mesh() const { return mesh_; }
  // True if every material is a Projective Dynamics energy (ARAP) with its own weight in L.
  bool projective_dynamics_exact() const;
  std::string material_names() const;  // e.g. "corotated, neohookean"

  // Prescribed motion of the fixed regions (fixed[k] moves the vertices fixed by region k).
  void set_fixed_motion(const std::vector<BoxRegion>& fixed) { fixed_regions_ = fixed; }
  // Moves the fixed vertices to their prescribed positions at time t (rest positions if none).
  void set_time(double t);

  // Local positions of all local vertices (3 each): free ones from the global vector x, fixed
  // ones from their prescribed positions.
  PetscErrorCode local_positions(Vec x, std::vector<double>& pos) const;
  // Local values of a global velocity vector (fixed vertices: their prescribed velocity).
  PetscErrorCode local_velocities(Vec v, std::vector<double>& vel) const;
  // E(x) summed over all ranks; if grad is not null, also dE/dx on the free dofs.
  PetscErrorCode energy_gradient(Vec x, PetscReal* energy, Vec grad) const;
  // det F per local tet at the given local positions.
  void cell_jacobians(const std::vector<double>& pos, std::vector<double>& J) const;

  // Lumped mass per dof (global vector layout): each vertex gets a quarter of its tets' mass
  // and half of its segments' mass.
  PetscErrorCode lumped_mass(Vec mass) const;
  // Total mass of the body (all vertices, fixed included).
  double total_mass() const { return total_mass_; }
  // A += scale * L with L = L1 (x) I3, L1 = sum_e w V_e G_e^T G_e over the tets plus
  // sum_s k_s (e_a - e_b)(e_a - e_b)^T over the segments (k_s = EA / L_s), on the free dofs.
  // components = 3: A has the dof layout (3 per free vertex); components = 1: A has the vertex
  // layout of mesh.vertex_dm and receives scale * L1.
  PetscErrorCode add_laplacian(Mat A, PetscReal scale, int components = 3) const;
  // H += scale * K(x) on the free dofs, K = sum_e V_e B_e^T C_e B_e with B_e = dvec(F_e)/dx_e,
  // plus the segments' spring stiffnesses. C_e = dP/dF(F_e) made positive semi-definite (psd, the
  // Newton baseline; springs: transverse stiffness clamped at 0) or exact (the true Hessian of E,
  // possibly indefinite; for tests). Adds into H's existing pattern.
  PetscErrorCode add_hessian(Vec x, Mat H, PetscReal scale, bool psd = true) const;
  // Positions of the rest shape as a global vector of free dofs.
  PetscErrorCode rest_positions(Vec x) const;

 private:
  // The strands' stiffness in L: EA, or the deck's override.
  double strand_weight() const { return strands_.laplacian_weight > 0 ? strands_.laplacian_weight : strands_.axial_stiffness; }
  // out = fixed_values, then the free vertices' entries overwritten from the global vector.
  PetscErrorCode scatter_to_local(Vec global, const std::vector<double>& fixed_values, std::vector<double>& out) const;

  const DistributedMesh& mesh_;
  std::vector<std::unique_ptr<Material>> materials_;  // by mesh.cell_material
  std::vector<double> weights_;      // weight in L, per material
  std::vector<double> spring_k_;     // per material: > 0 for mass-spring (materials_ entry null)
  std::vector<double> densities_;    // mass per rest volume, per material
  double total_mass_ = 0;
  std::vector<BoxRegion> fixed_regions_;
  std::vector<double> fixed_pos_;    // 3 per local vertex: prescribed positions (free: unused)
  std::vector<double> fixed_vel_;    // 3 per local vertex: prescribed velocities (free: 0)
  double time_ = 0;
  std::vector<Mat3> Dm_inv_;         // per local cell: inverse rest edge matrix
  std::vector<Mat3> Dm_;             // per local cell: rest edge matrix (for mass-spring cells)
  std::vector<double> volume_;       // per local cell: rest volume
  StrandMaterial strands_;
  std::vector<double> segment_length_;  // per local segment: rest length L
  mutable Vec local_ = nullptr;      // work: local (ghosted) vector
  mutable std::vector<double> pos_;  // work: local positions
};

}  // namespace hyperqn

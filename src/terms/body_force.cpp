// A body force: an acceleration a acting on the lumped mass of the free vertices in the box, as
// gravity acts on every vertex, E = -sum_v m_v a . (x_v - X_v). For a body force beyond gravity on
// part of a body (a centrifugal or magnetic load of constant density). Linear in x: no Hessian,
// exact for PD.
#include "terms/element_kernels.hpp"
#include "terms/load_kind.hpp"

namespace hyperqn {

namespace {

class BodyForce : public LoadTerm {
 public:
  BodyForce(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region)
      : LoadTerm(mesh, spec, index, std::move(region)), a_(spec_.vector("acceleration").data()) {}
  // The masses come once the scene knows them (EnergyTerm::set_masses), before any evaluation.
  PetscErrorCode set_masses(Vec mass) override {
    const PetscScalar* m;
    PetscInt lo, hi;
    PetscFunctionBeginUser;
    PetscCall(VecGetOwnershipRange(mass, &lo, &hi));
    PetscCall(VecGetArrayRead(mass, &m));
    dead_vertices_ = region_.vertices;
    dead_forces_.clear();
    for (PetscInt v : region_.vertices) dead_forces_.push_back(m[mesh_.global_dof[v] - lo] * a_);
    PetscCall(VecRestoreArrayRead(mass, &m));
    PetscFunctionReturn(0);
  }

 private:
  Vec3 a_;
};

std::unique_ptr<EnergyTerm> build(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region) {
  return std::make_unique<BodyForce>(mesh, spec, index, std::move(region));
}

}  // namespace

LoadKind body_force_kind() {
  const DeckKey<LoadSpec> acceleration{"acceleration", vector_field("acceleration"),
                                       "the acceleration it gives each vertex's mass (m/s² in SI), beside gravity",
                                       nonzero_vector()};
  return {"body_force", "an acceleration on the mass of the free vertices in the box, as gravity acts on all",
          LoadTarget::vertices, {acceleration}, build};
}

}  // namespace hyperqn

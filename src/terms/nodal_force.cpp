// A force on the free vertices of a box: the total force f shared equally among them (each carries
// f / N, N counted over all ranks), fixed in direction. E = -sum_v (f / N) . (x_v - X_v). Linear in
// x: no Hessian, exact for PD. A fixed vertex in the box takes no share: its support carries it.
#include "terms/element_kernels.hpp"
#include "terms/load_kind.hpp"

namespace hyperqn {

namespace {

class NodalForce : public LoadTerm {
 public:
  NodalForce(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region)
      : LoadTerm(mesh, spec, index, std::move(region)) {
    dead_vertices_ = region_.vertices;
    if (region_.global_count > 0)
      dead_forces_.assign(region_.vertices.size(), Vec3(spec_.vector("force").data()) / (double)region_.global_count);
  }
};

std::unique_ptr<EnergyTerm> build(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region) {
  return std::make_unique<NodalForce>(mesh, spec, index, std::move(region));
}

}  // namespace

LoadKind nodal_force_kind() {
  const DeckKey<LoadSpec> force{"force", vector_field("force"), "the total force (N in SI)", nonzero_vector()};
  return {"force", "a total force shared equally by the free vertices in the box", LoadTarget::vertices, {force}, build};
}

}  // namespace hyperqn

// A dead-load traction: a force per rest area t on boundary faces, fixed in direction and size
// (it does not follow the deformed surface). E = -sum_faces (A_f / 3) t . sum_a (x_a - X_a): each of
// a face's vertices carries a third of its rest area. Linear in x: no Hessian, exact for PD.
#include "terms/element_kernels.hpp"
#include "terms/load_kind.hpp"

namespace hyperqn {

namespace {

class Traction : public LoadTerm {
 public:
  Traction(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region)
      : LoadTerm(mesh, spec, index, std::move(region)) {
    const Vec3 t(spec_.vector("traction").data());
    for (const auto& f : region_.faces) {
      const Vec3 force = triangle_area(mesh_.rest.data(), f.data()) / 3 * t;
      for (PetscInt v : f) {  // each face's vertices in turn, with the face's force on it
        dead_vertices_.push_back(v);
        dead_forces_.push_back(force);
      }
    }
  }
};

std::unique_ptr<EnergyTerm> build(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region) {
  return std::make_unique<Traction>(mesh, spec, index, std::move(region));
}

}  // namespace

LoadKind traction_kind() {
  const DeckKey<LoadSpec> traction{"traction", vector_field("traction"), "the force per rest area (stress units: Pa in SI)",
                                   nonzero_vector()};
  return {"traction", "a force per rest area on boundary faces, fixed in direction (dead load)", LoadTarget::faces,
          {traction}, build};
}

}  // namespace hyperqn

// Loads: terms that apply an external force to a region of the body (the deck's loads: list,
// docs/deck-scene.md#loads). One kind per `type`: a file of src/terms/ (traction.cpp, pressure.cpp,
// nodal_force.cpp) holds its term, its own deck keys and its LoadKind, and one line of load_kinds()
// (model/load_kinds.cpp) lists it. docs/architecture.md, "Add a load".
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "terms/element_kernels.hpp"
#include "terms/energy_term.hpp"
#include "terms/load_spec.hpp"

namespace hyperqn {

// What a load acts on, this rank's part: the boundary faces of the rank's tets in the region (each
// face on one rank, its 3 local vertices ordered so that the rest normal points out of the body) or
// the free vertices the rank owns in it; and how many there are over all ranks.
enum class LoadTarget { faces, vertices };
struct LoadRegion {
  LoadTarget target = LoadTarget::faces;
  std::vector<std::array<PetscInt, 3>> faces;
  std::vector<PetscInt> vertices;
  long long global_count = 0;
  // A face_tag's faces: how many of the tag's triangles are not boundary faces of the tets (interior
  // faces, or no face of a tet), which the region leaves out (-1: no face_tag).
  long long tag_not_boundary = -1;
  // Faces: how many have a free vertex (a face of fixed vertices only takes nothing of the load).
  long long global_free_faces = 0;
};
// Collective. With a face_tag, the tag's boundary faces (vertices) in the box if there is one too.
LoadRegion select_load_region(const DistributedMesh& mesh, const LoadSpec& spec, LoadTarget target);

// A load's term for the deck's spec, acting on region (loads[index]).
using LoadBuilder = std::unique_ptr<EnergyTerm> (*)(const DistributedMesh& mesh, const LoadSpec& spec, int index,
                                                    LoadRegion region);

struct LoadKind {
  const char* type;                     // the deck's `type:` word
  const char* summary;                  // one line for --help and the docs
  LoadTarget target;
  std::vector<DeckKey<LoadSpec>> keys;  // its own keys (load_keys() makes them keys of this type only)
  LoadBuilder build;
};

// The part every load's term shares: the region, its name in messages, the check that it selects
// something, its curve, and a dead load: fixed forces on vertices (a kind fills dead_vertices_ and
// dead_forces_), E = -sum_k c(t) f_k . (x_k - X_k), linear in x (no Hessian, exact for PD). A kind
// whose load follows x (the closed pressure) overrides the energy.
class LoadTerm : public EnergyTerm {
 public:
  LoadTerm(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region)
      : mesh_(mesh), spec_(spec), index_(index), region_(std::move(region)), factor_(spec_.factor(0)) {}
  std::string name() const override { return spec_.type; }
  // The load's curve at the time the step solves for (StepStart::t).
  PetscErrorCode begin_step(const StepStart& step) override {
    factor_ = spec_.factor(step.t);
    return 0;
  }
  std::string describe() const override;
  PetscErrorCode check_start(const std::vector<double>& pos, InputProblem& out) const override;
  PetscErrorCode add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }

 protected:
  const DistributedMesh& mesh_;
  LoadSpec spec_;
  int index_;
  LoadRegion region_;
  double factor_;  // its value's factor now: the curve's c(t), 1 without one
  // The dead load: force dead_forces_[k] (times factor_) on local vertex dead_vertices_[k]; a
  // vertex may come several times.
  std::vector<PetscInt> dead_vertices_;
  std::vector<Vec3> dead_forces_;
};

}  // namespace hyperqn

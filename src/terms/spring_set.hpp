// A set of linear springs E = k/2 (l - L)^2 between pairs of a rank's local vertices (one spring:
// materials/spring.hpp), evaluated kBatch springs at a time: the cloth's edge springs, its bending
// springs and the strand segments. In a batch the lengths, energies and force factors are one
// vectorized loop; only reading the end points and adding the forces go spring by spring, the
// latter straight to the ends' dofs, looked up once when the spring is added (a fixed end has
// none; a release rebuilds the scene and its terms, so the dofs do not change under a term).
// A set may yield (set_yield: materials/yielding_spring.hpp): then each spring carries its plastic
// history in the set's ElementState and is evaluated one by one through the return map; a set
// that does not yield runs the elastic batches alone.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "materials/yielding_spring.hpp"
#include "mesh/distributed_mesh.hpp"
#include "terms/element_state.hpp"

namespace hyperqn {

class SpringSet {
 public:
  explicit SpringSet(const DistributedMesh& mesh) : mesh_(mesh) {}
  // A spring between the local vertices a and b; id: its global id (the same at every rank count),
  // for the history of a set that yields.
  void add(PetscInt a, PetscInt b, double rest_length, double stiffness, int64_t id = -1);
  // Reorders the springs, once the last one is added, so that side by side they rarely share a
  // vertex: the loop that adds the forces then does not wait, spring after spring, for the store
  // to a shared vertex's gradient before it (sheet81's g and grad g 7 % faster: docs/cloth.md#speed).
  // Within each run of kArrangeRun springs as added (kept together, so the vertices they touch stay
  // in cache), springs get the smallest colour none of their ends has yet, and are sorted by it.
  // Spring indices no longer follow the order of add() afterwards.
  void arrange();
  size_t size() const { return count_; }
  double rest_length(size_t s) const { return rest_[s]; }
  // Spring s's tension dE/dl at pos: k (l - L) (spring::tension), or its yielding one.
  double tension(size_t s, const double* pos) const;

  // From now on the springs yield (after the last add and arrange): their history is an
  // ElementState named `state` (the checkpoints' key), keyed by the ids given to add.
  void set_yield(const SpringYield& yield, const std::string& state);
  bool yields() const { return state_.has_value(); }
  ElementState* element_state() { return state_ ? &*state_ : nullptr; }
  // The history at the step's end from the step's start, at the accepted positions pos.
  void update_state(const double* pos);
  // The energy the springs have dissipated (J, as the history stands).
  double dissipated_energy() const;

  // *energy += the springs' energy at the local positions pos (3 per local vertex); their gradient
  // is added into `gradient` (the mesh's local dof array), unless it is null.
  void add_energy(const double* pos, double* energy, PetscScalar* gradient) const;
  // H += scale * d2E/dx2 at pos (psd: the transverse terms of compressed springs clamped at 0).
  // elastic: as springs that never flowed (a yielding set's history at its start: the rest stiffness).
  PetscErrorCode add_hessian(const double* pos, Mat H, double scale, bool psd, bool elastic = false) const;
  // A += scale * (each spring's stiffness) * [1 -1; -1 1] on its ends (EnergyTerm::add_laplacian).
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const;
  // The implicit midpoint's energy check (EnergyTerm::add_midpoint_defect) over the springs, each
  // as the elastic spring k/2 (l - L)^2 of its rest length (a yielding one's flow left out).
  void add_midpoint_defect(const double* start, const double* z, const double* end, double* defect,
                           double* scale) const;

 private:
  static constexpr size_t kArrangeRun = 256;
  const DistributedMesh& mesh_;
  size_t count_ = 0;
  // Padded to whole batches with springs of stiffness 0 from vertex 0 to itself (energy and force
  // 0) whose ends have no dofs.
  std::vector<PetscInt> a_, b_;          // local vertices
  std::vector<PetscInt> dof_a_, dof_b_;  // their x dofs in the local dof array, -1 if fixed
  std::vector<double> rest_, k_;
  std::vector<int64_t> ids_;
  SpringYield yield_;
  std::optional<ElementState> state_;  // set_yield's: per spring yielding_spring::kValues values
  // Spring s's condensed energy at its edge u: the return map from its history at the step's start.
  yielding_spring::Flow flow(size_t s, double length) const;
};

}  // namespace hyperqn

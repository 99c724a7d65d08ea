// Per-element state (terms/element_state.hpp) through a step's lifecycle, with a test-only term
// that counts each tet's accepted frames: a frame's accept adds one to every element, an undone
// frame (before or after its accept) leaves the count where the frame started, the fallback
// chain's sub-steps count nothing; the elements are keyed by their global ids, each on one rank.
// At 1 and 2 ranks. Checkpoints do not hold element state yet (docs/architecture.md).
#include <petscdmplex.h>

#include <algorithm>

#include "check.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

class FrameCounter : public EnergyTerm {
 public:
  explicit FrameCounter(const DistributedMesh& mesh) : state_("frames", 1, mesh.cell_ids) {}
  std::string name() const override { return "frame-counter"; }
  PetscErrorCode add_energy(Vec, const std::vector<double>&, double*, PetscScalar*) const override { return 0; }
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }
  ElementState* element_state() override { return &state_; }
  PetscErrorCode update_state(const std::vector<double>&) override {
    for (size_t e = 0; e < state_.elements(); ++e) *state_.current(e) = *state_.start(e) + 1;
    return 0;
  }
  ElementState state_;
};

// Every element's count is n, on every rank (collective).
bool all_counts(const ElementState& s, double n) {
  int ok = 1;
  for (double c : s.current_values()) ok = ok && c == n;
  MPI_Allreduce(MPI_IN_PLACE, &ok, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD);
  return ok;
}

PetscErrorCode check_counts() {
  TestScene s;
  FrameCounter* counter = nullptr;
  State state;
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("neohookean", true, s, {0, -9.81, 0},
                                   [&](const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
                                     auto term = std::make_unique<FrameCounter>(mesh);
                                     counter = term.get();
                                     terms.push_back(std::move(term));
                                   }));
  const ElementState& counts = counter->state_;
  // Each of the mesh's tets once over the ranks, by its global id.
  std::vector<int64_t> ids = counts.ids();
  long long local = (long long)ids.size(), total = 0;
  int64_t top = ids.empty() ? -1 : *std::max_element(ids.begin(), ids.end()), global_top;
  MPI_Allreduce(&local, &total, 1, MPI_LONG_LONG, MPI_SUM, PETSC_COMM_WORLD);
  MPI_Allreduce(&top, &global_top, 1, MPI_INT64_T, MPI_MAX, PETSC_COMM_WORLD);
  CHECK_MSG(total == (long long)s.mesh.global_cells && global_top == total - 1, "one count per tet, ids 0..cells - 1");
  PetscCall(state.create(s.step->layout()));
  PetscCall(s.body->rest_positions(state.x));
  StepLifecycle& life = s.step->lifecycle();

  PetscCall(s.step->begin_step(state));
  PetscCall(life.accept(state));
  CHECK_MSG(all_counts(counts, 1), "an accepted frame counts");
  PetscCall(s.step->begin_step(state));
  PetscCall(life.undo(state));
  CHECK_MSG(all_counts(counts, 1), "an undone frame does not");
  PetscCall(s.step->begin_step(state));
  PetscCall(life.accept(state));
  CHECK(all_counts(counts, 2));
  PetscCall(life.undo(state));  // an observer refused the accepted frame
  CHECK_MSG(all_counts(counts, 1), "undone after its accept: back at its start");
  // The fallback chain's way: sub-steps between the frame's begin and its accept count nothing.
  std::unique_ptr<StepObjective> sub;
  PetscCall(s.step->create_substep(2, sub));
  PetscCall(life.begin_substepped(state));
  State sub_state;
  PetscCall(sub_state.copy_from(state));
  for (int j = 0; j < 2; ++j) {
    PetscCall(sub->begin_step(sub_state));
    PetscCall(sub->lifecycle().accept(sub_state));
  }
  CHECK_MSG(all_counts(counts, 1), "sub-steps count nothing");
  PetscCall(VecCopy(sub_state.x, state.x));
  PetscCall(life.accept(state, sub_state.v));
  CHECK_MSG(all_counts(counts, 2), "the frame they make counts once");
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_counts());
  const int code = test_scene::tally("test_element_state");
  PetscCall(PetscFinalize());
  return code;
}

// Per-element state (terms/element_state.hpp) through a step's lifecycle, with a test-only term
// that counts each tet's accepted steps and sums their lengths: a frame's accept adds one step of
// h to every element, an undone frame (before or after its accept) leaves them where the frame
// started; a frame the fallback chain solves in sub-steps counts each sub-step with its length
// (h / parts) and the frame's accept adds nothing; a run of sub-steps that fails part-way (the
// chain's restart) and a frame undone after its sub-steps leave them at the frame's start; the
// elements are keyed by their global ids, each on one rank.
// Then a checkpoint: a term whose state follows the positions (each tet's frames and the sum of
// its det F at each accepted frame) checkpointed after 3 frames and restarted in a fresh scene goes
// on bit for bit as the uninterrupted run; a scene whose terms keep other state cannot restart from
// it; a rebuilt scene carries the state over by id. At 1 and 2 ranks. Then the midpoint's
// extrapolate and advance, and undo after them; a begin's swap (current standing for the start values
// until written); and the revision that changes with the start values.
#include <petscdmplex.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "io/checkpoint.hpp"
#include "terms/element_kernels.hpp"

#include "check.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

using test_scene::TestScene;

class FrameCounter : public EnergyTerm {
 public:
  explicit FrameCounter(const DistributedMesh& mesh) : state_("frames", 2, mesh.cell_ids) {}
  std::string name() const override { return "frame-counter"; }
  PetscErrorCode add_energy(Vec, const std::vector<double>&, double*, PetscScalar*) const override { return 0; }
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }
  PetscErrorCode begin_step(const StepStart& step) override {
    dt_ = step.t - step.t_start;
    return 0;
  }
  ElementState* element_state() override { return &state_; }
  PetscErrorCode update_state(const std::vector<double>&) override {
    for (size_t e = 0; e < state_.elements(); ++e) {
      state_.current(e)[0] = state_.start(e)[0] + 1;
      state_.current(e)[1] = state_.start(e)[1] + dt_;
    }
    return 0;
  }
  ElementState state_;
  double dt_ = 0;  // the length of the step begun last
};

// Each tet's accepted frames and the sum of its det F at their ends: a state that depends on x.
class VolumeHistory : public EnergyTerm {
 public:
  VolumeHistory(const DistributedMesh& mesh, const char* name)
      : mesh_(mesh), state_(name, 2, mesh.cell_ids) {}
  std::string name() const override { return "volume-history"; }
  PetscErrorCode add_energy(Vec, const std::vector<double>&, double*, PetscScalar*) const override { return 0; }
  PetscErrorCode add_hessian(const std::vector<double>&, Mat, double, bool) const override { return 0; }
  bool projective_dynamics_exact() const override { return true; }
  ElementState* element_state() override { return &state_; }
  PetscErrorCode update_state(const std::vector<double>& pos) override {
    for (size_t e = 0; e < state_.elements(); ++e) {
      const PetscInt* cell = &mesh_.cells[4 * e];
      const double J = edge_matrix(pos.data(), cell).determinant() / edge_matrix(mesh_.rest.data(), cell).determinant();
      state_.current(e)[0] = state_.start(e)[0] + 1;
      state_.current(e)[1] = state_.start(e)[1] + J;
    }
    return 0;
  }
  const DistributedMesh& mesh_;
  ElementState state_;
};

// Every element's count is n and its steps' lengths sum to time (to round-off), on every rank
// (collective); time < 0: not checked.
bool all_counts(const ElementState& s, double n, double time = -1) {
  int ok = 1;
  for (size_t e = 0; e < s.elements(); ++e) {
    const double* c = s.current_values().data() + 2 * e;
    ok = ok && c[0] == n && (time < 0 || std::fabs(c[1] - time) < 1e-12);
  }
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
  const double h = s.step->dt();
  CHECK_MSG(all_counts(counts, 1, h), "one step of h");
  // The fallback chain's way (FallbackChain::substeps): a run of 4 sub-steps that fails after its
  // first (the chain's restart puts the frame's start back), then 2 that hold: each sub-step
  // counts, with its length h / 2, and the frame's accept after them adds nothing.
  std::unique_ptr<StepObjective> sub2, sub4;
  PetscCall(s.step->create_substep(2, sub2));
  PetscCall(s.step->create_substep(4, sub4));
  PetscCall(life.begin_substepped(state));
  State sub_state;
  PetscCall(sub_state.copy_from(state));
  sub_state.drop_history();
  sub_state.frame = state.frame * 4;
  PetscCall(sub4->begin_step(sub_state));
  PetscCall(sub4->lifecycle().accept(sub_state));
  CHECK_MSG(all_counts(counts, 2, 1.25 * h), "an accepted sub-step counts, with its length h / 4");
  PetscCall(sub4->begin_step(sub_state));  // the next one fails
  life.restart_element_states();
  CHECK_MSG(all_counts(counts, 1, h), "a run of sub-steps that fails: back at the frame's start");
  PetscCall(sub_state.copy_from(state));
  sub_state.drop_history();
  sub_state.frame = state.frame * 2;
  for (int j = 0; j < 2; ++j) {
    PetscCall(sub2->begin_step(sub_state));
    if (j == 1) {  // a sub-step undone (its solve refused) and begun again
      PetscCall(sub2->lifecycle().undo(sub_state));
      CHECK_MSG(all_counts(counts, 2, 1.5 * h), "an undone sub-step leaves the one before");
      PetscCall(sub2->begin_step(sub_state));
    }
    PetscCall(sub2->lifecycle().accept(sub_state));
  }
  CHECK_MSG(all_counts(counts, 3, 2 * h), "each sub-step counts once, with its length h / 2");
  PetscCall(VecCopy(sub_state.x, state.x));
  PetscCall(life.accept(state, sub_state.v));
  CHECK_MSG(all_counts(counts, 3, 2 * h), "the frame's accept after sub-steps adds nothing");
  PetscCall(life.undo(state));  // an observer refused the frame
  CHECK_MSG(all_counts(counts, 1, h), "the frame undone after its sub-steps: back at its start");
  // The same frame again, in one step: its start is the frame's, not a sub-step's.
  PetscCall(s.step->begin_step(state));
  PetscCall(life.accept(state));
  CHECK_MSG(all_counts(counts, 2, 2 * h), "then a frame of one step counts once");
  PetscFunctionReturn(0);
}

// A scene with a VolumeHistory term named `name`, its state at the rest positions.
PetscErrorCode history_scene(TestScene& s, VolumeHistory*& term, State& state, const char* name = "volumes") {
  PetscFunctionBeginUser;
  PetscCall(test_scene::make_scene("neohookean", true, s, {0, -9.81, 0},
                                   [&](const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
                                     auto t = std::make_unique<VolumeHistory>(mesh, name);
                                     term = t.get();
                                     terms.push_back(std::move(t));
                                   }));
  PetscCall(state.create(s.step->layout()));
  PetscCall(s.body->rest_positions(state.x));
  PetscFunctionReturn(0);
}

// n frames, each the step's first guess stretched by 0.1% and accepted (no solve).
PetscErrorCode frames(TestScene& s, State& state, int n) {
  PetscFunctionBeginUser;
  for (int k = 0; k < n; ++k) {
    PetscCall(s.step->begin_step(state));
    PetscCall(VecScale(state.x, 1.001));
    PetscCall(s.step->lifecycle().accept(state));
  }
  PetscFunctionReturn(0);
}

// Whether a and b are bitwise equal on every rank (collective).
bool same_everywhere(const std::vector<double>& a, const std::vector<double>& b) {
  int same = a == b;
  MPI_Allreduce(MPI_IN_PLACE, &same, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD);
  return same;
}

PetscErrorCode check_checkpoint() {
  int size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  const std::string path = "test_element_state_np" + std::to_string(size) + ".h5";
  TestScene a, b;
  VolumeHistory *ta = nullptr, *tb = nullptr;
  State sa, sb;
  PetscFunctionBeginUser;
  PetscCall(history_scene(a, ta, sa));
  PetscCall(frames(a, sa, 3));
  // The checkpoint of frame 3: positions, velocities and the element state.
  CheckpointHeader h;
  h.frame = sa.frame;
  h.time = sa.time;
  h.body_time = a.body->time();
  long long top = 0;
  for (int64_t id : a.mesh.vertex_ids) top = std::max(top, (long long)id + 1);
  MPI_Allreduce(MPI_IN_PLACE, &top, 1, MPI_LONG_LONG, MPI_MAX, PETSC_COMM_WORLD);
  h.vertex_slots = top;
  VertexRows rows(2);
  PetscCall(a.body->local_positions(sa.x, rows[0]));
  PetscCall(a.body->local_velocities(sa.v, rows[1]));
  const ElementState& sta = ta->state_;
  PetscCall(write_checkpoint(PETSC_COMM_WORLD, path, h, a.mesh, rows,
                             {{sta.name(), sta.per_element(), sta.ids(), sta.current_values()}}));
  CheckpointHeader saved;
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  if (rank == 0) {
    const std::string why = inspect_checkpoint(path, &saved);
    CHECK_MSG(why.empty(), why);
    CHECK(saved.element_sets.size() == 1 && saved.element_sets[0].name == "volumes" &&
          saved.element_sets[0].width == 2 && saved.element_sets[0].slots == a.mesh.global_cells);
  }
  saved = broadcast_header(PETSC_COMM_WORLD, saved);
  PetscCall(frames(a, sa, 2));  // the uninterrupted run to frame 5

  // The restart: a fresh scene, the checkpoint's state, the same 2 frames.
  PetscCall(history_scene(b, tb, sb));
  PetscCall(read_checkpoint_vertices(PETSC_COMM_WORLD, path, b.mesh, saved, rows));
  PetscCall(b.body->resume(saved.body_time, rows[0], rows[1], sb.x, sb.v));
  sb.frame = saved.frame;
  sb.time = saved.time;
  std::vector<ElementRows> elements = {{"volumes", 2, tb->state_.ids(), {}}};
  PetscCall(read_checkpoint_elements(PETSC_COMM_WORLD, path, saved, elements));
  tb->state_.restore(elements[0].values);
  PetscCall(frames(b, sb, 2));
  CHECK_MSG(same_everywhere(sta.current_values(), tb->state_.current_values()), "restarted element state bitwise");
  std::vector<double> xa, xb;
  PetscCall(a.body->local_positions(sa.x, xa));
  PetscCall(b.body->local_positions(sb.x, xb));
  CHECK_MSG(same_everywhere(xa, xb), "restarted positions bitwise");
  double sum = 0;  // the state is not trivial: 5 frames of J near 1
  for (size_t e = 0; e < sta.elements(); ++e) sum += std::fabs(sta.current_values()[2 * e + 1] - 5);
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  CHECK_MSG(sum > 0, "the volumes changed");

  // Terms that keep other state cannot restart from it: every rank throws.
  std::vector<ElementRows> other = {{"plastic", 2, tb->state_.ids(), {}}};
  bool refused = false;
  try {
    PetscCall(read_checkpoint_elements(PETSC_COMM_WORLD, path, saved, other));
  } catch (const std::runtime_error& e) {
    refused = std::string(e.what()).find("volumes (2)") != std::string::npos;
  }
  CHECK_MSG(refused, "a checkpoint of other element state is refused, naming it");
  std::vector<ElementRows> none;
  refused = false;
  try {
    PetscCall(read_checkpoint_elements(PETSC_COMM_WORLD, path, saved, none));
  } catch (const std::runtime_error&) {
    refused = true;
  }
  CHECK_MSG(refused, "a scene without element state cannot restart from a checkpoint with it");

  // A rebuilt scene (a release) carries the state over by global id.
  TestScene c;
  VolumeHistory* tc = nullptr;
  State sc;
  PetscCall(history_scene(c, tc, sc));
  c.body->carry_element_states(*a.body);
  CHECK_MSG(same_everywhere(tc->state_.current_values(), sta.current_values()), "carried over");
  if (rank == 0) std::remove(path.c_str());
  PetscFunctionReturn(0);
}

}  // namespace

// The midpoint's moves (docs/inelastic.md#the-midpoint): extrapolate gives 2 current - start;
// advance makes the values at z the start of a step's second half, and undo (of the frame, or of a
// sub-step) still goes back to the step's start.
void check_midpoint_moves() {
  ElementState s("m", 2, {7, 3}, 1.0);
  s.begin();
  for (size_t e = 0; e < 2; ++e) s.current(e)[0] = 1.5, s.current(e)[1] = 1.25;  // updated at z
  s.extrapolate();
  CHECK(s.current(0)[0] == 2.0 && s.current(1)[1] == 1.5);
  s.undo();
  CHECK(s.current(0)[0] == 1.0 && s.start(1)[1] == 1.0);
  s.begin();
  s.current(0)[0] = 1.5;  // at z, then the second half from there
  s.advance();
  CHECK(s.start(0)[0] == 1.5);
  s.current(0)[0] = 1.75;
  s.undo();
  CHECK(s.start(0)[0] == 1.0 && s.current(0)[0] == 1.0);
  s.begin_substep();  // a sub-step's advance, undone as a sub-step: back to its start
  s.current(1)[0] = 2.0;
  s.advance();
  s.undo_substep();
  CHECK(s.start(1)[0] == 1.0 && s.current(1)[0] == 1.0);
}

// A step's begin swaps the values instead of copying them: current then stands for the start values
// until written, element by element through current() (the others kept) or all through overwrite()
// (InelasticTets' update); undo and extrapolate see the same values as with a copy.
void check_overwrite() {
  ElementState s("o", 2, {4, 9}, 1.0);
  s.begin();
  for (size_t e = 0; e < 2; ++e) s.overwrite(e)[0] = 2.0 + e, s.overwrite(e)[1] = 3.0 + e;
  CHECK(s.current(0)[0] == 2.0 && s.current(1)[1] == 4.0 && s.start(0)[0] == 1.0 && s.start(1)[1] == 1.0);
  s.begin();  // the written values become the start
  CHECK(s.start(1)[1] == 4.0 && s.current(1)[1] == 4.0 && s.current_values() == std::vector<double>({2, 3, 3, 4}));
  const ElementState copy = s;
  CHECK(copy.current_values() == std::vector<double>({2, 3, 3, 4}));
  for (size_t e = 0; e < 2; ++e) s.overwrite(e)[0] = 5.0, s.overwrite(e)[1] = 6.0;
  s.undo();
  CHECK(s.current_values() == std::vector<double>({2, 3, 3, 4}));
  s.current(0)[1] = 7.0;  // one value written through current(): the others are the start's
  CHECK(s.current_values() == std::vector<double>({2, 7, 3, 4}) && s.start(0)[1] == 3.0);
  s.begin();
  s.extrapolate();  // nothing written since: 2 start - start
  CHECK(s.current_values() == std::vector<double>({2, 7, 3, 4}));
  s.begin_substep();
  s.overwrite(0)[0] = 8.0, s.overwrite(0)[1] = 8.0, s.overwrite(1)[0] = 8.0, s.overwrite(1)[1] = 8.0;
  s.undo();  // back to the frame's start
  CHECK(s.current_values() == std::vector<double>({2, 7, 3, 4}) && s.start(1)[0] == 3.0);
}

// The revision a cache of the start values keys on (InelasticTets' step values): it changes with
// every call that may move the start values, and not with extrapolate (the current ones only).
void check_revision() {
  ElementState st("r", 1, {0, 1});
  uint64_t r = st.revision();
  const auto changed = [&](const char* what) {
    CHECK_MSG(st.revision() != r, std::string("revision changes with ") + what);
    r = st.revision();
  };
  st.begin(), changed("begin");
  st.current(0)[0] = 1.0;
  st.extrapolate();
  CHECK_MSG(st.revision() == r, "extrapolate leaves the revision");
  st.begin_substep(), changed("begin_substep");
  st.undo_substep(), changed("undo_substep");
  st.advance(), changed("advance");
  st.undo(), changed("undo");
  st.restore({2.0, 3.0}), changed("restore");
}

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  PetscCall(check_counts());
  PetscCall(check_checkpoint());
  check_midpoint_moves();
  check_overwrite();
  check_revision();
  const int code = test_scene::tally("test_element_state");
  PetscCall(PetscFinalize());
  return code;
}

#include "app/frame_step.hpp"

#include <cmath>
#include <cstdio>

#include "model/regions.hpp"

namespace hyperqn {

namespace {

// Longest element edge (tet edge, strand segment or triangle edge) over all ranks at the local positions pos.
double longest_edge(MPI_Comm comm, const DistributedMesh& mesh, const std::vector<double>& pos) {
  static const int tet_edges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double local = 0, global;  // squared lengths: one square root at the end (an edge whose square
                             // overflows is infinite, still beyond any limit)
  const auto measure = [&](PetscInt a, PetscInt b) {
    const double dx = pos[3 * a] - pos[3 * b], dy = pos[3 * a + 1] - pos[3 * b + 1], dz = pos[3 * a + 2] - pos[3 * b + 2];
    local = std::fmax(local, dx * dx + dy * dy + dz * dz);
  };
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    for (const auto& e : tet_edges) measure(mesh.cells[4 * c + e[0]], mesh.cells[4 * c + e[1]]);
  for (PetscInt k = 0; k < mesh.num_segments; ++k) measure(mesh.segments[2 * k], mesh.segments[2 * k + 1]);
  for (PetscInt t = 0; t < mesh.num_triangles; ++t)
    for (int e = 0; e < 3; ++e) measure(mesh.triangles[3 * t + e], mesh.triangles[3 * t + (e + 1) % 3]);
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE, MPI_MAX, comm);
  return std::sqrt(global);
}

// Why the state has diverged when its longest edge is `edge` rest diagonals long, or "".
std::string divergence(double edge, double limit) {
  if (edge <= limit) return "";
  char text[120];
  std::snprintf(text, sizeof text, "diverged: an element edge is %.4g rest bounding-box diagonals long (limit %g)", edge,
                limit);
  return text;
}

// In a static step (no inertia), the largest move of a vertex over the step beyond the largest
// move of a held one (a fixed vertex, a roller's held component), in units of `diagonal`, over all
// ranks: before and after are the local positions at the step's start and end. A load step that
// carries part of the body ten diagonals further than the supports went found no equilibrium (a
// piece set free flies off rigidly, its edges intact, and no edge check sees it).
double static_travel(MPI_Comm comm, const DistributedMesh& mesh, const std::vector<double>& before,
                     const std::vector<double>& after, double diagonal) {
  double local[2] = {0, 0}, global[2];  // squared: the largest free move, the largest held one
  const bool rollers = !mesh.held.empty();
  const PetscInt n = before.size() == after.size() ? mesh.num_vertices : 0;  // (always the same, within a step)
  for (PetscInt v = 0; v < n; ++v) {
    double moved = 0, held = 0;
    for (int d = 0; d < 3; ++d) {
      const double m = after[3 * v + d] - before[3 * v + d];
      moved += m * m;
      if (rollers && mesh.held[3 * v + d]) held += m * m;
    }
    if (mesh.fixed[v]) held = moved;
    local[0] = std::fmax(local[0], moved);
    local[1] = std::fmax(local[1], held);
  }
  MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_MAX, comm);
  return (std::sqrt(global[0]) - std::sqrt(global[1])) / diagonal;
}

// Why a static step has diverged when it moved a vertex `travel` rest diagonals beyond the
// supports, or "".
std::string static_runaway(double travel, double limit) {
  if (!(travel > limit)) return "";
  char text[200];
  std::snprintf(text, sizeof text,
                "diverged: the load step moved a vertex %.4g rest bounding-box diagonals farther than any held "
                "vertex moved (limit %g)",
                travel, limit);
  return text;
}

// Why the state has blown up locally when the largest |det F| of its elements is `volume`, or "".
std::string exploded(double volume, double limit) {
  if (!(limit > 0 && volume > limit)) return "";
  char text[120];
  std::snprintf(text, sizeof text, "elements exploded: |det F| reaches %.4g (limit %g)", volume, limit);
  return text;
}

// Whether every entry of a global vector is finite, on all ranks.
PetscErrorCode all_finite(MPI_Comm comm, Vec x, bool* finite) {
  const PetscScalar* a;
  PetscInt n;
  int local = 1, global;
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &a));
  for (PetscInt i = 0; i < n; ++i) local &= std::isfinite(a[i]) ? 1 : 0;
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCallMPI(MPI_Allreduce(&local, &global, 1, MPI_INT, MPI_MIN, comm));
  *finite = global == 1;
  PetscFunctionReturn(0);
}

}  // namespace

// No fixed vertex and no attachment: what holds the body (the deck rules asked for something) is
// contact with colliders (or with another body) alone.
static bool held_by_colliders_alone(const Scene& scene) {
  if (scene.mesh.global_fixed_vertices > 0 || scene.mesh.rollers) return false;
  bool contact = false;
  for (const auto& term : scene.body->terms()) {
    if (term->name() == "attachments") return false;
    contact = contact || term->name() == "contact";
  }
  return contact;
}

Guardrails Guardrails::of(const RunOptions& o, const Scene& s, const SceneSpec& spec) {
  Guardrails g;
  g.divergence_limit = o.divergence_limit;
  g.element_limit = o.element_limit;
  g.diagonal = rest_diagonal(s.mesh);
  for (size_t k = 0; k < spec.fixed.size(); ++k) g.fixed_keys.push_back(region_key(spec.fixed, k, "fixed"));
  std::vector<BoxRegion> attached;
  for (const AttachmentSpec& a : spec.attachments) attached.push_back(a.region);
  for (size_t k = 0; k < attached.size(); ++k) g.attachment_keys.push_back(region_key(attached, k, "attachments"));
  g.penalty_self_contact = spec.contact.self && spec.contact.model == ContactModel::penalty;
  return g;
}

// What a static step that found no equilibrium adds to its stop: the two causes, what the run
// released, and what holds a body by contact in a static step.
std::string Guardrails::static_hint(const Scene& scene, const State& state) const {
  std::string hint =
      "; static: either the load step is more than the body carries from the last equilibrium (more, "
      "smaller load steps: more frames), or a piece that nothing holds (no vertex fixed or attached, none "
      "on a collider: e.g. one that a cut, fracture, tear or snap or a released support set free) has no "
      "equilibrium (use a dynamic time.integrator for such a scene)";
  std::string released;
  for (size_t k = 0; k < state.released.size() && k < fixed_keys.size(); ++k)
    if (state.released[k]) released += (released.empty() ? "" : ", ") + fixed_keys[k];
  for (size_t k = 0; k < state.released_attachments.size() && k < attachment_keys.size(); ++k)
    if (state.released_attachments[k]) released += (released.empty() ? "" : ", ") + attachment_keys[k];
  if (!released.empty())
    hint += "; released before this step: " + released +
            " (what only they held is now held by nothing: hold it by another fixed region, an attachment or a "
            "collider, or release it in a dynamic run)";
  if (penalty_self_contact)
    hint += "; penalty self-contact (contact.model: penalty, the default) cannot hold a body in a static step: a "
            "load step can carry it through the contact layer, and nothing bounds it beyond; rest one body on "
            "another with contact: {self: true, model: barrier}";
  if (held_by_colliders_alone(scene))
    hint += "; here only colliders hold the body (no vertex fixed or attached), and a static step can lose it "
            "to them: g has no inertia, so nothing but contact bounds a step along the body's rigid modes; "
            "past a finite obstacle gravity's work has no lower bound, and on a ball or capsule the solvers "
            "slide the body off it (known, docs/method.md#time-integrators: a block on a ball of radius "
            "<= 0.5 m): let it settle with a dynamic time.integrator and damping, or fix or attach a vertex";
  return hint;
}

PetscErrorCode FrameStepper::step(const Scene& scene, const FrameSolve& solve, State& state,
                                  const IterationCallback& on_iteration, FrameStep& out) {
  const MPI_Comm comm = PetscObjectComm((PetscObject)state.x);
  const bool load_step = !scene.step->has_inertia();  // static: its answer is an equilibrium
  PetscFunctionBeginUser;
  out = FrameStep{};
  if (load_step && limits_.divergence_limit > 0) PetscCall(scene.body->local_positions(state.x, before_));
  PetscCall(solve(state, on_iteration, out.solve));
  if (out.solve.interrupted) PetscFunctionReturn(0);  // given up: the caller undoes the step
  const FrameResult& r = out.solve.result;
  bool finite_x = false;
  PetscCall(all_finite(comm, state.x, &finite_x));
  if (Objective::rejected(r.energy) || !std::isfinite(r.grad_norm)) {
    out.stop = "non-finite energy or gradient at every point tried (" + r.reason + ")";
    // What a term can say of it at the point the solve kept (e.g. which collider holds which vertex).
    PetscCall(scene.body->local_positions(state.x, pos_));
    for (const auto& term : scene.body->terms()) {
      std::string why;
      PetscCall(term->explain_rejection(pos_, why));
      if (!why.empty()) out.stop += ": " + why;
    }
  } else if (!finite_x) {
    out.stop = "the solver left non-finite positions (" + r.reason + ")";
  } else {
    if (out.solve.measured) {  // the fallback chain measured them
      out.min_J = out.solve.min_J;
      out.max_abs_J = out.solve.max_abs_J;
    } else {
      PetscCall(scene.body->volume_ratios(state.x, &out.min_J, &out.max_abs_J));
    }
    if (limits_.divergence_limit > 0) {
      PetscCall(scene.body->local_positions(state.x, pos_));
      if (load_step)
        out.stop = static_runaway(static_travel(comm, scene.mesh, before_, pos_, limits_.diagonal),
                                  limits_.divergence_limit);
      if (out.stop.empty())
        out.stop = divergence(longest_edge(comm, scene.mesh, pos_) / limits_.diagonal, limits_.divergence_limit);
    }
    if (out.stop.empty()) out.stop = exploded(out.max_abs_J, limits_.element_limit);
    // A static step that no stage of the chain made acceptable while its Newton ran away (non-finite,
    // an element past the limit or newly inverted): no equilibrium near, where a dynamic step would
    // be flagged and go on (pd past an inflation's limit point kept a frame far from one).
    if (out.stop.empty() && load_step && out.solve.newton_ran_away)
      out.stop = "no equilibrium found: every stage of the fallback chain ended far from converged (" + r.reason +
                 ") and its Newton ran away";
    if (!out.stop.empty() && load_step) out.stop += limits_.static_hint(scene, state);  // what a load step cannot have
    out.inverted = degenerate(out.min_J);
  }
  if (out.stop.empty()) PetscCall(scene.step->lifecycle().accept(state, out.solve.velocity));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "app/frame_step.hpp"

#include <cmath>
#include <cstdio>

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

Guardrails Guardrails::of(const RunOptions& o, const Scene& s) {
  return {o.divergence_limit, o.element_limit, rest_diagonal(s.mesh)};
}

PetscErrorCode FrameStepper::step(const Scene& scene, const FrameSolve& solve, State& state,
                                  const IterationCallback& on_iteration, FrameStep& out) {
  const MPI_Comm comm = PetscObjectComm((PetscObject)state.x);
  PetscFunctionBeginUser;
  out = FrameStep{};
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
      out.stop = divergence(longest_edge(comm, scene.mesh, pos_) / limits_.diagonal, limits_.divergence_limit);
      if (!out.stop.empty() && !scene.step->has_inertia())  // what a load step cannot have
        out.stop += "; static: either the load step is more than the body carries from the last equilibrium (more, "
                    "smaller load steps: more frames), or a piece that nothing holds (no vertex fixed or attached, none "
                    "on a collider: e.g. one that a cut, fracture, tear or snap or a released support set free) has no "
                    "equilibrium (use a dynamic time.integrator for such a scene)";
      if (!out.stop.empty() && !scene.step->has_inertia() && held_by_colliders_alone(scene))
        out.stop += "; here only colliders hold the body (no vertex fixed or attached), and a static step can lose it "
                    "to them: g has no inertia, so nothing but contact bounds a step along the body's rigid modes; "
                    "past a finite obstacle gravity's work has no lower bound, and on a ball or capsule the solvers "
                    "slide the body off it (known, docs/method.md#time-integrators: a block on a ball of radius "
                    "<= 0.5 m): let it settle with a dynamic time.integrator and damping, or fix or attach a vertex";
    }
    if (out.stop.empty()) out.stop = exploded(out.max_abs_J, limits_.element_limit);
    out.inverted = degenerate(out.min_J);
  }
  if (out.stop.empty()) PetscCall(scene.step->lifecycle().accept(state, out.solve.velocity));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

#include "model/initial_state.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace hyperqn {

PetscErrorCode apply_initial_state(const InitialSpec& initial, const Body& body, Vec x) {
  const DistributedMesh& m = body.mesh();
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  if (initial.kind == InitialKind::rest) PetscFunctionReturn(0);
  // The rest bounding box over all ranks, and its centre c.
  double lo[3], hi[3], c[3];
  rest_bounding_box(m, lo, hi);
  for (int d = 0; d < 3; ++d) c[d] = 0.5 * (lo[d] + hi[d]);

  PetscCall(DMGetLocalVector(m.dm, &xl));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < m.num_vertices; ++v) {
    const PetscInt off = m.local_dof[v];
    if (off < 0) continue;
    const double* X = &m.rest[3 * v];
    double p[3] = {X[0], X[1], X[2]};
    const int A = initial.axis;
    if (initial.kind == InitialKind::squash) {
      p[A] = c[A] + initial.factor * (X[A] - c[A]);
    } else if (initial.kind == InitialKind::collapse) {
      for (int d = 0; d < 3; ++d) p[d] = c[d];
    } else if (initial.kind == InitialKind::random) {
      std::seed_seq seq{(unsigned)initial.seed, (unsigned)m.vertex_ids[v], (unsigned)(m.vertex_ids[v] >> 32)};
      std::mt19937_64 gen(seq);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      for (int d = 0; d < 3; ++d) p[d] = lo[d] + u(gen) * (hi[d] - lo[d]);
    } else if (initial.kind == InitialKind::invert) {
      p[A] = 2 * c[A] - X[A];
    }
    for (int d = 0; d < 3; ++d) a[off + d] = p[d];
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(m.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(m.dm, &xl));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

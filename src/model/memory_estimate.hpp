// Memory a run will need, estimated from its mesh before anything big is allocated, and the
// memory there is: a box of 100^3 cells is refused with a deck error instead of ending in
// bad_alloc or in the kernel's out-of-memory killer.
#pragma once
#include <cstdint>
#include <string>

namespace hyperqn {

// Peak resident memory of a run on `ranks` processes (all of them together), in bytes, for a
// mesh of `vertices` vertices: 50 MB per process (MPI, PETSc) plus 5300 B per vertex (mesh,
// terms, vectors, L-BFGS history) plus 125 B per vertex^(4/3) (the fill of the factorization
// of M + h^2 L, which grows like V^(4/3) for 3-D meshes under nested dissection). Fitted to the
// peak RSS of boxes of 30^3 to 100^3 cells at 1 rank (default solver, MUMPS): within 6% of the
// measured 10^3 to 100^3 boxes (docs/guardrails.md). factored false: no sparse factorization
// (lbfgs with solver.h0: amg, lbfgs-identity, Newton on CG + AMG), so no fill term.
double estimated_run_bytes(int64_t vertices, int ranks, bool factored = true);

// The memory a run may take, in bytes: the environment variable HYPERQN_MEMORY_LIMIT_MB if set
// (a number > 0; anything else is an InputError naming it), else MemAvailable of /proc/meminfo;
// 0 when neither is known (no check). `source` says which, for messages.
double memory_limit_bytes(std::string* source);

}  // namespace hyperqn

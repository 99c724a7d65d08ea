// Memory each rank of a run will need, estimated from its mesh before anything big is allocated,
// and the memory each rank may take: a mesh whose run cannot fit is refused with a deck error
// instead of ending in bad_alloc or in the kernel's out-of-memory killer (docs/guardrails.md#memory).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <mpi.h>

#include "solvers/factored_system.hpp"
#include "solvers/solver_spec.hpp"

namespace hyperqn {

// What a rank holds of the constant matrix A = M + h^2 L (or M + h^2 K(x_rest)).
enum class H0Memory {
  none,      // no constant matrix (lbfgs-identity, newton)
  gathered,  // A gathered to rank 0 and factored there whole (solvers/factored_system.cpp; 1 rank alike)
  amg,       // solver.h0: amg: one V-cycle of the distributed A1, no factor
  split,     // each rank factors its own interior (V/p vertices) and holds the dense Schur complement of
             // the partition interface (s x s doubles, twice) whole
};

// What a run factors, from its solver settings (memory_plan).
struct MemoryPlan {
  H0Memory h0 = H0Memory::gathered;
  int components = 1;       // 1: the vertex matrix A1 (Laplacian); 3: the 3n x 3n rest stiffness
  int substep_sizes = 0;    // the fallback chain's sub-step sizes, each with its own A (solver.max_halvings)
  bool newton = false;      // Newton factors its 3n x 3n Hessian by MUMPS, whole on every rank
  bool newton_is_fallback = false;  // ... as the fallback chain's stage 3 (solver.newton_fallback)
  bool amg_allowed = false;         // the solver could take solver.h0: amg instead of a factor (lbfgs)
  bool h0_auto = false;  // solver.h0: auto: amg or the factor by the mesh and material (resolved_plan)
  double poisson_ratio = 0;  // ... the scene's largest tet Poisson ratio (SceneOptions::poisson_ratio)
  // ... and a scene held still: its SceneOptions::held_weight (0: not such a scene), and the
  // self-weight deflection scale that auto goes by (self_weight_deflection), from the mesh's rest
  // bounding box where the estimate knows it (with_rest_box); unknown (a partition file's mesh):
  // counted as a stiff scene's, the 3n x 3n rest stiffness
  double held_weight = 0;
  double weight_deflection = -1;  // < 0: unknown
  bool newton_auto = false;  // solver.linear_solver: auto: MUMPS or CG + AMG by the mesh (resolved_plan)
  bool split = false;    // on more than one rank the factor is split, not gathered (-hyperqn_h0_package
                         // auto while the interface is small, or split; resolved_plan)
  bool serial_mesh = true;  // rank 0 reads the whole mesh and sends its pieces (false: a generated box
                            // or sheet, or a partition file: each rank makes or reads its own piece)
};

// What a run with these settings factors, for its memory estimate (below): a
// constant matrix (gathered to rank 0, or by AMG), again for every sub-step size of the fallback
// chain, and Newton's Hessian with linear_solver mumps, as the solver or as the chain's last stage.
// Counted whether or not the chain will need them: once made, they stay for the rest of the run.
// rollers: the deck has a fixed region with `components` (the constant matrix is then factored whole).
MemoryPlan memory_plan(const SolverSpec& spec, FactorPackage package = default_factor_package(), bool rollers = false);

// The plan for this mesh: solver.h0: auto, the split factor and linear_solver: auto resolved as
// the run will (resolved_h0, choose_factor_package with the interface of interface_vertices,
// newton_uses_amg).
MemoryPlan resolved_plan(MemoryPlan plan, int64_t vertices, int64_t tets, int ranks);
// The plan for a mesh whose rest bounding box (after mesh.transform) is lo..hi, as the scene will
// measure it: solver.h0: auto's self-weight deflection scale known.
MemoryPlan with_rest_box(MemoryPlan plan, const double lo[3], const double hi[3]);

// One rank's estimated peak resident memory by parts, in bytes.
struct RankMemory {
  double process = 0;     // MPI and PETSc
  double share = 0;       // its share of the mesh, terms, vectors and L-BFGS history, with its halo
  double whole_mesh = 0;  // rank 0: the whole mesh, read there and sent in pieces from there (MemoryPlan::serial_mesh)
                          // (a phase of its own: freed before the rest is built)
  double h0 = 0;          // the constant matrix: factor and gathered A, AMG hierarchy, or interior factor + Schur block
  double substeps = 0;    // the same for every sub-step size of the fallback chain
  double newton = 0;      // Newton's factor of the 3n x 3n Hessian and the Hessian's copy it factors
  double total() const;    // process + the larger of whole_mesh and the rest
};

// Rank `rank` of `ranks`, for a mesh of `vertices` vertices (fitted to measured peaks: the
// coefficients and their table are in memory_estimate.cpp and docs/guardrails.md#memory).
RankMemory estimated_rank_memory(int64_t vertices, int ranks, int rank, const MemoryPlan& plan);

// Vertices on the interface of a box of `vertices` vertices cut into `ranks` near-cubic parts:
// 3 (p^(1/3) - 1) planes of V^(2/3) vertices, at least one plane when p > 1 (p = 2: one cut).
double interface_vertices(int64_t vertices, int ranks);

// The parts of m, largest first, as "the factor of M + h^2 L on rank 0: 3100 MB, ..." (those of
// at least 1 MB).
std::string describe_rank_memory(const RankMemory& m, int rank, const MemoryPlan& plan);

// Whether every rank of the run fits its limit: limits[r] is rank r's in bytes (<= 0: unknown, not
// checked); ranks past limits.size() (a run on more ranks) get the smallest known one.
bool run_fits(int64_t vertices, int ranks, const MemoryPlan& plan, const std::vector<double>& limits);

// The changes that would make a run that does not fit fit, as deck keys and what to do, e.g.
// "solver.h0: amg (no factorization); or a coarser mesh (at most about 120000 vertices with these
// settings, 450000 with all of solver.h0: amg (no factorization))": more ranks, solver.h0: amg, no
// Newton factor, fewer sub-step sizes, each alone or all together, and the largest mesh that fits
// as the run is set up and with all of those changes.
std::string ways_out(int64_t vertices, int ranks, const MemoryPlan& plan, const std::vector<double>& limits);

// The memory this rank may take.
struct MemoryLimit {
  double bytes = 0;              // 0: unknown (no check)
  bool from_environment = false;  // HYPERQN_MEMORY_LIMIT_MB, else MemAvailable
  int node_ranks = 1;             // ranks sharing this rank's node (MPI_COMM_TYPE_SHARED)
  double node_available = 0;      // MemAvailable of the node, bytes
};

// Collective over comm. The environment variable HYPERQN_MEMORY_LIMIT_MB (per rank; a number > 0,
// anything else is an InputError naming it) if set, else this node's MemAvailable (/proc/meminfo)
// divided by the ranks on this node.
MemoryLimit rank_memory_limit(MPI_Comm comm);
// Where the limit comes from, for messages: "HYPERQN_MEMORY_LIMIT_MB, per rank" or "MemAvailable
// in /proc/meminfo, 22000 MB on its node, shared by 2 rank(s)".
std::string describe_limit(const MemoryLimit& limit);

}  // namespace hyperqn

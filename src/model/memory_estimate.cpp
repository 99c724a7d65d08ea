#include "model/memory_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>
#include <vector>

#include "mesh/input_error.hpp"
#include "solvers/factored_system.hpp"
#include "solvers/newton_solver.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {

namespace {

constexpr double kMB = 1024.0 * 1024.0;

// Fitted to the peak RSS of each rank (summary.json peak_rss_mb_by_rank) of cube boxes of 20^3 to
// 44^3 cells (9,261 to 91,125 vertices, up to 511k tets) at 1 and 2 ranks, lbfgs with the
// factor and with solver.h0: amg, 2 frames (bench/memory_per_rank.py; the table is in
// docs/guardrails.md#memory); checked against the 1-rank peaks of 50^3 to 100^3 measured before.
constexpr double kProcessBytes = 45 * kMB;  // MPI and PETSc, per process
constexpr double kShareBytes = 2700;        // per own vertex: mesh, terms, vectors, L-BFGS history
constexpr double kParallelBytes = 900;      // per own vertex more on more than one rank (measured at 2
                                            // ranks: 870-940 B at 9k-91k vertices, in proportion to
                                            // the rank's vertices, not to its interface)
constexpr double kWholeMeshBytes = 1760;    // per vertex of the whole mesh on rank 0 while it is read
                                            // or generated and distributed (1758-1763 B measured)
constexpr double kAmgBytes = 1100;          // per own vertex: A1 and its GAMG hierarchy
constexpr double kMatrixBytes = 1200;       // per vertex of a factored A1: A1 (gathered), the copy
                                            // handed to the factorization, work vectors
constexpr double kFillBytes = 145;          // per vertex^(4/3) of a factored A1: the Cholesky factor
                                            // (3-D meshes, nested dissection) and its workspace
// Newton's 3n x 3n Hessian factored by MUMPS (solvers/newton_solver.cpp; PCREDUNDANT: whole on every
// rank at more than one rank): fitted to newton runs of 15^3 to 25^3 cells (4,096 to 17,576
// vertices) at 1 and 2 ranks (docs/guardrails.md#memory).
constexpr double kNewtonMatrixBytes = 1300;     // per vertex: the Hessian (9 blocks of ~15 per row)
constexpr double kNewtonRedundantBytes = 3600;  // per vertex more on more than one rank: its whole copy
constexpr double kNewtonFillBytes = 860;        // per vertex^(4/3): MUMPS's factor of the 3n x 3n matrix

// Ghost vertices of one of p near-cubic parts of V / p vertices: one layer on each face it shares
// (6 (1 - p^(-1/3)) faces on average, 1.26 at p = 2, 3 at p = 8) of (V / p)^(2/3) vertices.
double ghost_vertices(double v, int p) {
  if (p <= 1) return 0;
  return 6 * (1 - std::pow(double(p), -1.0 / 3.0)) * std::pow(v / p, 2.0 / 3.0);
}

// A factored matrix of v vertices (components 3: x, y and z coupled, nine times the entries).
double factor_bytes(double v, int components) {
  const double blocks = double(components) * components;
  return blocks * (kMatrixBytes * v + kFillBytes * std::pow(v, 4.0 / 3.0));
}

}  // namespace

double interface_vertices(int64_t vertices, int ranks) {
  if (ranks <= 1) return 0;
  const double planes = std::max(1.0, 3 * (std::cbrt(double(ranks)) - 1));
  return planes * std::pow(double(vertices), 2.0 / 3.0);
}

MemoryPlan memory_plan(const SolverSpec& spec, FactorPackage package, bool rollers) {
  MemoryPlan plan;
  const bool constant = solver_uses_constant_matrix(spec.type);
  const H0 h0 = solver_h0(spec);
  plan.h0 = !constant ? H0Memory::none : h0 == H0::amg ? H0Memory::amg : H0Memory::gathered;
  plan.components = constant && (h0 == H0::rest_stiffness || h0 == H0::volumetric || rollers) ? 3 : 1;  // rollers: FactoredSystem
  plan.substep_sizes = constant ? spec.max_halvings : 0;  // (the chain's Newton takes no constant matrix)
  plan.newton_is_fallback = spec.type != "newton" && spec.newton_fallback;
  plan.newton = (spec.type == "newton" || spec.newton_fallback) && spec.linear_solver != LinearSolver::cg_amg;
  plan.newton_auto = spec.linear_solver == LinearSolver::automatic;
  plan.amg_allowed = solver_takes_h0(spec.type) && plan.h0 != H0Memory::amg;
  plan.h0_auto = constant && h0 == H0::automatic;
  plan.split = splits_on_many_ranks(package);
  return plan;
}

MemoryPlan with_rest_box(MemoryPlan plan, const double lo[3], const double hi[3]) {
  plan.weight_deflection = self_weight_deflection(plan.held_weight, lo, hi);
  return plan;
}

MemoryPlan resolved_plan(MemoryPlan plan, int64_t vertices, int64_t tets, int ranks) {
  if (plan.h0_auto) {  // an unknown deflection scale of a scene held still: as small as can be (stiff)
    const double deflection = plan.weight_deflection >= 0 ? plan.weight_deflection
                              : plan.held_weight > 0      ? std::numeric_limits<double>::min()
                                                          : 0.0;
    const H0 h0 = resolved_h0(H0::automatic, tets, plan.poisson_ratio, deflection);
    if (h0 == H0::amg) plan.h0 = H0Memory::amg;
    if (h0 == H0::volumetric || h0 == H0::rest_stiffness) plan.components = 3;
  }
  if (plan.newton_auto && newton_uses_amg(LinearSolver::automatic, vertices)) plan.newton = false;
  if (plan.h0 == H0Memory::gathered && plan.split && ranks > 1 &&
      plan.components * interface_vertices(vertices, ranks) <= double(kMaxSplitInterface))
    plan.h0 = H0Memory::split;
  return plan;
}

RankMemory estimated_rank_memory(int64_t vertices, int ranks, int rank, const MemoryPlan& plan) {
  const double v = double(vertices), own = v / ranks;
  RankMemory m;
  m.process = kProcessBytes;
  m.share = (kShareBytes + (ranks > 1 ? kParallelBytes : 0)) * (own + ghost_vertices(v, ranks));
  if (rank == 0 && plan.serial_mesh) m.whole_mesh = kWholeMeshBytes * v;
  double h0 = 0;  // one constant matrix, on this rank
  switch (plan.h0) {
    case H0Memory::none: break;
    case H0Memory::gathered: h0 = rank == 0 ? factor_bytes(v, plan.components) : 0; break;
    case H0Memory::amg: h0 = kAmgBytes * (own + ghost_vertices(v, ranks)); break;
    case H0Memory::split: {
      const double s = double(plan.components) * interface_vertices(vertices, ranks);
      h0 = factor_bytes(own, plan.components) + 2 * 8 * s * s;
      break;
    }
  }
  m.h0 = h0;
  m.substeps = plan.substep_sizes * h0;
  if (plan.newton)
    m.newton = (kNewtonMatrixBytes + (ranks > 1 ? kNewtonRedundantBytes : 0)) * v + kNewtonFillBytes * std::pow(v, 4.0 / 3.0);
  return m;
}

double RankMemory::total() const {
  // The whole mesh is gone from rank 0 (sent in pieces, then freed) before the scene is built.
  return process + std::max(whole_mesh, share + h0 + substeps + newton);
}

std::string describe_rank_memory(const RankMemory& m, int rank, const MemoryPlan& plan) {
  const char* matrix = plan.components == 3 ? "M + h^2 K(x_rest)" : "M + h^2 L";
  char what[200];
  std::vector<std::pair<double, std::string>> parts;
  switch (plan.h0) {
    case H0Memory::none: break;
    case H0Memory::gathered: std::snprintf(what, sizeof what, "the factor of %s on rank 0", matrix); break;
    case H0Memory::amg: std::snprintf(what, sizeof what, "the AMG hierarchy of %s", matrix); break;
    case H0Memory::split:
      std::snprintf(what, sizeof what, "the factor of its interior of %s and the dense interface block (twice)", matrix);
      break;
  }
  if (m.h0 > 0) parts.emplace_back(m.h0, what);
  if (m.substeps > 0) {
    std::snprintf(what, sizeof what, "the same for the fallback chain's %d sub-step size(s) (solver.max_halvings)",
                  plan.substep_sizes);
    parts.emplace_back(m.substeps, what);
  }
  if (m.newton > 0)
    parts.emplace_back(m.newton, plan.newton_is_fallback
                                     ? "the fallback chain's Newton: its 3n x 3n Hessian and MUMPS factor, whole on every rank"
                                     : "Newton's 3n x 3n Hessian and its MUMPS factor, whole on every rank");
  parts.emplace_back(m.share, "its share of the mesh and the run's vectors");
  parts.emplace_back(m.process, "MPI and PETSc");
  std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string text;
  for (const auto& [bytes, name] : parts) {
    if (bytes < kMB) continue;
    std::snprintf(what, sizeof what, "%.0f MB", bytes / kMB);
    text += (text.empty() ? "" : ", ") + name + ": " + what;
  }
  if (rank == 0 && m.whole_mesh > 0) {  // a phase of its own: not added to the parts above
    std::snprintf(what, sizeof what, "; before that, the whole mesh on rank 0 while it is distributed: %.0f MB",
                  m.whole_mesh / kMB);
    text += what;
  }
  return text;
}

bool run_fits(int64_t vertices, int ranks, const MemoryPlan& plan, const std::vector<double>& limits) {
  double smallest = 0;
  for (double l : limits)
    if (l > 0 && (smallest <= 0 || l < smallest)) smallest = l;
  if (smallest <= 0) return true;
  // Every rank but 0 holds the same (estimated_rank_memory tells rank 0 alone apart).
  const double root = estimated_rank_memory(vertices, ranks, 0, plan).total();
  const double other = ranks > 1 ? estimated_rank_memory(vertices, ranks, 1, plan).total() : 0;
  for (int r = 0; r < ranks; ++r) {
    const double limit = r < (int)limits.size() ? limits[r] : smallest;
    if (limit > 0 && (r == 0 ? root : other) > limit) return false;
  }
  return true;
}

// The most vertices (below `vertices`, within 0.1%) with which the run fits; 0 if none.
static int64_t largest_fitting_mesh(int64_t vertices, int ranks, const MemoryPlan& plan, const std::vector<double>& limits) {
  int64_t lo = 0, hi = vertices;
  while (hi - lo > std::max<int64_t>(1, hi / 1000)) {
    const int64_t mid = lo + (hi - lo) / 2;
    (run_fits(mid, ranks, plan, limits) ? lo : hi) = mid;
  }
  return lo;
}

std::string ways_out(int64_t vertices, int ranks, const MemoryPlan& plan, const std::vector<double>& limits) {
  std::vector<std::string> alone;   // each of these alone makes it fit
  std::vector<std::string> all;     // every change there is, for "together"
  MemoryPlan together = plan;
  char text[200];
  constexpr int kMostRanks = 1 << 20;
  for (int more = 2 * ranks; more <= kMostRanks; more *= 2)
    if (run_fits(vertices, more, plan, limits)) {
      std::snprintf(text, sizeof text, "more ranks (%d at this memory per rank)", more);
      alone.push_back(text);
      break;
    }
  if (plan.amg_allowed) {
    MemoryPlan amg = plan;
    amg.h0 = together.h0 = H0Memory::amg;
    amg.components = together.components = 1;
    all.push_back("solver.h0: amg (no factorization)");
    if (run_fits(vertices, ranks, amg, limits)) alone.push_back(all.back());
  }
  if (plan.newton) {
    MemoryPlan no_newton = plan;
    no_newton.newton = together.newton = false;
    all.push_back(plan.newton_is_fallback ? "solver.newton_fallback: false (or linear_solver: cg-amg)"
                                          : "solver.linear_solver: cg-amg");
    if (run_fits(vertices, ranks, no_newton, limits)) alone.push_back(all.back());
  }
  if (plan.substep_sizes > 0) {
    MemoryPlan fewer = plan;
    together.substep_sizes = 0;
    for (fewer.substep_sizes = plan.substep_sizes - 1; fewer.substep_sizes >= 0; --fewer.substep_sizes)
      if (run_fits(vertices, ranks, fewer, limits)) break;
    all.push_back("solver.max_halvings: 0");
    if (fewer.substep_sizes >= 0) {
      std::snprintf(text, sizeof text, "solver.max_halvings: %d", fewer.substep_sizes);
      alone.push_back(text);
    }
  }
  std::string out;
  for (const std::string& w : alone) out += (out.empty() ? "" : "; or ") + w;
  if (alone.empty() && all.size() > 1 && run_fits(vertices, ranks, together, limits)) {
    out = "all of";
    for (size_t k = 0; k < all.size(); ++k) out += (k ? ", " : " ") + all[k];
  }
  // The largest mesh that fits as the run is set up, and with every change above.
  const int64_t most = largest_fitting_mesh(vertices, ranks, plan, limits);
  if (most > 0) {
    std::snprintf(text, sizeof text, "a coarser mesh (at most about %lld vertices with these settings", (long long)most);
    out += (out.empty() ? "" : "; or ") + std::string(text);
  } else {
    out += (out.empty() ? "" : "; or ") + std::string("a coarser mesh (none fits with these settings");
  }
  if (!all.empty()) {
    const int64_t most_together =
        run_fits(vertices, ranks, together, limits) ? vertices : largest_fitting_mesh(vertices, ranks, together, limits);
    std::snprintf(text, sizeof text, ", %lld with all of", (long long)most_together);
    out += text;
    for (size_t k = 0; k < all.size(); ++k) out += (k ? ", " : " ") + all[k];
  }
  return out + ")";
}

MemoryLimit rank_memory_limit(MPI_Comm comm) {
  MemoryLimit limit;
  MPI_Comm node;  // the ranks sharing this rank's memory
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  MPI_Comm_size(node, &limit.node_ranks);
  MPI_Comm_free(&node);
  if (const char* env = std::getenv("HYPERQN_MEMORY_LIMIT_MB")) {
    char* end = nullptr;
    const double mb = std::strtod(env, &end);
    if (end == env || *end != '\0' || !(mb > 0) || !std::isfinite(mb))
      throw InputError("environment variable HYPERQN_MEMORY_LIMIT_MB: must be a number of MB > 0 (per rank), got '" +
                       std::string(env) + "'");
    limit.from_environment = true;
    limit.bytes = mb * kMB;
    return limit;
  }
  std::FILE* f = std::fopen("/proc/meminfo", "r");
  if (!f) return limit;
  char line[256];
  double kb = 0;
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "MemAvailable: %lf kB", &kb) == 1) break;
  std::fclose(f);
  limit.node_available = kb * 1024;
  limit.bytes = limit.node_available / limit.node_ranks;
  return limit;
}

std::string describe_limit(const MemoryLimit& limit) {
  if (limit.from_environment) return "HYPERQN_MEMORY_LIMIT_MB, per rank";
  char text[160];
  std::snprintf(text, sizeof text, "MemAvailable in /proc/meminfo, %.0f MB on its node, shared by %d rank(s)",
                limit.node_available / kMB, limit.node_ranks);
  return text;
}

}  // namespace hyperqn

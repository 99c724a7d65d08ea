// Unit test of the memory estimate of each rank (model/memory_estimate.hpp): its parts by path
// (gathered factor, AMG, split), the fallback chain's factors and Newton's, the limit per rank
// (HYPERQN_MEMORY_LIMIT_MB, or MemAvailable shared by the node's ranks), and the ways out.
#include <mpi.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "check.hpp"
#include "mesh/input_error.hpp"
#include "model/memory_estimate.hpp"
#include "solvers/solver_registry.hpp"

using namespace hyperqn;

namespace {

constexpr double MB = 1024.0 * 1024.0;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

void test_paths() {
  const int64_t V = 1000000;  // a 99^3-cell box
  MemoryPlan gathered;        // the default: M + h^2 L gathered to rank 0
  const RankMemory one = estimated_rank_memory(V, 1, 0, gathered);
  const RankMemory root = estimated_rank_memory(V, 64, 0, gathered), other = estimated_rank_memory(V, 64, 1, gathered);
  // The whole factor stays on rank 0 whatever the ranks; the others hold none.
  CHECK(root.h0 == one.h0 && one.h0 > 10000 * MB);
  CHECK(other.h0 == 0);
  // The share falls with the ranks, but by less than 64: the parallel overhead and the halo.
  CHECK(other.share < one.share / 40 && other.share > one.share / 64);
  CHECK(root.share == other.share);
  // Rank 0's peak: its steady parts, or the whole mesh while it is distributed if that is larger.
  CHECK(root.whole_mesh > 0 && other.whole_mesh == 0);
  CHECK_NEAR(root.total(), root.process + root.share + root.h0, 1);
  MemoryPlan amg_only;
  amg_only.h0 = H0Memory::amg;
  const RankMemory amg64 = estimated_rank_memory(V, 64, 0, amg_only);
  CHECK_NEAR(amg64.total(), amg64.process + amg64.whole_mesh, 1);  // the mesh phase on rank 0 is the larger
  // A generated box or a partition file: each rank makes its own piece, rank 0 holds no whole mesh.
  MemoryPlan pieces = amg_only;
  pieces.serial_mesh = false;
  const RankMemory amg64_pieces = estimated_rank_memory(V, 64, 0, pieces);
  CHECK(amg64_pieces.whole_mesh == 0);
  CHECK_NEAR(amg64_pieces.total(), amg64.process + amg64.share + amg64.h0, 1);
  // AMG: distributed, no fill (linear in V per rank).
  MemoryPlan amg = gathered;
  amg.h0 = H0Memory::amg;
  const double a1 = estimated_rank_memory(V, 1, 0, amg).h0, a2 = estimated_rank_memory(2 * V, 1, 0, amg).h0;
  CHECK_NEAR(a2 / a1, 2.0, 1e-12);
  CHECK(estimated_rank_memory(V, 64, 1, amg).h0 < a1 / 40);
  // The factor grows like V^(4/3) (plus the matrix, linear).
  const double f8 = estimated_rank_memory(8 * V, 1, 0, gathered).h0;
  CHECK(f8 / one.h0 > 8 && f8 / one.h0 < 16);
  // The 3n x 3n rest stiffness: nine times the entries.
  MemoryPlan rest = gathered;
  rest.components = 3;
  CHECK_NEAR(estimated_rank_memory(V, 1, 0, rest).h0 / one.h0, 9.0, 1e-12);
  // Split: each rank its interior's factor plus the dense interface block s x s twice, on every rank.
  MemoryPlan split = gathered;
  split.h0 = H0Memory::split;
  CHECK(estimated_rank_memory(V, 1, 0, split).h0 == one.h0);  // 1 rank: no interface
  const double s2 = interface_vertices(V, 2);
  CHECK_NEAR(s2, std::pow(double(V), 2.0 / 3.0), 1e-6);  // two parts: one plane
  CHECK_NEAR(interface_vertices(V, 8), 3 * std::pow(double(V), 2.0 / 3.0), 1e-6);  // octants: three planes
  const RankMemory split2_0 = estimated_rank_memory(V, 2, 0, split), split2_1 = estimated_rank_memory(V, 2, 1, split);
  CHECK(split2_0.h0 == split2_1.h0);
  const RankMemory half = estimated_rank_memory(V / 2, 1, 0, gathered);
  CHECK_NEAR(split2_0.h0 - half.h0, 16 * s2 * s2, 1e-3 * 16 * s2 * s2);
}

void test_fallback_and_newton() {
  const int64_t V = 100000;
  SolverSpec spec;  // lbfgs, laplacian, max_halvings 3, newton_fallback with mumps
  const MemoryPlan plan = memory_plan(spec);
  CHECK(plan.h0 == H0Memory::gathered && plan.substep_sizes == 3 && plan.newton && plan.newton_is_fallback);
  CHECK(plan.amg_allowed);
  const RankMemory m = estimated_rank_memory(V, 2, 0, plan);
  CHECK_NEAR(m.substeps, 3 * m.h0, 1);  // one factor per sub-step size h/2, h/4, h/8
  CHECK(m.newton > m.h0);                // 3n x 3n
  CHECK(estimated_rank_memory(V, 2, 1, plan).newton > estimated_rank_memory(V, 1, 0, plan).newton);  // whole on every rank
  spec.newton_fallback = false;
  spec.max_halvings = 0;
  const MemoryPlan bare = memory_plan(spec);
  CHECK(!bare.newton && bare.substep_sizes == 0);
  spec.h0 = H0::amg;
  CHECK(memory_plan(spec).h0 == H0Memory::amg && !memory_plan(spec).amg_allowed);
  spec.type = "newton";
  spec.linear_solver = LinearSolver::cg_amg;
  const MemoryPlan cg = memory_plan(spec);
  CHECK(cg.h0 == H0Memory::none && !cg.newton);
  spec.linear_solver = LinearSolver::mumps;
  CHECK(memory_plan(spec).newton && !memory_plan(spec).newton_is_fallback);
  spec.type = "pd";
  CHECK(memory_plan(spec).h0 == H0Memory::gathered && !memory_plan(spec).amg_allowed);  // pd needs the exact factor
}

// solver.h0: auto is resolved by the mesh and the material in resolved_h0 alone (the V-cycle on
// large meshes whatever the material, the volumetric H0 from kVolumetricFromPoisson on, to
// round-off); the other settings pass through, and pd (which does not take h0) always factors M + h^2 L.
void test_resolved_h0() {
  CHECK(resolved_h0(H0::automatic, kAmgFromTets - 1, 0.3) == H0::laplacian);
  CHECK(resolved_h0(H0::automatic, kAmgFromTets, 0.3) == H0::amg);
  CHECK(resolved_h0(H0::automatic, kAmgFromTets, 0.4999) == H0::amg);
  CHECK(resolved_h0(H0::automatic, kAmgFromTets - 1, 0.4999) == H0::volumetric);
  CHECK(resolved_h0(H0::automatic, 24, kVolumetricFromPoisson) == H0::volumetric);
  CHECK(resolved_h0(H0::automatic, 24, kVolumetricFromPoisson * (1 - 1e-15)) == H0::volumetric);
  CHECK(resolved_h0(H0::automatic, 24, 0.4988) == H0::laplacian);
  CHECK(resolved_h0(H0::automatic, 0, 0.4999) == H0::laplacian);  // no tets: nothing volumetric
  CHECK(resolved_h0(H0::rest_stiffness, kAmgFromTets, 0.3) == H0::rest_stiffness);
  CHECK(resolved_h0(H0::laplacian, kAmgFromTets, 0.4999) == H0::laplacian);
  CHECK(resolved_h0(H0::laplacian, 24, 0.4999) == H0::laplacian);
  SolverSpec spec;
  spec.type = "pd";
  spec.h0 = H0::amg;  // (a deck error; pd ignores the setting here)
  CHECK(resolved_h0(spec, 10 * kAmgFromTets, 0.3) == H0::laplacian);
  spec.h0 = H0::automatic;
  CHECK(resolved_h0(spec, 24, 0.4999) == H0::laplacian);  // pd is defined by M + h^2 L
  spec.type = "lbfgs";
  CHECK(resolved_h0(spec, 24, 0.4999) == H0::volumetric);
  spec.h0 = H0::amg;
  CHECK(resolved_h0(spec, 1, 0.3) == H0::amg);
  // The memory estimate counts the volumetric H0's 3n x 3n factor when auto takes it.
  spec.h0 = H0::automatic;
  MemoryPlan plan = memory_plan(spec);
  plan.poisson_ratio = 0.3;
  CHECK(resolved_plan(plan, 100, 24, 1).components == 1);
  plan.poisson_ratio = 0.4999;
  CHECK(resolved_plan(plan, 100, 24, 1).components == 3);
  CHECK(resolved_plan(plan, 100, kAmgFromTets, 1).h0 == H0Memory::amg);
}

void test_ways_out() {
  SolverSpec spec;
  spec.newton_fallback = false;
  spec.max_halvings = 0;
  const MemoryPlan plan = memory_plan(spec);
  const int64_t V = 1000000;
  // 2 ranks of 4 GB: the factor on rank 0 does not fit; more ranks do not help, AMG does.
  const std::vector<double> limits(2, 4096 * MB);
  CHECK(!run_fits(V, 2, plan, limits));
  const std::string ways = ways_out(V, 2, plan, limits);
  CHECK_MSG(contains(ways, "solver.h0: amg") && !contains(ways, "more ranks") && contains(ways, "a coarser mesh"), ways);
  MemoryPlan amg = plan;
  amg.h0 = H0Memory::amg;
  CHECK(run_fits(V, 2, amg, limits));
  // The largest mesh it names fits, and one a little larger does not.
  const size_t at = ways.find("at most about ");
  CHECK(at != std::string::npos);
  const long long most = std::atoll(ways.c_str() + at + 14);
  CHECK(run_fits(most, 2, plan, limits) && !run_fits(most * 101 / 100, 2, plan, limits));
  // AMG at 1 rank of 2 GB: only more ranks (its share) help; at 1 GB not even they: the whole mesh
  // on rank 0 while it is distributed needs 1.7 GB.
  const std::vector<double> small(1, 2048 * MB);
  CHECK(!run_fits(V, 1, amg, small));
  CHECK_MSG(contains(ways_out(V, 1, amg, small), "more ranks (4 at"), ways_out(V, 1, amg, small));
  CHECK(!contains(ways_out(V, 1, amg, {1024 * MB}), "more ranks"));
  // Newton and the chain's factors: each alone, or all together.
  SolverSpec chain;
  const MemoryPlan full = memory_plan(chain);
  const int64_t W = 200000;
  const std::vector<double> roomy(2, estimated_rank_memory(W, 2, 0, plan).total() * 1.5);
  const std::string both = ways_out(W, 2, full, roomy);
  CHECK_MSG(contains(both, "solver.newton_fallback: false") || contains(both, "all of"), both);
  CHECK(run_fits(W, 2, plan, roomy) && !run_fits(W, 2, full, roomy));
  // Unknown limits: no check.
  CHECK(run_fits(V, 2, plan, {0.0, 0.0}));
}

void test_limit(int size) {
  setenv("HYPERQN_MEMORY_LIMIT_MB", "1234", 1);
  MemoryLimit l = rank_memory_limit(MPI_COMM_WORLD);
  CHECK(l.from_environment && l.bytes == 1234 * MB);  // per rank, whatever the ranks
  CHECK(l.node_ranks == size);                         // every test rank is on this node
  CHECK(contains(describe_limit(l), "HYPERQN_MEMORY_LIMIT_MB"));
  setenv("HYPERQN_MEMORY_LIMIT_MB", "lots", 1);
  bool refused = false;
  try {
    rank_memory_limit(MPI_COMM_WORLD);
  } catch (const InputError& e) {
    refused = contains(e.what(), "HYPERQN_MEMORY_LIMIT_MB") && contains(e.what(), "'lots'");
  }
  CHECK(refused);
  unsetenv("HYPERQN_MEMORY_LIMIT_MB");
  l = rank_memory_limit(MPI_COMM_WORLD);
  CHECK(!l.from_environment && l.node_available > 0);
  CHECK_NEAR(l.bytes, l.node_available / size, 1);  // shared by the node's ranks
  CHECK_MSG(contains(describe_limit(l), "MemAvailable") && contains(describe_limit(l), std::to_string(size) + " rank(s)"),
            describe_limit(l));
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  test_paths();
  test_fallback_and_newton();
  test_resolved_h0();
  test_ways_out();
  test_limit(size);
  const int code = check::summary(rank == 0 ? "test_memory_estimate" : "test_memory_estimate (rank > 0)");
  MPI_Finalize();
  return code;
}

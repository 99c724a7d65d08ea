// What an L-BFGS direction costs besides H0 (docs/performance.md#what-stops-scaling-first): PETSc 3.18's
// BFGS matrix as TAOLMVM drives it (MatLMVMUpdate, then MatSolve) against solver.two_loop streamed
// (solvers/streamed_two_loop.hpp, behind TAO's BFGS matrix with no pairs of its own, as
// LbfgsSolver sets it up), in one process, rounds in turn. H0 is the identity (a copy), so only
// the vector work is timed. The iterates: g = D x on a diagonal D in [1, 10], x <- x - 0.05 d with
// each variant's own direction, the pairs forgotten every 30 iterations (about a hair84k step) as TAO does at each
// step's start. Prints CPU ms per iteration (median of -rounds) for each length n.
// Run: build/two_loop_bench [-lengths 266910,77568,67446] [-pairs 5] [-iterations 120] [-rounds 5]
// (not -history: PETSc takes that as a file to write its log to)
#include <petsctao.h>

#include <ctime>
#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "solvers/streamed_two_loop.hpp"

using namespace hyperqn;

namespace {

PetscErrorCode copy_solve(Mat, Vec b, Vec x) { return VecCopy(b, x); }

// The process's CPU time: on a shared machine a descheduled process's wall time would be counted too.
PetscErrorCode cpu_seconds(PetscLogDouble* t) {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  *t = ts.tv_sec + 1e-9 * ts.tv_nsec;
  return 0;
}

PetscErrorCode identity(MPI_Comm comm, Vec layout, Mat* h0) {
  PetscInt n, N;
  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(layout, &n));
  PetscCall(VecGetSize(layout, &N));
  PetscCall(MatCreateShell(comm, n, n, N, N, nullptr, h0));
  PetscCall(MatShellSetOperation(*h0, MATOP_SOLVE, (void (*)(void))copy_solve));
  PetscFunctionReturn(0);
}

struct Variant {
  Mat bfgs = nullptr;
  Vec x = nullptr, g = nullptr, d = nullptr;
};

// One variant's run of `iterations`: returns ms per iteration of MatLMVMUpdate + MatSolve.
PetscErrorCode run(Tao tao, Variant& v, Vec diag, int iterations, int frame, double* ms) {
  PetscLogDouble t0, t1, total = 0;
  PetscFunctionBeginUser;
  PetscCall(VecSet(v.x, 1.0));
  PetscCall(TaoSetSolution(tao, v.x));
  for (int it = 0; it < iterations; ++it) {
    PetscCall(VecPointwiseMult(v.g, diag, v.x));
    PetscCall(TaoSetIterationNumber(tao, it % frame));
    PetscCall(cpu_seconds(&t0));
    if (it % frame == 0) PetscCall(MatLMVMReset(v.bfgs, PETSC_FALSE));
    PetscCall(MatLMVMUpdate(v.bfgs, v.x, v.g));
    PetscCall(MatSolve(v.bfgs, v.g, v.d));
    PetscCall(cpu_seconds(&t1));
    total += t1 - t0;
    PetscCall(VecAXPY(v.x, -0.05, v.d));
  }
  *ms = 1e3 * total / iterations;
  PetscFunctionReturn(0);
}

PetscErrorCode bench(PetscInt n, int history, int iterations, int rounds) {
  MPI_Comm comm = PETSC_COMM_WORLD;
  Vec layout, diag;
  Mat h0;
  Tao tao;
  Variant petsc, streamed;
  PetscFunctionBeginUser;
  PetscCall(VecCreateMPI(comm, PETSC_DECIDE, n, &layout));
  PetscCall(VecDuplicate(layout, &diag));
  PetscRandom rand;
  PetscCall(PetscRandomCreate(comm, &rand));
  PetscCall(PetscRandomSetInterval(rand, 1.0, 10.0));
  PetscCall(VecSetRandom(diag, rand));
  PetscCall(PetscRandomDestroy(&rand));
  PetscCall(identity(comm, layout, &h0));
  PetscCall(TaoCreate(comm, &tao));
  PetscCall(TaoSetType(tao, TAOLMVM));
  StreamedTwoLoop two_loop(tao, h0, history);
  PetscCall(two_loop.setup(layout));
  for (Variant* v : {&petsc, &streamed}) {
    PetscCall(VecDuplicate(layout, &v->x));
    PetscCall(VecDuplicate(layout, &v->g));
    PetscCall(VecDuplicate(layout, &v->d));
    // As TAOLMVM makes its matrix: the history is an option read before the matrix is allocated
    // (MatLMVMSetHistorySize ignores 0 in 3.18, and resizing an allocated matrix crashes).
    const bool own = v == &petsc;
    PetscCall(MatCreate(comm, &v->bfgs));
    PetscCall(MatSetType(v->bfgs, MATLMVMBFGS));
    PetscCall(MatSetSizes(v->bfgs, PETSC_DECIDE, PETSC_DECIDE, n, n));
    PetscCall(MatSetOptionsPrefix(v->bfgs, own ? "petsc_" : "streamed_"));
    PetscCall(PetscOptionsSetValue(nullptr, own ? "-petsc_mat_lmvm_hist_size" : "-streamed_mat_lmvm_hist_size",
                                   own ? std::to_string(history).c_str() : "0"));
    PetscCall(MatSetFromOptions(v->bfgs));
    PetscCall(MatLMVMAllocate(v->bfgs, v->x, v->g));
    PetscCall(MatLMVMSetJ0(v->bfgs, v == &petsc ? h0 : two_loop.operator_mat()));
  }
  std::vector<double> a, b;
  for (int r = 0; r < rounds; ++r) {
    double ms;
    PetscCall(run(tao, petsc, diag, iterations, 30, &ms));
    a.push_back(ms);
    PetscCall(run(tao, streamed, diag, iterations, 30, &ms));
    b.push_back(ms);
  }
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  PetscCall(PetscPrintf(comm, "| %" PetscInt_FMT " | %d | %.3f | %.3f | %.2f |\n", n, history, a[rounds / 2],
                        b[rounds / 2], b[rounds / 2] / a[rounds / 2]));
  for (Variant* v : {&petsc, &streamed}) {
    PetscCall(MatDestroy(&v->bfgs));
    PetscCall(VecDestroy(&v->x));
    PetscCall(VecDestroy(&v->g));
    PetscCall(VecDestroy(&v->d));
  }
  PetscCall(TaoDestroy(&tao));
  PetscCall(MatDestroy(&h0));
  PetscCall(VecDestroy(&diag));
  PetscCall(VecDestroy(&layout));
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  char lengths[256] = "266910,77568,67446";
  PetscInt history = 5, iterations = 120, rounds = 5;
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-lengths", lengths, sizeof lengths, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-pairs", &history, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-iterations", &iterations, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-rounds", &rounds, nullptr));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| n | history | PETSc BFGS ms/it | streamed ms/it | streamed/PETSc |\n|---|---|---|---|---|\n"));
  std::stringstream list(lengths);
  for (std::string item; std::getline(list, item, ',');)
    PetscCall(bench(std::stol(item), (int)history, (int)iterations, (int)rounds));
  PetscCall(PetscFinalize());
  return 0;
}

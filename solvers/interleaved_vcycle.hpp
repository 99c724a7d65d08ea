// One V-cycle of A = A1 (x) I3 applied to a dof vector (x, y, z interleaved per vertex) in one
// pass, built from the multigrid hierarchy PETSc's GAMG made for the scalar matrix A1.
//
// Why: the V-cycle is bound by memory bandwidth, and A1's hierarchy is the same for x, y and z.
// Applied column by column (three V-cycles per A^{-1} b) it reads every level's matrix three
// times; here every level's matrix and prolongator is wrapped by PETSc's MAIJ (MatCreateMAIJ(M, 3):
// M (x) I3 on interleaved vectors, M's entries read once for the three components), so a V-cycle
// reads them once.
//
// The same operator B as GAMG's own cycle on each column: the same levels, prolongators P and
// restrictions P^T, the same smoother (Chebyshev in D^-1 A_l of GAMG's degree, with the
// eigenvalue bounds this class estimates and also gives GAMG's smoothers), and GAMG's own coarse
// solve, applied to each component. tests/test_assembly.cpp checks that both give B b to
// round-off. Symmetric positive definite as GAMG's cycle is.
//
// Only for GAMG with its default smoothers (Chebyshev + Jacobi): supported() says whether a set-up
// PC qualifies; with other options (-h0_pc_type hypre, -h0_mg_levels_pc_type sor,
// -h0_pc_mg_cycle_type w, ...) the V-cycle runs column by column.
#pragma once
#include <petscksp.h>

#include <vector>

namespace hyperqn {

class InterleavedVCycle {
 public:
  InterleavedVCycle() = default;
  ~InterleavedVCycle();
  InterleavedVCycle(const InterleavedVCycle&) = delete;
  InterleavedVCycle& operator=(const InterleavedVCycle&) = delete;

  // True if `pc` (set up) is GAMG (or PCMG) whose every smoother is Chebyshev with Jacobi.
  static PetscErrorCode supported(PC pc, PetscBool* ok);
  // Estimates each smoothed level's eigenvalue bounds, sets them on `pc`'s smoothers and builds
  // the interleaved cycle from `pc`'s levels. `pc` must stay alive: its coarse solve is used.
  PetscErrorCode setup(PC pc);
  // x = B b, b and x dof vectors (3 entries per row of A1, interleaved).
  PetscErrorCode apply(Vec b, Vec x) const;
  // The coarse level's solve on an interleaved vector (the cycle's PCSHELL calls it).
  PetscErrorCode coarse_solve(Vec b, Vec x) const;

 private:
  KSP ksp_ = nullptr;           // preonly with the PCMG over the MAIJ levels
  std::vector<Mat> owned_;      // the MAIJ wrappers, destroyed with this
  std::vector<Vec> inverse_diagonals_;  // per smoothed level: 1/diag(A_l), three times per row
  KSP coarse_ = nullptr;        // GAMG's coarse solver (borrowed)
  Vec coarse_in_ = nullptr, coarse_out_ = nullptr;  // one component on the coarse level
};

}  // namespace hyperqn

// Assembly of a parallel matrix whose entries are the same bits run after run at a fixed rank
// count. PETSc's MatAssemblyEnd adds the entries other ranks sent for a row in the order their
// messages arrive; once three or more ranks share a vertex, two of them send to one entry and
// its sum changes in the last bits from run to run (measured: M + h^2 L of the cube on a rope at
// 4 ranks differed on one rank in three of five runs, and lbfgs took other iteration counts).
// Here each rank adds its own contributions to its rows in the order the terms give them, sums
// those for other ranks' rows by itself, and sends each owner one value per entry; the owner
// adds them in the order of the sending ranks.
#pragma once
#include <petscmat.h>

#include <functional>

namespace hyperqn {

// Calls add(S) with a stand-in S of A's sizes that takes MatSetValues(S, .., ADD_VALUES) with
// global indices (negative ones ignored), then adds what it took into A in a fixed order and
// assembles A (MAT_FINAL_ASSEMBLY). A: preallocated, with room for every entry added (collective).
PetscErrorCode add_in_rank_order(Mat A, const std::function<PetscErrorCode(Mat)>& add);

}  // namespace hyperqn

// What a run says on the console besides its progress: an error goes to standard error (the
// progress, warnings and summary line to standard output), printed once by rank 0 of comm.
#pragma once
#include <petscsys.h>

#include <string>

namespace hyperqn {

// "hyperqn: error: <what>" on standard error. Collective on comm.
inline PetscErrorCode print_error(MPI_Comm comm, const std::string& what) {
  return PetscFPrintf(comm, PETSC_STDERR, "hyperqn: error: %s\n", what.c_str());
}

}  // namespace hyperqn

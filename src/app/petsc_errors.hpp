// PETSc errors while a scene is set up or run, said as a user reads them: PETSc's own message,
// and the option it is about (with its deck line when it came from the deck's petsc: section),
// instead of a stack trace. Most such errors are bad option values.
#pragma once
#include <petscsys.h>

#include <string>

#include "app/deck.hpp"

namespace hyperqn {

class PetscErrors {
 public:
  PetscErrors();   // from here on PETSc errors are recorded, not printed
  ~PetscErrors();  // PETSc's own handler again
  PetscErrors(const PetscErrors&) = delete;
  PetscErrors& operator=(const PetscErrors&) = delete;

  // e.g. "option -tao_ls_type (deck.yaml:12): PETSc: Unable to find requested TaoLineSearch type x"
  std::string describe(const Deck& deck) const;
  std::string describe() const;  // no deck (yet): every option counts as the command line's
  const std::string& message() const { return message_; }  // PETSc's, of the first error recorded

 private:
  static PetscErrorCode record(MPI_Comm, int, const char* function, const char*, PetscErrorCode, PetscErrorType type,
                               const char* message, void* ctx);
  std::string message_, function_;
};

}  // namespace hyperqn

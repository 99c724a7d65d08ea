// The constant SPD matrix A = M + h^2 L of a scene, assembled and factored once by MUMPS
// Cholesky, then applied as A^{-1} as often as needed (L-BFGS initial Hessian, PD global step).
#pragma once
#include <petscmat.h>

#include "time_step.hpp"

namespace hyperqn {

class FactoredSystem {
 public:
  FactoredSystem() = default;
  ~FactoredSystem();
  FactoredSystem(const FactoredSystem&) = delete;
  FactoredSystem& operator=(const FactoredSystem&) = delete;

  // Assembles A and computes its Cholesky factorization (the only factorization of a run).
  PetscErrorCode setup(const TimeStep& step);
  // x = A^{-1} b.
  PetscErrorCode solve(Vec b, Vec x) const;
  Mat matrix() const { return A_; }
  // A shell matrix whose MatSolve applies A^{-1} and whose MatMult applies A: the form
  // TaoLMVMSetH0 takes.
  Mat inverse_operator() const { return shell_; }

  int factorizations() const { return factorizations_; }
  double assembly_seconds() const { return assembly_s_; }
  double factor_seconds() const { return factor_s_; }
  PetscInt solves() const { return solves_; }
  double solve_seconds() const { return solve_s_; }

 private:
  Mat A_ = nullptr, factor_ = nullptr, shell_ = nullptr;
  int factorizations_ = 0;
  double assembly_s_ = 0, factor_s_ = 0;
  mutable PetscInt solves_ = 0;
  mutable double solve_s_ = 0;
};

}  // namespace hyperqn

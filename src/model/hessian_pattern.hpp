// Newton's Hessian holds couplings beyond the mesh's pattern when a term couples surfaces that come
// close (self-contact: EnergyTerm::add_couplings). HessianPattern makes room for them in one go,
// only when the terms' lists of them change, and remembers which matrix and lists it last saw.
#pragma once
#include <petscmat.h>

#include <array>
#include <vector>

#include "model/body.hpp"

namespace hyperqn {

class HessianPattern {
 public:
  // Makes room in H for the couplings the body's terms may add at x beyond the mesh's pattern
  // (Body::hessian_couplings): if they are not the ones H was made for, H is preallocated again
  // for the mesh's pattern and exactly these couplings, with explicit zeros at every entry, and
  // *grown counts it (collective).
  PetscErrorCode grow(const Body& body, Vec x, Mat H, long long* grown);

 private:
  // The Hessian grow last looked at, its nonzero state then and the couplings' generation: while
  // all three are the same, its pattern holds the couplings.
  struct {
    PetscObjectId id = -1;
    PetscObjectState state = 0;
    unsigned long long generation = 0;
  } seen_;
  // This rank's rows' vertex couplings (dof pairs, sorted) H was last made for: empty for a new H.
  std::vector<std::array<PetscInt, 2>> made_for_;
};

}  // namespace hyperqn

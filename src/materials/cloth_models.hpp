// The choices of a cloth's material (deck cloth:, model/material_spec.hpp), in the deck's order:
// the enums the deck is read into and the terms are built from (no PETSc, no Eigen).
#pragma once

namespace hyperqn {

// The membrane's energy density of the 3x2 deformation gradient (materials/membrane.hpp).
namespace membrane {
enum class Model { stvk, corotated, neohookean };
}

// Bending across the interior edges (terms/cloth_bending.hpp); none: no bending term.
enum class BendingModel { quadratic, dihedral, springs, none };

}  // namespace hyperqn

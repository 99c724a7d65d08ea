// A symmetric 3 x 3 matrix kept as 6 values, xx, yy, zz, xy, yz, xz: the order of the inelastic
// models' histories (C_v^{-1}, E_p) and of the output's symmetric tensors.
#pragma once
#include "materials/material.hpp"

namespace hyperqn {

inline Mat3 unpack_symmetric(const double* h) {
  Mat3 A;
  A << h[0], h[3], h[5], h[3], h[1], h[4], h[5], h[4], h[2];
  return A;
}

// A's symmetric part.
inline void pack_symmetric(const Mat3& A, double* h) {
  h[0] = A(0, 0);
  h[1] = A(1, 1);
  h[2] = A(2, 2);
  h[3] = 0.5 * (A(0, 1) + A(1, 0));
  h[4] = 0.5 * (A(1, 2) + A(2, 1));
  h[5] = 0.5 * (A(0, 2) + A(2, 0));
}

}  // namespace hyperqn

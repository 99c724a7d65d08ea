// Cofactor matrix cof(F) = dJ/dF (= J F^{-T} when J != 0) and its derivative d^2 J/dF^2.
// Used instead of F^{-1} by every J-dependent term: it is polynomial in F, so it is defined and
// smooth at J = 0 and for inverted F. Header-only (shared by Neo-Hookean, StVK and the tests).
#pragma once
#include "materials/material.hpp"

namespace hyperqn {

// Columns of cof(F) are cross products of the other two columns of F.
inline Mat3 cofactor(const Mat3& F) {
  Mat3 C;
  C.col(0) = F.col(1).cross(F.col(2));
  C.col(1) = F.col(2).cross(F.col(0));
  C.col(2) = F.col(0).cross(F.col(1));
  return C;
}

// The same for a batch (materials/lanes.hpp): C = cof(F) component by component (column-major,
// as StressBatch), and J = det F = F(:, 0) . cof(:, 0). (Out-parameters: a vector of 8 doubles
// returned by value would change the calling convention between the x86-64 and AVX clones.)
inline void cofactor_lanes(const Lanes* F, Lanes* C, Lanes& J) {
  for (int a = 0; a < 3; ++a) {  // cof(:, a) = F(:, a + 1) x F(:, a + 2)
    const int p = 3 * ((a + 1) % 3), q = 3 * ((a + 2) % 3);
    C[3 * a] = F[p + 1] * F[q + 2] - F[p + 2] * F[q + 1];
    C[3 * a + 1] = F[p + 2] * F[q] - F[p] * F[q + 2];
    C[3 * a + 2] = F[p] * F[q + 1] - F[p + 1] * F[q];
  }
  J = F[0] * C[0] + F[1] * C[1] + F[2] * C[2];
}

// Levi-Civita symbol.
inline double levi_civita(int i, int j, int k) { return 0.5 * (i - j) * (j - k) * (k - i); }

// d cof(F) / dF = d^2 J / dF^2 (9x9, linear in F): d cof_ij / d F_kl = sum_mn e_ikm e_jln F_mn.
// Each entry has exactly one nonzero term, so the matrix is exactly symmetric.
inline Mat9 cofactor_derivative(const Mat3& F) {
  Mat9 D = Mat9::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) {
          if (i == k || j == l) continue;
          const int m = 3 - i - k, n = 3 - j - l;
          D(i + 3 * j, k + 3 * l) = levi_civita(i, k, m) * levi_civita(j, l, n) * F(m, n);
        }
  return D;
}

}  // namespace hyperqn

// Signed ("rotation-variant") SVD of a 3x3 deformation gradient and the assembly of dP/dF for
// isotropic energies written in its singular values. Header-only: the build lists no svd3.cpp.
#pragma once
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>

#include "materials/cofactor.hpp"
#include "materials/material.hpp"

namespace hyperqn {

// F = U diag(sigma) V^T with U, V proper rotations. |sigma_1| >= |sigma_2| >= |sigma_3|, sigma_1,2 >= 0,
// and sigma_3 < 0 exactly when det F < 0 (so inversion shows up in the singular values, not in U or V).
struct SignedSVD {
  Mat3 U, V;
  Vec3 sigma;
  Mat3 rotation() const { return U * V.transpose(); }  // R of the polar decomposition F = R S
};

// The robust path: Jacobi SVD (any F, including inverted and singular ones).
inline SignedSVD signed_svd_jacobi(const Mat3& F) {
  // A square 3x3 needs no QR preconditioning.
  Eigen::JacobiSVD<Mat3, Eigen::NoQRPreconditioner> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  SignedSVD s{svd.matrixU(), svd.matrixV(), svd.singularValues()};
  // Move each reflection into the smallest singular value so that U and V become rotations.
  if (s.U.determinant() < 0) {
    s.U.col(2) *= -1.0;
    s.sigma(2) *= -1.0;
  }
  if (s.V.determinant() < 0) {
    s.V.col(2) *= -1.0;
    s.sigma(2) *= -1.0;
  }
  return s;
}

// F = U diag(sigma) V^T as above. For well-conditioned, non-inverted F (the common case) it uses
// the closed-form eigen-decomposition of F^T F (several times faster than Jacobi: the corotated
// energy's cost was dominated by the SVD), U = F V diag(1/sigma); otherwise, and whenever that
// U is not a rotation to round-off, the Jacobi SVD.
inline SignedSVD signed_svd(const Mat3& F) {
  const double J = F.determinant();
  const double scale = F.squaredNorm();
  if (J > 0 && J * J > 1e-9 * scale * scale * scale) {
    Eigen::SelfAdjointEigenSolver<Mat3> eig;
    eig.computeDirect(F.transpose() * F);  // eigenvalues ascending
    const Vec3 lambda = eig.eigenvalues();
    if (lambda(0) > 1e-6 * lambda(2)) {
      SignedSVD s;
      for (int k = 0; k < 3; ++k) {  // descending, like the Jacobi SVD
        s.sigma(k) = std::sqrt(lambda(2 - k));
        s.V.col(k) = eig.eigenvectors().col(2 - k);
      }
      if (s.V.determinant() < 0) s.V.col(2) *= -1.0;
      s.U = F * s.V * s.sigma.cwiseInverse().asDiagonal();
      if ((s.U.transpose() * s.U - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-12) return s;
    }
  }
  return signed_svd_jacobi(F);
}

// R of the signed polar decomposition F = R S: the rotation nearest F, equal to signed_svd(F).rotation()
// up to round-off, det R = +1 also for inverted F. For det F > 0 and cond(F) < 100 (as
// ||F||_F ||F^-1||_F = ||F|| ||cof F|| / det F), Newton's iteration X <- (X + X^{-T}) / 2 from X = F,
// X^{-T} = cof(X) / det X: it keeps the singular vectors and maps each singular value s to
// (s + 1/s) / 2, so X -> U V^T quadratically from any such F (no state, no start guess). After one
// step every s >= 1, so det X - 1 >= sum (s - 1) bounds the error, and det X is needed for the next
// step anyway: once it is <= 1e-8, one more step leaves an error <= (1e-8)^2 / 2, below round-off.
// That is 3 or 4 steps for strains of 1-5%, about 4 + |log2 s| for a singular value s far from 1.
// The rounding of the first cof(F) puts up to about cond(F) * 2.5e-17 into R (measured), hence the bound. For
// det F <= 0 the iteration would converge to the reflection U diag(1, 1, -1) V^T (unsigned SVD);
// those F, worse conditioned ones and any not converged in kPolarMaxSteps take the Jacobi SVD, which
// puts the reflection in sigma_3 (and is accurate for every F, unlike the eigen path of signed_svd).
constexpr int kPolarMaxSteps = 24;
inline Mat3 signed_polar_rotation(const Mat3& F) {
  Mat3 X = F, C = cofactor(F);
  double det = F.col(0).dot(C.col(0));  // det X = x_0 . cof(X)_0
  if (det > 0 && F.squaredNorm() * C.squaredNorm() < 1e4 * det * det) {
    for (int k = 0; k < kPolarMaxSteps; ++k) {
      X = 0.5 * X + (0.5 / det) * C;
      C = cofactor(X);
      det = X.col(0).dot(C.col(0));
      if (det - 1.0 <= 1e-8) return 0.5 * X + (0.5 / det) * C;
    }
  }
  return signed_svd_jacobi(F).rotation();
}

// Index of F(i,j) in vec(F) (column-major).
constexpr int vec_index(int i, int j) { return i + 3 * j; }

// The three off-diagonal pairs (i,j), i < j, in the order used by the pair coefficient arrays below.
constexpr int kPairI[3] = {0, 0, 1};
constexpr int kPairJ[3] = {1, 2, 2};

// dP/dF of psi(F) = Psi(sigma) for an isotropic Psi of the signed singular values.
// In the rotated frame F_hat = U^T F V = diag(sigma) the Hessian decouples (Teran et al. 2005,
// "Robust quasistatic finite elements"):
//  - the diagonal entries F_hat(i,i) couple through d2psi = d^2 Psi / d sigma^2 (3x3);
//  - each pair (F_hat(i,j), F_hat(j,i)) is a 2x2 block with eigenvector (1,1)/sqrt2 (symmetric
//    stretch) of eigenvalue sym[k] = (Psi_i - Psi_j)/(sigma_i - sigma_j), and eigenvector
//    (1,-1)/sqrt2 (rotation) of eigenvalue skew[k] = (Psi_i + Psi_j)/(sigma_i + sigma_j).
// The caller supplies sym/skew so it can take the limits sigma_i -> sigma_j analytically.
// Then dP/dF = W H_hat W^T with W = V (x) U, since vec(U X V^T) = (V (x) U) vec(X).
inline Mat9 isotropic_stress_derivative(const SignedSVD& s, const Mat3& d2psi, const Vec3& sym,
                                        const Vec3& skew) {
  Mat9 H = Mat9::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) H(vec_index(i, i), vec_index(j, j)) = d2psi(i, j);
  for (int k = 0; k < 3; ++k) {
    const int a = vec_index(kPairI[k], kPairJ[k]), b = vec_index(kPairJ[k], kPairI[k]);
    H(a, a) = H(b, b) = 0.5 * (sym(k) + skew(k));
    H(a, b) = H(b, a) = 0.5 * (sym(k) - skew(k));
  }
  Mat9 W;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) W.block<3, 3>(3 * i, 3 * j) = s.V(i, j) * s.U;
  Mat9 dPdF = W * H * W.transpose();
  return 0.5 * (dPdF + dPdF.transpose());  // exact Hessian is symmetric; remove round-off asymmetry
}

}  // namespace hyperqn

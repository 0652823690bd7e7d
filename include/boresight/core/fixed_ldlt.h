// LDL^T factorisation and solve of a small fixed-size symmetric positive-definite matrix, column by
// column, no pivoting, plain loops. The core uses this instead of Eigen's LDLT where a solve with
// several right-hand sides would take Eigen's blocked triangular solve, which links function-local
// statics and exception symbols (test/core/check_core_symbols.cmake). Without pivoting the
// factorisation of an SPD matrix is backward stable (as Cholesky); it agrees with Eigen's pivoted
// LDLT to rounding (thermal_test: random SPD matrices, condition numbers up to 1e8).
#pragma once

#include <Eigen/Core>

#include <cmath>

namespace boresight::core {

/// M = L D L^T (L unit lower triangular; only M's lower triangle is read). false when a pivot is not
/// positive and finite (M not positive definite, or not finite): L and D are then unspecified.
template <int N>
bool ldltFactor(const Eigen::Matrix<double, N, N>& M, Eigen::Matrix<double, N, N>& L, Eigen::Matrix<double, N, 1>& D) {
  L.setIdentity();
  for (int j = 0; j < N; ++j) {
    double d = M(j, j);
    for (int k = 0; k < j; ++k) d -= L(j, k) * L(j, k) * D[k];
    if (!(d > 0) || !std::isfinite(d)) return false;
    D[j] = d;
    const double inv = 1.0 / d;
    for (int i = j + 1; i < N; ++i) {
      double v = M(i, j);
      for (int k = 0; k < j; ++k) v -= L(i, k) * L(j, k) * D[k];
      L(i, j) = v * inv;
    }
  }
  return true;
}

/// x <- M^-1 x from ldltFactor's L and D (forward, diagonal, backward substitution).
template <int N>
void ldltSolveInPlace(const Eigen::Matrix<double, N, N>& L, const Eigen::Matrix<double, N, 1>& D,
                      Eigen::Matrix<double, N, 1>& x) {
  for (int i = 1; i < N; ++i)
    for (int k = 0; k < i; ++k) x[i] -= L(i, k) * x[k];
  for (int i = 0; i < N; ++i) x[i] /= D[i];
  for (int i = N - 2; i >= 0; --i)
    for (int k = i + 1; k < N; ++k) x[i] -= L(k, i) * x[k];
}

}  // namespace boresight::core

// Internal to the calibration library: temporal and spatial whitening of each head's epochs.
//
// The CRN acceleration noise of one head is stationary (white attitude noise through a fixed kernel),
// so the noise of its decimated epochs k, m has covariance rho(|t_k - t_m| / D) Sigma (Sigma the
// epoch's 3x3 covariance, rho = CalibrationSpan::noise_correlation, zero beyond its length). With the
// banded Cholesky factor L of the correlation matrix (band = the length of rho minus one; the noise
// library's model::BandedWhitener), the
// sequences z = L^-1 x of every data column (alpha_S, alpha_A, jerk_A and the constant 1 that carries
// the bias) are uncorrelated in time; the model is linear in those columns, so the residual of the
// whitened columns is the whitened residual. Spatial: the epoch's covariance (head noise plus the
// accelerometer's rotated into the head frame with the nominal C_Sh_A) gives sqrt_info.
// Approximation: one correlation for both terms (the accelerometer's is about 1e-4 of the variance).
#pragma once

#include "boresight/calib/problem.h"

#include <vector>

namespace boresight::calib {

struct WhitenedRow {
  Vec3 zS = Vec3::Zero(), zA = Vec3::Zero(), zJ = Vec3::Zero();
  double zc = 1.0;
  Mat3 sqrt_info = Mat3::Identity();  ///< U with U^T U = the epoch's inverse covariance
  std::size_t obs = 0;                ///< index into span.obs
};

struct Whitened {
  std::array<std::vector<WhitenedRow>, kMaxHeads> rows;
};

/// C_Sh_A by slot (nominal), rho as in CalibrationSpan::noise_correlation ({1} = independent epochs).
/// reject (optional, one byte per observation): bit h set leaves head h of that epoch out (an outlier:
/// left out before the whitening, so that it does not leak into its neighbours; the correlation of the
/// remaining epochs follows their time lags).
Whitened whiten(const CalibrationSpan& span, const std::array<Mat3, kMaxHeads>& C_S_A, const std::vector<double>& rho,
                const std::vector<std::uint8_t>* reject = nullptr);

}  // namespace boresight::calib

// boresight::calib - the method A solver (METHODS 1.7): Ceres over a CalibrationSpan, with the
// relative attitude as a hard constraint or a prior, optional accelerometer bias / scale /
// non-orthogonality and a star-camera-to-accelerometer time offset, the covariance, the Fisher
// information of the same model (Cramer-Rao bound) and the observability of every head axis.
//
// Contract owned by the solver; the CLI (`boresight calibrate`) only reads the result.
#pragma once

#include "boresight/calib/problem.h"

#include <optional>
#include <string>
#include <vector>

namespace boresight::calib {

enum class RelativeMode { kHardConstraint, kPrior };

struct SolveOptions {
  RelativeMode relative = RelativeMode::kHardConstraint;
  bool estimate_acc_bias = true;
  bool estimate_acc_scale = false;
  bool estimate_acc_nonorthogonality = false;
  bool estimate_time_offset = false;
  double huber_sigma = 5.0;           ///< robust loss threshold in whitened residual units (0 = none)
  int max_iterations = 50;
  int threads = 1;                    ///< Ceres threads (1 = deterministic)
  /// A direction is "not determined" when its information gives a sigma above this, arcsec.
  double unobservable_sigma_arcsec = 3600.0;
};

/// One estimated quantity with its sigma; sigma is empty when not determined (never a small number).
struct Estimate3 {
  std::array<double, 3> value{};
  std::array<std::optional<double>, 3> sigma{};
};

struct HeadResult {
  int id = 0;
  std::array<double, 3> error_angles_arcsec{};             ///< r in S_h
  std::array<std::optional<double>, 3> sigma_arcsec{};     ///< empty where not determined
  std::array<double, 3> crlb_arcsec{};                     ///< Cramer-Rao bound (inf where not determined)
  std::array<bool, 3> observable{};
};

struct SolveResult {
  bool ok = false;
  std::string message;                            ///< why not ok, or the solver's summary line
  std::vector<HeadResult> heads;
  std::vector<Vec3> unobservable_directions_B;    ///< unit vectors, shared by all heads
  std::vector<double> covariance_arcsec2;         ///< all head angles, (3n x 3n) row-major
  std::optional<Estimate3> acc_bias_radps2, acc_scale, acc_nonorthogonality_arcsec;
  std::optional<double> time_offset_s, time_offset_sigma_s;  ///< + : accelerometer tags late
  double residual_rms_radps2 = 0.0;
  std::size_t epochs = 0;
  double span_s = 0.0;
  std::vector<double> excitation_eigenvalues;     ///< of sum a a^T in B, ascending, rad^2/s^4
};

/// Refuses (ok = false, message says why and what would be needed) a span too short or too quiet.
SolveResult solve(const CalibrationSpan& span, const SolveOptions& opt);

}  // namespace boresight::calib

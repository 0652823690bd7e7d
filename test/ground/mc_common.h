// Monte Carlo over simulated method C measurements: seed and refined errors against the truth, the
// refined covariance's consistency (NEES), the observability flags. Used by the small MC in ctest
// (ground_mc_test) and by the bench tool (ground_mc_bench).
#pragma once

#include <boresight/core/rotation.h>
#include <boresight/ground/simulate.h>
#include <boresight/ground/solver.h>

#include <chrono>
#include <cmath>
#include <string>

namespace boresight::ground::mc {

struct Stats {
  int runs = 0, failures = 0;
  Vec3 seed_mean = Vec3::Zero(), seed_rms = Vec3::Zero();  ///< arcsec, sensor axes
  Vec3 ref_mean = Vec3::Zero(), ref_rms = Vec3::Zero();
  Vec3 mean_sigma = Vec3::Zero();   ///< mean reported 1-sigma, arcsec
  Vec3 mean_hidden = Vec3::Zero();  ///< mean reported hidden tilt, arcsec
  double nees = 0;                  ///< mean of err^T P^-1 err (3 for a consistent 3-D estimate)
  int not_separated[3] = {0, 0, 0}; ///< runs in which each bias axis was flagged
  Vec3 bias_err_rms_ug = Vec3::Zero();
  double solve_ms = 0;              ///< mean wall time of solveGround
  std::string first_error;
};

/// `runs` measurements of set-up `setup` (simulate.h names) with seeds first_seed.. and the fixed
/// bias `bias_ug` (IMU axes).
inline Stats run(const std::string& setup, int runs, std::uint64_t first_seed, const Vec3& bias_ug,
                 int targets = 40, int accel_samples = 2000) {
  Stats s;
  const double as = kArcsecPerRad, ug = 9.80665e-6;
  for (int i = 0; i < runs; ++i) {
    SimConfig cfg;
    applySetup(setup, cfg);
    cfg.seed = first_seed + static_cast<std::uint64_t>(i);
    cfg.fixed_bias = true;
    cfg.bias_ug = bias_ug;
    cfg.targets = targets;
    cfg.accel_samples = accel_samples;
    Measurement m;
    SimTruth truth;
    GroundResult r;
    std::string err;
    if (!simulateGround(cfg, m, truth, &err)) {
      ++s.failures;
      if (s.first_error.empty()) s.first_error = err;
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const bool ok = solveGround(m, RefineOptions{}, r, &err);
    s.solve_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (!ok) {
      ++s.failures;
      if (s.first_error.empty()) s.first_error = err;
      continue;
    }
    // errors as rotation vectors in sensor axes: Log(C_est C_true^T)
    const Mat3 C_true = truth.q_s_t.toRotationMatrix();
    const Vec3 es = core::so3Log(r.seed.C_s_t * C_true.transpose());
    const Vec3 er = core::so3Log(r.C_s_t * C_true.transpose());
    s.seed_mean += es * as;
    s.seed_rms += (es * as).cwiseAbs2();
    s.ref_mean += er * as;
    s.ref_rms += (er * as).cwiseAbs2();
    s.mean_sigma += r.error_cov_rad2.diagonal().cwiseSqrt() * as;
    s.mean_hidden += r.hidden_tilt_rad * as;
    s.nees += er.dot(r.error_cov_rad2.ldlt().solve(er));
    for (int j = 0; j < 3; ++j) s.not_separated[j] += r.bias_observable[j] ? 0 : 1;
    s.bias_err_rms_ug += ((r.bias_mps2 - truth.bias_mps2) / ug).cwiseAbs2();
    ++s.runs;
  }
  if (s.runs > 0) {
    const double n = s.runs;
    s.seed_mean /= n;
    s.ref_mean /= n;
    s.seed_rms = (s.seed_rms / n).cwiseSqrt();
    s.ref_rms = (s.ref_rms / n).cwiseSqrt();
    s.mean_sigma /= n;
    s.mean_hidden /= n;
    s.nees /= n;
    s.bias_err_rms_ug = (s.bias_err_rms_ug / n).cwiseSqrt();
  }
  if (s.runs + s.failures > 0) s.solve_ms /= (s.runs + s.failures);
  return s;
}

}  // namespace boresight::ground::mc

// truth.yaml: everything behind a simulated data set, written by `boresight simulate` and read back
// (by the audit's --truth, by tests) into the same specs and sensor configurations.
//
// Keys (angles in arcseconds unless the key names another unit; quaternions scalar first; q_Si_B maps
// body to head; C_B_A maps accelerometer-frame vectors to the body; times in seconds since the start):
//   scenario, seed, satellite, start_gps_us, start_date_gps, duration_s, effect_args
//   effects[]        name, sensor, origin and every parameter of the spec (defaults filled in); read
//                    back through model::makeEffect, so the specs equal the simulated ones
//   orbit            type, altitude_km, inclination_deg, raan_deg, arg_latitude_deg, j2_nodal_precession,
//                    gnv1b_file (the scenario's keys)
//   attitude         the scenario's attitude keys (step_s ... manoeuvres[]), thruster_pulses,
//                    max_abs_angular_acceleration_rad_s2
//   mounting_error_sigma_arcsec
//   heads[]          id, q_Si_B_nominal, q_Si_B_true, mounting_error_arcsec (the drawn part included),
//                    relative_misalignment_arcsec, boresight, noise_cross_arcsec / noise_about_arcsec
//                    (effective, after cross_noise / anisotropic_noise), noise {configured_cross_arcsec,
//                    configured_about_arcsec, star_arcsec}, time_offset_s (sum of time_offset specs),
//                    clock_drifts[] {offset_s, rate_ppm, start_s}, rate_hz, tags {offset_us, jitter_us,
//                    drift_ppm}, geometry {fov_half_angle_deg, limiting_magnitude, sun/earth/moon_exclusion_deg},
//                    samples_written, blinded_sun/earth/moon, missing_gaps_dropouts, outliers, sign_flips,
//                    events {outlier_probability, sign_flip_probability, expected_random_missing_fraction,
//                    missing_runs, missing_intervals_s [[start, end], ...] (only when missing_runs <= 500)},
//                    and only when the effect is on (so older files and clean runs are unchanged):
//                    coloured_noise / thermal_wander {cross: [TERM...], about: [TERM...], realised_rms_arcsec
//                    [e1, e2, b]}, TERM = {kind: gauss_markov, sigma_arcsec, tau_s} or {kind: power_law,
//                    sigma_arcsec, alpha, f_lo_hz, f_hi_hz} (one per spec, in spec order);
//                    fov_error {fields: [{order, rms_arcsec, cx_arcsec: [...], cy_arcsec: [...]}] (the drawn
//                    coefficients, model/sensors.h FovErrorField), realised_rms_arcsec [e1, e2, b],
//                    realised_mean_arcsec [e1, e2, b] (the mean acts as a relative misalignment)}
//   accelerometer    C_B_A_nominal, C_B_A_true, misalignment_arcsec, bias_rad_s2 (nominal + injected),
//                    nominal_bias_rad_s2, injected_bias_rad_s2, scale_error, white_noise_rad_s2,
//                    lowfreq_noise_rad_s2, lowfreq_tau_s, lin_bias_m_s2, lin_white_noise_m_s2, rate_hz,
//                    tags {...}, time_offset_s, clock_drifts[], samples_written, missing_gaps,
//                    events {expected_random_missing_fraction, missing_runs, missing_intervals_s}, and when on:
//                    coloured_noise / bias_wander {x: [TERM...], y: [...], z: [...], realised_rms_rad_s2},
//                    TERM with sigma_rad_s2 in place of sigma_arcsec
//   files
#pragma once

#include <boresight/model/effects.h>
#include <boresight/model/sensors.h>
#include <boresight/sim/attitude.h>
#include <boresight/sim/orbit.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace boresight::sim {

class Simulator;

/// truth.yaml (keys above) for a finished run: effect_args are the --effect strings, files the
/// products written.
bool writeTruthYaml(const std::string& path, const Simulator& sim, const std::vector<std::string>& effect_args,
                    const std::vector<std::string>& files, std::string* error);

struct TruthHead {
  /// The head as simulated: id, q_Si_B (nominal), mounting_error_rad (the drawn part included),
  /// boresight, configured noise (sigma_cross_rad, sigma_roll_rad, sigma_star_rad), rate, tags
  /// (tag_offset_us, tag_jitter_us, tag_drift_ppm), FOV, limiting magnitude and exclusion cones.
  model::HeadConfig config;
  Quat q_Si_B_true = Quat::Identity();
  Vec3 relative_misalignment_rad = Vec3::Zero();
  double sigma_cross_rad = 0, sigma_about_rad = 0;  ///< effective noise levels
  double time_offset_s = 0;
  std::vector<model::ClockDriftTerm> clock_drifts;
  std::uint64_t samples = 0, blinded_sun = 0, blinded_earth = 0, blinded_moon = 0, missing = 0, outliers = 0,
                sign_flips = 0, missing_runs = 0;
  double outlier_probability = 0, sign_flip_probability = 0, expected_random_missing_fraction = 0;
  std::vector<model::Interval> missing_intervals;  ///< empty when missing_runs exceeds the recorded limit
  /// coloured_noise and thermal_wander models (rad), the fov_error fields, and the realised RMS of each
  /// over the delivered samples (head axes e1, e2, b; rad). Empty / zero when the effect is off.
  model::NoiseModel coloured_cross, coloured_about, wander_cross, wander_about;
  std::vector<model::FovErrorField> fov_fields;
  Vec3 coloured_rms_rad = Vec3::Zero(), wander_rms_rad = Vec3::Zero(), fov_rms_rad = Vec3::Zero();
  Vec3 fov_mean_rad = Vec3::Zero();
};

struct TruthAccel {
  /// As simulated: rate, tags, C_A_B (nominal), noise (white, Gauss-Markov sigma and tau, linear),
  /// nominal bias, linear bias.
  model::AccelConfig config;
  Mat3 C_B_A_true = Mat3::Identity();
  Vec3 misalignment_rad = Vec3::Zero(), injected_bias_rad_s2 = Vec3::Zero(), scale = Vec3::Zero();
  double time_offset_s = 0;
  std::vector<model::ClockDriftTerm> clock_drifts;
  std::uint64_t samples = 0, missing = 0, missing_runs = 0;
  double expected_random_missing_fraction = 0;
  std::vector<model::Interval> missing_intervals;
  /// acc_coloured_noise and acc_bias_wander per A axis (rad/s^2) and their realised RMS.
  std::array<model::NoiseModel, 3> coloured, bias_wander;
  Vec3 coloured_rms_rad_s2 = Vec3::Zero(), bias_wander_rms_rad_s2 = Vec3::Zero();
};

struct TruthFile {
  std::string scenario;
  std::uint64_t seed = 0;
  char satellite = 'C';
  TimeUs start = 0;
  double duration_s = 0;
  std::vector<std::string> effect_args, files;
  std::vector<model::EffectSpec> effects;  ///< rebuilt through model::makeEffect
  OrbitConfig orbit;
  AttitudeConfig attitude;
  double mounting_error_sigma_rad = 0;
  std::uint64_t thruster_pulses = 0;
  double max_abs_alpha = 0;
  std::vector<TruthHead> heads;
  TruthAccel acc;
  /// The head with this id, or nullptr.
  const TruthHead* head(int id) const;
};

/// Reads truth.yaml. On failure returns false with *error = "PATH:LINE: key 'k': reason".
bool readTruthYaml(const std::string& path, TruthFile& out, std::string* error);

}  // namespace boresight::sim

// Ground set-up simulator for method C: a vehicle (IMU + prism + star sensor, rigid) in one or more
// positions in the laboratory, theodolite 1 autocollimated on one or two prism faces, theodolite 2
// pointing collimated beams into the star sensor, the IMU's accelerometers at rest. The truth (the
// mounting, the bias, the intrinsics, every position's attitude) is returned beside the measurement.
//
// Noise model (1 sigma, defaults): theodolite direction 1.5" (isotropic: azimuth noise / cos e),
// centroid 0.05 px, accelerometer 50 ug per sample and axis, bias 100 ug per axis (drawn, or fixed),
// intrinsics drawn within the camera block's stated sigmas, mounting error 300" per axis.
// Deterministic for a seed (std::mt19937_64 bits turned into normals here, not by the library's
// distributions, so files agree across standard libraries).
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/ground/measurement.h>

#include <cstdint>
#include <string>
#include <vector>

namespace boresight::ground {

/// The default design mounting: boresight at 60 deg elevation and 30 deg azimuth in IMU axes.
Quat defaultDesign();

struct SimConfig {
  std::uint64_t seed = 1;
  int positions = 1;
  double turn_deg = 0.0;   ///< position k turned by k * turn_deg about the vertical
  double tilt_deg = 0.0;   ///< position k >= 1 tilted by tilt_deg about lab x (k odd) or lab y (k even)
  int prism_faces = 1;     ///< 1: IMU +x face; 2: +x and +y faces
  int targets = 40;        ///< per position
  int accel_samples = 2000;
  double centroid_sigma_px = 0.05;
  double theodolite_sigma_arcsec = 1.5;
  double accel_noise_ug = 50.0;       ///< per sample and axis
  double accel_bias_sigma_ug = 100.0; ///< used when !fixed_bias
  bool fixed_bias = false;
  Vec3 bias_ug = Vec3::Zero();        ///< the bias when fixed_bias
  double mounting_sigma_arcsec = 300.0;
  double level_sigma_deg = 0.1;       ///< how far from level and from azimuth 0 the vehicle stands
  bool draw_intrinsics = true;        ///< true intrinsics drawn within the prior's sigmas
  double true_k1 = 0.0;               ///< true radial distortion
  double gravity_mps2 = 9.80665;
  CameraPrior camera;                 ///< laboratory values written to the file (defaults of measurement.h)
  Quat q_s_t_design = defaultDesign();
};

struct SimTruth {
  Quat q_s_t = Quat::Identity();
  Vec3 error_angles_rad = Vec3::Zero();  ///< Log(C_s_t C_s_t(design)^T)
  Vec3 bias_mps2 = Vec3::Zero();
  Intrinsics camera;
  std::vector<Mat3> C_t_m;
};

/// Named set-ups (positions, turns, tilts, prism faces):
///   single     1 position, 1 prism face            (bias along the unreferenced axis NOT separated)
///   turned     3 positions turned 120 deg about the vertical, 1 face (NOT separated either)
///   two-faces  1 position, prism faces +x and +y     (separated)
///   tilted     3 positions: level, tilted 20 deg about lab x and about lab y, 1 face (separated)
/// Returns false for an unknown name.
bool applySetup(const std::string& name, SimConfig& cfg);
const char* setupNames();

/// Simulates one measurement. Returns false (with a reason) for an impossible configuration.
bool simulateGround(const SimConfig& cfg, Measurement& m, SimTruth& truth, std::string* error);

/// Writes the truth as YAML (q_s_t scalar first, error angles in arcsec, bias in m/s^2 and ug,
/// intrinsics, each position's q_t_m).
bool writeTruth(const std::string& path, const SimConfig& cfg, const SimTruth& truth, std::string* error);

}  // namespace boresight::ground

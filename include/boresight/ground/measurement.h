// The method C measurement file (YAML) as a plain struct, its reader and its writer.
//
// File format (angles in degrees, pixels, m/s^2):
//   gravity_mps2: 9.80665                # local gravity; an error in it appears as a bias along z
//   camera: {focal_length_px: 2800.0, principal_point_px: [512.0, 512.0], pixel_aspect: 1.0,
//            focal_length_sigma_px: 0.5, principal_point_sigma_px: 0.05, pixel_aspect_sigma: 2.0e-5,
//            detector_px: [1024, 1024],           # optional (default 1024 x 1024): width, height
//            radial_k1: 0.0, radial_k1_sigma: 1e-3}  # optional: estimate k1 under this prior
//   design_q_s_t: [q0, q1, q2, q3]       # scalar first, R(q) = C_s_t (IMU axes -> sensor axes)
//   noise: {centroid_sigma_px: 0.05, theodolite_sigma_arcsec: 1.5,  # optional block, these defaults;
//           accel_sigma_mps2: 4.9e-4}    # accel: per sample; absent -> the samples' own scatter
//   positions:
//     - name: position 1
//       prisms: [{axis_t: [1, 0, 0], azimuth_deg: .., elevation_deg: ..}]  # face normal, IMU axes
//       accel_mps2: [[fx, fy, fz], ...]  # static specific force, IMU axes: f_t = C_t_m (0,0,g) + b
//       targets: [{azimuth_deg: .., elevation_deg: .., centroid_px: [u, v]}]
// Instead of azimuth_deg / elevation_deg a surveyor's clockwise azimuth and zenith angle may be given
// as azimuth_cw_deg (a = -a') and zenith_deg (e = 90 - z). The detector covers 0 <= u <= width,
// 0 <= v <= height (pixel centres at half-integers); a centroid outside it is an error.
// Unknown keys are errors (a misspelt key must not be ignored silently).
// The accelerometer samples have a reader of their own (yaml-cpp's scanner is too slow for thousands
// of numbers): `accel_mps2:` must be a plain key at the start of its line (after its indentation and
// any "- "), its value a block list of "- [fx, fy, fz]" rows or a flow list [[fx, fy, fz], ...] (either
// may run over several lines and carry comments) of plain numbers; other spellings are refused.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/ground/geometry.h>

#include <string>
#include <vector>

namespace boresight::ground {

/// A theodolite-1 autocollimation on one IMU prism face.
struct PrismReading {
  Vec3 axis_t = Vec3::UnitX();  ///< unit face normal in IMU axes, pointing out towards theodolite 1
  double az_rad = 0.0;          ///< the normal's direction in the lab frame m
  double el_rad = 0.0;
  int line = 0;                 ///< 1-based source line (0: not from a file)
};

/// A theodolite-2 collimated beam seen by the star sensor.
struct TargetReading {
  double az_rad = 0.0;  ///< line of sight, sensor towards source, lab frame m
  double el_rad = 0.0;
  double u_px = 0.0, v_px = 0.0;
  int line = 0;
};

struct Position {
  std::string name;
  std::vector<PrismReading> prisms;
  std::vector<Vec3> accel_mps2;  ///< static specific-force samples, IMU axes
  std::vector<TargetReading> targets;
  int line = 0;
};

/// Laboratory intrinsics with their 1-sigma uncertainty (the refinement's priors).
struct CameraPrior {
  Intrinsics nominal;
  double f_sigma_px = 0.5;
  double pp_sigma_px = 0.05;
  double sx_sigma = 2.0e-5;
  bool estimate_k1 = false;  ///< true when the file gives radial_k1_sigma
  double k1_sigma = 0.0;
  double width_px = 1024.0, height_px = 1024.0;
};

/// Measurement noise (1 sigma). accel_sigma_mps2 <= 0: use the samples' own scatter.
struct NoiseModel {
  double centroid_sigma_px = 0.05;
  double theodolite_sigma_rad = 1.5 * kRadPerArcsec;
  double accel_sigma_mps2 = 0.0;
};

struct Measurement {
  double gravity_mps2 = 9.80665;
  CameraPrior camera;
  Quat q_s_t_design = Quat::Identity();
  NoiseModel noise;
  std::vector<Position> positions;
};

/// Reads and validates a measurement file. On failure returns false with "file:line: reason" in
/// *error (line from the YAML mark of the offending node). Never throws.
bool loadMeasurement(const std::string& path, Measurement& out, std::string* error);
/// The same from YAML text; `name` stands for the file name in messages.
bool parseMeasurement(const std::string& yaml_text, const std::string& name, Measurement& out, std::string* error);

/// Checks the content (counts, finiteness, detector bounds, targets not on a line). Messages carry
/// `name:line:` where the reading has a line. Run by the readers; the solvers call it too.
bool validateMeasurement(const Measurement& m, const std::string& name, std::string* error);

/// Writes the file format above (round trip with loadMeasurement to the printed precision).
bool writeMeasurement(const std::string& path, const Measurement& m, std::string* error);

}  // namespace boresight::ground

// Platform configuration files (config/*.yaml) parsed and validated into the real-time core's plain
// config structs. The core never reads files; this is the only place that turns YAML into them.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/io/level1.h>
#include <boresight/model/overlay.h>

#include <array>
#include <string>
#include <vector>

namespace boresight::io {

struct PlatformConfig {
  std::string platform;          ///< name from the file
  std::string file;              ///< the file loaded (its `base:` files are merged in)
  core::PipelineConfig pipeline;  ///< ready for Pipeline::configure()
  bool mounting_from_qsa1b = false;  ///< the heads' q_Si_B must come from a QSA1B file
  /// heads.mounting_uncertainty_arcsec: how well the mountings are known before a calibration (1-sigma
  /// per axis); a calibration's axis or body direction whose sigma is above it is not determined by the
  /// data. 0: not given.
  double mounting_uncertainty_arcsec = 0;
  /// Where each head slot's q_Si_B came from ("FILE heads.list[0].q_Si_B", "QSA1B FILE", "overlay FILE
  /// (datum ..., epoch ...)"); empty while a QSA1B mounting is still to come.
  std::array<std::string, core::kMaxHeads> mounting_source{};
  /// The platform file's `noise` section (its bases merged in: an axis given replaces the base's, a
  /// `heads` list replaces the base's list).
  model::NoiseSection noise;
  /// The model of every head axis and accelerometer axis, and where it came from (the platform file;
  /// an overlay laid over it by applyOverlayNoise). The heads' sigma_cross_rad / sigma_roll_rad /
  /// sigma_star_rad in `pipeline` are derived from it (deriveHeadSigmas).
  model::NoiseInUse noise_in_use;
  /// The data_events section (the audit's expected missing-sample runs; none by default); an overlay's
  /// data_events replace it (io::applyOverlay).
  model::DataEventRates events;
};

/// Parses and validates a platform file. On failure returns false and sets *error to
/// "FILE:LINE: key 'KEY': reason" (or "FILE:LINE:COL: reason" for YAML syntax errors).
///
/// `base: OTHER.yaml` (relative to the file) makes the file an overlay of another platform file: every
/// key not given is the base's; a key given replaces the base's value (mappings key by key, lists
/// whole); noise axes replace the base's axis by axis. Bases nest at most 4 deep.
///
/// The noise section (io/overlay_yaml.h for the form): `noise.head_defaults` (cross_x, cross_y,
/// about_boresight, star_direction; arcsec), `noise.heads` (per-head overrides by id) and
/// `noise.accelerometer` (x, y, z of the frame A; rad/s^2). Every head axis and accelerometer axis must
/// end up with a model. The old heads.list[].sigma_*_arcsec keys are errors that name the new place.
bool loadPlatformConfig(const std::string& path, PlatformConfig& out, std::string* error);

/// Sets every head's sigma_cross_rad, sigma_roll_rad and sigma_star_rad from cfg.noise_in_use: the
/// total per-sample standard deviation of the axis's model (white and coloured parts; cross-boresight:
/// the RMS of cross_x and cross_y, the core has one cross-boresight level).
void deriveHeadSigmas(PlatformConfig& cfg);

/// Fills the heads' mountings from QSA1B records (q_Si_B); the latest record of each head at or
/// before `t_ref` wins. False with *error when a configured head has no record. Heads whose
/// mounting_source already names an overlay keep their mounting.
bool applyQsa1bMounting(PlatformConfig& cfg, const std::vector<QsaRecord>& qsa, TimeUs t_ref, std::string* error);

}  // namespace boresight::io

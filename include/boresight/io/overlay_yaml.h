// The model overlay as a YAML file, and the one YAML form of a noise model (shared with the platform
// file's `noise` section). The schema (README "The model overlay"; an example: the file calibrate
// --write-model writes):
//
//   boresight_overlay: 1                 # the schema and its version (required, first)
//   written_by: boresight calibrate 0.9.0
//   platform: GRACE-FO                   # optional: the platform file's `platform` name
//   note: "..."                          # optional
//   mountings:                           # per head
//     - {head: 1, q_Si_B: [q0, q1, q2, q3], datum: accelerometer, epoch: "2023-06-01 00:07:10.000000",
//        sigma_arcsec: [12.1, 13.0, null], valid_from: "...", valid_to: "..."}
//   noise:                               # the platform file's noise section, with validity spans
//     head_defaults: {cross_x: [...], cross_y: [...], about_boresight: [...], star_direction: [...]}
//     heads: [{id: 2, about_boresight: [{kind: white, sigma_arcsec: 31}], valid_from: ...}]
//     accelerometer: {x: [{kind: white, sigma_rad_s2: 1.5e-7}], y: ..., z: ...}
//   thermal: {datum_head: 1, beta_ref_deg: 12.5, heads: [{id: 2, constant_arcsec: [..],
//             constant_sigma_arcsec: [..], harmonics: [{harmonic: 1, cos_arcsec: [..],
//             cos_sigma_arcsec: [..], sin_arcsec: [..], sin_sigma_arcsec: [..]}], beta_harmonics: []}]}
//   accelerometer: {bias_rad_s2: [..], bias_sigma_rad_s2: [..], scale: [..], scale_sigma: [..],
//                   misalignment_arcsec: [..], misalignment_sigma_arcsec: [..],
//                   nonorthogonality_arcsec: [..], nonorthogonality_sigma_arcsec: [..]}
//   time_offsets: [{sensor: accelerometer, relative_to: heads, offset_s: 0.015, offset_sigma_s: 0.001}]
//
// A noise model is a list of terms (model/noise.h):
//   - {kind: white, sigma_arcsec: 2.0}
//   - {kind: gauss_markov, sigma_arcsec: 0.5, tau_s: 600}
//   - {kind: power_law, sigma_arcsec: 1.0, alpha: 1.0, f_lo_hz: 1.0e-4, f_hi_hz: 1.0e-2}
// with, optionally per term, `uncertainty: {sigma_arcsec: 0.1, tau_s: 120}` (standard errors) and
// `not_determined: {tau_s: "slower than the span"}`. Head axes take sigma_arcsec, accelerometer axes
// sigma_rad_s2. Every item may carry valid_from / valid_to (GPS calendar, io/time_format.h) in an
// overlay; 1-sigmas are null where not determined.
//
// The reader refuses an unknown version, an unknown or misspelt key (naming the nearest known one), a
// key given twice, NaN/Inf and out-of-range values, as "FILE:LINE: key 'k': reason".
#pragma once

#include <boresight/model/overlay.h>

#include <string>

namespace boresight::io {

/// Reads an overlay file. False with *error ("FILE:LINE: key 'k': reason").
bool readOverlay(const std::string& path, model::Overlay& out, std::string* error);
/// The same from text (`file` names it in errors).
bool parseOverlay(const std::string& text, const std::string& file, model::Overlay& out, std::string* error);

/// The overlay as YAML text (a header comment, then the keys in the order above).
std::string overlayYaml(const model::Overlay& o);
/// Writes overlayYaml(o) to `path`. False with *error ("cannot write PATH").
bool writeOverlay(const std::string& path, const model::Overlay& o, std::string* error);

/// The YAML of a noise section's keys (head_defaults, heads, accelerometer), each line indented by
/// `indent` spaces: what goes under `noise:` in a platform file or an overlay. Validity spans only when
/// `with_validity` (overlays).
std::string noiseSectionYaml(const model::NoiseSection& s, int indent, bool with_validity);
/// One axis as a flow list of terms: "[{kind: white, sigma_arcsec: 2}]" (head axes: arcsec;
/// otherwise rad/s^2).
std::string axisNoiseYaml(const model::AxisNoise& a, bool head_axis);

/// Shortest decimal text that reads back as exactly v ("2", "1.5e-07", "0.1").
std::string yamlNumber(double v);

}  // namespace boresight::io

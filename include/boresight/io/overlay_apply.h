// A model overlay laid over a platform configuration, as every program that takes `--overlay FILE`
// (process, calibrate, audit) and the node (`overlay:` in its configuration) does:
//   - noise: the overlay's noise section over the platform file's, axis by axis (per-head entries over
//     the overlay's head defaults, both over whatever the platform file gave); the heads' core sigmas
//     are derived again (io::deriveHeadSigmas);
//   - mountings: the overlay's q_Si_B of a head replaces the platform file's or QSA1B's; when it gives
//     every configured head, no QSA1B is needed;
//   - thermal (for programs that take it: process, boresightd): the terms as the core's thermal model
//     (OverlayUse::thermal_model), which predicts the relative corrections of pairs a head epoch does
//     not see from the orbit (Engine::setThermalModel);
//   - accelerometer (for programs that take it: process, audit): the bias, scale, misalignment and
//     non-orthogonality correct every accelerometer sample before the core (core::AccCorrection);
//   - every other part (accelerometer terms for the other programs, time offsets, noise or mountings of heads
//     the platform does not configure, and parts the program does not use) is named as not applied,
//     with the reason: never silently ignored.
// Call before stream::prepareConfig (which applies QSA1B to the heads the overlay leaves).
#pragma once

#include <boresight/io/core_config.h>
#include <boresight/model/overlay.h>

#include <optional>
#include <string>
#include <vector>

namespace boresight::io {

/// The parts of an overlay a program uses.
struct OverlayUses {
  bool noise = true;
  bool mountings = true;
  bool thermal = false;  ///< the program runs the core's thermal prediction (needs the orbit among its inputs)
  /// The accelerometer terms correct every accelerometer sample before the core's CRN
  /// (core::AccCorrection: bias, scale, misalignment, non-orthogonality; a term not given is zero).
  bool accelerometer = false;
  /// The expected missing-sample runs (the audit's null for its data events) replace the platform
  /// file's data_events section.
  bool data_events = false;
};

/// The core's correction (core::AccCorrection) for an overlay's accelerometer terms: M = R(Exp(m))^T
/// K^-1, K = I + diag(s) + N(n) (calib/solver.h), bias b. False with *error when K is singular or a value
/// is not finite.
bool accCorrectionFromOverlay(const model::AccelerometerTerms& t, core::AccCorrection& out, std::string* error);

/// What a program did with an overlay (for its terminal output and its JSON / report).
struct OverlayUse {
  std::string file;                      ///< the overlay file; empty: no overlay
  model::Overlay overlay;                ///< as read
  std::vector<std::string> applied;      ///< "noise: head 1 cross_x, ...", "mountings: heads 1, 2, 3 (datum ...)"
  std::vector<std::string> not_applied;  ///< "thermal: PROGRAM does not use thermal terms", ...
  /// The overlay's thermal terms as the core's model (OverlayUses::thermal and the overlay has them).
  std::optional<core::ThermalHarmonicModel> thermal_model;
};

/// The overlay's thermal terms as the core's model (core/thermal_harmonics.h) for the platform's head
/// set: every harmonic any head names becomes one of the model's orders (at most
/// core::kMaxThermalHarmonics), a head's missing harmonic is zero, the beta modulation is on when a
/// head has beta harmonics (then beta_ref is needed). The prediction covariance of a head is diagonal:
/// per axis the constant's variance plus half the sum of its harmonics' cos and sin variances (their
/// mean over the orbit; a sigma the overlay does not give counts as zero). Anchored prediction. False
/// with *error: a head or the datum not in the platform, the datum with terms, too many harmonics.
bool thermalModelFromOverlay(const model::ThermalTerms& t, const core::HeadSetConfig& heads,
                             core::ThermalHarmonicModel& out, std::string* error);

/// Reads the overlay at `path` (refusing an unknown version or key with FILE:LINE) and lays it over
/// `pc` for `program` (its name in the messages, e.g. "boresight process"). False with *error; an
/// overlay whose `platform` names another platform than pc.platform is refused.
bool applyOverlay(const std::string& path, const std::string& program, const OverlayUses& uses, PlatformConfig& pc,
                  OverlayUse& use, std::string* error);

/// The same with an overlay already read (`path` names it in the messages).
bool applyOverlay(const model::Overlay& ov, const std::string& path, const std::string& program, const OverlayUses& uses,
                  PlatformConfig& pc, OverlayUse& use, std::string* error);

/// After a run over data from t0 to t1 (GPS): one warning per applied item whose validity span does not
/// cover the data ("overlay FILE: mountings of head 1 valid until ..., the data run to ...").
std::vector<std::string> validityWarnings(const OverlayUse& use, TimeUs t0, TimeUs t1);

/// The model a program runs with, for people: the noise of every head and accelerometer axis with its
/// source, every head's mounting with its source, and the overlay's applied / not applied parts.
std::vector<std::string> modelInUseLines(const PlatformConfig& pc, const OverlayUse& use);

}  // namespace boresight::io

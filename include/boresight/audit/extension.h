// The audit's extension as a model: the named causes with their estimates written as a model overlay
// (model/overlay.h, the schema every program reads), so that the extended model can be applied - by the
// audit itself on a second pass (`boresight audit --write-model`), by process, calibrate, simulate.
//
// What is carried, and how (estimates from the extended model's joint fit on the fitting blocks):
//   relative_misalignment[k] (relative family) -> every head's mounting: q_Si_B = Exp(r_k - C_Sk_B rho)
//       q_Si_B(in use), r_k the estimate in the head frame (model/effects.h: C_Si_B(true) = R(Exp(r))
//       C_Si_B(nominal); zero for heads not named), rho the information-weighted mean of C_B_Sk r_k over
//       the heads: datum star_cameras, the fused attitude stays (and with it what the accelerometer's
//       terms were estimated against); sigma per head axis for the named heads;
//   acc_bias, acc_scale, acc_misalignment -> the accelerometer terms (A frame; a_A = (I + diag(s))
//       R(Exp(m)) C_A_B a_B + b), added to the overlay's own when the audit ran with one (first order);
//   cross_noise / anisotropic_noise[k] -> the white term of head k's cross-boresight (x and y) or
//       about-boresight model set to the estimated level; coloured_noise (relative family, per head
//       levels) -> a Gauss-Markov term of each head axis with a level, the estimated correlation time;
//   time_offset[acc] (angular-acceleration family) -> an accelerometer time offset against the heads;
//       time_offset[k] (relative family) -> head k's against the other heads (t_tag = t_true + offset,
//       positive: late).
// Everything else that was named (steps, drifts, clock drifts, harmonics, the reference family's
// findings, events) is listed as not carried, with the reason. The overlay starts from the one the
// audit ran with (--overlay), so a second extension builds on the first.
#pragma once

#include <boresight/audit/audit.h>
#include <boresight/report/svg_plot.h>
#include <boresight/io/core_config.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/model/overlay.h>

#include <string>
#include <vector>

namespace boresight::audit {

struct Extension {
  model::Overlay overlay;
  std::vector<std::string> carried;      ///< "relative_misalignment[2] -> mountings: head 2 ..."
  std::vector<std::string> not_carried;  ///< "step[1] at 2400 s: the overlay has no steps ..."
};

struct ExtensionContext {
  TimeUs t0 = 0, t1 = 0;     ///< the data's span: the items' validity and the mountings' epoch
  std::string written_by;    ///< e.g. "boresight audit 0.9"
  std::string note;          ///< what the overlay was made from
};

/// The extended model of `r` (an audit run with the configuration `pc` and the overlay `base`, empty
/// file: none) as a model overlay. Pure: reads nothing, writes nothing.
Extension extensionOverlay(const AuditResult& r, const io::PlatformConfig& pc, const io::OverlayUse& base,
                           const ExtensionContext& ctx);

/// The extension applied end to end: the same data audited again with the overlay in place (the
/// pipeline re-run with its mountings, accelerometer correction and noise), per residual family the
/// held-out RMS of the configured model (first pass, no effect) against that of the applied extension
/// (second pass, no effect: nothing fitted to the held-out blocks on either pass), and what the second
/// pass still names.
struct AppliedFamily {
  std::string family, unit;
  double heldout_rms_configured = kNaN;  ///< first pass, baseline
  double heldout_rms_applied = kNaN;     ///< second pass, baseline (the overlay applied)
  double heldout_rms_fitted = kNaN;      ///< first pass, the extended model fitted (the in-audit gain)
};
struct AppliedExtension {
  std::vector<AppliedFamily> families;
  std::vector<std::string> still_named;    ///< "name[sensor] (family)" of the second pass
  std::vector<std::string> newly_named;    ///< ... of those, the ones the first pass did not name
  /// Lines for people (terminal and report).
  std::vector<std::string> lines() const;
};
AppliedExtension compareApplied(const AuditResult& first, const AuditResult& second);

/// Closing the loop: the data audited with the extended model applied (the second pass) against a
/// simulation of the extended model audited the same way (the overlay as the simulation's truth,
/// sim/overlay.h). When the model is right both residuals are what the model leaves (its noise), so
/// their statistics agree; a line or a colour the model lacks shows in the data's residual only.
/// Compared: the causes each audit names (one named on the data only is what the model lacks: the
/// audit's own calibrated tests, the most powerful check of a line); per family the held-out RMS of the baseline (here: the extended model); per residual
/// component: the mean power of the amplitude spectrum in frequency bands (cycles/rev: below the
/// orbit, the 1/rev and 2/rev lines, between them, 2.2-5, 5-20 and above; other units: decades). A band
/// agrees when the power ratio lies inside the two-sided F(2k, 2k) interval at a family-wise 1 % over
/// all bands, widened by a factor 1.28: k is the band's independent frequencies (its width times the
/// span, at most its points), a periodogram ordinate of noise is exponential so the ratio of two means of
/// k is F(2k, 2k); the factor is for what is not noise (the excitation - thruster pulses, attitude - is
/// another draw in the simulation) and the spectra's approximations (bin means, Lomb-Scargle).
struct SimulatedBand {
  std::string family, label, band;  ///< band: "<0.8", "1/rev", "0.8-1.2" ...
  double lo = 0, hi = 0;            ///< in the spectrum's unit
  int k = 0;                        ///< independent frequencies
  double power_data = kNaN, power_sim = kNaN, ratio = kNaN, tolerance = kNaN;
  bool agrees = true;
};
struct SimulatedFamily {
  std::string family, unit;
  double heldout_rms_data = kNaN, heldout_rms_sim = kNaN, ratio = kNaN, tolerance = kNaN;
  double kurtosis = 3.0;  ///< the larger of the two residuals' kurtosis (the tolerance's)
  bool agrees = true;
};
struct SimulatedCheck {
  std::vector<SimulatedFamily> families;
  std::vector<SimulatedBand> bands;
  std::vector<std::string> named_data, named_sim;  ///< "name[sensor] (family)" of each audit
  /// Causes the audit names on the data but not on the simulation of the model: what the model lacks.
  std::vector<std::string> namedOnDataOnly() const;
  /// Every family and band agrees and nothing is named on the data only.
  bool agrees() const;
  std::vector<std::string> lines() const;
  /// Per family with spectra in both: one plot of every component's spectrum, data and simulation.
  std::vector<std::pair<std::string, report::Plot>> plots() const;
  std::vector<Spectrum> data_spectra, sim_spectra;  ///< as compared (the baselines' "before")
  std::vector<std::string> amplitude_units;         ///< per data_spectra entry: its series' unit ("arcsec", ...)
};
SimulatedCheck compareWithSimulation(const AuditResult& data, const AuditResult& simulation);

}  // namespace boresight::audit

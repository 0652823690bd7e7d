// The model overlay: what the project knows about an instrument set beyond its nominal configuration
// (the platform file), as one versioned schema that every program reads and the estimators write:
//   - per head the mounting q_Si_B, with its datum, reference epoch and 1-sigma;
//   - noise models per sensor axis (model/noise.h): each head's cross-boresight x and y, about the
//     boresight and one star direction; the accelerometer's angular acceleration per A axis;
//   - thermal terms: orbit harmonics of each head's deformation relative to a datum head;
//   - accelerometer terms: bias, scale, misalignment, non-orthogonality;
//   - time offsets per sensor;
//   - the node's published frame and calibration in use (its state file);
// each with its uncertainty and validity span. SI units here (rad, rad/s^2, s; times TimeUs); the YAML
// form (io/overlay_yaml.h) carries arcsec for angles of heads and GPS calendar strings for times.
//
// The platform file's `noise` section is a NoiseSection too (the same YAML form, read by the same
// code); an overlay's noise section overrides it axis by axis (NoiseInUse below says which model each
// axis got, and from where).
//
// Eigen and the core's conventions only: no YAML here.
#pragma once

#include <boresight/core/capacities.h>
#include <boresight/core/conventions.h>
#include <boresight/model/noise.h>

#include <array>
#include <cstdint>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace boresight::model {

/// The schema's version this code reads and writes (`boresight_overlay: 1`).
constexpr int kOverlayVersion = 1;

/// Where an item holds: from `from` to `to` (GPS time, inclusive); an end not given is open.
struct Validity {
  std::optional<TimeUs> from, to;
  bool open() const { return !from && !to; }
  /// True when [a, b] lies inside the span.
  bool covers(TimeUs a, TimeUs b) const { return (!from || *from <= a) && (!to || b <= *to); }
  bool operator==(const Validity& o) const { return from == o.from && to == o.to; }
};

// ---------------------------------------------------------------------------------------------
// Noise per sensor axis

/// One axis's noise: the model (model/noise.h, values in rad for heads, rad/s^2 for the accelerometer)
/// and, optionally, what is known about its parameters: NoiseParam entries as fitNoise() reports them,
/// named "<term>.<parameter>" with <term> the k-th term of its kind counted from 1 in `model.terms`
/// order ("white", "white2", ...; "gm1", "gm2", ...; "pl", "pl2", ...: noiseTermName()) and
/// <parameter> one of sigma, tau_s, alpha, f_lo_hz, f_hi_hz. A parameter is given with a standard
/// error (sigma finite), or as not determined (determined false, note says why), or both. `value` is
/// the term's own value; log_sigma = sigma / value for the log-scale parameters (all but alpha).
struct AxisNoise {
  NoiseModel model;
  std::vector<NoiseParam> params;
};

/// The name of term `index` of a model for NoiseParam (see AxisNoise): "white", "gm1", "pl", ...
std::string noiseTermName(const NoiseModel& m, std::size_t index);
/// The parameter names of a term's kind: white {sigma}; gauss_markov {sigma, tau_s}; power_law {sigma,
/// alpha, f_lo_hz, f_hi_hz}.
std::vector<std::string> noiseTermParameters(NoiseKind k);
/// The value of a term's parameter (by the names above); NaN for a name the kind does not have.
double noiseTermValue(const NoiseTerm& t, const std::string& parameter);
/// Checks an axis: model valid and not empty, every param names an existing term and parameter, its
/// sigma finite and >= 0 or the parameter not determined. "" when valid.
std::string validateAxisNoise(const AxisNoise& a);

/// Head axes: cross-boresight about the head's x and y axes (GRACE-FO's boresight is +z), about the
/// boresight, and the direction error of one star vector (per axis of the direction, for the
/// multi-head Wahba solution).
enum class HeadAxis : std::uint8_t { CrossX = 0, CrossY, AboutBoresight, StarDirection };
constexpr int kHeadAxes = 4;
const char* headAxisKey(HeadAxis a);  ///< "cross_x", "cross_y", "about_boresight", "star_direction"
/// Accelerometer angular-acceleration axes of the frame A: "x", "y", "z".
const char* accAxisKey(int axis);

/// Noise models of one head's axes (any subset). id 0 in NoiseSection::head_defaults.
struct HeadNoise {
  int id = 0;
  std::array<std::optional<AxisNoise>, kHeadAxes> axis;
  Validity valid;  ///< overlays only (the platform file's section has none)
};

/// The accelerometer's angular-acceleration noise per A axis (any subset).
struct AccNoise {
  std::array<std::optional<AxisNoise>, 3> axis;
  Validity valid;
};

/// A noise section: the platform file's `noise` key, or an overlay's. Per-head entries override the
/// head defaults axis by axis.
struct NoiseSection {
  std::optional<HeadNoise> head_defaults;
  std::vector<HeadNoise> heads;
  std::optional<AccNoise> accelerometer;
  bool empty() const { return !head_defaults && heads.empty() && !accelerometer; }
};

/// The noise model each axis of a configured instrument set is given, and where it came from.
struct NoiseInUse {
  struct Axis {
    bool set = false;
    AxisNoise noise;
    std::string source;  ///< e.g. "config/gracefo.yaml noise.head_defaults" or "overlay o.yaml noise.heads[id 2]"
  };
  int n_heads = 0;
  std::array<int, core::kMaxHeads> head_id{};
  std::array<std::array<Axis, kHeadAxes>, core::kMaxHeads> head{};
  std::array<Axis, 3> acc{};

  /// Starts an empty table for these head ids (slot order).
  void reset(const std::vector<int>& ids);
  /// Lays a section over the table: per-head entries over the section's head defaults, both over what
  /// was set before (so the platform file first, then an overlay). `source` names the file. Entries for
  /// head ids not in the table are listed in *unused (as "noise.heads[id N]"), not an error.
  void layer(const NoiseSection& s, const std::string& source, std::vector<std::string>* unused = nullptr);
  /// "" when every head axis and accelerometer axis has a model; else the first that has none
  /// ("head 2 about_boresight").
  std::string missing() const;
  /// Per-sample 1-sigma the core weights with (the total stationary variance of the model, white and
  /// coloured): cross-boresight as the RMS of the x and y axes, about the boresight, one star direction.
  double crossSigmaRad(int slot) const;
  double aboutSigmaRad(int slot) const;
  double starSigmaRad(int slot) const;
  /// The white part of an accelerometer axis, rad/s^2 per sample (method A's span builder models the
  /// accelerometer as white through the CRN low-pass: calib/span_builder.h).
  double accWhiteSigma(int axis) const;
  /// One line per head and one for the accelerometer: "head 1: cross_x white 2\", ... (SOURCE)".
  std::vector<std::string> describe() const;
};

// ---------------------------------------------------------------------------------------------
// The other items

/// The frame a mounting is expressed against (the body frame B of q_Si_B).
enum class MountingDatum : std::uint8_t {
  Accelerometer = 0,  ///< B as the configured C_B_A puts the accelerometer frame A into it (method A)
  Ground,             ///< the ground (pre-launch) alignment's body frame, as QSA1B carries it
  StarCameras,        ///< the body frame the heads define together (zero weighted mean correction)
};
const char* mountingDatumKey(MountingDatum d);  ///< "accelerometer", "ground", "star_cameras"

/// Three values with their 1-sigma; a sigma that is NaN is "not determined" (never a small number).
struct Uncertain3 {
  Vec3 value = Vec3::Zero();
  Vec3 sigma = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  bool operator==(const Uncertain3& o) const;
};

/// One head's mounting.
struct MountingEntry {
  int head = 0;                      ///< telemetry head id
  Quat q_Si_B = Quat::Identity();    ///< R(q_Si_B) = C_Si_B, unit
  MountingDatum datum = MountingDatum::Accelerometer;
  TimeUs epoch = 0;                  ///< the reference epoch of the value
  Vec3 sigma_rad = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());  ///< 1-sigma about the head axes
  Validity valid;
  bool operator==(const MountingEntry& o) const;
};

/// One harmonic of the argument of latitude u: delta = cos_rad cos(harmonic u) + sin_rad sin(harmonic u).
struct ThermalHarmonicEntry {
  int harmonic = 1;  ///< cycles per revolution, >= 1
  Uncertain3 cos_rad, sin_rad;
  bool operator==(const ThermalHarmonicEntry& o) const;
};

/// One head's deformation relative to the datum head, rotation vectors in the datum head's frame.
struct ThermalHeadEntry {
  int head = 0;
  Uncertain3 constant_rad;
  std::vector<ThermalHarmonicEntry> harmonics;
  /// Beta-angle modulation per unit of cos(beta) - cos(beta_ref) (calib/thermal_fit.h); may be empty.
  std::vector<ThermalHarmonicEntry> beta_harmonics;
  bool operator==(const ThermalHeadEntry& o) const;
};

struct ThermalTerms {
  int datum_head = 1;
  std::optional<double> beta_ref_rad;  ///< needed when a head has beta harmonics
  std::vector<ThermalHeadEntry> heads;
  Validity valid;
  bool operator==(const ThermalTerms& o) const;
};

/// The accelerometer's angular acceleration a_A = K^-1 ... (calib/solver.h): bias in A (rad/s^2), scale
/// factors (-), a misalignment (rotation of A from the configured C_B_A, rad) and the symmetric
/// non-orthogonality n (rad). Each optional.
struct AccelerometerTerms {
  std::optional<Uncertain3> bias_rad_s2, scale, misalignment_rad, nonorthogonality_rad;
  Validity valid;
  bool operator==(const AccelerometerTerms& o) const;
};

/// A time-tag offset: positive when `sensor`'s tags are late against `relative_to`.
struct TimeOffsetEntry {
  std::string sensor;       ///< "accelerometer" or "head<id>"
  std::string relative_to;  ///< "heads" (the star cameras' time), "head<id>", "accelerometer" or "gps"
  double offset_s = 0;
  double sigma_s = std::numeric_limits<double>::quiet_NaN();
  Validity valid;
  bool operator==(const TimeOffsetEntry& o) const;
};

/// How often the data are expected to miss samples: the model audit's null for its data events (a count
/// of runs against Poisson(rate x span)). Runs per day; 0: none expected. The platform file's
/// `data_events` section and an overlay's (which replaces it whole) have this form.
struct DataEventRates {
  double head_dropouts_per_day = 0;  ///< one head missing while the others deliver, outside its blinding cones
  std::vector<std::pair<int, double>> head_dropouts_by_id;  ///< per-head rates (head id, rate), over the above
  double epoch_gaps_per_day = 0;     ///< every head missing at once
  double acc_gaps_per_day = 0;       ///< accelerometer samples missing
  /// The longest run expected of each kind, s (NaN: no limit): a longer run is a finding whatever the
  /// count (a rate of short gaps does not make an hour-long outage expected).
  double head_dropout_max_s = std::numeric_limits<double>::quiet_NaN();
  double epoch_gap_max_s = std::numeric_limits<double>::quiet_NaN();
  double acc_gap_max_s = std::numeric_limits<double>::quiet_NaN();
  /// The head's rate: its own, else head_dropouts_per_day.
  double headDropoutsPerDay(int id) const {
    for (const auto& [h, r] : head_dropouts_by_id)
      if (h == id) return r;
    return head_dropouts_per_day;
  }
  bool operator==(const DataEventRates& o) const {
    const auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
    return head_dropouts_per_day == o.head_dropouts_per_day && head_dropouts_by_id == o.head_dropouts_by_id &&
           epoch_gaps_per_day == o.epoch_gaps_per_day && acc_gaps_per_day == o.acc_gaps_per_day &&
           same(head_dropout_max_s, o.head_dropout_max_s) && same(epoch_gap_max_s, o.epoch_gap_max_s) &&
           same(acc_gap_max_s, o.acc_gap_max_s);
  }
};

/// boresightd's state beyond the mountings (its state file, so a restart does not jump): the rotation
/// of the frame its attitude is published in from the heads' datum (frame changes; identity before the
/// first) and the calibration in use.
struct PublishedFrame {
  Quat q_B_Bpub = Quat::Identity();  ///< unit; identity: the heads' datum
  TimeUs epoch = 0;                  ///< data time of the last frame change (0: none)
  std::int64_t calibration = 0;      ///< identifier of the calibration in use (0: none), >= 0
  bool operator==(const PublishedFrame& o) const;
};

struct Overlay {
  int version = kOverlayVersion;
  std::string written_by;  ///< the program that wrote it ("boresight calibrate 0.9.0"), or a person
  std::string platform;    ///< optional: the platform file's `platform` name it belongs to
  std::string note;        ///< optional free text
  std::vector<MountingEntry> mountings;
  NoiseSection noise;
  std::optional<ThermalTerms> thermal;
  std::optional<AccelerometerTerms> accelerometer;
  std::vector<TimeOffsetEntry> time_offsets;
  std::optional<PublishedFrame> published_frame;
  /// The data's expected missing-sample runs (the audit's null for its data events; replaces the
  /// platform file's data_events section whole).
  std::optional<DataEventRates> data_events;
  /// The parts present, by key: "mountings", "noise", "thermal", "accelerometer", "time_offsets",
  /// "published_frame", "data_events".
  std::vector<std::string> parts() const;
};

/// Checks the ranges a reader also checks (unit quaternions, sigmas >= 0, noise models valid,
/// harmonics >= 1 and distinct, validity from <= to, ids > 0, no head twice). "" or "KEY: reason".
std::string validate(const Overlay& o);

/// The differences between two overlays, one line each ("mountings[0].q_Si_B: ... vs ..."); numbers
/// compare within `rel_tol` of their magnitude (the file's arcsec and the struct's rad differ in the
/// last bit), everything else exactly. Empty when equal.
std::vector<std::string> compareOverlays(const Overlay& a, const Overlay& b, double rel_tol = 1e-12);

}  // namespace boresight::model

// boresight calibrate --config FILE INPUT... --json FILE [--yaml FILE] [--report DIR]: method A, the
// mounting-error angles of every head from the star cameras and the accelerometer (METHODS 1.7).
// Option parsing and printing only: the replay engine feeds a calib::SpanBuilder through its input
// observer, calib::solve() estimates, report:: writes.
#include <boresight/calib/calibration.h>
#include <boresight/calib/raw_bound.h>
#include <boresight/calib/solver.h>
#include <boresight/calib/span_builder.h>
#include <boresight/calib/thermal_fit.h>
#include <boresight/calib/windows.h>
#include <boresight/core/rotation.h>
#include <boresight/model/orbit_context.h>
#include <boresight/model/parallel.h>
#include <boresight/io/product_stream.h>
#include <boresight/io/core_config.h>
#include <boresight/io/files.h>
#include <boresight/io/level1.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/io/time_format.h>
#include <boresight/report/calibration.h>
#include <boresight/report/svg_plot.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>

#include "cli_common.h"
#include "commands.h"
#include "model_json.h"
#include "replay_summary.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <map>
#include <optional>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include <sys/resource.h>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_calibrate {
namespace {

const char* kUsage =
    "usage: boresight calibrate --config FILE INPUT... --json FILE [--yaml FILE] [--report DIR]\n"
    "                           [--overlay FILE] [--write-model FILE] [--write-qsa1b FILE [--satellite X]]\n"
    "                           [--relative hard|prior] [--no-acc-bias] [--acc-scale] [--acc-nonorthogonality]\n"
    "                           [--method crn|attitude] [--time-offset|--no-time-offset] [--huber S] [--no-whiten] [--decimation S] [--max-observations N]\n"
    "                           [--crn-bandwidth HZ --crn-length S] [--moments]\n"
    "                           [--unobservable-sigma ARCSEC] [--plan-excitation RADPS2] [--plan-sigma ARCSEC]\n"
    "                           [--lookahead S] [--strict] [--window S]\n"
    "\n"
    "Method A: estimates how each star-camera head is really mounted from each head's angular\n"
    "acceleration (the CRN differentiator on that head's attitude, in its own frame) against the\n"
    "accelerometer's (the same CRN low-pass, the same tags), with the heads' relative attitudes tying them\n"
    "together,\n"
    "and says how well that is known: covariance, Cramer-Rao bound, and which directions are not\n"
    "observable (no excitation about them).\n"
    "\n"
    "INPUT: Level-1 files (SCA1A heads, ACC1A accelerometer, QSA1B nominal mountings when the config\n"
    "says heads.mounting: qsa1b; GNI1B or GNV1B orbit for the thermal fit) or an LCM log (its ORBIT\n"
    "messages for the thermal fit), recognised by content. Other products are listed as ignored.\n"
    "\n"
    "Datum: the accelerometer frame. B is the body frame as the configured C_B_A puts A into it; a\n"
    "rotation of the accelerometer cannot be told from a common rotation of all heads. Error angles:\n"
    "rotation vector r in the head frame, C_S_B(true) = Exp([r]x) C_S_B(nominal), arcsec.\n"
    "\n"
    "  --config FILE            platform file (config/gracefo.yaml; config/gracefo_ideal.yaml for data simulated\n"
    "                           with the ideal noise preset)\n"
    "  --overlay FILE           a model overlay (README \"The model overlay\"): its noise models replace the\n"
    "                           platform file's (the weights of the heads and the accelerometer), its mountings\n"
    "                           the nominal ones (the error angles are then relative to them); the parts\n"
    "                           calibrate does not use are listed as not applied\n"
    "  --write-model FILE       the result as a model overlay: per head the mounting Exp([r]x) q_Si_B(nominal)\n"
    "                           with its sigma (datum: the accelerometer frame; epoch: the middle of the span;\n"
    "                           valid over the span), the accelerometer terms, the thermal harmonics and the\n"
    "                           time offset when estimated. With --raw the mountings and their sigmas\n"
    "                           are the attitude-domain estimate's, else the CRN solver's\n"
    "  --write-qsa1b FILE       the calibrated mountings as a GRACE-FO QSA1B file (one record per head at the\n"
    "                           span's first whole second, q_Si_B = Exp([r]x) q_Si_B(nominal), scalar first,\n"
    "                           the fixed header of the static product): an input of process, calibrate\n"
    "                           and any Level-1B chain in place of the nominal QSA1B. From the attitude-\n"
    "                           domain estimate with --raw (body directions not observable keep their\n"
    "                           nominal value), else from the CRN solver\n"
    "  --satellite X            the satellite letter of the QSA1B file's header and records (default C)\n"
    "  --json FILE              the result (keys: heads[] {id, error_angles_arcsec, sigma_arcsec (null: not\n"
    "                           determined), crlb_arcsec, observable}, unobservable_directions_B,\n"
    "                           covariance_arcsec2, accelerometer, time_offset_s, time_offset_sigma_s,\n"
    "                           thermal, residual_rms_radps2, epochs, span_s, ...)\n"
    "  --yaml FILE              the same result as YAML, for people\n"
    "  --report DIR             DIR/report.md with plots (residuals against time, excitation, estimates with\n"
    "                           their sigma against the Cramer-Rao bound)\n"
    "  --relative MODE          the heads' mean relative attitude as a hard constraint (hard, default) or a\n"
    "                           prior with its covariance (prior)\n"
    "  --no-acc-bias            do not estimate the accelerometer bias (estimated by default)\n"
    "  --acc-scale              estimate the accelerometer scale factors (the default with --method\n"
    "                           attitude: a scale error left out reads as mounting error)\n"
    "  --no-acc-scale           hold the scale factors at one (also with --method attitude)\n"
    "                           (--method attitude holds a scale factor the span does not determine - sigma\n"
    "                           above 1 %: no angular acceleration about that axis - and says so: JSON\n"
    "                           attitude_domain.acc_scale_held)\n"
    "  --acc-nonorthogonality   estimate the accelerometer axes' non-orthogonality\n"
    "  --time-offset            estimate the time offset (positive: the accelerometer's tags are late);\n"
    "                           the default with --method attitude, where the raw samples determine it\n"
    "                           to a fraction of a millisecond in manoeuvres\n"
    "  --no-time-offset         hold the time offset at zero (also with --method attitude)\n"
    "  --huber S                robust loss threshold in whitened residual units (default 5; 0: none)\n"
    "  --no-whiten              treat the epochs as independent (default: whiten each head's epochs in time\n"
    "                           with the CRN noise correlation; without it the sigmas are optimistic)\n"
    "  --decimation S           one observation per S seconds (default 10: the CRN correlation length)\n"
    "  --max-observations N     keep at most N observations (0: no limit)\n"
    "  --moments                constant memory: keep only each head's sufficient statistics (10x10 moments of\n"
    "                           the whitened epochs), not the epochs; the solver then has no robust loss and\n"
    "                           no outlier rounds, and the report has no residual or excitation plot\n"
    "  --crn-bandwidth HZ, --crn-length S\n"
    "                           a calibration CRN for the heads and the accelerometer instead of the\n"
    "                           platform's (e.g. 0.05 Hz, 100 s: the acceleration noise grows as B^5 while\n"
    "                           100 s manoeuvres pass any B above ~0.02 Hz; length x accelerometer rate\n"
    "                           <= 1023 taps)\n"
    "  --unobservable-sigma A   an axis whose sigma would exceed A arcsec is not determined (default 3600;\n"
    "                           --raw: the platform file's heads.mounting_uncertainty_arcsec when smaller,\n"
    "                           and a common body direction above it is held at its nominal value)\n"
    "  --plan-excitation R      for a refused span: the excitation (rad/s^2 RMS per axis) assumed when\n"
    "                           saying what span the bound would need (default 4.9e-5: a 1 deg, 100 s\n"
    "                           calibration manoeuvre)\n"
    "  --plan-sigma A           ... and the 1-sigma (arcsec) it should reach (default 30)\n"
    "  --lookahead S            out-of-order tolerance of the inputs, seconds (default 2)\n"
    "  --strict                 stop at the first malformed input line\n"
    "  --method MODE            crn (default): the CRN-domain solver alone; attitude: also the\n"
    "                           attitude-domain estimate below, whose mountings are the ones written\n"
    "                           (--write-model, --write-qsa1b); the accelerometer's time offset and\n"
    "                           scale factors estimated in it unless --no-time-offset, --no-acc-scale;\n"
    "                           it uses no CRN row, so a span the CRN solver refuses is still\n"
    "                           calibrated by it (the refusal printed, JSON ok false and crn_solver)\n"
    "  --raw                    the same as --method attitude\n"
    "                           The attitude-domain estimate (beside the CRN result, JSON key\n"
    "                           attitude_domain): the raw head samples and accelerometer angular\n"
    "                           accelerations at their own rates, the trajectory driven by the\n"
    "                           accelerometer, weighted with the noise models in use, no filter or\n"
    "                           decimation (calib/raw_bound.h; bias, time offset and scale unless\n"
    "                           --no-time-offset, --no-acc-scale; the stars' aberration removed where an orbit\n"
    "                           (GNI1B / GNV1B, ORBIT messages) gives the velocity; orbit harmonics\n"
    "                           of the relative alignment, --raw-harmonics). Three passes; sigmas at the noise model\n"
    "                           fitted to the data (--raw-noise) and, beside them, from the data's own\n"
    "                           scores over 600 s blocks (sigma_score_blocks_arcsec); variance factors\n"
    "                           and chi-square per degree of freedom per head, cross and about\n"
    "  --raw-harmonics K        the attitude-domain estimate's model of heads 2..n's alignment: constant\n"
    "                           plus harmonics 1..K of the argument of latitude (the thermal motion, so\n"
    "                           that the relative sigmas include it; default 2, 0: constant), when an\n"
    "                           orbit among the inputs covers at least one revolution of the span\n"
    "  --window S               with --method attitude: calibrate window after window of S seconds of data\n"
    "                           (whole multiples of S after 00:00 GPS: 86400 gives GPS days, as the daily\n"
    "                           Level-1 files), each window on its own (its own trajectory, bias, scale, time\n"
    "                           offset and noise fit; memory: one window's, whatever the record's length),\n"
    "                           and the windows combined: JSON windows[] (the time series) and joint (the\n"
    "                           information-weighted mean, the windows' scatter about it - chi-square per\n"
    "                           degree of freedom, and per head axis the spread between windows beyond their\n"
    "                           sigmas, tau, with its 95 % interval - and the sigma with that spread, which\n"
    "                           is the one written: --write-model, --write-qsa1b take the joint). The report\n"
    "                           plots each head's windows against time\n"
    "  --raw-noise MODE         fit (default): every head axis's noise model fitted to the second pass's\n"
    "                           data less the trajectory's prediction (white, + Gauss-Markov, + power\n"
    "                           law, by BIC) and used in the third, with the slow parts of the models in\n"
    "                           use that the span cannot resolve kept beside it; in-use: the noise\n"
    "                           models in use (platform file, --overlay) scaled by the variance factors\n"
    "                           estimated in the second pass\n"
    "\n"
    "Exit status: 0 calibrated; 1 refused (span too short or too quiet for the CRN solver without\n"
    "--method attitude: the reason and what would be needed) or bad input (the reason); 2 usage error.\n";

/// The engine's inputs into method A (a calib::CalibrationFeed, or window after window a
/// calib::WindowedCalibration): head epochs as the core's validator leaves them, the accelerometer samples
/// the core accepted, the orbit from the same stream when the feed wants it (GNI1B / GNV1B files, ORBIT
/// messages).
template <class Feed>
class FeedObserver final : public stream::InputObserver {
 public:
  explicit FeedObserver(Feed& f) : f_(f) {}
  void onHeads(const core::HeadEpoch& e, core::Status) override { f_.pushHeads(e); }
  void onAcc(TimeUs t, const Vec3& a_A, core::Status st) override {
    if (core::accepted(st)) f_.pushAcc(t, a_A);
  }
  bool wantsOrbit() const override { return f_.wantsOrbit(); }
  void onOrbit(const model::OrbitSample& o) override { f_.pushOrbit(o); }
  void onEnd() override { f_.finish(); }

 private:
  Feed& f_;
};

int fail(const std::string& msg) {
  std::fprintf(stderr, "boresight calibrate: %s\n", msg.c_str());
  return 1;
}

bool writeText(const std::string& path, const std::string& text, std::string* error) {
  return io::writeFileAtomic(path, text, error);  // whole or not at all
}

/// Wall time since `t0` in seconds, and the peak resident memory so far in MB (the stage summary).
struct Stages {
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  std::string text;
  void mark(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    char b[128];
    std::snprintf(b, sizeof b, "%s%s %.3f s (peak RSS %.1f MB)", text.empty() ? "" : ", ", stage,
                  std::chrono::duration<double>(now - t0).count(), double(ru.ru_maxrss) / 1024.0);
    text += b;
    t0 = now;
  }
};

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

/// The noise model a head axis had in the attitude-domain estimate's last pass, in arcsec.
std::string m_describe(const calib::RawEstimate& est, const calib::RawBoundConfig& rc, std::size_t i, std::size_t j) {
  const model::NoiseModel& m = est.fitted_noise.empty() ? rc.heads[i].noise[j] : est.fitted_noise[i][j];
  return m.describe(kArcsecPerRad, "\"");
}

/// A sigma given in arcsec (empty: not determined) -> rad (NaN: not determined).
double sigmaRad(const std::optional<double>& arcsec) {
  return arcsec ? *arcsec * kRadPerArcsec : std::numeric_limits<double>::quiet_NaN();
}

model::Uncertain3 uncertain(const calib::Estimate3& e, double scale) {
  model::Uncertain3 u;
  for (int i = 0; i < 3; ++i) {
    u.value[i] = e.value[static_cast<std::size_t>(i)] * scale;
    u.sigma[i] = e.sigma[static_cast<std::size_t>(i)] ? *e.sigma[static_cast<std::size_t>(i)] * scale
                                                      : std::numeric_limits<double>::quiet_NaN();
  }
  return u;
}

/// The result as a model overlay (--write-model): mountings in the accelerometer datum, the
/// accelerometer terms, the thermal harmonics and the time offset, valid over the data's span.
/// Per configured head slot, the mounting error r (Si axes, C_Si_B(true) = Exp([r]x) C_Si_B(nominal)) and
/// its 1-sigma per Si axis (NaN: not determined), from the estimate the outputs take.
struct MountingResult {
  std::vector<Vec3> r_Si, sigma_Si;
  std::string source;
  /// The attitude-domain estimate's accelerometer terms and time offset (value, sigma), written with
  /// its mountings in place of the CRN solver's (one estimate in one overlay).
  bool attitude = false;
  std::optional<model::Uncertain3> bias, scale;
  std::optional<std::pair<double, double>> time_offset_s;
};

Quat calibratedMounting(const io::PlatformConfig& pc, const MountingResult& m, std::size_t slot) {
  return (core::quatExp(m.r_Si[slot]) * pc.pipeline.heads.head[slot].q_Si_B).normalized();
}

/// The calibrated mountings as a QSA1B file (--write-qsa1b).
bool writeMountingsQsa1b(const std::string& path, const io::PlatformConfig& pc, const MountingResult& m, TimeUs t0, char satellite,
                         std::string* error) {
  std::vector<std::pair<std::int32_t, Quat>> heads;
  for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
    heads.emplace_back(pc.pipeline.heads.head[static_cast<std::size_t>(s)].id, calibratedMounting(pc, m, static_cast<std::size_t>(s)));
  return io::writeProduct(path, io::mountingsQsa1b(satellite, t0, heads), error);
}

model::Overlay resultOverlay(const calib::SolveResult& r, const io::PlatformConfig& pc, const calib::ThermalFitResult* tf,
                             TimeUs t0, TimeUs t1, const std::string& config, const MountingResult& mr) {
  model::Overlay o;
  o.written_by = std::string("boresight calibrate ") + BORESIGHT_VERSION;
  o.platform = pc.platform;
  o.note = "method A over " + fmt("%.1f", toSeconds(t1 - t0)) + " s of data from " + io::formatTime(t0) + " (platform file " +
           config + ")";
  model::Validity span;
  span.from = t0;
  span.to = t1;
  // The heads the mountings came for: the CRN solver's, or with the attitude-domain estimate every
  // configured head (it runs also where the CRN solver refused).
  std::vector<int> ids;
  if (mr.attitude)
    for (int s = 0; s < pc.pipeline.heads.n_heads; ++s) ids.push_back(pc.pipeline.heads.head[static_cast<std::size_t>(s)].id);
  else
    for (const auto& hr : r.heads) ids.push_back(hr.id);
  for (const int id : ids) {
    const int s = core::slotOf(pc.pipeline.heads, id);
    if (s < 0) continue;
    model::MountingEntry m;
    m.head = id;
    m.q_Si_B = calibratedMounting(pc, mr, static_cast<std::size_t>(s));
    m.datum = model::MountingDatum::Accelerometer;
    m.epoch = t0 + (t1 - t0) / 2;
    for (int a = 0; a < 3; ++a) m.sigma_rad[a] = mr.sigma_Si[static_cast<std::size_t>(s)](a);
    m.valid = span;
    o.mountings.push_back(m);
  }
  if (mr.attitude) {
    if (mr.bias || mr.scale) {
      model::AccelerometerTerms a;
      a.bias_rad_s2 = mr.bias;
      a.scale = mr.scale;
      a.valid = span;
      o.accelerometer = a;
    }
    if (mr.time_offset_s) {
      model::TimeOffsetEntry t;
      t.sensor = "accelerometer";
      t.relative_to = "heads";
      t.offset_s = mr.time_offset_s->first;
      t.sigma_s = mr.time_offset_s->second;
      t.valid = span;
      o.time_offsets.push_back(t);
    }
  } else if (r.acc_bias_radps2 || r.acc_scale || r.acc_nonorthogonality_arcsec) {
    model::AccelerometerTerms a;
    if (r.acc_bias_radps2) a.bias_rad_s2 = uncertain(*r.acc_bias_radps2, 1.0);
    if (r.acc_scale) a.scale = uncertain(*r.acc_scale, 1.0);
    if (r.acc_nonorthogonality_arcsec) a.nonorthogonality_rad = uncertain(*r.acc_nonorthogonality_arcsec, kRadPerArcsec);
    a.valid = span;
    o.accelerometer = a;
  }
  if (r.time_offset_s && !mr.attitude) {
    model::TimeOffsetEntry t;
    t.sensor = "accelerometer";
    t.relative_to = "heads";
    t.offset_s = *r.time_offset_s;
    t.sigma_s = r.time_offset_sigma_s.value_or(std::numeric_limits<double>::quiet_NaN());
    t.valid = span;
    o.time_offsets.push_back(t);
  }
  if (tf && tf->ok) {
    model::ThermalTerms th;
    th.valid = span;
    if (tf->beta_determined) th.beta_ref_rad = tf->beta_ref_deg * kRadPerDeg;
    for (const calib::ThermalHeadFit& h : tf->heads) {
      th.datum_head = h.datum_id;
      if (!h.determined) continue;
      model::ThermalHeadEntry e;
      e.head = h.id;
      for (int a = 0; a < 3; ++a) {
        e.constant_rad.value[a] = h.axis[static_cast<std::size_t>(a)].constant_arcsec * kRadPerArcsec;
        e.constant_rad.sigma[a] = h.axis[static_cast<std::size_t>(a)].sigma_constant_arcsec * kRadPerArcsec;
      }
      auto harmonics = [&](bool beta) {
        std::vector<model::ThermalHarmonicEntry> out;
        const std::size_t n = beta ? h.axis[0].beta_terms.size() : h.axis[0].terms.size();
        for (std::size_t i = 0; i < n; ++i) {
          model::ThermalHarmonicEntry x;
          for (int a = 0; a < 3; ++a) {
            const auto& t = beta ? h.axis[static_cast<std::size_t>(a)].beta_terms[i] : h.axis[static_cast<std::size_t>(a)].terms[i];
            x.harmonic = t.harmonic;
            x.cos_rad.value[a] = t.cos_arcsec * kRadPerArcsec;
            x.cos_rad.sigma[a] = t.sigma_cos_arcsec * kRadPerArcsec;
            x.sin_rad.value[a] = t.sin_arcsec * kRadPerArcsec;
            x.sin_rad.sigma[a] = t.sigma_sin_arcsec * kRadPerArcsec;
          }
          out.push_back(x);
        }
        return out;
      };
      e.harmonics = harmonics(false);
      e.beta_harmonics = harmonics(true);
      th.heads.push_back(e);
    }
    if (!th.heads.empty()) o.thermal = th;
  }
  return o;
}

/// Where --window writes, and what it says about the model in use.
struct WindowOutputs {
  const io::PlatformConfig& pc;
  std::string config, json_path, yaml_path, report_dir, write_model, write_qsa1b;
  char satellite = 'C';
  double window_s = 0, unobs_arcsec = 0;
  nlohmann::ordered_json model_in_use;
  std::vector<std::string> model_lines;
};

/// A value in arcsec, null when not finite.
report::Json arcsecOrNull(double rad) { return std::isfinite(rad) ? report::Json(rad * kArcsecPerRad) : report::Json(nullptr); }

/// --window: the windows' time series, their joint solution, the report and the written mountings.
int writeWindows(const calib::WindowedCalibration& wc, const WindowOutputs& o, Stages& stages) {
  const std::vector<calib::WindowSolution>& ws = wc.windows();
  const auto& heads = o.pc.pipeline.heads;
  const auto n = static_cast<std::size_t>(heads.n_heads);
  const calib::JointMountings jm = calib::combineWindows(ws, n, o.unobs_arcsec * kRadPerArcsec);
  stages.mark("joint");
  if (jm.windows == 0) {
    std::string why;
    for (const auto& w : ws) why += "\n  " + io::formatTime(w.from) + ": " + w.note;
    return fail("no window was estimated:" + (why.empty() ? std::string(" no data") : why));
  }
  // The written sigma: the joint's, with the spread between windows where the windows show one.
  const std::vector<Vec3>& sigma_out = jm.sigma_written;

  report::Json j;
  j["method"] = "attitude domain, window after window (calib/windows.h): each window its own estimate, the windows combined";
  j["config"] = o.config;
  j["window_s"] = o.window_s;
  j["model_in_use"] = o.model_in_use;
  j["peak_raw_samples_per_window"] = wc.peakRawSamples();
  j["late_samples"] = wc.lateSamples();
  report::Json jw = report::Json::array();
  for (const calib::WindowSolution& w : ws) {
    report::Json x;
    x["from"] = io::formatTime(w.from);
    x["to"] = io::formatTime(w.to);
    x["first_epoch"] = io::formatTime(w.first);
    x["last_epoch"] = io::formatTime(w.last);
    x["head_epochs"] = w.head_epochs;
    x["accelerometer_samples"] = w.acc_samples;
    x["estimated"] = w.estimated;
    x["seconds"] = w.seconds;
    if (!w.estimated) x["note"] = w.note;
    if (w.estimated) {
      x["chi2_per_observation"] = w.chi2_per_obs;
      x["acc_bias_rad_s2"] = {w.bias_rad_s2.x(), w.bias_rad_s2.y(), w.bias_rad_s2.z()};
      x["time_offset_s"] = w.time_offset_s ? report::Json(*w.time_offset_s) : report::Json(nullptr);
      x["time_offset_sigma_s"] = w.time_offset_sigma_s ? report::Json(*w.time_offset_sigma_s) : report::Json(nullptr);
      for (std::size_t i = 0; i < n; ++i) {
        report::Json h;
        h["id"] = heads.head[i].id;
        for (int a = 0; a < 3; ++a) {
          h["error_angles_arcsec"].push_back(w.mountings.r_Si[i](a) * kArcsecPerRad);
          h["sigma_arcsec"].push_back(arcsecOrNull(w.mountings.sigma_Si[i](a)));
        }
        x["heads"].push_back(h);
      }
    }
    x["beta_deg"] = w.beta_rad ? report::Json(*w.beta_rad / kRadPerDeg) : report::Json(nullptr);
    for (const calib::OrbitHarmonicTerm& t : w.harmonics) {
      report::Json ht;
      ht["id"] = heads.head[t.head].id;
      ht["harmonic"] = t.harmonic;
      for (int a = 0; a < 3; ++a) {
        ht["cos_arcsec"].push_back(t.cos_Si(a) * kArcsecPerRad);
        ht["cos_sigma_arcsec"].push_back(std::sqrt(std::max(0.0, t.cov_cos_Si(a, a))) * kArcsecPerRad);
        ht["sin_arcsec"].push_back(t.sin_Si(a) * kArcsecPerRad);
        ht["sin_sigma_arcsec"].push_back(std::sqrt(std::max(0.0, t.cov_sin_Si(a, a))) * kArcsecPerRad);
      }
      x["orbit_harmonics"].push_back(ht);
    }
    jw.push_back(x);
  }
  j["windows"] = jw;
  report::Json jj;
  jj["windows_estimated"] = jm.windows;
  jj["chi2"] = jm.chi2;
  jj["dof"] = jm.dof;
  jj["chi2_per_dof"] = jm.dof > 0 ? report::Json(jm.chi2 / jm.dof) : report::Json(nullptr);
  std::string text = "\njoint of " + std::to_string(jm.windows) + " estimated windows (of " + std::to_string(ws.size()) +
                     "): the windows' scatter about it chi2/dof " + (jm.dof > 0 ? fmt("%.2f", jm.chi2 / jm.dof) : std::string("-")) +
                     " (" + fmt("%.0f", jm.dof) + " dof)\n" +
                     "  head  axis   error [arcsec]   sigma [arcsec]   windows independent   chi2/dof   spread between windows tau [95 %]\n";
  for (std::size_t i = 0; i < n; ++i) {
    report::Json h;
    h["id"] = heads.head[i].id;
    for (int a = 0; a < 3; ++a) {
      const bool det = std::isfinite(jm.sigma_Si[i](a));
      h["error_angles_arcsec"].push_back(jm.r_Si[i](a) * kArcsecPerRad);
      h["sigma_arcsec"].push_back(det ? arcsecOrNull(sigma_out[i](a)) : report::Json(nullptr));
      h["sigma_windows_independent_arcsec"].push_back(arcsecOrNull(jm.sigma_Si[i](a)));
      h["chi2_per_dof"].push_back(det && std::isfinite(jm.axis_chi2_per_dof[i](a)) ? report::Json(jm.axis_chi2_per_dof[i](a)) : report::Json(nullptr));
      h["tau_arcsec"].push_back(det ? arcsecOrNull(jm.tau[i](a)) : report::Json(nullptr));
      h["tau_95_arcsec"].push_back(det && std::isfinite(jm.tau[i](a)) ? report::Json({jm.tau_lo[i](a) * kArcsecPerRad, jm.tau_hi[i](a) * kArcsecPerRad})
                                                                      : report::Json(nullptr));
      h["windows"].push_back(jm.axis_windows[i](a));
      text += "  " + fmt("%4.0f", heads.head[i].id) + "  " + std::string(1, "xyz"[a]) + "     " + fmt("%14.2f", jm.r_Si[i](a) * kArcsecPerRad) +
              "   " +
              (det ? fmt("%14.2f", sigma_out[i](a) * kArcsecPerRad) + "   " + fmt("%19.2f", jm.sigma_Si[i](a) * kArcsecPerRad) + "   " +
                         (std::isfinite(jm.tau[i](a)) ? fmt("%8.2f", jm.axis_chi2_per_dof[i](a)) + "   " + fmt("%.2f", jm.tau[i](a) * kArcsecPerRad) +
                                                            " [" + fmt("%.2f", jm.tau_lo[i](a) * kArcsecPerRad) + ", " +
                                                            fmt("%.2f", jm.tau_hi[i](a) * kArcsecPerRad) + "]"
                                                      : std::string("       -   (one window)"))
                   : std::string("  not determined")) +
              "\n";
    }
    jj["heads"].push_back(h);
  }
  {
    report::Json cov = report::Json::array();
    const Eigen::Index n3 = jm.covariance_Si.rows();
    for (Eigen::Index a = 0; a < n3; ++a) {
      report::Json row = report::Json::array();
      for (Eigen::Index b = 0; b < n3; ++b) {
        const bool d = std::isfinite(jm.sigma_Si[static_cast<std::size_t>(a / 3)](a % 3)) && std::isfinite(jm.sigma_Si[static_cast<std::size_t>(b / 3)](b % 3));
        row.push_back(d ? report::Json(jm.covariance_Si(a, b) * kArcsecPerRad * kArcsecPerRad) : report::Json(nullptr));
      }
      cov.push_back(row);
    }
    jj["covariance_windows_independent_arcsec2"] = cov;
  }
  // The thermal beta-angle modulation of the orbit harmonics, from the windows' series.
  {
    const calib::BetaModulation bm = calib::fitBetaModulation(ws);
    report::Json jb;
    jb["model"] = "term = a + b (cos beta - cos_beta_ref), per head, harmonic, cos/sin and axis of the head's frame";
    jb["windows"] = bm.windows;
    if (bm.windows > 0) jb["beta_range_deg"] = {bm.beta_min_rad / kRadPerDeg, bm.beta_max_rad / kRadPerDeg};
    if (!bm.determined) {
      jb["status"] = "not determined: " + bm.note;
      text += "beta modulation of the orbit harmonics: not determined: " + bm.note + "\n";
    } else {
      jb["status"] = "determined";
      jb["cos_beta_ref"] = bm.cos_ref;
      jb["time_correlation"] = bm.time_correlation;
      if (!bm.caution.empty()) jb["caution"] = bm.caution;
      text += "beta modulation of the orbit harmonics (beta " + fmt("%.1f", bm.beta_min_rad / kRadPerDeg) + ".." +
              fmt("%.1f", bm.beta_max_rad / kRadPerDeg) + " deg over " + std::to_string(bm.windows) +
              " windows; term = a + b (cos beta - " + fmt("%.3f", bm.cos_ref) + "), arcsec, head frame x y z):\n";
      if (!bm.caution.empty()) text += "  caution: " + bm.caution + "\n";
      for (const auto& c : bm.terms) {
        report::Json t;
        t["id"] = heads.head[c.head].id;
        t["harmonic"] = c.harmonic;
        t["term"] = c.sine ? "sin" : "cos";
        std::string line = "  head " + std::to_string(heads.head[c.head].id) + " " + std::to_string(c.harmonic) + "/rev " +
                           (c.sine ? "sin" : "cos") + ":";
        for (int a = 0; a < 3; ++a) {
          t["a_arcsec"].push_back(c.a(a) * kArcsecPerRad);
          t["a_sigma_arcsec"].push_back(c.sigma_a(a) * kArcsecPerRad);
          t["b_arcsec"].push_back(c.b(a) * kArcsecPerRad);
          t["b_sigma_arcsec"].push_back(c.sigma_b(a) * kArcsecPerRad);
          t["chi2_per_dof"].push_back(c.chi2_per_dof(a));
          line += " " + std::string(1, "xyz"[a]) + " a " + fmt("%.2f", c.a(a) * kArcsecPerRad) + " b " + fmt("%.2f", c.b(a) * kArcsecPerRad) +
                  " +- " + fmt("%.2f", c.sigma_b(a) * kArcsecPerRad);
        }
        jb["terms"].push_back(t);
        text += line + "\n";
      }
    }
    jj["beta_modulation"] = jb;
  }
  jj["sigma"] = "sigma_arcsec: the larger of the windows-independent sigma and the random-effects sigma with the spread tau "
                "between windows (Paule-Mandel, 95 % Q-profile interval): the mounting over the record when it moves by tau "
                "from window to window";
  j["joint"] = jj;
  const std::string source = "joint of the windows (information-weighted mean; sigma with the spread between windows)";
  j["mountings_written_from"] = source;
  std::string err;
  if (!writeText(o.json_path, j.dump(2) + "\n", &err)) return fail(err);
  if (!o.yaml_path.empty() && !writeText(o.yaml_path, report::toYaml(j), &err)) return fail(err);

  TimeUs t0 = 0, t1 = 0;
  bool any = false;
  for (const auto& w : ws)
    if (w.head_epochs > 0) {
      if (!any) t0 = w.first;
      t1 = w.last;
      any = true;
    }
  if (!o.report_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.report_dir, ec);
    std::string md = "# Method A, window after window\n\n" + std::to_string(ws.size()) + " windows of " + fmt("%g", o.window_s) +
                     " s from " + io::formatTime(ws.front().from) + ", " + std::to_string(jm.windows) +
                     " estimated. Each head's plot shows every estimated window's error angles less the joint (1-sigma bars) "
                     "and the joint's sigma with the spread between windows (lines): a window outside the band, or a trend, "
                     "is the mounting moving.\n\n```\n" + text + "```\n\n";
    for (std::size_t i = 0; i < n; ++i) {
      report::Plot p;
      p.title = "head " + std::to_string(heads.head[i].id) + ": window estimates less the joint";
      p.xlabel = "window middle, hours after " + io::formatTime(ws.front().from);
      p.ylabel = "arcsec";
      double xmin = 1e300, xmax = -1e300;
      for (int a = 0; a < 3; ++a) {
        report::Series sr;
        sr.name = std::string(1, "xyz"[a]);
        sr.style = report::Series::Style::kPoints;
        sr.dx = (a - 1) * 0.02 * o.window_s / 3600.0;
        for (const auto& w : ws) {
          if (!w.estimated || !std::isfinite(w.mountings.sigma_Si[i](a))) continue;
          const double x = toSeconds(w.from + (w.to - w.from) / 2 - ws.front().from) / 3600.0;
          sr.x.push_back(x);
          sr.y.push_back((w.mountings.r_Si[i](a) - jm.r_Si[i](a)) * kArcsecPerRad);
          sr.yerr.push_back(w.mountings.sigma_Si[i](a) * kArcsecPerRad);
          xmin = std::min(xmin, x);
          xmax = std::max(xmax, x);
        }
        p.series.push_back(sr);
      }
      for (int a = 0; a < 3; ++a) {
        if (!(xmax >= xmin) || !std::isfinite(sigma_out[i](a))) continue;
        const double sg = sigma_out[i](a) * kArcsecPerRad;
        report::Series band;
        band.name = std::string("joint sigma ") + "xyz"[a];
        band.x = {xmin, xmax, std::nan(""), xmin, xmax};
        band.y = {sg, sg, std::nan(""), -sg, -sg};
        p.series.push_back(band);
      }
      const std::string f = "head" + std::to_string(heads.head[i].id) + "_windows.svg";
      if (!report::writeSvgPlot(o.report_dir + "/" + f, p, &err)) return fail(err);
      md += "![head " + std::to_string(heads.head[i].id) + "](" + f + ")\n\n";
    }
    md += "## Windows\n\n| from | head epochs | estimate |\n|---|---|---|\n";
    for (const auto& w : ws)
      md += "| " + io::formatTime(w.from) + " | " + std::to_string(w.head_epochs) + " | " +
            (w.estimated ? "chi2 per observation " + fmt("%.3f", w.chi2_per_obs) : "not estimated: " + w.note) + " |\n";
    md += "\n## Model in use\n\n```\n";
    for (const auto& l : o.model_lines) md += l + "\n";
    md += "```\n";
    if (!io::writeFileAtomic(o.report_dir + "/report.md", md, &err)) return fail(err);
  }
  MountingResult mr;
  mr.attitude = true;  // the windows' own accelerometer terms and time offsets are not written: they change by window
  mr.source = source;
  mr.r_Si = jm.r_Si;
  mr.sigma_Si = sigma_out;
  if (!o.write_model.empty()) {
    const model::Overlay m = resultOverlay(calib::SolveResult{}, o.pc, nullptr, t0, t1, o.config, mr);
    if (!io::writeOverlay(o.write_model, m, &err)) return fail(err);
  }
  if (!o.write_qsa1b.empty() && !writeMountingsQsa1b(o.write_qsa1b, o.pc, mr, t0, o.satellite, &err)) return fail(err);
  stages.mark("output");
  std::printf("%s", text.c_str());
  std::printf("stages: %s\n", stages.text.c_str());
  std::printf("-> %s%s%s%s%s\n", o.json_path.c_str(), o.yaml_path.empty() ? "" : ", ", o.yaml_path.c_str(),
              o.report_dir.empty() ? "" : ", ", o.report_dir.empty() ? "" : (o.report_dir + "/report.md").c_str());
  if (!o.write_model.empty() || !o.write_qsa1b.empty()) std::printf("   mountings written from the %s\n", source.c_str());
  return 0;
}

}  // namespace

int runCalibrate(int argc, char** argv) {
  CLI::App app{"boresight calibrate"};
  std::string config, json_path, yaml_path, report_dir, relative = "hard", overlay, write_model, raw_noise = "fit",
              write_qsa1b, satellite = "C";
  std::vector<std::string> files;
  bool moments = false, no_whiten = false, no_bias = false, acc_scale = false, acc_nonorth = false, time_offset = false, strict = false,
       raw = false, no_time_offset = false, no_acc_scale = false;
  std::string method = "crn";
  double huber = 5.0, decimation = 10.0, unobs = 3600.0, lookahead_s = 2.0, plan_exc = 4.9e-5, plan_sigma = 30.0;
  std::size_t max_obs = 0;
  double crn_bw = 0.0, crn_len = 0.0;
  int raw_harmonics = 2;
  double window_s = 0.0;
  app.add_option("--config", config)->required();
  app.add_option("--json", json_path)->required();
  app.add_option("--yaml", yaml_path);
  app.add_option("--report", report_dir);
  app.add_option("--overlay", overlay);
  app.add_option("--write-model", write_model);
  app.add_option("--write-qsa1b", write_qsa1b);
  app.add_option("--satellite", satellite)->check(CLI::IsMember({"A", "B", "C", "D"}));
  app.add_option("--relative", relative)->check(CLI::IsMember({"hard", "prior"}));
  app.add_flag("--no-acc-bias", no_bias);
  app.add_flag("--acc-scale", acc_scale);
  app.add_flag("--acc-nonorthogonality", acc_nonorth);
  app.add_flag("--time-offset", time_offset);
  app.add_flag("--no-time-offset", no_time_offset);
  app.add_flag("--no-acc-scale", no_acc_scale);
  app.add_option("--method", method)->check(CLI::IsMember({"crn", "attitude"}));
  app.add_flag("--no-whiten", no_whiten);
  app.add_flag("--moments", moments);
  app.add_option("--huber", huber)->check(finiteRange(0.0, 1e6));
  app.add_option("--decimation", decimation)->check(finiteRange(0.1, 3600.0));
  app.add_option("--max-observations", max_obs);
  app.add_option("--crn-bandwidth", crn_bw)->check(finiteRange(1e-4, 10.0));
  app.add_option("--crn-length", crn_len)->check(finiteRange(1.0, 1e4));
  app.add_option("--unobservable-sigma", unobs)->check(finiteRange(1e-6, 1e9));
  app.add_option("--plan-excitation", plan_exc)->check(finiteRange(1e-12, 1.0));
  app.add_option("--plan-sigma", plan_sigma)->check(finiteRange(1e-6, 1e9));
  app.add_option("--lookahead", lookahead_s)->check(finiteRange(0.0, 3600.0));
  app.add_flag("--strict", strict);
  app.add_flag("--raw", raw);
  app.add_option("--raw-noise", raw_noise)->check(CLI::IsMember({"fit", "in-use"}));
  app.add_option("--raw-harmonics", raw_harmonics)->check(CLI::Range(0, 8));
  app.add_option("--window", window_s)->check(finiteRange(60.0, 1e9));
  app.add_option("inputs", files)->required();
  if (int st = parseCommandLine(app, argc, argv, "calibrate", kUsage); st >= 0) return st;
  for (const auto& [yes, no, what] : {std::make_tuple(time_offset, no_time_offset, "--time-offset and --no-time-offset"),
                                      std::make_tuple(acc_scale, no_acc_scale, "--acc-scale and --no-acc-scale")})
    if (yes && no) {
      std::fprintf(stderr, "boresight calibrate: %s contradict each other\n(boresight calibrate --help lists the options)\n", what);
      return 2;
    }
  raw = raw || method == "attitude";
  // The attitude domain estimates the time offset and the scale unless told not to (either one left out
  // reads as mounting error: on the committed calibration day, 15 ms and 0.05-0.2 % put the angles 5
  // sigma off); the CRN solver only when asked.
  const bool raw_time_offset = raw && !no_time_offset, raw_acc_scale = raw && !no_acc_scale;

  calib::SolveOptions so;
  so.relative = relative == "prior" ? calib::RelativeMode::kPrior : calib::RelativeMode::kHardConstraint;
  so.estimate_acc_bias = !no_bias;
  so.estimate_acc_scale = acc_scale;
  so.estimate_acc_nonorthogonality = acc_nonorth;
  so.estimate_time_offset = time_offset;
  so.huber_sigma = huber;
  so.whiten = !no_whiten;
  so.from_moments = moments;
  so.unobservable_sigma_arcsec = unobs;

  Stages stages;
  std::string err;
  {  // outputs never destroy inputs, checked before anything is read or written
    std::vector<std::string> ins = files;
    ins.push_back(config);
    if (!overlay.empty()) ins.push_back(overlay);
    if (!io::checkOutputs(ins, {{"--json", json_path}, {"--yaml", yaml_path}, {"--report", report_dir, true},
                                {"--write-model", write_model}, {"--write-qsa1b", write_qsa1b}},
                          &err))
      return fail(err);
  }
  stream::ReplayRequest rq;
  rq.program = "boresight calibrate";
  rq.config = config;
  rq.overlay = overlay;
  rq.uses = io::OverlayUses{};  // noise and mountings: method A estimates its own thermal and accelerometer terms
  rq.inputs = files;
  rq.strict = strict;
  rq.lookahead_s = lookahead_s;
  rq.star_vectors = false;  // SCV1A star vectors feed the multi-head Wahba solution, which method A does not use
  stream::Replay rp;
  if (!stream::openReplay(rq, rp, &err)) return fail(err);
  io::PlatformConfig& pc = rp.pc;
  const io::OverlayUse& ovu = rp.overlay;
  const stream::ReplayInputs& in = rp.in;
  stream::Engine& engine = *rp.engine;
  for (const auto& [f, product] : in.ignored)
    if (product != "GNV1B" && product != "GNI1B")
      std::printf("%s: %s is not an input of calibrate (SCA1A, ACC1A, QSA1B, GNI1B/GNV1B, LCM log): ignored\n",
                  f.c_str(), product.c_str());
  if (!pc.pipeline.use_accelerometer)
    return fail("no accelerometer input: method A compares the heads' angular acceleration with the "
                "accelerometer's; give ACC1A files or an LCM log with accelerometer messages");

  for (const auto& l : io::modelInUseLines(pc, ovu)) std::printf("%s\n", l.c_str());

  // The attitude-domain estimate's configuration (--raw), checked before anything is read.
  calib::RawBoundOptions ro;
  std::optional<calib::RawBoundConfig> raw_cfg;
  double raw_unobs = unobs;
  if (raw) {
    if (const std::string e = pc.noise_in_use.missing(); !e.empty()) return fail("--raw needs a noise model for " + e);
    ro.bias = !no_bias;
    ro.scale = raw_acc_scale;
    ro.time_offset = raw_time_offset;
    ro.fit_noise = raw_noise == "fit";
    ro.threads = model::defaultThreads();  // the noise fits, one per head axis
    // Not determined: a sigma above what is known without the data (the platform file's
    // heads.mounting_uncertainty_arcsec), else above --unobservable-sigma.
    raw_unobs = pc.mounting_uncertainty_arcsec > 0 ? std::min(pc.mounting_uncertainty_arcsec, unobs) : unobs;
    ro.unobservable_sigma_rad = raw_unobs * kRadPerArcsec;
    raw_cfg = calib::rawBoundConfig(pc.pipeline, pc.noise_in_use, ro);
    if (const std::string e = raw_cfg->validate(); !e.empty()) return fail("--raw: " + e);
  }

  calib::SpanOptions spo;
  spo.decimation_s = decimation;
  // The accelerometer's weight: the white part of each A axis's noise model (the span builder models
  // white noise through the CRN low-pass).
  for (int a = 0; a < 3; ++a) spo.acc_white_noise_radps2[a] = pc.noise_in_use.accWhiteSigma(a);
  spo.max_observations = max_obs;
  if ((crn_bw > 0) != (crn_len > 0)) return fail("--crn-bandwidth and --crn-length go together");
  spo.crn_bandwidth_hz = crn_bw;
  spo.crn_length_s = crn_len;
  spo.keep_observations = !moments;
  // The run's options (calib::runCalibration, as the node's worker): the solve, the thermal fit and, for a
  // refused span, what would be needed.
  calib::RunOptions ro_run;
  ro_run.solve = so;
  ro_run.plan_excitation_radps2 = plan_exc;
  ro_run.plan_sigma_arcsec = plan_sigma;
  ro_run.plan_excitation_name = "--plan-excitation";
  ro_run.raw = raw_cfg;  // --raw: the attitude-domain estimate from the raw samples after the CRN solve
  ro_run.raw_harmonics = raw_harmonics;
  // --window: window after window (calib/windows.h), the feed emptied at every window's end.
  calib::WindowedCalibration windowed;
  if (window_s > 0) {
    if (!raw) {
      std::fprintf(stderr, "boresight calibrate: --window needs --method attitude (each window's estimate is the attitude-domain "
                           "one)\n(boresight calibrate --help lists the options)\n");
      return 2;
    }
    // Two windows estimated at once on a 2-core machine (each window's estimate is independent of the others).
    if (!windowed.configure(pc.pipeline, spo, window_s, ro_run, raw_unobs * kRadPerArcsec, &err, model::defaultThreads()))
      return fail(err);
    windowed.onWindow([&](const calib::WindowSolution& w) {
      std::printf("window %s .. %s: %llu head epochs, %llu accelerometer samples: %s (%.1f s)\n", io::formatTime(w.from).c_str(),
                  io::formatTime(w.to).c_str(), static_cast<unsigned long long>(w.head_epochs),
                  static_cast<unsigned long long>(w.acc_samples),
                  w.estimated ? ("estimated, chi2 per observation " + fmt("%.3f", w.chi2_per_obs)).c_str() : w.note.c_str(), w.seconds);
      std::fflush(stdout);
    });
  }
  // The thermal harmonic fit of the heads' relative deformation needs the argument of latitude: only
  // with an orbit among the inputs (GNI1B / GNV1B files, or an LCM log's ORBIT messages), read in the
  // same stream as the heads.
  bool with_thermal = window_s <= 0 && (!in.orbit.empty() || !in.lcm.empty()) && pc.pipeline.heads.n_heads >= 2;
  calib::CalibrationFeed cal;
  if (window_s <= 0 && !cal.configure(pc.pipeline, spo, with_thermal, &err, raw)) return fail(err);
  for (const auto& f : in.orbit)
    std::printf("%s: orbit for the %s\n", f.c_str(), window_s > 0 ? "stars' aberration and the orbit harmonics" : "thermal harmonic fit");
  FeedObserver<calib::CalibrationFeed> feed(cal);
  FeedObserver<calib::WindowedCalibration> wfeed(windowed);
  // Before the sources: the orbit files are opened for an observer that wants them.
  if (window_s > 0) engine.addObserver(&wfeed);
  else engine.addObserver(&feed);
  if (!stream::startReplay(rp, &err)) return fail(err);
  if (engine.run() != stream::Engine::Result::kDone) return fail(engine.error());
  stages.mark(window_s > 0 ? "replay and windows" : "replay and span");
  printSourceCounters(engine);
  const core::Health h = engine.health();
  printCoreHealth(h);
  for (const auto& w : io::validityWarnings(ovu, engine.firstEpoch(), engine.lastEpoch())) std::printf("warning: %s\n", w.c_str());

  // Bad input the replay survived but a calibration must not.
  const auto& tot = engine.counters();
  if (tot.used_heads == 0) return fail("no star sensor samples in the inputs (every record rejected: see above)");
  if (tot.used_accel == 0) return fail("no accelerometer samples in the inputs (every record rejected?)");
  const auto unknown = h.by_status[std::size_t(core::Status::kUnknownHead)];
  if (unknown > 0) {
    std::string ids;
    for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
      ids += (s ? ", " : "") + std::to_string(pc.pipeline.heads.head[std::size_t(s)].id);
    return fail("inconsistent head ids: " + std::to_string(unknown) +
                " head samples carry an id that is not in the configuration (" + config + ": heads " + ids +
                "); fix the configuration or the inputs");
  }
  if (window_s > 0) {
    const WindowOutputs wo{pc,           config,    json_path, yaml_path, report_dir, write_model, write_qsa1b, satellite[0],
                           window_s,     raw_unobs, modelInUseJson(pc, ovu), io::modelInUseLines(pc, ovu)};
    return writeWindows(windowed, wo, stages);
  }
  const calib::CalibrationSpan& span = cal.span();
  const double span_s = toSeconds(engine.lastEpoch() - engine.firstEpoch());
  std::printf("span: %.1f s of head data, %llu head epochs, %llu accelerometer samples -> %zu observations\n",
              span_s, static_cast<unsigned long long>(span.head_epochs),
              static_cast<unsigned long long>(span.acc_samples), static_cast<std::size_t>(span.epochs_total));

  // The solve, the thermal fit and, for a refused span, what would be needed (calib::runCalibration,
  // as the node's worker).
  calib::CalibrationRun run = calib::runCalibration(cal, ro_run);
  stages.mark(raw && run.raw_estimated ? "solve and attitude-domain estimate" : "solve");
  // A span the CRN solver refuses still has the attitude-domain estimate with --method attitude: the
  // refusal is reported and the outputs take that estimate; without it the refusal ends the run.
  const bool crn_ok = run.ok;
  if (!crn_ok && !(raw && run.raw_estimated)) return fail(run.refusal_text + (run.raw_note.empty() ? "" : "\n" + run.raw_note));
  if (!crn_ok)
    std::printf("CRN solver %s\n(the attitude-domain estimate below does not use the CRN: its outputs are written)\n",
                run.refusal_text.c_str());
  const calib::SolveResult& r = run.result;

  std::string thermal_text;
  calib::ThermalFitResult thermal_fit;
  report::CalibrationContext ctx;
  ctx.config = config;
  ctx.inputs = in.sca;
  ctx.inputs.insert(ctx.inputs.end(), in.acc.begin(), in.acc.end());
  ctx.inputs.insert(ctx.inputs.end(), in.qsa.begin(), in.qsa.end());
  ctx.inputs.insert(ctx.inputs.end(), in.lcm.begin(), in.lcm.end());
  ctx.options = so;
  ctx.span_options = spo;
  if (run.thermal_fitted) {
    thermal_fit = run.thermal;
    const calib::ThermalFitResult& tf = thermal_fit;
    ctx.thermal = report::thermalJson(tf);
    thermal_text = calib::formatThermalFit(tf);
    stages.mark("thermal fit");
    for (const auto& f : in.orbit) ctx.inputs.push_back(f);
  } else {
    ctx.thermal = {{"status", !crn_ok ? "not computed: the CRN solver refused the span (the thermal fit follows its solve)"
                              : pc.pipeline.heads.n_heads < 2 ? "not computed: one head"
                                                               : "not computed: no orbit among the inputs (GNI1B or GNV1B "
                                                                 "files, ORBIT messages; the harmonic model needs the "
                                                                 "argument of latitude)"}};
  }
  ctx.ignored.clear();
  for (const auto& ig : in.ignored)
    if (ig.second != "GNV1B" && ig.second != "GNI1B") ctx.ignored.push_back(ig);
  report::Json j = report::calibrationJson(r, ctx);
  if (!crn_ok) j["crn_solver"] = run.refusal_text;
  j["model_in_use"] = modelInUseJson(pc, ovu);
  // The mountings the outputs take: the CRN solver's, replaced by the attitude-domain estimate's with --raw.
  MountingResult mounting;
  mounting.source = "CRN solver";
  for (int s = 0; s < pc.pipeline.heads.n_heads; ++s) {
    const auto slot = static_cast<std::size_t>(s);
    mounting.r_Si.push_back(crn_ok && slot < r.estimate.r_S.size() ? r.estimate.r_S[slot] : Vec3::Zero());
    Vec3 sg = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    for (const auto& hr : r.heads)
      if (hr.id == pc.pipeline.heads.head[slot].id)
        for (int a = 0; a < 3; ++a) sg(a) = sigmaRad(hr.sigma_arcsec[static_cast<std::size_t>(a)]);
    mounting.sigma_Si.push_back(sg);
  }
  std::string raw_text;
  if (raw && !run.raw_estimated) {
    // Asked for and not made (no samples, or no body direction determined): said, and the CRN
    // solver's mountings are the ones written.
    j["attitude_domain"] = {{"status", "not estimated: " + run.raw_note}};
    raw_text = "\nattitude domain: not estimated: " + run.raw_note + "\n";
  }
  if (raw && run.raw_estimated) {
    // The attitude-domain estimate from the raw samples (calib::estimateRaw in runCalibration; no CRN,
    // no decimation).
    const calib::RawEstimate& est = run.raw;
    const calib::RawBoundConfig& rc = run.raw_config;  // with the orbit harmonics when they were estimated
    const std::uint64_t aberrated = cal.aberratedSamples();
    report::Json jr;
    jr["method"] = "attitude domain: raw head samples and accelerometer angular accelerations at their rates, "
                   "trajectory driven by the accelerometer, noise models in use (calib/raw_bound.h)";
    jr["passes"] = est.passes;
    jr["chi2_per_observation"] = est.chi2_per_obs;
    jr["head_samples_rejected"] = est.head_samples_rejected;
    jr["aberration_removed_head_samples"] = aberrated;
    jr["noise"] = ro.fit_noise ? "fitted to the second pass's data less the trajectory's prediction, with the slow parts of the models in use that the span cannot resolve" : "in use, scaled by the variance factors";
    jr["score_blocks"] = est.score_blocks;
    raw_text = "\nattitude domain (--raw: raw samples, no CRN; noise " +
               std::string(ro.fit_noise ? "fitted to the data" : "in use with variance factors") + "; chi2 per observation " +
               fmt("%.3f", est.chi2_per_obs) +
               ", " + std::to_string(est.head_samples_rejected) + " head samples rejected; aberration " +
               (aberrated ? "removed from " + std::to_string(aberrated) + " head samples (orbit among the inputs)"
                          : std::string("not removed: no orbit among the inputs")) +
               ")\n  head  axis   error [arcsec]   sigma [arcsec]   data sigma [arcsec]\n";
    // The mountings with their sigmas (an axis is determined when its sigma, the unobservable directions
    // held, is below the threshold): the node's worker publishes the same conversion.
    const calib::RawMountings rm = calib::rawMountings(est, rc, raw_unobs * kRadPerArcsec);
    for (std::size_t i = 0; i < rc.heads.size(); ++i) {
      const Mat3& A = rc.heads[i].axes_Si;
      const auto o = static_cast<Eigen::Index>(3 * i);
      // The data's own covariance (score blocks) in the same frame.
      const bool have_r = est.robust_covariance.rows() >= o + 3;
      const Mat3 R_Si = have_r ? Mat3(A.transpose() * Mat3(est.robust_covariance.block<3, 3>(o, o)) * A) : Mat3::Zero();
      report::Json hj;
      hj["id"] = rc.heads[i].id;
      mounting.r_Si[i] = rm.r_Si[i];
      mounting.sigma_Si[i] = rm.sigma_Si[i];
      for (int a = 0; a < 3; ++a) {
        const double e = rm.r_Si[i](a) * kArcsecPerRad;
        const bool determined = std::isfinite(rm.sigma_Si[i](a));
        const double sg = rm.sigma_Si[i](a) * kArcsecPerRad;
        const double sr = std::sqrt(std::max(0.0, R_Si(a, a))) * kArcsecPerRad;
        hj["error_angles_arcsec"].push_back(e);
        hj["sigma_arcsec"].push_back(determined ? report::Json(sg) : report::Json(nullptr));
        hj["sigma_score_blocks_arcsec"].push_back(determined && have_r ? report::Json(sr) : report::Json(nullptr));
        raw_text += "  " + fmt("%4.0f", rc.heads[i].id) + "  " + std::string(1, "xyz"[a]) + "     " + fmt("%14.2f", e) + "   " +
                    (determined ? fmt("%14.2f", sg) + "   " + (have_r ? fmt("%19.2f", sr) : std::string("")) : std::string("  not determined")) +
                    "\n";
      }
      static const char* kAx[3] = {"e1", "e2", "b"};
      for (std::size_t ax = 0; ax < 3; ++ax) hj["noise_arcsec"][kAx[ax]] = m_describe(est, rc, i, ax);
      hj["variance_factor"] = {{"cross", est.variance_factor[i][0]}, {"about", est.variance_factor[i][1]}};
      hj["chi2_per_dof"] = {{"cross", est.chi2_per_dof[i][0]}, {"about", est.chi2_per_dof[i][1]}};
      raw_text += "        noise e1 " + m_describe(est, rc, i, 0) + "; e2 " + m_describe(est, rc, i, 1) + "; b " + m_describe(est, rc, i, 2) +
                  "\n        chi2/dof cross " + fmt("%.3f", est.chi2_per_dof[i][0]) + ", about " + fmt("%.3f", est.chi2_per_dof[i][1]) +
                  " (variance factors applied " + fmt("%.3f", est.variance_factor[i][0]) + ", " + fmt("%.3f", est.variance_factor[i][1]) + ")\n";
      jr["heads"].push_back(hj);
    }
    // The covariance of every head's angles (Si frames, head after head, x y z; arcsec^2), null where an
    // axis is not determined: what a user needs to combine spans or to carry the mountings on.
    {
      report::Json cov = report::Json::array();
      const Eigen::Index n3 = rm.covariance_Si.rows();
      for (Eigen::Index a = 0; a < n3; ++a) {
        report::Json row = report::Json::array();
        const bool da = std::isfinite(rm.sigma_Si[static_cast<std::size_t>(a / 3)](a % 3));
        for (Eigen::Index b = 0; b < n3; ++b) {
          const bool db = std::isfinite(rm.sigma_Si[static_cast<std::size_t>(b / 3)](b % 3));
          const double v = rm.covariance_Si(a, b) * kArcsecPerRad * kArcsecPerRad;
          row.push_back(da && db && std::isfinite(v) ? report::Json(v) : report::Json(nullptr));
        }
        cov.push_back(row);
      }
      jr["covariance_arcsec2"] = cov;
    }
    for (int k = 0; k < 3; ++k) {
      const Vec3 u = est.bound.common_axes_B.col(k);
      const double sg = est.bound.common_sigma_rad(k);
      jr["common_rotation"].push_back({{"direction_B", {u.x(), u.y(), u.z()}},
                                       {"sigma_arcsec", std::isfinite(sg) ? report::Json(sg * kArcsecPerRad) : report::Json(nullptr)}});
    }
    jr["unobservable_directions_B"] = report::Json::array();
    for (const Vec3& d : est.bound.unobservable_B) {
      jr["unobservable_directions_B"].push_back({d.x(), d.y(), d.z()});
      raw_text += "  not observable: body direction (" + fmt("%.3f", d.x()) + ", " + fmt("%.3f", d.y()) + ", " + fmt("%.3f", d.z()) +
                  ") - the common rotation about it is held at its nominal value (sigma above " + fmt("%.0f", raw_unobs) + "\")\n";
    }
    if (ro.bias) jr["acc_bias_rad_s2"] = {est.bias_rad_s2.x(), est.bias_rad_s2.y(), est.bias_rad_s2.z()};
    if (ro.scale) {
      jr["acc_scale"] = {est.scale.x(), est.scale.y(), est.scale.z()};
      // Axes the span does not determine (no angular acceleration about them) are held at nominal.
      jr["acc_scale_held"] = report::Json::array();
      for (const auto& name : est.bound.held) {
        jr["acc_scale_held"].push_back(name);
        raw_text += "  " + name + " held at its nominal value: the span does not determine it (sigma above " +
                    fmt("%g", ro.scale_hold_sigma) + ")\n";
      }
    }
    // Sigma of a named parameter of the estimate (NaN when absent).
    const auto sigmaOfName = [&](const std::string& name) { return calib::parameterSigma(est.bound, name); };
    mounting.attitude = true;
    const auto terms = [&](const Vec3& v, const char* stem) {
      model::Uncertain3 u;
      for (int a = 0; a < 3; ++a) {
        const std::string name = std::string(stem) + "xyz"[a];
        u.value[a] = v(a);
        const bool held = std::find(est.bound.held.begin(), est.bound.held.end(), name) != est.bound.held.end();
        u.sigma[a] = held ? std::numeric_limits<double>::quiet_NaN() : sigmaOfName(name);  // NaN: not determined
      }
      return u;
    };
    if (ro.bias) mounting.bias = terms(est.bias_rad_s2, "acc_bias.");
    if (ro.scale) mounting.scale = terms(est.scale, "acc_scale.");
    if (ro.time_offset) {
      // A sigma of zero is the pseudo-inverse's null space: the span does not determine the offset (no
      // angular jerk the accelerometer sees). Reported so, and not written to the overlay.
      const double sg = sigmaOfName("acc_time_offset");
      if (sg > 0) {
        mounting.time_offset_s = std::make_pair(est.time_offset_s, sg);
        jr["time_offset_s"] = est.time_offset_s;
        jr["time_offset_sigma_s"] = sg;
        raw_text += "  time offset " + fmt("%.4f", est.time_offset_s) + " s +- " + fmt("%.4f", sg) + " s (accelerometer tags late)\n";
      } else {
        jr["time_offset_s"] = nullptr;
        jr["time_offset_sigma_s"] = nullptr;
        raw_text += "  time offset: not determined by the span (not reported, not written)\n";
      }
    }
    // The relative alignment's orbit harmonics: head i's mounting rotates against the others by
    // sum_k c_k cos(k u) + s_k sin(k u) (Si axes x, y, z, as the error angles; the estimate's head-axis
    // parameters H enter as -axes_Si^T H, RawEstimate::harmonics), u the argument of latitude.
    const int K = rc.options.harmonics;
    if (K > 0 && est.harmonics.size() > 0) {
      report::Json jh;
      jh["argument"] = "argument of latitude u = phase + rate t (the orbit's, fitted over the span)";
      jh["rate_rad_s"] = rc.options.orbit_rate_rad_s;
      jh["phase_rad"] = rc.options.orbit_phase_rad;  // u at the span's first sample
      jh["relative_to_head"] = rc.heads[0].id;
      jh["frame"] = "each head's own frame Si (x, y, z), as error_angles_arcsec";
      raw_text += "  relative alignment's orbit harmonics (rotation of the mounting in its own frame x, y, z; arcsec +- sigma):\n";
      // The terms (calib::orbitHarmonicTerms: columns by the estimate's parameter names), per head.
      const std::vector<calib::OrbitHarmonicTerm> terms_h = calib::orbitHarmonicTerms(est, rc);
      for (std::size_t i = 1; i < rc.heads.size(); ++i) {
        report::Json hh;
        hh["id"] = rc.heads[i].id;
        for (const calib::OrbitHarmonicTerm& t : terms_h) {
          if (t.head != i) continue;
          report::Json tk;
          tk["harmonic"] = t.harmonic;
          std::string line = "    head " + std::to_string(rc.heads[i].id) + " " + std::to_string(t.harmonic) + "/rev:";
          for (int c = 0; c < 2; ++c) {
            const char* cs = c == 0 ? "cos" : "sin";
            const Vec3 v = (c == 0 ? t.cos_Si : t.sin_Si) * kArcsecPerRad;
            const Mat3& Cs = c == 0 ? t.cov_cos_Si : t.cov_sin_Si;
            line += " " + std::string(cs) + " (";
            for (int a = 0; a < 3; ++a) {
              const double sg = std::sqrt(std::max(0.0, Cs(a, a))) * kArcsecPerRad;
              tk[std::string(cs) + "_arcsec"].push_back(v(a));
              tk[std::string(cs) + "_sigma_arcsec"].push_back(sg);
              line += (a ? ", " : "") + fmt("%.2f", v(a)) + " +- " + fmt("%.2f", sg);
            }
            line += ")";
          }
          hh["terms"].push_back(tk);
          raw_text += line + "\n";
        }
        jh["heads"].push_back(hh);
      }
      jr["orbit_harmonics"] = jh;
    } else {
      jr["orbit_harmonics"] = {{"status", run.raw_harmonics_note.empty() ? std::string("not estimated (--raw-harmonics 0)") : run.raw_harmonics_note}};
      if (!run.raw_harmonics_note.empty()) raw_text += "  " + run.raw_harmonics_note + "\n";
    }
    j["attitude_domain"] = jr;
    mounting.source = "attitude-domain estimate (--method attitude)";
  }
  j["mountings_written_from"] = mounting.source;
  if (!writeText(json_path, j.dump(2) + "\n", &err)) return fail(err);
  if (!yaml_path.empty() && !writeText(yaml_path, report::toYaml(j), &err)) return fail(err);
  if (!report_dir.empty()) {
    // The report's plots are the CRN solver's (its residuals and its estimates); refused, a report that
    // says so and where the attitude-domain estimate is.
    if (crn_ok && !report::writeCalibrationReport(report_dir, span, r, j, &err)) return fail(err);
    if (!crn_ok) {
      std::error_code ec;
      std::filesystem::create_directories(report_dir, ec);
      if (!io::writeFileAtomic(report_dir + "/report.md",
                               "# Method A calibration\n\nCRN solver " + run.refusal_text +
                                   "\n\nThe attitude-domain estimate (`attitude_domain` in " + json_path + "):\n\n```\n" + raw_text + "```\n",
                               &err))
        return fail(err);
    }
    std::string text = "\n## Model in use\n\n```\n";
    for (const auto& l : io::modelInUseLines(pc, ovu)) text += l + "\n";
    // Appended by rewriting the whole file (whole or not at all, as every output).
    const std::string md_path = report_dir + "/report.md";
    std::string md;
    if (!io::readBounded(md_path, io::kMaxTableBytes, "report", md, &err) ||
        !io::writeFileAtomic(md_path, md + text + "```\n", &err))
      return fail(err);
  }
  if (!write_model.empty()) {
    const model::Overlay m = resultOverlay(r, pc, run.thermal_fitted ? &thermal_fit : nullptr, span.t_first, span.t_last, config, mounting);
    if (!io::writeOverlay(write_model, m, &err)) return fail(err);
  }
  if (!write_qsa1b.empty() && !writeMountingsQsa1b(write_qsa1b, pc, mounting, span.t_first, satellite[0], &err)) return fail(err);
  stages.mark("output");

  if (!crn_ok) std::printf("\nCRN solver: refused (above)\n");
  else std::printf("\n%s (%zu epochs over %.1f s, residual RMS %.3e rad/s^2, relative attitude as a %s)\n",
              r.message.c_str(), r.epochs, r.span_s, r.residual_rms_radps2,
              so.relative == calib::RelativeMode::kPrior ? "prior" : "hard constraint");
  if (crn_ok) std::printf("  head  axis   error [arcsec]   sigma [arcsec]   CRLB [arcsec]\n");
  const char* ax = "xyz";
  for (const auto& hr : crn_ok ? r.heads : std::vector<calib::HeadResult>{})
    for (std::size_t a = 0; a < 3; ++a)
      std::printf("  %4d  %c     %14.2f   %14s   %13s\n", hr.id, ax[a], hr.error_angles_arcsec[a],
                  hr.sigma_arcsec[a] ? fmt("%.2f", *hr.sigma_arcsec[a]).c_str() : "not determined",
                  std::isfinite(hr.crlb_arcsec[a]) ? fmt("%.2f", hr.crlb_arcsec[a]).c_str() : "inf");
  for (const auto& d : crn_ok ? r.unobservable_directions_B : std::vector<Vec3>{})
    std::printf("  not observable: body direction (%.3f, %.3f, %.3f) has no excitation\n", d.x(), d.y(), d.z());
  if (crn_ok && r.time_offset_s)
    std::printf("  time offset %.4f s +- %.4f s (accelerometer tags late)\n", *r.time_offset_s,
                r.time_offset_sigma_s.value_or(NAN));
  if (!raw_text.empty()) std::printf("%s", raw_text.c_str());
  if (!thermal_text.empty()) std::printf("\nthermal harmonic model:\n%s", thermal_text.c_str());
  else std::printf("thermal: %s\n", ctx.thermal["status"].get<std::string>().c_str());
  std::printf("stages: %s\n", stages.text.c_str());
  std::printf("-> %s%s%s%s%s%s%s%s%s\n", json_path.c_str(), yaml_path.empty() ? "" : ", ", yaml_path.c_str(),
              report_dir.empty() ? "" : ", ", report_dir.empty() ? "" : (report_dir + "/report.md").c_str(),
              write_model.empty() ? "" : ", model overlay ", write_model.c_str(), write_qsa1b.empty() ? "" : ", QSA1B ",
              write_qsa1b.c_str());
  if (!write_model.empty() || !write_qsa1b.empty()) std::printf("   mountings written from the %s\n", mounting.source.c_str());
  return 0;
}

}  // namespace cmd_calibrate

int runCalibrate(int argc, char** argv) { return cmd_calibrate::runCalibrate(argc, argv); }

}  // namespace boresight::cli

// Method A's orchestration (include/boresight/calib/calibration.h).
#include "boresight/calib/calibration.h"

#include "boresight/core/crn.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace boresight::calib {
namespace {

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

SpanNeed spanNeed(const core::PipelineConfig& cfg, double decimation_s, double excitation_rms_radps2,
                  double target_sigma_arcsec) {
  SpanNeed n;
  core::CrnKernel ka, kb;
  const bool a_ok = core::designCrn(cfg.crn_attitude, ka) == core::Status::kOk;
  const bool b_ok = cfg.use_accelerometer && core::designCrn(cfg.crn_acc, kb) == core::Status::kOk;
  n.crn_s = std::max(a_ok ? ka.tf_s : cfg.crn_attitude.length_s, b_ok ? kb.tf_s : 0.0);
  double g2 = 0.0;
  if (a_ok)
    for (int j = 0; j < ka.nf; ++j) g2 += ka.g[2][std::size_t(j)] * ka.g[2][std::size_t(j)];
  double sigma_cross = INFINITY;
  for (int s = 0; s < cfg.heads.n_heads; ++s)
    sigma_cross = std::min(sigma_cross, cfg.heads.head[std::size_t(s)].sigma_cross_rad);
  n.sigma_alpha_radps2 = sigma_cross * std::sqrt(g2);
  const double per_obs = n.sigma_alpha_radps2 / (excitation_rms_radps2 * target_sigma_arcsec * kRadPerArcsec);
  n.observations = std::ceil(per_obs * per_obs);
  n.bound_s = n.crn_s + n.observations * decimation_s;
  return n;
}

double weakestExcitation(const CalibrationSpan& span) {
  const double n = span.acc_moments(3, 3);
  if (!(n > 0)) return 0.0;
  const Vec3 mean_A = span.acc_moments.block<3, 1>(0, 3) / n;
  const Mat3 cov_A = span.acc_moments.block<3, 3>(0, 0) / n - mean_A * mean_A.transpose();
  const Mat3 cov_B = span.C_B_A * cov_A * span.C_B_A.transpose();
  return std::sqrt(std::max(0.0, cov_B.diagonal().minCoeff()));
}

// ------------------------------------------------------------------------------------------------
CalibrationFeed::CalibrationFeed(const CalibrationFeed& o)
    : cfg_(o.cfg_),
      so_(o.so_),
      builder_(o.builder_),
      thermal_(o.thermal_ ? std::make_unique<ThermalCollector>(*o.thermal_) : nullptr),
      orbit_samples_(o.orbit_samples_),
      configured_(o.configured_),
      finished_(o.finished_),
      with_raw_(o.with_raw_),
      with_crn_(o.with_crn_),
      raw_(o.raw_),
      sum_A_(o.sum_A_),
      n_acc_(o.n_acc_),
      aberrated_(o.aberrated_),
      orbit_v_(o.orbit_v_),
      orbit_line_(o.orbit_line_),
      t0_(o.t0_),
      have_t0_(o.have_t0_) {}

CalibrationFeed& CalibrationFeed::operator=(const CalibrationFeed& o) {
  if (this != &o) {
    CalibrationFeed c(o);
    *this = std::move(c);
  }
  return *this;
}

CalibrationFeed::~CalibrationFeed() = default;

bool CalibrationFeed::configure(const core::PipelineConfig& cfg, const SpanOptions& so, bool with_thermal,
                                std::string* error, bool with_raw, bool with_crn) {
  configured_ = finished_ = false;
  orbit_samples_ = 0;
  thermal_.reset();
  with_raw_ = with_raw;
  with_crn_ = with_crn || !with_raw;
  raw_ = RawData{};
  sum_A_ = Vec3::Zero();
  n_acc_ = aberrated_ = 0;
  orbit_v_.clear();
  orbit_line_ = OrbitLine{};
  have_t0_ = false;
  cfg_ = cfg;
  so_ = so;
  builder_ = SpanBuilder();
  if (!builder_.configure(cfg, so, error)) return false;
  if (with_thermal) {
    thermal_ = std::make_unique<ThermalCollector>();
    if (!thermal_->configure(cfg.heads, ThermalFitConfig{}, error)) {
      thermal_.reset();
      return false;
    }
  }
  configured_ = true;
  return true;
}

void CalibrationFeed::restart(TimeUs keep_orbit_from) {
  if (!configured_) return;
  std::string error;
  builder_ = SpanBuilder();
  builder_.configure(cfg_, so_, &error);  // accepted at configure(): the same configuration again
  if (thermal_) {
    thermal_ = std::make_unique<ThermalCollector>();
    thermal_->configure(cfg_.heads, ThermalFitConfig{}, &error);
  }
  finished_ = false;
  raw_.heads.clear();  // the capacity stays
  raw_.acc.clear();
  sum_A_ = Vec3::Zero();
  n_acc_ = aberrated_ = 0;
  orbit_line_ = OrbitLine{};
  have_t0_ = false;
  orbit_v_.erase(orbit_v_.begin(), std::find_if(orbit_v_.begin(), orbit_v_.end(),
                                                [keep_orbit_from](const OrbitPoint& x) { return x.t >= keep_orbit_from; }));
  orbit_samples_ = orbit_v_.size();
}

CalibrationFeed CalibrationFeed::handOver(TimeUs keep_orbit_from) {
  CalibrationFeed out(std::move(*this));
  // This feed again: the configuration, no data, the orbit segment from keep_orbit_from on (restart).
  cfg_ = out.cfg_;
  so_ = out.so_;
  configured_ = out.configured_;
  with_raw_ = out.with_raw_;
  with_crn_ = out.with_crn_;
  if (out.thermal_) thermal_ = std::make_unique<ThermalCollector>();  // configured by restart()
  raw_ = RawData{};
  orbit_v_ = out.orbit_v_;
  restart(keep_orbit_from);
  return out;
}

double CalibrationFeed::rawTime(TimeUs t) {
  if (!have_t0_) {
    t0_ = t;
    have_t0_ = true;
  }
  return static_cast<double>(t - t0_) * 1e-6;
}

void CalibrationFeed::pushHeads(const core::HeadEpoch& e) {
  if (!configured_ || finished_) return;
  if (with_crn_) builder_.pushHeads(e);
  if (thermal_) thermal_->pushHeads(e);
  if (!with_raw_) return;
  for (int k = 0; k < e.n; ++k) {
    const auto& h = e.sample[static_cast<std::size_t>(k)];
    const int slot = core::slotOf(cfg_.heads, h.head_id);
    if (slot < 0) continue;
    raw_.heads.push_back(RawData::Head::sample(rawTime(e.t), slot, h.q_I_Si));
  }
  trimRaw(e.t);
}

void CalibrationFeed::trimRaw(TimeUs newest) {
  // The raw samples' window: as much data time as the span builder's window of observations (the
  // oldest dropped in blocks of 1/16 of it, as the builder drops its observations).
  if (!with_raw_ || so_.max_observations == 0 || raw_.empty()) return;
  const double window_s = static_cast<double>(so_.max_observations) * so_.decimation_s;
  const double now_s = static_cast<double>(newest - t0_) * 1e-6;
  const double oldest = std::min(raw_.heads.empty() ? now_s : raw_.heads.front().t_s, raw_.acc.empty() ? now_s : raw_.acc.front().t_s);
  if (oldest >= now_s - window_s * (1.0 + 1.0 / 16.0)) return;
  const double cut = now_s - window_s;
  raw_.heads.erase(raw_.heads.begin(), std::find_if(raw_.heads.begin(), raw_.heads.end(), [cut](const RawData::Head& x) { return x.t_s >= cut; }));
  raw_.acc.erase(raw_.acc.begin(), std::find_if(raw_.acc.begin(), raw_.acc.end(), [cut](const RawData::Acc& x) { return x.t_s >= cut; }));
  const TimeUs cut_us = t0_ + static_cast<TimeUs>(std::llround(cut * 1e6)) - 60 * kUsPerSecond;  // orbit: one segment more
  const auto o = std::find_if(orbit_v_.begin(), orbit_v_.end(), [cut_us](const OrbitPoint& x) { return x.t >= cut_us; });
  orbit_v_.erase(orbit_v_.begin(), o);
}

void CalibrationFeed::pushAcc(TimeUs t, const Vec3& a_A) {
  if (!configured_ || finished_) return;
  if (with_crn_) builder_.pushAcc(t, a_A);
  if (!with_raw_) return;
  raw_.acc.push_back(RawData::Acc::sample(rawTime(t), a_A));
  sum_A_ += a_A;
  ++n_acc_;
  trimRaw(t);
}

void CalibrationFeed::pushOrbit(const model::OrbitSample& o) {
  if (!configured_ || finished_ || !wantsOrbit()) return;
  if (thermal_) thermal_->pushOrbit(o);
  if (with_raw_) orbit_v_.push_back(OrbitPoint{o.t, o.v_I, o.u_rad, o.u_rate_rad_s});
  ++orbit_samples_;
}

void CalibrationFeed::finish() {
  if (!configured_ || finished_) return;
  builder_.finish();
  finished_ = true;
  if (!with_raw_ || orbit_v_.size() < 2 || !have_t0_) return;
  // Every head sample inside the orbit's span gets the observer velocity (the satellite's, linear
  // between orbit samples, and the Earth's), so that the estimate removes the stars' aberration.
  std::stable_sort(orbit_v_.begin(), orbit_v_.end(), [](const OrbitPoint& a, const OrbitPoint& b) { return a.t < b.t; });
  fitOrbitLine();
  // Segment j is [orbit j, orbit j+1]; it serves t inside it unless it spans an orbit gap (> 60 s).
  const auto serves = [&](std::size_t j, TimeUs t) {
    const TimeUs ta = orbit_v_[j].t, tb = orbit_v_[j + 1].t;
    return t >= ta && t <= tb && tb > ta && tb - ta <= 60 * kUsPerSecond;
  };
  std::size_t k = 0;
  for (auto& ev : raw_.heads) {  // in time order, as the orbit
    const TimeUs t = t0_ + static_cast<TimeUs>(std::llround(ev.t_s * 1e6));
    while (k + 2 < orbit_v_.size() && orbit_v_[k + 1].t < t) ++k;
    // A sample at an orbit sample's time belongs to either segment: the next one when this one is a gap.
    std::size_t j = k;
    if (!serves(j, t) && j + 2 < orbit_v_.size() && serves(j + 1, t)) ++j;
    if (!serves(j, t)) continue;  // outside the orbit's span, or in an orbit gap
    const OrbitPoint& a = orbit_v_[j];
    const OrbitPoint& b = orbit_v_[j + 1];
    const double f = static_cast<double>(t - a.t) / static_cast<double>(b.t - a.t);
    ev.setObserverVelocity(a.v_I + f * (b.v_I - a.v_I) + model::earthVelocityLowPrecision(toSeconds(t)));
    ++aberrated_;
  }
}

void CalibrationFeed::fitOrbitLine() {
  orbit_line_ = OrbitLine{};
  if (orbit_v_.size() < 2) return;
  // Unwrap: between two samples u moves by about the mean of their rates times the interval (across any
  // gap); the turns added are those that bring the step nearest to that.
  std::vector<double> t(orbit_v_.size()), u(orbit_v_.size());
  for (std::size_t k = 0; k < orbit_v_.size(); ++k) {
    t[k] = static_cast<double>(orbit_v_[k].t - t0_) * 1e-6;
    u[k] = orbit_v_[k].u;
    if (k == 0) continue;
    const double expected = 0.5 * (orbit_v_[k].u_rate + orbit_v_[k - 1].u_rate) * (t[k] - t[k - 1]);
    u[k] += 2 * kPi * std::round((u[k - 1] + expected - u[k]) / (2 * kPi));
  }
  // u = phase + rate t by least squares (about the means: well conditioned over any span).
  const double n = static_cast<double>(t.size());
  double tm = 0, um = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    tm += t[k] / n;
    um += u[k] / n;
  }
  double stt = 0, stu = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    stt += (t[k] - tm) * (t[k] - tm);
    stu += (t[k] - tm) * (u[k] - um);
  }
  if (!(stt > 0)) return;
  OrbitLine& l = orbit_line_;
  l.rate_rad_s = stu / stt;
  l.phase_rad = um - l.rate_rad_s * tm;
  double ss = 0;
  for (std::size_t k = 0; k < t.size(); ++k) ss += std::pow(u[k] - l.phase_rad - l.rate_rad_s * t[k], 2);
  l.rms_rad = std::sqrt(ss / n);
  l.span_s = t.back() - t.front();
  l.samples = t.size();
  l.ok = l.rate_rad_s > 0 && std::isfinite(l.phase_rad);
}

// ------------------------------------------------------------------------------------------------
CalibrationRun runCalibration(CalibrationFeed& feed, const RunOptions& o) {
  CalibrationRun run;
  feed.finish();
  const CalibrationSpan& span = feed.span();
  const SpanOptions& spo = feed.spanOptions();
  // What a refused span would need: the CRN's length (the calibration CRN when one is given) and the
  // bound's span at the planning excitation and at the span's own.
  core::PipelineConfig need_cfg = feed.config();
  if (spo.crn_bandwidth_hz > 0 && spo.crn_length_s > 0)
    for (core::CrnConfig* c : {&need_cfg.crn_attitude, &need_cfg.crn_acc}) {
      c->bandwidth_hz = spo.crn_bandwidth_hz;
      c->length_s = spo.crn_length_s;
    }
  const double decimation = spo.decimation_s;
  run.need = spanNeed(need_cfg, decimation, o.plan_excitation_radps2, o.plan_sigma_arcsec);
  run.weakest_excitation_radps2 = weakestExcitation(span);
  if (run.weakest_excitation_radps2 > 0)
    run.need_own = spanNeed(need_cfg, decimation, run.weakest_excitation_radps2, o.plan_sigma_arcsec);
  auto needText = [&](const SpanNeed& n, double excitation, const char* what) {
    return "the Cramer-Rao bound needs about " + fmt("%.0f", n.observations) + " decorrelated observations (one per " +
           fmt("%g", decimation) + " s) to reach " + fmt("%g", o.plan_sigma_arcsec) + "\" with " + fmt("%.2g", excitation) +
           " rad/s^2 RMS excitation per axis (" + what + "; head noise through the CRN " +
           fmt("%.2g", n.sigma_alpha_radps2) + " rad/s^2): at least " +
           (n.bound_s < 86400.0 * 365 ? fmt("%.0f", n.bound_s) + " s (" + fmt("%.1f", n.bound_s / 3600) + " h)"
                                      : fmt("%.2g", n.bound_s / (86400.0 * 365.25)) + " years");
  };
  const std::string plan_need = needText(run.need, o.plan_excitation_radps2, o.plan_excitation_name.c_str());

  // The attitude-domain estimate: from the raw samples alone, so it runs whatever the CRN solver says
  // (a span the CRN refuses - too short for its filter, too quiet for its bound - still gets the
  // estimate, with sigmas that say what the data determine).
  const auto runRaw = [&]() {
    if (!o.raw || !feed.collectsRaw()) return;
    const std::size_t n_head = feed.raw().heads.size(), n_acc = feed.raw().acc.size();
    if (n_head < 2 || n_acc < 2) {
      run.raw_note = "the attitude-domain estimate needs head and accelerometer samples (" + std::to_string(n_head) + " and " +
                     std::to_string(n_acc) + " in the window)";
      return;
    }
    run.raw_config = *o.raw;
    if (o.raw_harmonics > 0 && run.raw_config.heads.size() > 1) {
      // The relative alignment's orbit harmonics need the orbit's phase over at least one revolution.
      const CalibrationFeed::OrbitLine& l = feed.rawOrbitLine();
      if (!l.ok) {
        run.raw_harmonics_note = "no orbit among the inputs (GNI1B / GNV1B, ORBIT messages): the relative alignment's orbit "
                                 "harmonics not estimated";
      } else if (l.span_s * l.rate_rad_s < 2 * kPi) {
        run.raw_harmonics_note = "the orbit covers " + fmt("%.2f", l.span_s * l.rate_rad_s / (2 * kPi)) +
                                 " revolutions of the span (at least one needed): the relative alignment's orbit harmonics not estimated";
      } else {
        run.raw_config.options.harmonics = o.raw_harmonics;
        run.raw_config.options.orbit_rate_rad_s = l.rate_rad_s;
        run.raw_config.options.orbit_phase_rad = l.phase_rad;
      }
    }
    run.raw = estimateRaw(run.raw_config, feed.raw(), feed.rawMeanAcc(), o.raw_passes);
    run.raw_estimated = true;
    // No body direction of the common rotation determined (no excitation the accelerometer sees): the
    // heads' alignment to the accelerometer's datum, which method A calibrates, is not in the span; the
    // time offset and the scale factors are not either.
    if (run.raw.bound.unobservable_B.size() >= 3) {
      run.raw_estimated = false;
      run.raw_note = "the attitude-domain estimate determines no body direction of the common rotation (the span has no "
                     "angular acceleration the accelerometer sees above its noise): refused as well";
    }
  };

  if (!feed.collectsCrn()) {  // the attitude-domain estimate alone
    run.result.ok = false;
    run.result.refusal = Refusal::kTooFewEpochs;
    run.result.message = "no CRN rows collected (the attitude-domain estimate alone)";
    runRaw();
    return run;
  }
  if (span.epochs_total == 0) {
    const double span_s = span.head_epochs ? static_cast<double>(span.t_last - span.t_first) * 1e-6 : 0.0;
    run.result.ok = false;
    run.result.refusal = Refusal::kTooFewEpochs;
    run.result.message = "the span is too short (" + fmt("%.1f", span_s) +
                         " s of head data, no CRN angular acceleration in it)";
    run.refusal_text = "refused: " + run.result.message +
                       ".\nNeeded: the CRN gives an angular acceleration only with Tf = " + fmt("%.1f", run.need.crn_s) +
                       " s of head and accelerometer data centred on it; " + plan_need + " of excited data.";
    runRaw();
    return run;
  }

  run.result = solve(span, o.solve);
  // From the moments the solver reports no epochs (it counts kept observations): the span made them.
  if (run.result.ok && run.result.epochs == 0) run.result.epochs = static_cast<std::size_t>(span.epochs_total);
  if (!run.result.ok) {
    // What the bound needs is said for the refusals about the data's length or excitation; other
    // refusals (a head never seen with the others, ...) carry their own remedy.
    const Refusal why = run.result.refusal;
    run.refusal_text = "refused: " + run.result.message;
    if (why == Refusal::kTooFewEpochs || why == Refusal::kTooQuiet)
      run.refusal_text += "\nNeeded: " + plan_need + "; at this span's weakest-axis excitation " +
                          (run.weakest_excitation_radps2 > 0
                               ? needText(run.need_own, run.weakest_excitation_radps2, "this span")
                               : std::string("(none)")) +
                          ".";
    runRaw();
    return run;
  }
  run.ok = true;
  runRaw();
  if (o.thermal_fit && feed.thermal() && feed.orbitSamples() > 0) {
    run.thermal = feed.thermal()->fit();
    run.thermal_fitted = true;
  }
  return run;
}

}  // namespace boresight::calib

// Method A's orchestration (calib/calibration.h): the feed, the run, the refusal advice - the steps
// `boresight calibrate` and the node's worker share.
#include "synthetic.h"

#include <boresight/calib/calibration.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace boresight::calib {
namespace {

using synth::manoeuvreCase;

SpanOptions spanOptions(const synth::Config& c) {
  SpanOptions so;
  so.decimation_s = c.decimation_s;
  so.acc_white_noise_radps2 = c.acc_white;
  return so;
}

/// The synthetic data through a feed configured as synth::generate configures a span builder.
void feed(const synth::Config& c, CalibrationFeed& f, bool finish = true) {
  std::string err;
  ASSERT_TRUE(f.configure(synth::pipelineConfig(c), spanOptions(c), false, &err)) << err;
  synth::stream(c, f);
  if (finish) f.finish();
}

TEST(SpanNeed, CrnNoiseAndTheBoundsScaling) {
  core::PipelineConfig cfg;
  cfg.heads.n_heads = 2;
  cfg.heads.head[0].sigma_cross_rad = 6.0 * kRadPerArcsec;
  cfg.heads.head[1].sigma_cross_rad = 9.0 * kRadPerArcsec;
  const auto n = spanNeed(cfg, 10.0, 5e-5, 30.0);
  // The CRN length, and the head noise through the second-derivative kernel against the ideal
  // band-limited differentiator: white noise of variance s^2 at fs through (2 pi f)^2 up to B gives
  // s^2 (2 pi)^4 2 B^5 / (5 fs); the CRN's gentle edge keeps it within a few ten per cent.
  EXPECT_NEAR(n.crn_s, cfg.crn_attitude.length_s, 0.5);
  const double s = 6.0 * kRadPerArcsec, B = cfg.crn_attitude.bandwidth_hz, fs = cfg.crn_attitude.fs_hz;
  const double ideal = s * std::sqrt(std::pow(2 * kPi, 4) * 2 * std::pow(B, 5) / (5 * fs));
  EXPECT_NEAR(n.sigma_alpha_radps2 / ideal, 1.0, 0.3) << n.sigma_alpha_radps2 << " vs " << ideal;
  // N ~ (sigma_alpha / (excitation target))^2: twice the excitation or twice the target, a quarter.
  const auto n2 = spanNeed(cfg, 10.0, 1e-4, 30.0), n3 = spanNeed(cfg, 10.0, 5e-5, 60.0);
  EXPECT_NEAR(n2.observations / n.observations, 0.25, 0.01);
  EXPECT_NEAR(n3.observations / n.observations, 0.25, 0.01);
  EXPECT_NEAR(n.bound_s, n.crn_s + n.observations * 10.0, 1e-6);
}

// The run adds nothing to the solver's answer: the same estimate, covariance and epochs as solve() on
// the same span, from the epochs and from the moments (where the epochs are the span's count).
TEST(RunCalibration, SolvedSpanIsTheSolversResult) {
  const synth::Config c = manoeuvreCase(3);
  CalibrationFeed f;
  feed(c, f);
  RunOptions o;
  const CalibrationRun run = runCalibration(f, o);
  ASSERT_TRUE(run.ok) << run.refusal_text;
  EXPECT_TRUE(run.refusal_text.empty());
  const SolveResult direct = solve(f.span(), o.solve);
  ASSERT_TRUE(direct.ok);
  for (int h = 0; h < c.n_heads; ++h)
    EXPECT_EQ(run.result.estimate.r_S[std::size_t(h)], direct.estimate.r_S[std::size_t(h)]) << h;
  EXPECT_EQ(run.result.covariance_arcsec2, direct.covariance_arcsec2);
  EXPECT_EQ(run.result.epochs, direct.epochs);
  // The truth within 4 sigma on every axis (the orchestration hands the span over whole).
  for (int h = 0; h < c.n_heads; ++h)
    for (int a = 0; a < 3; ++a) {
      const auto& hr = run.result.heads[std::size_t(h)];
      ASSERT_TRUE(hr.sigma_arcsec[std::size_t(a)].has_value());
      EXPECT_LT(std::abs(hr.error_angles_arcsec[std::size_t(a)] - c.truth.r_S[std::size_t(h)][a] / kRadPerArcsec),
                4 * *hr.sigma_arcsec[std::size_t(a)])
          << "head " << h << " axis " << a;
    }
  EXPECT_FALSE(run.thermal_fitted);  // no thermal collection asked
  // The residuals the report plots are the solver's model at its estimate: their RMS is the solver's.
  const SpanResiduals res = residuals(f.span(), run.result.estimate);
  ASSERT_EQ(res.r_S.size(), f.span().obs.size());
  double ss = 0;
  std::size_t n = 0;
  for (const auto& row : res.r_S)
    for (int h = 0; h < c.n_heads; ++h)
      if (row[std::size_t(h)].allFinite()) {
        ss += row[std::size_t(h)].squaredNorm();
        n += 3;
      }
  EXPECT_NEAR(std::sqrt(ss / static_cast<double>(n)) / run.result.residual_rms_radps2, 1.0, 1e-9);

  // From the moments only: the solver counts no kept observation, the run gives the span's epochs.
  CalibrationFeed fm;
  std::string err;
  SpanOptions so = spanOptions(c);
  so.keep_observations = false;
  ASSERT_TRUE(fm.configure(synth::pipelineConfig(c), so, false, &err)) << err;
  synth::stream(c, fm);
  RunOptions om;
  om.solve.from_moments = true;
  const CalibrationRun rm = runCalibration(fm, om);  // the run finishes the feed itself
  ASSERT_TRUE(rm.ok) << rm.refusal_text;
  EXPECT_TRUE(fm.finished());
  EXPECT_EQ(rm.result.epochs, static_cast<std::size_t>(fm.span().epochs_total));
  EXPECT_GT(rm.result.epochs, 300u);
}

// A span shorter than the CRN: refused without a solve, with the CRN's length and the bound's span at
// the planning excitation named.
TEST(RunCalibration, SpanShorterThanTheCrnSaysWhatIsNeeded) {
  synth::Config c = manoeuvreCase(4);
  c.duration_s = 16;  // the real Level-1 excerpts' length
  CalibrationFeed f;
  feed(c, f);
  ASSERT_EQ(f.span().epochs_total, 0u);
  RunOptions o;
  o.plan_excitation_name = "--plan-excitation";
  const CalibrationRun run = runCalibration(f, o);
  EXPECT_FALSE(run.ok);
  EXPECT_EQ(run.result.refusal, Refusal::kTooFewEpochs);
  EXPECT_EQ(run.result.iterations, 0);  // never handed to the solver
  EXPECT_NE(run.refusal_text.find("refused: the span is too short (15.5 s of head data"), std::string::npos)
      << run.refusal_text;
  const SpanNeed n = spanNeed(synth::pipelineConfig(c), c.decimation_s, o.plan_excitation_radps2, o.plan_sigma_arcsec);
  char tf[64];
  std::snprintf(tf, sizeof tf, "Tf = %.1f s", n.crn_s);
  EXPECT_NE(run.refusal_text.find(tf), std::string::npos) << run.refusal_text;
  EXPECT_NE(run.refusal_text.find("(--plan-excitation;"), std::string::npos) << run.refusal_text;
  EXPECT_DOUBLE_EQ(run.need.bound_s, n.bound_s);
}

// A quiet span: the solver's refusal with the bound's span at this span's own weakest-axis excitation,
// which is the RMS about the mean of the accelerometer's CRN angular acceleration in B, weakest axis -
// checked here from the kept observations themselves.
TEST(RunCalibration, QuietSpanAdviceUsesItsOwnWeakestExcitation) {
  synth::Config c = manoeuvreCase(8);
  c.manoeuvres.clear();
  c.duration_s = 1800;
  CalibrationFeed f;
  feed(c, f);
  const CalibrationRun run = runCalibration(f, RunOptions{});
  EXPECT_FALSE(run.ok);
  EXPECT_EQ(run.result.refusal, Refusal::kTooQuiet);
  EXPECT_NE(run.refusal_text.find("\nNeeded: the Cramer-Rao bound needs about"), std::string::npos) << run.refusal_text;
  EXPECT_NE(run.refusal_text.find("at this span's weakest-axis excitation the Cramer-Rao bound"), std::string::npos)
      << run.refusal_text;
  // The weakest axis from the observations (every epoch is kept: no max_observations).
  const auto& obs = f.span().obs;
  ASSERT_EQ(obs.size(), f.span().epochs_total);
  Vec3 mean = Vec3::Zero();
  for (const auto& o : obs) mean += f.span().C_B_A * o.alpha_A;
  mean /= static_cast<double>(obs.size());
  Vec3 var = Vec3::Zero();
  for (const auto& o : obs) var += (f.span().C_B_A * o.alpha_A - mean).cwiseAbs2();
  var /= static_cast<double>(obs.size());
  const double weakest = std::sqrt(var.minCoeff());
  EXPECT_NEAR(run.weakest_excitation_radps2 / weakest, 1.0, 1e-6);
  // Quieter than the plan, so it needs a longer span than the plan's.
  EXPECT_LT(run.weakest_excitation_radps2, RunOptions{}.plan_excitation_radps2);
  EXPECT_GT(run.need_own.bound_s, run.need.bound_s);
}

// A refusal that is not about the span's length or excitation carries the solver's own remedy only.
TEST(RunCalibration, OtherRefusalsHaveNoSpanAdvice) {
  synth::Config c = manoeuvreCase(12);
  c.blind.push_back({2, 0.0, 1e9});  // head 3 never delivers: never seen with the others
  CalibrationFeed f;
  feed(c, f);
  const CalibrationRun run = runCalibration(f, RunOptions{});
  ASSERT_FALSE(run.ok);
  EXPECT_EQ(run.result.refusal, Refusal::kHeadsNotLinked) << refusalName(run.result.refusal);
  EXPECT_EQ(run.refusal_text, "refused: " + run.result.message);
}

// A copy of a feed is a snapshot: the node's worker solves the copy while the original keeps taking
// data. The copy's run equals a feed given only the data up to the copy; the original's equals a feed
// given all of it.
TEST(CalibrationFeed, CopyIsAnIndependentSnapshot) {
  const synth::Config c = manoeuvreCase(5);
  synth::Config first = c;
  first.duration_s = 2700;
  // All of c's data, the copy taken once the first 2700 s are in.
  struct Splitter {
    CalibrationFeed& f;
    TimeUs cut;
    std::unique_ptr<CalibrationFeed> snap;
    void pushHeads(const core::HeadEpoch& e) {
      take(e.t);
      f.pushHeads(e);
    }
    void pushAcc(TimeUs t, const Vec3& a) {
      take(t);
      f.pushAcc(t, a);
    }
    void take(TimeUs t) {
      if (!snap && t >= cut) snap = std::make_unique<CalibrationFeed>(f);
    }
  };
  CalibrationFeed whole;
  std::string err;
  ASSERT_TRUE(whole.configure(synth::pipelineConfig(c), spanOptions(c), false, &err)) << err;
  Splitter sp{whole, c.t0 + static_cast<TimeUs>(2700e6), nullptr};
  synth::stream(c, sp);
  ASSERT_TRUE(sp.snap);
  CalibrationFeed early, full;
  feed(first, early, false);
  feed(c, full, false);
  const CalibrationRun r_snap = runCalibration(*sp.snap, RunOptions{}), r_early = runCalibration(early, RunOptions{});
  const CalibrationRun r_whole = runCalibration(whole, RunOptions{}), r_full = runCalibration(full, RunOptions{});
  ASSERT_TRUE(r_snap.ok && r_early.ok && r_whole.ok && r_full.ok) << r_snap.refusal_text << r_early.refusal_text;
  EXPECT_EQ(sp.snap->span().head_epochs, early.span().head_epochs);
  EXPECT_LT(sp.snap->span().head_epochs, whole.span().head_epochs);
  for (int h = 0; h < c.n_heads; ++h) {
    EXPECT_EQ(r_snap.result.estimate.r_S[std::size_t(h)], r_early.result.estimate.r_S[std::size_t(h)]) << h;
    EXPECT_EQ(r_whole.result.estimate.r_S[std::size_t(h)], r_full.result.estimate.r_S[std::size_t(h)]) << h;
  }
  EXPECT_NE(r_snap.result.estimate.r_S[0], r_whole.result.estimate.r_S[0]);
}

// The raw samples for the attitude-domain estimate: every head sample of a configured head and every
// accelerometer sample, in the order pushed, times from the first; the observer velocity interpolated
// between orbit samples (plus the Earth's) only inside the orbit's span and not across an orbit gap
// over 60 s; nothing kept unless asked.
TEST(CalibrationFeed, RawSamplesAndTheObserverVelocityAtTheOrbitsSeams) {
  synth::Config c = manoeuvreCase(7);
  c.duration_s = 400;
  CalibrationFeed none;
  feed(c, none);
  EXPECT_TRUE(none.raw().empty());
  EXPECT_FALSE(none.wantsOrbit());

  CalibrationFeed f;
  std::string err;
  ASSERT_TRUE(f.configure(synth::pipelineConfig(c), spanOptions(c), false, &err, true)) << err;
  EXPECT_TRUE(f.wantsOrbit());  // for the aberration
  // Orbit samples every 10 s from 100 s to 300 s with a gap from 200 s to 290 s; v_I = (1000 t, 7000, 0).
  auto orbitAt = [&](double ts) {
    model::OrbitSample o;
    o.t = c.t0 + static_cast<TimeUs>(ts * 1e6);
    o.v_I = Vec3(1000.0 * ts, 7000.0, 0.0);
    return o;
  };
  struct Tee {
    CalibrationFeed& f;
    std::function<model::OrbitSample(double)> orbit;
    TimeUs t0;
    double next_orbit_s = 100.0;
    void at(TimeUs t) {
      while (next_orbit_s <= 300.0 && c0(t) >= next_orbit_s) {
        if (!(next_orbit_s > 200.0 && next_orbit_s < 290.0)) f.pushOrbit(orbit(next_orbit_s));
        next_orbit_s += 10.0;
      }
    }
    double c0(TimeUs t) const { return static_cast<double>(t - t0) * 1e-6; }
    void pushHeads(const core::HeadEpoch& e) {
      at(e.t);
      f.pushHeads(e);
    }
    void pushAcc(TimeUs t, const Vec3& a) {
      at(t);
      f.pushAcc(t, a);
    }
  } tee{f, orbitAt, c.t0};
  synth::stream(c, tee);
  f.finish();
  const RawData& raw = f.raw();
  std::size_t heads = 0, acc = 0, with_v = 0;
  Vec3 sum = Vec3::Zero();
  double last_t = -1.0;
  for (const auto& e : raw.acc) {
    EXPECT_GE(e.t_s, last_t);
    last_t = e.t_s;
    ++acc;
    sum += e.z_A();
  }
  last_t = -1.0;
  for (const auto& e : raw.heads) {
    EXPECT_GE(e.t_s, last_t);
    last_t = e.t_s;
    ++heads;
    const bool inside = (e.t_s >= 100.0 && e.t_s <= 200.0) || (e.t_s >= 290.0 && e.t_s <= 300.0);
    if (!inside) {
      EXPECT_EQ(e.v_obs_I(), Vec3::Zero()) << e.t_s;
      continue;
    }
    ++with_v;
    const Vec3 want = Vec3(1000.0 * e.t_s, 7000.0, 0.0) +
                      model::earthVelocityLowPrecision(toSeconds(c.t0) + e.t_s);
    // Stored in single precision: relative 6e-8.
    EXPECT_LT((e.v_obs_I() - want).norm(), 1e-7 * want.norm()) << e.t_s;
  }
  EXPECT_EQ(std::min(raw.heads.front().t_s, raw.acc.front().t_s), 0.0);
  EXPECT_EQ(heads, static_cast<std::size_t>(c.duration_s * c.head_rate_hz) * 3);
  EXPECT_EQ(acc, static_cast<std::size_t>(c.duration_s * c.acc_rate_hz));
  EXPECT_EQ(f.aberratedSamples(), with_v);
  EXPECT_EQ(with_v, (201u + 21u) * 3u);  // 100..200 s and 290..300 s at 2 Hz, three heads
  EXPECT_LT((f.rawMeanAcc() - sum / static_cast<double>(acc)).norm(), 1e-15);
  // A copy keeps them.
  const CalibrationFeed copy(f);
  EXPECT_EQ(copy.raw().heads.size(), raw.heads.size());
  EXPECT_EQ(copy.raw().acc.size(), raw.acc.size());
}

// With a window of observations (SpanOptions::max_observations, the node's), the raw samples keep the
// same window of data time, so the attitude-domain estimate does not grow without bound; without one
// they are the whole span. The oldest go in blocks of 1/16 of the window, as the observations do.
TEST(CalibrationFeed, RawSamplesKeepTheObservationsWindowOfDataTime) {
  synth::Config c = manoeuvreCase(7);
  c.duration_s = 900;
  SpanOptions so = spanOptions(c);
  so.max_observations = 20;  // 20 x decimation_s of data time
  const double window_s = static_cast<double>(so.max_observations) * so.decimation_s;
  ASSERT_LT(window_s * 1.5, c.duration_s);
  CalibrationFeed f, whole;
  std::string err;
  ASSERT_TRUE(f.configure(synth::pipelineConfig(c), so, false, &err, true)) << err;
  ASSERT_TRUE(whole.configure(synth::pipelineConfig(c), spanOptions(c), false, &err, true)) << err;
  synth::stream(c, f);
  synth::stream(c, whole);
  f.finish();
  whole.finish();
  ASSERT_FALSE(f.raw().heads.empty());
  ASSERT_FALSE(f.raw().acc.empty());
  EXPECT_EQ(std::min(whole.raw().heads.front().t_s, whole.raw().acc.front().t_s), 0.0);
  const double newest = std::max(whole.raw().heads.back().t_s, whole.raw().acc.back().t_s);
  // What is kept, of the head samples and of the accelerometer's: the last window (and at most a block
  // more), every sample of it, in order.
  const auto kept = [&](const auto& ev, const auto& all) {
    EXPECT_GE(ev.front().t_s, newest - window_s * (1.0 + 1.0 / 16.0) - 1e-9);
    EXPECT_LE(ev.front().t_s, newest - window_s + 1.0);
    EXPECT_GE(ev.back().t_s, newest - 0.5);
    EXPECT_EQ(ev.back().t_s, all.back().t_s);
    const auto first = std::find_if(all.begin(), all.end(), [&](const auto& x) { return x.t_s >= ev.front().t_s; });
    ASSERT_EQ(static_cast<std::size_t>(all.end() - first), ev.size());
    for (std::size_t i = 0; i < ev.size(); ++i) EXPECT_EQ(ev[i].t_s, first[static_cast<std::ptrdiff_t>(i)].t_s);
  };
  kept(f.raw().heads, whole.raw().heads);
  kept(f.raw().acc, whole.raw().acc);
  for (std::size_t i = 0; i < f.raw().heads.size(); ++i)
    EXPECT_EQ(f.raw().heads[i].head, whole.raw().heads[whole.raw().heads.size() - f.raw().heads.size() + i].head);
  // The observations' window is the same data time.
  ASSERT_FALSE(f.span().obs.empty());
  EXPECT_LE(static_cast<double>(f.span().obs.back().t - f.span().obs.front().t) * 1e-6, window_s);
}

// A configuration the span builder cannot run is refused when the feed is configured, with the reason
// (the node says it at start-up), and a feed not configured takes nothing.
TEST(CalibrationFeed, ConfigurationRefusedAtConfigure) {
  synth::Config c = manoeuvreCase(6);
  CalibrationFeed f;
  std::string err;
  SpanOptions so = spanOptions(c);
  so.decimation_s = 0.2;  // below the 2 Hz heads' interval
  EXPECT_FALSE(f.configure(synth::pipelineConfig(c), so, false, &err));
  EXPECT_NE(err.find("decimation_s must be at least the head sampling interval"), std::string::npos) << err;
  EXPECT_FALSE(f.configured());
  core::HeadEpoch e;
  e.t = c.t0;
  f.pushHeads(e);
  EXPECT_EQ(f.span().head_epochs, 0u);
  // The thermal collection needs two heads.
  c.n_heads = 1;
  EXPECT_FALSE(f.configure(synth::pipelineConfig(c), spanOptions(c), true, &err));
  EXPECT_FALSE(err.empty());
  EXPECT_TRUE(f.configure(synth::pipelineConfig(c), spanOptions(c), false, &err)) << err;
}

}  // namespace
}  // namespace boresight::calib

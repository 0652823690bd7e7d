// The Collector's seams on synthetic head epochs: doubling the bin length (exact merges) must not change
// the analysis; a gap of every head, one head's dropout, and the first and last epochs are accounted for.
#include <boresight/audit/audit.h>
#include <boresight/model/rotation.h>
#include <boresight/model/stats.h>

#include <gtest/gtest.h>

#include "synthetic_heads.h"

#include <cmath>
#include <random>

namespace {

using namespace boresight;

using audittest::threeHeads;

struct Feed {
  std::uint64_t epochs = 0;
};

/// Two hours at 2 Hz of a body turning about y at the orbital rate; head 2 misaligned by `mis` (head
/// frame); every head missing from 3000 s to 3060 s; head 3 missing from 5000 s to 5100 s.
/// With `acc_elsewhere`, accelerometer samples come as well, in time order: 600 a day before the first
/// epoch, 100 in the 10 s after the last, and 6000 two days later (an accelerometer file of another day).
void feed(audit::Collector& c, const core::PipelineConfig& cfg, const Vec3& mis, Feed& f, bool acc_elsewhere = false) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> n01;
  const TimeUs t0 = audittest::kT0;
  const Vec3 a(1e-7, -2e-7, 3e-8);
  auto accRun = [&](TimeUs from, int n) {
    for (int i = 0; i < n; ++i) c.onAcc(from + static_cast<TimeUs>(i) * 100000, a, core::Status::kOk);
  };
  if (acc_elsewhere) accRun(t0 - 86400 * kUsPerSecond, 600);
  for (int i = 0; i < 14400; ++i) {
    const double t = 0.5 * i;
    if (t >= 3000 && t < 3060) continue;
    const Quat q_I_B = audittest::pitchTurn(t);
    core::HeadEpoch e;
    e.t = t0 + static_cast<TimeUs>(i) * 500000;
    for (int k = 0; k < 3; ++k) {
      if (k == 2 && t >= 5000 && t < 5100) continue;
      const Quat& q_nom = cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B;
      audittest::addSample(e, cfg, k, q_I_B, k == 1 ? Quat(model::quatExp(mis) * q_nom) : q_nom, rng, n01);
    }
    c.onHeads(e, core::Status::kOk);
    ++f.epochs;
  }
  if (acc_elsewhere) {
    const TimeUs last = t0 + 14399LL * 500000;
    accRun(last + 100000, 100);
    accRun(last + 2 * 86400 * kUsPerSecond, 6000);
  }
  c.onEnd();
}

const audit::EffectTest* named(const audit::AuditResult& r, const std::string& name, const std::string& sensor) {
  for (const auto& e : r.named)
    if (e.name == name && e.sensor == sensor) return &e;
  return nullptr;
}

/// Two hours like feed() without a misalignment: head 2 drops out for 20 s at `runs` times spread over
/// the span, and every head for 10 s at `epoch_runs` times.
void feedDropouts(audit::Collector& c, const core::PipelineConfig& cfg, int runs, int epoch_runs) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n01;
  // run j of n starts at first + j * 6600 / n (head 2 from 300 s, every head from 450 s: never together)
  const auto inRun = [](double t, int n, double len, double first) {
    for (int j = 0; j < n; ++j) {
      const double a = first + j * 6600.0 / n;
      if (t >= a && t < a + len) return true;
    }
    return false;
  };
  for (int i = 0; i < 14400; ++i) {
    const double t = 0.5 * i;
    if (inRun(t, epoch_runs, 10, 450)) continue;
    core::HeadEpoch e;
    e.t = audittest::kT0 + static_cast<TimeUs>(i) * 500000;
    for (int k = 0; k < 3; ++k) {
      if (k == 1 && inRun(t, runs, 20, 300)) continue;
      audittest::addSample(e, cfg, k, audittest::pitchTurn(t), cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B, rng, n01);
    }
    c.onHeads(e, core::Status::kOk);
  }
  c.onEnd();
}

const audit::EffectTest* tested(const audit::AuditResult& r, const std::string& name, const std::string& sensor) {
  for (const auto& e : r.effects)
    if (e.name == name && e.sensor == sensor) return &e;
  return nullptr;
}

double param(const audit::EffectTest& e, const std::string& key) {
  for (const auto& p : e.params)
    if (p.key == key) return p.value;
  return std::nan("");
}

TEST(AuditCollector, MissingSampleRunsAreTestedAgainstTheConfiguredRate) {
  // 12 dropouts of head 2 and 6 gaps of every head in 2 h (144 and 72 a day). With no rate configured
  // every run is a finding; at the configured rates they are what is expected and nothing is named; at a
  // twentieth of the rates (0.6 and 0.3 expected) the counts are far beyond chance and both are named.
  const auto cfg = threeHeads();
  // Last: at their rates, but head 2's runs (20 s) longer than the 10 s its kind is expected to last at
  // most: named (a rate of short gaps does not make a long one expected); every head's 10 s gaps not.
  struct Case {
    double head_rate, epoch_rate, head_max_s;
    bool named, epoch_named;
  };
  const double kNoLimit = std::nan("");
  for (const Case& cs : {Case{0, 0, kNoLimit, true, true}, Case{144, 72, kNoLimit, false, false}, Case{7.2, 3.6, kNoLimit, true, true},
                         Case{1e6, 1e6, kNoLimit, false, false}, Case{144, 72, 10, true, false}}) {
    SCOPED_TRACE(cs.head_rate);
    audit::AuditOptions opt;
    opt.data_events.head_dropouts_by_id = {{audittest::threeHeads().heads.head[1].id, cs.head_rate}};
    opt.data_events.epoch_gaps_per_day = cs.epoch_rate;
    opt.data_events.head_dropout_max_s = cs.head_max_s;
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    feedDropouts(c, cfg, 12, 6);
    const audit::AuditResult r = audit::analyse(c, opt);
    const auto* g = tested(r, "gaps", "2");
    const auto* a = tested(r, "gaps", "all");
    ASSERT_NE(g, nullptr);
    ASSERT_NE(a, nullptr);
    EXPECT_EQ(g->statistic, 12.0) << g->note;
    EXPECT_EQ(a->statistic, 6.0) << a->note;
    EXPECT_NEAR(param(*g, "expected_by_chance"), cs.head_rate * 7199.5 / 86400, 0.01);
    EXPECT_NEAR(param(*a, "expected_by_chance"), cs.epoch_rate * 7199.5 / 86400, 0.01);
    EXPECT_NEAR(param(*g, "per_day"), 144, 1);
    EXPECT_NEAR(param(*g, "missing_samples"), 12 * 40, 12);
    EXPECT_EQ(g->named, cs.named) << g->note << " p " << g->p_value;
    EXPECT_EQ(a->named, cs.epoch_named) << a->note << " p " << a->p_value;
    EXPECT_NEAR(param(*g, "longest_s"), 20, 0.6);
    EXPECT_EQ(named(r, "gaps", "2") != nullptr, cs.named);
    // the threshold is the count the per-test level allows by chance
    if (std::isfinite(cs.head_max_s)) {
      EXPECT_NE(g->note.find("longer than the 10 s data_events expects at most"), std::string::npos) << g->note;
    } else if (cs.named) {
      EXPECT_LT(g->threshold, g->statistic);
    } else {
      EXPECT_GT(g->threshold, g->statistic);
    }
    // the threshold is the smallest count whose chance probability is under the level (at 1e6 a day,
    // 83 000 expected in 2 h: beyond the expectation, found without counting up to it)
    const double lambda = param(*g, "expected_by_chance");
    EXPECT_GT(g->threshold, lambda);
    const double alpha_each = opt.false_alarm / r.tests;
    EXPECT_LT(model::stats::poissonSfGe(g->threshold + 0.5, lambda), alpha_each);
    EXPECT_GE(model::stats::poissonSfGe(g->threshold - 0.5, lambda), alpha_each);
    const auto* d = tested(r, "head_dropout", "3");  // head 3 never missed a sample
    ASSERT_NE(d, nullptr);
    EXPECT_FALSE(d->named) << d->note;
    EXPECT_EQ(d->statistic, 0.0);
  }
}

// The data's first and last epochs are seams too: a head that delivers only from 600 s on (switched on
// late) and one that stops 900 s before the end (lost) while the others deliver are dropouts with the
// samples they miss, as inside the data; a head that never delivers misses the whole span; a first or
// last epoch cut between its heads is not a run. Before, the runs were only found between two samples
// of the head, and all three went unseen.
TEST(AuditCollector, DropoutsAtTheFirstAndLastEpochsAreRuns) {
  const auto cfg = threeHeads();
  for (bool never : {false, true}) {
    SCOPED_TRACE(never);
    audit::AuditOptions opt;
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    std::mt19937_64 rng(11);
    std::normal_distribution<double> n01;
    // Without `never` the data begin and end inside an epoch: the first (-0.5 s) and the last (7200 s)
    // hold head 1 alone, as where a file is cut between the heads of one epoch - one sample, not a run.
    const int first = never ? 0 : -1, last = never ? 14400 : 14401;
    for (int i = first; i < last; ++i) {
      const double t = 0.5 * i;
      core::HeadEpoch e;
      e.t = audittest::kT0 + static_cast<TimeUs>(i) * 500000;
      for (int k = 0; k < 3; ++k) {
        if (k > 0 && (i == -1 || i == 14400)) continue;  // the cut epochs
        if (!never && k == 1 && t < 600.0) continue;  // head 2 from 600 s
        if (k == 2 && (never || t >= 6300.0)) continue;  // head 3 up to 6300 s, or never
        audittest::addSample(e, cfg, k, audittest::pitchTurn(t), cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B, rng, n01);
      }
      c.onHeads(e, core::Status::kOk);
    }
    c.onEnd();
    c.onEnd();  // a second end adds nothing
    const audit::AuditResult r = audit::analyse(c, opt);
    const auto* h1 = tested(r, "head_dropout", std::to_string(cfg.heads.head[0].id));
    ASSERT_NE(h1, nullptr);
    EXPECT_EQ(h1->statistic, 0.0) << h1->note;  // the first head delivered throughout
    const auto* h3 = tested(r, "head_dropout", std::to_string(cfg.heads.head[2].id));
    ASSERT_NE(h3, nullptr);
    EXPECT_EQ(h3->statistic, 1.0) << h3->note;
    EXPECT_TRUE(h3->named) << h3->note;  // no rate configured: every run is a finding
    // seconds since the first epoch (-0.5 s when cut); bounds as inside the data: the samples around
    EXPECT_EQ(param(*h3, "missing_samples"), never ? 14400.0 : 1801.0) << h3->note;
    EXPECT_NEAR(param(*h3, "at_s"), never ? -0.5 : 6300.0, 1e-9);
    EXPECT_NEAR(param(*h3, "duration_s"), never ? 7200.5 : 901.0, 1e-9);
    const auto* h2 = tested(r, "head_dropout", std::to_string(cfg.heads.head[1].id));
    ASSERT_NE(h2, nullptr);
    if (never) {
      EXPECT_EQ(h2->statistic, 0.0) << h2->note;
    } else {
      EXPECT_EQ(h2->statistic, 1.0) << h2->note;
      EXPECT_TRUE(h2->named) << h2->note;
      EXPECT_EQ(param(*h2, "missing_samples"), 1201.0) << h2->note;
      EXPECT_NEAR(param(*h2, "at_s"), -0.5, 1e-9);
      EXPECT_NEAR(param(*h2, "duration_s"), 601.0, 1e-9);
    }
  }
}

TEST(AuditCollector, BinDoublingLeavesTheAnalysisUnchangedAndSeamsAreCounted) {
  const auto cfg = threeHeads();
  const Vec3 mis = Vec3(10, -4, 0) * kRadPerArcsec;
  audit::AuditResult res[2];
  double bin_s[2];
  for (int run = 0; run < 2; ++run) {
    audit::AuditOptions opt;
    opt.max_bins = run == 0 ? 16384 : 16;  // the second run merges bins 10 times (0.5 s -> 512 s)
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    Feed f;
    feed(c, cfg, mis, f);
    res[run] = audit::analyse(c, opt);
    bin_s[run] = res[run].baseline.bin_s;
    EXPECT_EQ(res[run].baseline.head_epochs, f.epochs);
  }
  EXPECT_DOUBLE_EQ(bin_s[0], 0.5);
  EXPECT_DOUBLE_EQ(bin_s[1], 512.0);
  for (int run = 0; run < 2; ++run) {
    SCOPED_TRACE(run);
    const auto* m = named(res[run], "relative_misalignment", "2");
    ASSERT_NE(m, nullptr);
    EXPECT_NEAR(m->params[0].value, 10.0, 0.5);
    EXPECT_NEAR(m->params[1].value, -4.0, 0.5);
    // the gap of every head (one run of 120 epochs) and head 3's dropout (one run) are named
    const auto* g = named(res[run], "gaps", "all");
    ASSERT_NE(g, nullptr);
    EXPECT_DOUBLE_EQ(g->statistic, 1.0);  // one run
    EXPECT_DOUBLE_EQ(param(*g, "missing_samples"), 120.0);
    EXPECT_NEAR(param(*g, "longest_s"), 60.5, 0.6);
    const auto* d = named(res[run], "head_dropout", "3");
    ASSERT_NE(d, nullptr);
    EXPECT_NEAR(d->params[1].value, 100.5, 0.6);  // duration from the last sample before to the first after
    EXPECT_EQ(named(res[run], "outliers", "1"), nullptr);
    EXPECT_EQ(named(res[run], "cross_noise", "1"), nullptr);
  }
  // The held-out blocks follow bin boundaries, so the fitting epochs differ slightly between the runs:
  // the misalignment agrees within its sigma (0.1"), and the noise levels (estimated on the fitting bins:
  // the sums merge exactly, but a 512 s bin moves whole into or out of a held-out block) within theirs.
  const auto* a = named(res[0], "relative_misalignment", "2");
  const auto* b = named(res[1], "relative_misalignment", "2");
  ASSERT_TRUE(a && b);
  for (int q = 0; q < 3; ++q) EXPECT_NEAR(a->params[static_cast<std::size_t>(q)].value, b->params[static_cast<std::size_t>(q)].value, 0.3);
  double lvl[2] = {0, 0}, sig[2] = {0, 0};
  for (int run = 0; run < 2; ++run)
    for (const auto& e : res[run].effects)
      if (e.name == "cross_noise" && e.sensor == "2") lvl[run] = e.params[0].value, sig[run] = e.params[0].sigma;
  EXPECT_GT(lvl[0], 0);
  EXPECT_GT(sig[0], 0);
  EXPECT_NEAR(lvl[0], lvl[1], 2 * sig[0]) << "sigma " << sig[0];
}

/// The configuration with every head's noise (cross and about the boresight) times `factor`.
core::PipelineConfig scaledNoise(core::PipelineConfig cfg, double factor) {
  for (int k = 0; k < 3; ++k) {
    auto& h = cfg.heads.head[static_cast<std::size_t>(k)];
    h.sigma_cross_rad *= factor;
    h.sigma_roll_rad *= factor;
  }
  return cfg;
}

/// The outlier gate stands in the data's noise, not the configured one: heads 2.5x quieter than the
/// configuration (as the real GRACE-FO heads are against the ideal preset), and 40 samples of head 1
/// off by 90" about its x axis. The pairs' second differences carry the other head's about-boresight
/// noise too, so that is above the gate in the data's noise but below the configured one: with the
/// configured gate (a temporary build) none of the 40 was found (and 0 of 40 at 140"), with the data's all 40.
TEST(AuditCollector, OutlierGateFollowsTheDataNoise) {
  const auto cfg = threeHeads();
  const auto quiet = scaledNoise(cfg, 0.4);
  for (const int n_out : {0, 40}) {
    SCOPED_TRACE(n_out);
    audit::AuditOptions opt;
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n01;
    for (int i = 0; i < 14400; ++i) {
      const double t = 0.5 * i;
      const Quat q_I_B = audittest::pitchTurn(t);
      core::HeadEpoch e;
      e.t = audittest::kT0 + static_cast<TimeUs>(i) * 500000;
      // outliers at every 300th epoch from the 500th (none in the gate's first minutes)
      const bool spike = n_out > 0 && i >= 500 && (i - 500) % 300 == 0 && (i - 500) / 300 < n_out;
      for (int k = 0; k < 3; ++k) {
        Quat q_S_B = cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B;
        if (spike && k == 0) q_S_B = Quat(model::quatExp(Vec3(90 * kRadPerArcsec, 0, 0)) * q_S_B);
        audittest::addSample(e, quiet, k, q_I_B, q_S_B, rng, n01);
      }
      c.onHeads(e, core::Status::kOk);
    }
    c.onEnd();
    const auto r = audit::analyse(c, opt);
    const audit::EffectTest* o = nullptr;
    for (const auto& e : r.effects)
      if (e.name == "outliers" && e.sensor == "1") o = &e;
    ASSERT_NE(o, nullptr);
    if (n_out == 0) {
      EXPECT_FALSE(o->named) << o->statistic << " outliers on clean quiet data: " << o->note;
      EXPECT_LE(o->statistic, 1.0) << o->note;
    } else {
      EXPECT_TRUE(o->named) << o->note;
      EXPECT_NEAR(o->statistic, n_out, 2.0) << o->note;
    }
    // the note gives the measured scale: 0.40 of the configured noise
    EXPECT_NE(o->note.find("1-2 0.4"), std::string::npos) << o->note;
  }
}

/// The other way and at the first epochs: heads 2.5x noisier than configured. The gate starts from the
/// configured noise and follows the data's within its first epochs; no clean sample may be called an
/// outlier on the way (with the configured gate, 6 sigma of it is 2.4 sigma of these data: thousands).
TEST(AuditCollector, OutlierGateOnNoisierDataRaisesNoAlarmFromTheFirstEpoch) {
  const auto cfg = threeHeads();
  const auto loud = scaledNoise(cfg, 2.5);
  for (const std::uint64_t seed : {11, 12, 13}) {
    SCOPED_TRACE(seed);
    audit::AuditOptions opt;
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> n01;
    for (int i = 0; i < 2400; ++i) {
      core::HeadEpoch e;
      e.t = audittest::kT0 + static_cast<TimeUs>(i) * 500000;
      for (int k = 0; k < 3; ++k)
        audittest::addSample(e, loud, k, audittest::pitchTurn(0.5 * i), cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B,
                             rng, n01);
      c.onHeads(e, core::Status::kOk);
    }
    c.onEnd();
    const auto r = audit::analyse(c, opt);
    for (const auto& e : r.effects) {
      if (e.name == "outliers") {
        EXPECT_EQ(e.statistic, 0.0) << "head " << e.sensor << ": " << e.note;
      }
    }
  }
}

/// Accelerometer samples far outside the star data (files of another day) are counted, said, and kept out
/// of the time bins: the bins stay 0.5 s and the star families give what they give without them.
TEST(AuditCollector, AccelerometerDataOutsideTheStarSpanIsCountedAndDoesNotStretchTheBins) {
  const auto cfg = threeHeads();
  const Vec3 mis = Vec3(10, -4, 0) * kRadPerArcsec;
  audit::AuditResult res[2];
  for (int run = 0; run < 2; ++run) {
    audit::AuditOptions opt;
    audit::Collector c;
    std::string err;
    ASSERT_TRUE(c.configure(cfg, opt, &err)) << err;
    Feed f;
    feed(c, cfg, mis, f, run == 1);
    res[run] = audit::analyse(c, opt);
  }
  EXPECT_EQ(res[1].baseline.acc_samples, 6700u);
  EXPECT_EQ(res[1].baseline.acc_samples_outside, 6600u);
  EXPECT_DOUBLE_EQ(res[1].baseline.bin_s, 0.5);
  EXPECT_NEAR(res[1].baseline.span_s, res[0].baseline.span_s, 11.0);
  bool said = false;
  for (const auto& s : res[1].findings) said = said || s.find("6600 of 6700 samples (") != std::string::npos;
  EXPECT_TRUE(said);
  const auto* a = named(res[0], "relative_misalignment", "2");
  const auto* b = named(res[1], "relative_misalignment", "2");
  ASSERT_TRUE(a && b);
  for (int q = 0; q < 3; ++q) EXPECT_NEAR(a->params[static_cast<std::size_t>(q)].value, b->params[static_cast<std::size_t>(q)].value, 1e-6);
  EXPECT_EQ(named(res[1], "gaps", "acc"), nullptr);  // samples outside the star data are not a gap
}

}  // namespace

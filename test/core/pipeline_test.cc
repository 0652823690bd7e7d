// Pipeline: heads at 2 Hz and the accelerometer at 10 Hz in, one row per second out, with the fused
// attitude, rates, both angular accelerations on the same tags in the body frame, IBAs, heads used.
#include "boresight/core/pipeline.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

namespace boresight::core {
namespace {

using test::Rng;

constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;

struct Truth {  // orbit-rate pitch plus a libration about a fixed body axis
  Vec3 n = Vec3(0.6, 0.0, 0.8);
  double amp = 2e-4, f = 0.015, w_orb = 2 * kPi / 5640.0;
  double s(TimeUs t) const { return toSeconds(t - kT0); }
  Quat q_I_B(TimeUs t) const { return quatExp(Vec3(0, -w_orb * s(t), 0)) * quatExp(amp * std::sin(2 * kPi * f * s(t)) * n); }
  Vec3 w_B(TimeUs t) const {
    const double th = amp * std::sin(2 * kPi * f * s(t)), thd = amp * 2 * kPi * f * std::cos(2 * kPi * f * s(t));
    return quatExp(th * n).conjugate() * Vec3(0, -w_orb, 0) + thd * n;
  }
  Vec3 alpha_B(TimeUs t) const {
    const double th = amp * std::sin(2 * kPi * f * s(t)), w = 2 * kPi * f;
    const double thd = amp * w * std::cos(w * s(t)), thdd = -amp * w * w * std::sin(w * s(t));
    return thdd * n - thd * n.cross(quatExp(th * n).conjugate() * Vec3(0, -w_orb, 0));
  }
};

struct PipelineRun {
  std::vector<PipelineRow> rows;
  Health health;
};

PipelineRun runPipeline(bool noise, int seconds, bool acc_gap) {
  Rng rng(71);
  Truth tr;
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  auto p = std::make_unique<Pipeline>();
  EXPECT_EQ(p->configure(pc), Status::kOk);
  PipelineRun out;
  TimeUs ta = kT0 + 6901;
  for (int i = 0; i < 2 * seconds; ++i) {
    const TimeUs t = kT0 + 30000 + static_cast<TimeUs>(i) * 500000;
    while (ta <= t) {
      const bool in_gap = acc_gap && ta > kT0 + 300 * kUsPerSecond && ta < kT0 + 320 * kUsPerSecond;
      if (!in_gap) p->stepAcc(ta, pc.C_B_A.transpose() * tr.alpha_B(ta));
      ta += 100000;
    }
    HeadEpoch e;
    e.t = t;
    for (int k = 0; k < 3; ++k) {
      if (k == 2 && i >= 400 && i < 440) continue;  // head 3 blinded for 20 s
      const HeadConfig& h = pc.heads.head[static_cast<std::size_t>(k)];
      const Quat q = tr.q_I_B(t) * h.q_Si_B.conjugate();
      HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
      s.head_id = h.id;
      s.q_I_Si = noise ? test::noisyHead(rng, q, h) : q;
    }
    EXPECT_EQ(p->stepHeads(e), Status::kOk);
    PipelineRow r;
    while (p->popRow(r)) out.rows.push_back(r);
  }
  p->flush();
  PipelineRow r;
  while (p->popRow(r)) out.rows.push_back(r);
  out.health = p->health();
  return out;
}

TEST(Pipeline, RowsOnePerSecondWithRatesAndAccelerationsOnTheSameTags) {
  const int seconds = 600;
  const PipelineRun run = runPipeline(false, seconds, false);
  Truth tr;
  ASSERT_EQ(static_cast<int>(run.rows.size()), seconds);
  int full = 0;
  double worst_w = 0, worst_a = 0, worst_acc = 0, worst_q = 0;
  const double w_lib = tr.amp * 2 * kPi * tr.f, a_lib = w_lib * 2 * kPi * tr.f;
  for (std::size_t i = 0; i < run.rows.size(); ++i) {
    const PipelineRow& r = run.rows[i];
    EXPECT_EQ(r.t, kT0 + 30000 + static_cast<TimeUs>(i) * kUsPerSecond);  // the head epochs nearest whole seconds
    EXPECT_EQ(r.heads_used, (r.t >= kT0 + 200 * kUsPerSecond && r.t < kT0 + 220 * kUsPerSecond) ? 2 : 3);
    worst_q = std::max(worst_q, angleBetween(r.q_I_B, tr.q_I_B(r.t)));
    // the CRN needs 35 s (centre tap, 35.3 s at 10 Hz) of data on both sides of a row
    const bool interior = r.t > kT0 + 36 * kUsPerSecond && r.t < kT0 + (seconds - 36) * kUsPerSecond;
    const bool edge = r.t < kT0 + 34 * kUsPerSecond || r.t > kT0 + (seconds - 34) * kUsPerSecond;
    if (interior) {
      EXPECT_TRUE(r.has_rates && r.has_acc) << i;
    }
    if (edge) {
      EXPECT_FALSE(r.has_rates || r.has_acc) << i;
    }
    if (!r.has_rates) {
      EXPECT_TRUE(std::isnan(r.w_B.x()));
      continue;
    }
    ++full;
    worst_w = std::max(worst_w, (r.w_B - tr.w_B(r.t)).norm() / w_lib);
    worst_a = std::max(worst_a, (r.a_sc_B - tr.alpha_B(r.t)).norm() / a_lib);
    worst_acc = std::max(worst_acc, (r.a_acc_B - r.a_sc_B).norm() / a_lib);
    EXPECT_NEAR(r.iba_dev_rad[static_cast<std::size_t>(pairIndex(0, 1))], 0.0, 1e-10);
    for (int pr : {pairIndex(0, 2), pairIndex(1, 2)}) {
      if (r.heads_used == 3) {
        EXPECT_NEAR(r.iba_dev_rad[static_cast<std::size_t>(pr)], 0.0, 1e-10);
      } else {
        EXPECT_TRUE(std::isnan(r.iba_dev_rad[static_cast<std::size_t>(pr)]));  // head 3 blinded
      }
    }
  }
  EXPECT_GT(full, seconds - 80);
  EXPECT_LT(worst_q, 1e-10);
  EXPECT_LT(worst_w, 0.002);
  EXPECT_LT(worst_a, 0.002);
  EXPECT_LT(worst_acc, 0.002);
  std::printf("pipeline: %d full rows; errors / libration amplitude: rate %.2e, sc accel %.2e, acc-sc %.2e\n", full,
              worst_w, worst_a, worst_acc);
}

TEST(Pipeline, AccelerometerGapLeavesOnlyThoseRowsWithoutAcc) {
  const PipelineRun run = runPipeline(true, 600, true);
  int no_acc_interior = 0;
  for (const PipelineRow& r : run.rows) {
    const bool interior = r.t > kT0 + 36 * kUsPerSecond && r.t < kT0 + 564 * kUsPerSecond;
    if (interior && !r.has_acc) {
      ++no_acc_interior;
      // only rows whose CRN window touches the gap (300-320 s) or the restart after it
      EXPECT_GT(r.t, kT0 + 264 * kUsPerSecond);
      EXPECT_LT(r.t, kT0 + 392 * kUsPerSecond);
    }
    if (interior) {
      EXPECT_TRUE(r.has_rates);
    }
    EXPECT_TRUE(std::isfinite(r.iba_rad[0]));
  }
  EXPECT_GT(no_acc_interior, 20);
  EXPECT_EQ(run.health.count(Status::kGapRestarted), 1u);
}

// Heads gap in all heads: epochs [600, 600 + gap) at 2 Hz are missing (5 min into a 10 min run); with
// acc_gap, accelerometer samples [3000, 3000 + acc_gap) at 10 Hz are missing too (the same time).
PipelineRun runPipelineHeadGap(int gap, int acc_gap = 0) {
  Rng rng(72);
  Truth tr;
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  auto p = std::make_unique<Pipeline>();
  EXPECT_EQ(p->configure(pc), Status::kOk);
  PipelineRun out;
  TimeUs ta = kT0 + 6901;
  PipelineRow r;
  for (int i = 0; i < 1200; ++i) {
    const TimeUs t = kT0 + 30000 + static_cast<TimeUs>(i) * 500000;
    while (ta <= t) {
      const long ia = static_cast<long>((ta - kT0 - 6901) / 100000);
      if (!(ia >= 3000 && ia < 3000 + acc_gap)) p->stepAcc(ta, pc.C_B_A.transpose() * tr.alpha_B(ta));
      ta += 100000;
    }
    HeadEpoch e;
    e.t = t;
    for (int k = 0; k < 3; ++k) {
      const HeadConfig& h = pc.heads.head[static_cast<std::size_t>(k)];
      HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
      s.head_id = h.id;
      s.q_I_Si = test::noisyHead(rng, tr.q_I_B(t) * h.q_Si_B.conjugate(), h);  // drawn also in the gap
    }
    if (i >= 600 && i < 600 + gap) continue;
    EXPECT_EQ(p->stepHeads(e), Status::kOk);
    while (p->popRow(r)) out.rows.push_back(r);
  }
  p->flush();
  while (p->popRow(r)) out.rows.push_back(r);
  out.health = p->health();
  return out;
}

TEST(Pipeline, HeadGapsOf1_2_5_20EpochsAndARestartKeepEveryRowWithinTheNoGapError) {
  Truth tr;
  const PipelineRun ref = runPipelineHeadGap(0);
  double sw = 0, sa = 0;
  int n = 0;
  for (const PipelineRow& r : ref.rows) {
    if (!r.has_rates) continue;
    sw += (r.w_B - tr.w_B(r.t)).squaredNorm();
    sa += (r.a_sc_B - tr.alpha_B(r.t)).squaredNorm();
    ++n;
  }
  ASSERT_GT(n, 500);
  const double ew = std::sqrt(sw / n), ea = std::sqrt(sa / n);
  const TimeUs gap_start = kT0 + 30000 + 600 * 500000;
  for (int gap : {1, 2, 5, 20, 40}) {  // 40 epochs (20 s) exceed the bridge limit (20): restart
    const PipelineRun run = runPipelineHeadGap(gap);
    const bool restart = gap > 20;
    EXPECT_EQ(run.health.count(Status::kGapBridged), restart ? 0u : 1u) << gap;
    EXPECT_EQ(run.health.count(Status::kGapRestarted), restart ? 1u : 0u) << gap;
    const TimeUs gap_end = gap_start + gap * 500000;  // first epoch after the gap
    std::size_t j = 0;
    double worst_w = 0, worst_a = 0;
    int compared = 0;
    for (const PipelineRow& a : ref.rows) {
      if (a.t >= gap_start && a.t < gap_end) continue;  // no head epoch there: no row
      ASSERT_LT(j, run.rows.size());
      const PipelineRow& b = run.rows[j++];
      ASSERT_EQ(b.t, a.t) << "gap " << gap;
      EXPECT_EQ(b.has_acc, a.has_acc);
      const bool window_clear = a.t + 35 * kUsPerSecond < gap_start || a.t - 35 * kUsPerSecond >= gap_end;
      if (!restart || window_clear) {
        EXPECT_EQ(b.has_rates, a.has_rates) << "gap " << gap << " row " << toSeconds(a.t - kT0);
      } else {
        EXPECT_FALSE(b.has_rates);  // a restart: no rates for the rows whose window spans the gap
      }
      if (!(a.has_rates && b.has_rates)) continue;
      // flagged with the bridged epochs inside the rate window (M = 70 epochs = 35 s), and only then;
      // its sigmas then include the bridged values (never below the same row's without the gap)
      int expect_bridged = 0;
      for (int k = 0; k < gap && !restart; ++k)
        expect_bridged += std::llabs(gap_start + k * 500000 - a.t) <= 35 * kUsPerSecond;
      EXPECT_EQ(a.rate_bridged, 0);
      EXPECT_EQ(b.rate_bridged, expect_bridged) << "gap " << gap << " row " << toSeconds(a.t - kT0);
      for (int k = 0; k < 3; ++k) {
        EXPECT_GT(a.w_sigma_B[k], 0.0);
        EXPECT_GT(a.a_sc_sigma_B[k], 0.0);
        EXPECT_GE(b.w_sigma_B[k], 0.999 * a.w_sigma_B[k]);
        EXPECT_GE(b.a_sc_sigma_B[k], 0.999 * a.a_sc_sigma_B[k]);
        if (expect_bridged > 0 && std::abs(gap_start + gap * 250000 - a.t) < 30 * kUsPerSecond) {
          EXPECT_GT(b.w_sigma_B[k], a.w_sigma_B[k]);  // the gap is inside the window's weight
        }
      }
      ++compared;
      worst_w = std::max(worst_w, (b.w_B - a.w_B).norm() / ew);
      worst_a = std::max(worst_a, (b.a_sc_B - a.a_sc_B).norm() / ea);
    }
    EXPECT_EQ(j, run.rows.size());
    EXPECT_LT(worst_w, 4.0) << gap;  // the tolerance of rates_test's RatesGaps (same reasoning)
    EXPECT_LT(worst_a, 4.0) << gap;
    std::printf("pipeline heads gap %2d epochs: %d rows compared, worst difference / no-gap rms error: rate %.2f, "
                "accel %.2f\n", gap, compared, worst_w, worst_a);
  }
}

// Accelerometer gaps of 5 and 20 samples (10 Hz, noise-free input): the rows whose accelerometer window
// (+-35.3 s) holds bridged samples are flagged with their number, the others are bit-identical to the
// no-gap run, and a flagged row's difference stays within its published bound.
TEST(Pipeline, AccelerometerGapsFlagOnlyTheRowsWhoseWindowHoldsThem) {
  const PipelineRun ref = runPipelineHeadGap(0);
  for (int acc_gap : {5, 20}) {
    const PipelineRun run = runPipelineHeadGap(0, acc_gap);
    EXPECT_EQ(run.health.count(Status::kGapBridged), 1u);
    ASSERT_EQ(run.rows.size(), ref.rows.size());
    const TimeUs first_missing = kT0 + 6901 + 3000 * 100000;
    int flagged = 0;
    double worst = 0;
    for (std::size_t i = 0; i < ref.rows.size(); ++i) {
      const PipelineRow &a = ref.rows[i], &b = run.rows[i];
      ASSERT_EQ(a.t, b.t);
      if (!(a.has_acc && b.has_acc)) continue;
      int expect = 0;
      for (int k = 0; k < acc_gap; ++k) expect += std::llabs(first_missing + k * 100000 - a.t) <= 353 * 100000 + 50000;
      EXPECT_EQ(a.acc_bridged, 0);
      EXPECT_EQ(b.acc_bridged, expect) << acc_gap << " row " << toSeconds(a.t - kT0);
      const double d = (b.a_acc_B - a.a_acc_B).cwiseAbs().maxCoeff();
      if (expect == 0) {
        EXPECT_EQ(d, 0.0);
        EXPECT_EQ(b.a_acc_sigma_bridge, 0.0);
        continue;
      }
      ++flagged;
      EXPECT_LE(d, b.a_acc_sigma_bridge + 1e-15);
      if (d > 1e-13) worst = std::max(worst, d / b.a_acc_sigma_bridge);
    }
    EXPECT_GT(flagged, 65);  // about 71 rows at 1 Hz
    std::printf("accelerometer gap of %2d samples: %d rows flagged, worst |difference| / bound %.2f\n", acc_gap,
                flagged, worst);
  }
}

// ---- dropout continuity: a head 45" off its ground mounting drops out for 10 minutes ----

struct DropoutRun {
  std::vector<TimeUs> t;
  std::vector<Vec3> err_B;    // Log(q_true^-1 q_fused), rad in B
  std::vector<Vec3> diff_B;   // against the nominal-mounting pipeline on the same input
  std::vector<double> sigma;  // max per-axis 1-sigma of the fused attitude
  std::vector<int> used;
};

// 40 minutes at 2 Hz; head 3's true mounting is 45" (cross-boresight) off its configured one; it is
// blind from minute 20 to 30 (and, when early_dropout, also from epoch 60 to 100: before the start-up
// minimum of 120 epochs). mode: the pipeline under test; a second pipeline with nominal mountings
// gets the same input. hand: the true mountings are handed in at the start (batch solver's way).
DropoutRun runDropout(FusionAlignment mode, bool hand, bool early_dropout, Pipeline* reuse = nullptr) {
  Rng rng(73);
  Truth tr;
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  pc.use_accelerometer = false;
  pc.fusion_alignment = mode;
  std::array<Quat, kMaxHeads> q_true = filled<Quat, kMaxHeads>(Quat::Identity());
  for (int k = 0; k < 3; ++k) q_true[static_cast<std::size_t>(k)] = pc.heads.head[static_cast<std::size_t>(k)].q_Si_B;
  const Vec3 delta_S3 = 45.0 * kRadPerArcsec * Vec3(1, 1, 0).normalized();  // about cross-boresight axes
  q_true[2] = (quatExp(delta_S3) * q_true[2]).normalized();
  std::unique_ptr<Pipeline> own;
  Pipeline* p = reuse;
  if (!p) {
    own = std::make_unique<Pipeline>();
    p = own.get();
    EXPECT_EQ(p->configure(pc), Status::kOk);
  }
  PipelineConfig pn = pc;
  pn.fusion_alignment = FusionAlignment::kNominal;
  auto nominal = std::make_unique<Pipeline>();
  EXPECT_EQ(nominal->configure(pn), Status::kOk);
  if (hand) {
    EXPECT_EQ(p->handMountings(q_true), Status::kOk);
  }
  DropoutRun out;
  for (int i = 0; i < 4800; ++i) {
    const TimeUs t = kT0 + 30000 + static_cast<TimeUs>(i) * 500000;
    HeadEpoch e;
    e.t = t;
    const bool blind = (i >= 2400 && i < 3600) || (early_dropout && i >= 60 && i < 100);
    for (int k = 0; k < 3; ++k) {
      const HeadConfig& h = pc.heads.head[static_cast<std::size_t>(k)];
      const Quat q = tr.q_I_B(t) * q_true[static_cast<std::size_t>(k)].conjugate();
      const Quat qn = test::noisyHead(rng, q, h);
      if (k == 2 && blind) continue;
      HeadSample& sm = e.sample[static_cast<std::size_t>(e.n++)];
      sm.head_id = h.id;
      sm.q_I_Si = qn;
    }
    EXPECT_EQ(p->stepHeads(e), Status::kOk);
    EXPECT_EQ(nominal->stepHeads(e), Status::kOk);
    const FusedAttitude& f = p->fusion().output();
    out.t.push_back(t);
    out.err_B.push_back(quatLog(tr.q_I_B(t).conjugate() * f.q_I_B));
    out.diff_B.push_back(quatLog(nominal->fusion().output().q_I_B.conjugate() * f.q_I_B));
    out.sigma.push_back(std::sqrt(f.P_B.diagonal().maxCoeff()));
    out.used.push_back(f.heads_used);
    PipelineRow r;
    while (p->popRow(r)) {
    }
    while (nominal->popRow(r)) {
    }
  }
  return out;
}

Vec3 meanOver(const DropoutRun& r, int from, int to) {
  Vec3 m = Vec3::Zero();
  for (int i = from; i < to; ++i) m += r.err_B[static_cast<std::size_t>(i)];
  return m / (to - from);
}

TEST(Pipeline, HeadDropoutDoesNotMoveTheFusedAttitude) {
  const double as = kRadPerArcsec;
  for (bool hand : {false, true}) {
    const DropoutRun run = runDropout(FusionAlignment::kRunningMeans, hand, false);
    const Vec3 before = meanOver(run, 1200, 2400), during = meanOver(run, 2400, 3600), after = meanOver(run, 3600, 4800);
    // the per-epoch 1-sigma of the fused attitude (all heads), per axis, from the model covariance
    PipelineConfig pc;
    pc.heads = test::graceLikeHeads(3);
    HeadFusion hf;
    ASSERT_EQ(hf.configure(pc.heads), Status::kOk);
    Mat3 W = Mat3::Zero();
    for (int k = 0; k < 3; ++k) W += hf.information_B(k);
    const Vec3 sigma = Mat3(W.inverse()).diagonal().cwiseSqrt();
    for (int a = 0; a < 3; ++a) {
      EXPECT_LT(std::abs(during[a] - before[a]), sigma[a]) << "axis " << a << (hand ? " handed" : " running");
      EXPECT_LT(std::abs(after[a] - before[a]), sigma[a]) << "axis " << a;
    }
    std::printf("%s alignment: fused mean jump at the dropout %.2f\" (per-axis 1-sigma %.1f/%.1f/%.1f\"), at the "
                "return %.2f\"\n", hand ? "handed" : "running-mean", (during - before).norm() / as, sigma[0] / as,
                sigma[1] / as, sigma[2] / as, (after - before).norm() / as);
    // the datum: with all heads present the fused attitude is where the nominal mountings put it
    double worst = 0;
    for (std::size_t i = 0; i < run.t.size(); ++i)
      if (run.used[i] == 3) worst = std::max(worst, run.diff_B[i].norm() / run.sigma[i]);
    EXPECT_LT(worst, 0.05);
    std::printf("  all heads present: largest |aligned - nominal| %.3f of the fused 1-sigma\n", worst);
  }
  // the same test against the nominal mountings only (the seed's fusion): the jump is visible
  const DropoutRun nominal = runDropout(FusionAlignment::kNominal, false, false);
  const Vec3 jump = meanOver(nominal, 2400, 3600) - meanOver(nominal, 1200, 2400);
  std::printf("nominal mountings: fused mean jump at the dropout %.2f\"\n", jump.norm() / as);
  EXPECT_GT(jump.norm(), 5 * as);
}

TEST(Pipeline, AlignmentAtStartUpDropoutAndAfterReset) {
  // start-up: nominal mountings until every pair has relative_min_epochs (120); a dropout inside that
  // time is fused with the nominal mountings (it moves, as in the seed); everything stays finite and,
  // with all heads present, at the nominal fusion
  const DropoutRun run = runDropout(FusionAlignment::kRunningMeans, false, true);
  for (std::size_t i = 0; i < run.t.size(); ++i) {
    ASSERT_TRUE(run.err_B[i].allFinite()) << i;
    if (i < 119) {
      EXPECT_EQ(run.diff_B[i].norm(), 0.0) << i;  // nominal before the minimum data
    }
    if (run.used[i] == 3) {
      EXPECT_LT(run.diff_B[i].norm(), 0.05 * run.sigma[i]) << i;
    }
  }
  EXPECT_LT(run.err_B[3000].norm(), 60 * kRadPerArcsec);
  // reset: the alignment is dropped with the means, and a rerun gives the same result as a new pipeline
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  pc.use_accelerometer = false;
  auto p = std::make_unique<Pipeline>();
  ASSERT_EQ(p->configure(pc), Status::kOk);
  const DropoutRun first = runDropout(FusionAlignment::kRunningMeans, false, false, p.get());
  EXPECT_NE(p->fusion().relativeAlignment().mask, 0u);
  p->reset();
  EXPECT_EQ(p->fusion().relativeAlignment().mask, 0u);
  EXPECT_FALSE(p->means().mean(0, 1).valid);
  const DropoutRun second = runDropout(FusionAlignment::kRunningMeans, false, false, p.get());
  for (std::size_t i = 0; i < first.t.size(); ++i) ASSERT_EQ(first.err_B[i], second.err_B[i]) << i;
  // bad handed mountings are refused and change nothing
  std::array<Quat, kMaxHeads> bad = filled<Quat, kMaxHeads>(Quat(2, 0, 0, 0));
  EXPECT_EQ(p->handMountings(bad), Status::kInvalidConfig);
  HeadAlignment partial;
  partial.mask = 1u;
  HeadFusion hf;
  ASSERT_EQ(hf.configure(pc.heads), Status::kOk);
  EXPECT_EQ(hf.setRelativeAlignment(partial), Status::kInvalidConfig);
}

}  // namespace
}  // namespace boresight::core

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

// Heads gap in all heads: epochs [600, 600 + gap) at 2 Hz are missing (5 min into a 10 min run).
PipelineRun runPipelineHeadGap(int gap) {
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
      p->stepAcc(ta, pc.C_B_A.transpose() * tr.alpha_B(ta));
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

}  // namespace
}  // namespace boresight::core

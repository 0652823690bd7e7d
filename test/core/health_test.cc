// Bad input: each rejection reason is provoked and counted by reason; random garbage crashes nothing.
#include "boresight/core/pipeline.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>

namespace boresight::core {
namespace {

using test::Rng;

HeadEpoch goodEpoch(const HeadSetConfig& heads, TimeUs t) {
  HeadEpoch e;
  e.t = t;
  for (int k = 0; k < heads.n_heads; ++k) {
    HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
    s.head_id = heads.head[static_cast<std::size_t>(k)].id;
    s.q_I_Si = heads.head[static_cast<std::size_t>(k)].q_Si_B.conjugate();
  }
  return e;
}

TEST(Health, EveryRejectionReasonIsCounted) {
  const HeadSetConfig heads = test::graceLikeHeads(3);
  HeadInputValidator v;
  EXPECT_EQ(v.step(goodEpoch(heads, 1)), Status::kNotConfigured);
  EXPECT_EQ(v.health().count(Status::kNotConfigured), 1u);
  ASSERT_EQ(v.configure(heads), Status::kOk);
  EXPECT_EQ(v.step(goodEpoch(heads, 1000)), Status::kOk);

  HeadEpoch e = goodEpoch(heads, 2000);
  e.sample[0].q_I_Si = Quat(std::numeric_limits<double>::quiet_NaN(), 0, 0, 0);  // non-finite
  e.sample[1].q_I_Si = Quat(1.01, 0, 0, 0);                                      // non-unit
  e.sample[2].head_id = 7;                                                       // unknown head
  EXPECT_EQ(v.step(e), Status::kNonFinite);  // nothing valid: the first reason
  EXPECT_EQ(v.health().count(Status::kNonFinite), 1u);
  EXPECT_EQ(v.health().count(Status::kNonUnitQuaternion), 1u);
  EXPECT_EQ(v.health().count(Status::kUnknownHead), 1u);

  e = goodEpoch(heads, 3000);
  e.sample[1].head_id = e.sample[0].head_id;  // the same head twice
  e.sample[2].q_I_Si = Quat(std::numeric_limits<double>::infinity(), 0, 0, 0);
  EXPECT_EQ(v.step(e), Status::kOk);  // head 1 still usable
  EXPECT_EQ(v.output().count(), 1);
  EXPECT_EQ(v.health().count(Status::kDuplicateHead), 1u);
  EXPECT_EQ(v.health().count(Status::kNonFinite), 2u);

  EXPECT_EQ(v.step(goodEpoch(heads, 3000)), Status::kDuplicateTime);
  EXPECT_EQ(v.step(goodEpoch(heads, 2500)), Status::kTimeBackwards);
  EXPECT_EQ(v.health().count(Status::kDuplicateTime), 1u);
  EXPECT_EQ(v.health().count(Status::kTimeBackwards), 1u);
  EXPECT_EQ(v.health().rejected(), 7u);  // configure() reset the not-configured count

  // gap, irregular time and filter-level time errors in a CRN stream
  CrnStream<3> s;
  CrnConfig c;
  c.fs_hz = 10;
  ASSERT_EQ(s.configure(c), Status::kOk);
  TimeUs t = 0;
  for (int i = 0; i < 10; ++i) ASSERT_EQ(s.step(t += 100000, Vec3::Zero()), Status::kOk);
  EXPECT_EQ(s.step(t + 50000, Vec3::Zero()), Status::kIrregularTime);
  EXPECT_EQ(s.step(t, Vec3::Zero()), Status::kDuplicateTime);
  EXPECT_EQ(s.step(t - 1, Vec3::Zero()), Status::kTimeBackwards);
  EXPECT_EQ(s.step(t + 100000, Vec3::Constant(std::numeric_limits<double>::quiet_NaN())), Status::kNonFinite);
  EXPECT_EQ(s.step(t + 5 * 100000, Vec3::Zero()), Status::kGapRestarted);
  for (Status r : {Status::kIrregularTime, Status::kDuplicateTime, Status::kTimeBackwards, Status::kNonFinite,
                   Status::kGapRestarted})
    EXPECT_EQ(s.health().count(r), 1u) << statusName(r);

  // too few stars
  WahbaConfig wc;
  wc.heads = heads;
  MultiHeadWahba w;
  ASSERT_EQ(w.configure(wc), Status::kOk);
  StarEpoch se;
  se.t = 1;
  EXPECT_EQ(w.step(se), Status::kTooFewStars);
  EXPECT_EQ(w.health().count(Status::kTooFewStars), 1u);
}

TEST(Health, NoValidInputNumericalFailureAndCapacityThroughThePipeline) {
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  pc.use_accelerometer = false;
  auto p = std::make_unique<Pipeline>();
  ASSERT_EQ(p->configure(pc), Status::kOk);
  TimeUs t = 1000;
  ASSERT_EQ(p->stepHeads(goodEpoch(pc.heads, t)), Status::kOk);

  // kNoValidInput: an epoch without any head sample
  HeadEpoch empty;
  empty.t = (t += 500000);
  EXPECT_EQ(p->stepHeads(empty), Status::kNoValidInput);
  EXPECT_EQ(p->health().count(Status::kNoValidInput), 1u);

  // kNumericalFailure: sigma scales so large (1e160: information 1e-320, below the smallest double)
  // that the fusion's information matrix is singular
  HeadEpoch huge = goodEpoch(pc.heads, t += 500000);
  for (int k = 0; k < huge.n; ++k) huge.sample[static_cast<std::size_t>(k)].sigma_scale = 1e160;
  EXPECT_EQ(p->stepHeads(huge), Status::kNumericalFailure);
  EXPECT_EQ(p->fusion().health().count(Status::kNumericalFailure), 1u);
  EXPECT_GE(p->health().count(Status::kNumericalFailure), 1u);
  EXPECT_EQ(p->stepHeads(goodEpoch(pc.heads, t += 500000)), Status::kOk);  // and the next epoch is fine

  // kCapacityExceeded (1): more head samples than kMaxHeads in one epoch: the excess is dropped
  HeadEpoch many = goodEpoch(pc.heads, t += 500000);
  many.n = kMaxHeads + 1;
  EXPECT_EQ(p->stepHeads(many), Status::kOk);
  EXPECT_EQ(p->health().count(Status::kCapacityExceeded), 1u);

  // kCapacityExceeded (2): nobody pops rows: past kMaxPendingRows the oldest ready rows are dropped,
  // each counted
  const std::uint64_t before = p->health().count(Status::kCapacityExceeded);
  int epochs = 0;
  for (; epochs < 2 * (kMaxPendingRows + 200); ++epochs)
    ASSERT_EQ(p->stepHeads(goodEpoch(pc.heads, t += 500000)), Status::kOk);
  EXPECT_EQ(p->rowsReady(), kMaxPendingRows);
  p->flush();
  // rows: one per second of the run (the head epochs nearest whole seconds), ready ones kept up to capacity
  const std::uint64_t dropped = p->health().count(Status::kCapacityExceeded) - before;
  EXPECT_GT(dropped, 150u);
  int popped = 0;
  PipelineRow r;
  while (p->popRow(r)) ++popped;
  EXPECT_EQ(popped, kMaxPendingRows);
  std::printf("capacity: %llu rows dropped and counted, %d kept\n", static_cast<unsigned long long>(dropped), popped);

  // kCapacityExceeded (3): more star inputs than kMaxStarInputs
  StarEpoch se;
  se.t = t;
  se.n = kMaxStarInputs + 5;
  for (auto& o : se.star) {
    o.head_id = 1;
    o.s_Sk = Vec3::UnitZ();
    o.r_I = Vec3::UnitX();
  }
  p->stepStars(se);
  EXPECT_GE(p->wahba().health().count(Status::kCapacityExceeded), 1u);

  // kNotReady / kUnavailable of evaluateAt
  RateOutput ro;
  EXPECT_EQ(p->rates().evaluateAt(t, ro), Status::kNotReady);
  EXPECT_EQ(p->rates().evaluateAt(t - 1000 * kUsPerSecond, ro), Status::kUnavailable);
  for (int i = 0; i < kStatusCount; ++i) std::printf("%s=%llu ", statusName(static_cast<Status>(i)),
                                                     static_cast<unsigned long long>(p->health().by_status[static_cast<std::size_t>(i)]));
  std::printf("\n");
}

TEST(Health, InvalidConfigurationsAreRejected) {
  HeadSetConfig h = test::graceLikeHeads(3);
  h.head[1].id = h.head[0].id;
  EXPECT_EQ(HeadFusion().configure(h), Status::kInvalidConfig);
  h = test::graceLikeHeads(3);
  h.head[2].boresight_Si = Vec3(0, 0, 2);
  EXPECT_EQ(HeadFusion().configure(h), Status::kInvalidConfig);
  h = test::graceLikeHeads(3);
  h.n_heads = kMaxHeads + 1;
  EXPECT_EQ(HeadFusion().configure(h), Status::kInvalidConfig);
  HeadFusion f;
  EXPECT_EQ(f.step(ValidHeads{}), Status::kNotConfigured);
}

TEST(Health, RandomGarbageThroughThePipelineNeverCrashes) {
  constexpr int kRuns = 200000;  // random inputs of every kind
  Rng rng(61);
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  auto p = std::make_unique<Pipeline>();
  ASSERT_EQ(p->configure(pc), Status::kOk);
  std::uniform_int_distribution<int> pick(0, 9), id(-1, 5), n(-2, kMaxHeads + 2);
  std::uniform_int_distribution<TimeUs> dt(-2000000, 3000000);
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 0.0, 1.0,
                             -1.0, 1e300, 0.5, 1e-300};
  auto val = [&]() { return pick(rng) < 2 ? specials[pick(rng) % 8] : std::normal_distribution<double>(0, 1)(rng); };
  TimeUs t = 0;
  std::uint64_t calls = 0;
  for (int r = 0; r < kRuns; ++r) {
    t += dt(rng) / 4;
    const int kind = pick(rng);
    if (kind < 5) {
      HeadEpoch e;
      e.t = t;
      e.n = n(rng);
      for (auto& s : e.sample) {
        s.head_id = id(rng);
        if (pick(rng) < 6) {
          s.q_I_Si = test::randomQuat(rng);
        } else {
          s.q_I_Si = Quat(val(), val(), val(), val());
        }
        s.sigma_scale = pick(rng) < 8 ? 1.0 : val();
      }
      p->stepHeads(e);
    } else if (kind < 9) {
      p->stepAcc(t, Vec3(val(), val(), val()));
    } else {
      auto se = std::make_unique<StarEpoch>();
      se->t = t;
      se->n = std::uniform_int_distribution<int>(-1, kMaxStarInputs + 3)(rng);
      for (auto& s : se->star) {
        s.head_id = id(rng);
        s.s_Sk = pick(rng) < 7 ? test::randomUnit(rng) : Vec3(val(), val(), val());
        s.r_I = pick(rng) < 7 ? test::randomUnit(rng) : Vec3(val(), val(), val());
        s.sigma_rad = pick(rng) < 8 ? 0.0 : val();
      }
      p->stepStars(*se);
    }
    ++calls;
    PipelineRow row;
    while (p->popRow(row)) {
      EXPECT_TRUE(std::isfinite(row.q_I_B.w()));
      EXPECT_TRUE(std::isfinite(row.P_B.trace()));
    }
  }
  p->flush();
  const Health h = p->health();
  EXPECT_GT(h.rejected(), 0u);
  std::printf("%llu calls with random input; counters:", static_cast<unsigned long long>(calls));
  for (int i = 0; i < kStatusCount; ++i)
    if (h.by_status[static_cast<std::size_t>(i)]) std::printf(" %s=%llu", statusName(static_cast<Status>(i)),
                                                             static_cast<unsigned long long>(h.by_status[static_cast<std::size_t>(i)]));
  std::printf("\n");
}

}  // namespace
}  // namespace boresight::core

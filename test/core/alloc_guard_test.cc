// Guard: step() of every core component makes no heap allocation.
// Two independent detectors: (1) every operator new / delete of the program is replaced and counted,
// and (outside sanitizer builds) malloc/calloc/realloc/aligned allocations are interposed and counted;
// (2) the core sources are compiled into this binary with EIGEN_RUNTIME_NO_MALLOC and assertions on,
// and Eigen::internal::set_is_malloc_allowed(false) is in force around the calls, so any Eigen heap
// allocation aborts the test.
#include "boresight/core/pipeline.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <memory>
#include <new>

#include "alloc_interpose.h"

namespace boresight::core {
namespace {

using test::Rng;

/// Arms both detectors for its lifetime; allocations() reads the count afterwards.
class NoHeap {
 public:
  NoHeap() {
    Eigen::internal::set_is_malloc_allowed(false);
    allocguard::arm();
  }
  ~NoHeap() { disarm(); }
  long disarm() {
    const long n = allocguard::disarm();
    Eigen::internal::set_is_malloc_allowed(true);
    return n;
  }
};

TEST(AllocGuard, DetectorsWork) {
  // the guard must be able to fail: an allocation inside the scope is seen
  NoHeap g;
  auto* p = new int(3);
  const long n = g.disarm();
  delete p;
  EXPECT_GE(n, 1);
  NoHeap g2;
  volatile void* m = std::malloc(16);
  const long n2 = g2.disarm();
  std::free(const_cast<void*>(m));
#ifndef BORESIGHT_NO_MALLOC_INTERPOSE
  EXPECT_GE(n2, 1);
#else
  (void)n2;
#endif
  EXPECT_TRUE(Eigen::internal::is_malloc_allowed());
  // and Eigen's own check aborts on a heap allocation while forbidden
  EXPECT_DEATH(
      {
        Eigen::internal::set_is_malloc_allowed(false);
        Eigen::VectorXd v(100);
        v.setZero();
      },
      "heap allocation is forbidden");
}

HeadEpoch epochOf(Rng& rng, const HeadSetConfig& heads, const Quat& q_I_B, TimeUs t, std::uint32_t mask = 7) {
  HeadEpoch e;
  e.t = t;
  for (int k = 0; k < heads.n_heads; ++k) {
    if (!((mask >> k) & 1u)) continue;
    const auto u = static_cast<std::size_t>(k);
    HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
    s.head_id = heads.head[u].id;
    s.q_I_Si = test::noisyHead(rng, q_I_B * heads.head[u].q_Si_B.conjugate(), heads.head[u]);
  }
  return e;
}

TEST(AllocGuard, EveryComponentStepIsAllocationFree) {
  Rng rng(51);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  // configure (may allocate by contract; these do not, but it is outside the guard)
  auto validator = std::make_unique<HeadInputValidator>();
  auto fusion = std::make_unique<HeadFusion>();
  auto means = std::make_unique<RelativeAttitudeMeans>();
  auto monitor = std::make_unique<BoresightMonitor>();
  auto rates = std::make_unique<AttitudeRates>();
  auto acc = std::make_unique<AccAngularFilter>();
  auto crn = std::make_unique<CrnStream<3>>();
  auto wahba = std::make_unique<MultiHeadWahba>();
  auto pipe = std::make_unique<Pipeline>();
  ASSERT_EQ(validator->configure(heads), Status::kOk);
  ASSERT_EQ(fusion->configure(heads), Status::kOk);
  ASSERT_EQ(means->configure(heads), Status::kOk);
  ASSERT_EQ(monitor->configure(heads), Status::kOk);
  CrnConfig ca;
  ca.fs_hz = 2.0;
  ca.gap_policy = GapPolicy::kBridge;
  ASSERT_EQ(rates->configure(ca), Status::kOk);
  CrnConfig cb;
  cb.fs_hz = 10.0;
  ASSERT_EQ(acc->configure(cb, accToBodyDefault()), Status::kOk);
  ASSERT_EQ(crn->configure(cb), Status::kOk);
  WahbaConfig wc;
  wc.heads = heads;
  ASSERT_EQ(wahba->configure(wc), Status::kOk);
  PipelineConfig pc;
  pc.heads = heads;
  pc.acc_correction.on = true;  // an overlay's accelerometer terms: the corrected path is the one guarded
  pc.acc_correction.bias_A = Vec3(1e-7, -2e-7, 3e-7);
  pc.acc_correction.M = Mat3::Identity() * 0.999;
  ASSERT_EQ(pipe->configure(pc), Status::kOk);

  // inputs prepared outside the guard (the test's own data may allocate)
  constexpr int kEpochs = 400;  // 200 s at 2 Hz: every filter produces outputs
  std::vector<HeadEpoch> epochs;
  std::vector<StarEpoch> stars;
  for (int i = 0; i < kEpochs; ++i) {
    const TimeUs t = 1000 + static_cast<TimeUs>(i) * 500000 + (i > 300 ? 3 * 500000 : 0);  // one bridged gap
    const Quat q = quatExp(Vec3(1e-3, 2e-3, -1.1e-3 * toSeconds(t)));
    epochs.push_back(epochOf(rng, heads, q, t, (i % 7 == 3) ? 5u : 7u));
    StarEpoch se;
    se.t = t;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < kMaxStarsPerHead; ++j) {
        StarObservation& o = se.star[static_cast<std::size_t>(se.n++)];
        o.head_id = k + 1;
        o.s_Sk = (Vec3::UnitZ() + test::randomVec(rng, 0.05)).normalized();
        o.r_I = (q * heads.head[static_cast<std::size_t>(k)].q_Si_B.conjugate()) * o.s_Sk;
      }
    stars.push_back(se);
  }
  HeadEpoch bad = epochs[5];
  bad.sample[0].q_I_Si = Quat(std::nan(""), 0, 0, 0);
  bad.sample[1].head_id = 99;

  long allocs = 0;
  int outputs = 0, rows = 0;
  {
    NoHeap guard;
    for (int i = 0; i < kEpochs; ++i) {
      const HeadEpoch& e = epochs[static_cast<std::size_t>(i)];
      if (validator->step(e) == Status::kOk) {
        const ValidHeads& v = validator->output();
        fusion->step(v);
        means->step(v);
        monitor->step(v);
        rates->step(e.t, fusion->output().q_I_B);
        outputs += rates->numOutputs();
        RateOutput ro;
        rates->evaluateAt(e.t - 40 * kUsPerSecond, ro);
      }
      validator->step(bad);  // rejected input paths
      for (int j = 0; j < 5; ++j) {
        const TimeUs ta = e.t + j * 100000;
        const Vec3 a(1e-7 * j, 2e-7, -3e-7);
        acc->step(ta, a);
        crn->step(ta, a);
        AccOutput ao;
        acc->evaluateAt(e.t - 40 * kUsPerSecond, ao);
        pipe->stepAcc(ta, a);
      }
      wahba->setRelative(1, monitor->correctedRelative(0, 1));
      wahba->step(stars[static_cast<std::size_t>(i)]);  // 48 inputs > kMaxStars: selection path
      pipe->stepHeads(e);
      pipe->stepHeads(bad);
      pipe->stepStars(stars[static_cast<std::size_t>(i)]);
      PipelineRow row;
      while (pipe->popRow(row)) ++rows;
      const Health h = pipe->health();
      (void)h;
    }
    means->mean(0, 1);
    means->closure(0, 1, 2);
    monitor->mean(0, 2);
    pipe->flush();
    PipelineRow row;
    while (pipe->popRow(row)) ++rows;
    allocs = guard.disarm();
  }
  EXPECT_EQ(allocs, 0);
  EXPECT_GT(outputs, 100);
  EXPECT_GT(rows, 150);
  EXPECT_GT(wahba->health().count(Status::kOk), 300u);
  EXPECT_GT(pipe->health().count(Status::kGapBridged), 0u);
}

TEST(AllocGuard, ConfigureReanchoringAlignmentAndRestartAreAllocationFree) {
  Rng rng(52);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  auto validator = std::make_unique<HeadInputValidator>();
  auto fusion = std::make_unique<HeadFusion>();
  auto means = std::make_unique<RelativeAttitudeMeans>();
  auto monitor = std::make_unique<BoresightMonitor>();
  auto rates = std::make_unique<AttitudeRates>();
  auto acc = std::make_unique<AccAngularFilter>();
  auto crn = std::make_unique<CrnStream<4>>();
  auto wahba = std::make_unique<MultiHeadWahba>();
  auto pipe = std::make_unique<Pipeline>();
  PipelineConfig pc;
  pc.heads = heads;
  pc.alignment_update_epochs = 8;
  WahbaConfig wc;
  wc.heads = heads;
  CrnConfig cr;  // restart policy for the plain stream
  cr.fs_hz = 2.0;
  cr.gap_policy = GapPolicy::kRestart;
  CrnConfig cb;
  cb.fs_hz = 10.0;
  // head 2 turns away from its mounting by 8 mrad over the run: the pair means re-anchor
  constexpr int kEpochs = 2000;
  std::vector<HeadEpoch> epochs;
  for (int i = 0; i < kEpochs; ++i) {
    const TimeUs t = 1000 + static_cast<TimeUs>(i) * 500000 + (i >= 1000 ? 60 * kUsPerSecond : 0);  // a 60 s gap
    const Quat q = quatExp(Vec3(1e-3, 2e-3, -1.1e-3 * toSeconds(t)));
    HeadEpoch e = epochOf(rng, heads, q, t);
    e.sample[1].q_I_Si = (e.sample[1].q_I_Si * quatExp(Vec3(8e-3 * i / kEpochs, 0, 0))).normalized();
    epochs.push_back(e);
  }
  std::array<Quat, kMaxHeads> mountings = filled<Quat, kMaxHeads>(Quat::Identity());
  for (int k = 0; k < 3; ++k) mountings[static_cast<std::size_t>(k)] = heads.head[static_cast<std::size_t>(k)].q_Si_B;

  long allocs = 0;
  std::uint64_t reanchors = 0, restarts = 0;
  bool aligned = false;
  {
    NoHeap guard;
    // configure() of every component (allowed to allocate by the contract; none does)
    bool ok = validator->configure(heads) == Status::kOk && fusion->configure(heads) == Status::kOk &&
              means->configure(heads) == Status::kOk && monitor->configure(heads) == Status::kOk &&
              rates->configure(cr) == Status::kOk && acc->configure(cb, accToBodyDefault()) == Status::kOk &&
              crn->configure(cr) == Status::kOk && wahba->configure(wc) == Status::kOk &&
              pipe->configure(pc) == Status::kOk;
    for (int i = 0; i < kEpochs && ok; ++i) {
      const HeadEpoch& e = epochs[static_cast<std::size_t>(i)];
      if (validator->step(e) != Status::kOk) continue;
      const ValidHeads& v = validator->output();
      means->step(v);
      HeadAlignment a;
      if (i % 16 == 0 && means->alignment(a)) fusion->setRelativeAlignment(a);
      fusion->step(v);
      rates->step(e.t, fusion->output().q_I_B);  // the 60 s gap restarts (restart policy)
      const Quat& q = fusion->output().q_I_B;
      crn->step(e.t, Eigen::Vector4d(q.w(), q.x(), q.y(), q.z()));
      pipe->stepAcc(e.t - 100000, Vec3(1e-7, 0, 0));
      pipe->stepHeads(e);  // pipeline: bridge policy, 60 s > the bridge limit: restart
      PipelineRow row;
      while (pipe->popRow(row)) {
      }
      if (i == 1500) pipe->handMountings(mountings);
    }
    pipe->flush();
    // the paths under test really ran (reading counters does not allocate)
    reanchors = means->reanchors();
    restarts = rates->health().count(Status::kGapRestarted) + crn->health().count(Status::kGapRestarted) +
               pipe->health().count(Status::kGapRestarted);
    aligned = fusion->relativeAlignment().mask != 0;
    pipe->reset();
    means->reset();
    allocs = guard.disarm();
    ASSERT_TRUE(ok);
  }
  EXPECT_EQ(allocs, 0);
  EXPECT_GT(reanchors, 0u);
  EXPECT_EQ(restarts, 4u);  // rates, the plain stream, and the pipeline's rate and accelerometer filters
  EXPECT_TRUE(aligned);
}

TEST(AllocGuard, ThermalModelPredictionWhileAHeadIsBlindIsAllocationFree) {
  Rng rng(53);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  ThermalHarmonicModel m;
  m.n_harmonics = 3;
  m.order = {1, 2, 3};
  m.beta_terms = true;
  m.cos_beta_ref = 0.8;
  for (int k = 1; k < 3; ++k) {
    ThermalHeadModel& h = m.head[static_cast<std::size_t>(k)];
    h.valid = true;
    h.constant_rad = Vec3(1e-5, -2e-5, 3e-5);
    for (int n = 0; n < 3; ++n) {
      h.cos_rad[static_cast<std::size_t>(n)] = Vec3(5e-5, 1e-5, -2e-5) / (n + 1);
      h.sin_rad[static_cast<std::size_t>(n)] = Vec3(-3e-5, 2e-5, 1e-5) / (n + 1);
      h.beta_cos_rad[static_cast<std::size_t>(n)] = Vec3(1e-6, 0, 0);
    }
    h.cov_rad2 = Mat3::Identity() * 1e-12;
  }
  constexpr int kEpochs = 1200;
  std::vector<HeadEpoch> epochs;
  for (int i = 0; i < kEpochs; ++i) {
    const TimeUs t = 1000 + static_cast<TimeUs>(i) * 500000;
    const Quat q = quatExp(Vec3(1e-3, 2e-3, -1.1e-3 * toSeconds(t)));
    // head 3 blind for epochs 400..799, head 2 for 900..999 (pairs through and around the datum)
    const std::uint32_t mask = (i >= 400 && i < 800) ? 3u : (i >= 900 && i < 1000) ? 5u : 7u;
    epochs.push_back(epochOf(rng, heads, q, t, mask));
  }
  PipelineConfig pc;
  pc.heads = heads;
  pc.use_accelerometer = false;
  auto pipe = std::make_unique<Pipeline>();
  auto anchored = std::make_unique<Pipeline>();
  auto predictor = std::make_unique<ThermalPredictor>();
  long allocs = 0;
  std::uint64_t predicted = 0, no_orbit = 0;
  Status set_abs = Status::kNotConfigured, set_anch = Status::kNotConfigured, set_pred = Status::kNotConfigured;
  {
    NoHeap guard;
    const bool ok = pipe->configure(pc) == Status::kOk && anchored->configure(pc) == Status::kOk;
    m.mode = ThermalPredictionMode::kAbsolute;
    set_abs = pipe->setThermalModel(m);
    m.mode = ThermalPredictionMode::kAnchored;
    set_anch = anchored->setThermalModel(m);
    set_pred = predictor->configure(heads, m);
    for (int i = 0; i < kEpochs && ok; ++i) {
      const HeadEpoch& e = epochs[static_cast<std::size_t>(i)];
      const double u = 1.1e-3 * toSeconds(e.t);
      if (i % 2 == 0 && !(i >= 700 && i < 1000)) {  // orbit at 1 Hz, with a gap: the no-orbit path too
        pipe->stepOrbit(e.t, u, 1.1e-3, 0.5);
        anchored->stepOrbit(e.t, u, 1.1e-3, 0.5);
        predictor->stepOrbit(e.t, u, 1.1e-3, 0.5);
      }
      pipe->stepHeads(e);
      anchored->stepHeads(e);
      PipelineRow row;
      while (pipe->popRow(row)) {
      }
      while (anchored->popRow(row)) {
      }
      Vec3 d;
      Mat3 P;
      predictor->predictPair(1, 2, u, 0.7, d, P);
      Mat3 C, Q;
      pipe->monitor().relativeFor(0, 2, RelativeCorrection::kFilteredThreeAxis, e.t, C, Q);
      if (pipe->monitor().filtered(0, 2).predicted) ++predicted;
    }
    no_orbit = pipe->health().count(Status::kUnavailable);
    pipe->reset();
    allocs = guard.disarm();
    ASSERT_TRUE(ok);
  }
  EXPECT_EQ(allocs, 0);
  EXPECT_EQ(set_abs, Status::kOk);
  EXPECT_EQ(set_anch, Status::kOk);
  EXPECT_EQ(set_pred, Status::kOk);
  EXPECT_GT(predicted, 200u);  // the prediction path really ran
  EXPECT_GT(no_orbit, 0u);     // and the one without orbit input
}

}  // namespace
}  // namespace boresight::core

// The chain stars -> thermal correction -> multi-head Wahba against the TRUE attitude.
//
// Three GRACE-like heads at 2 Hz; head 2 is deformed relative to head 1 by an orbit-periodic
// three-axis rotation (20/15/25" sinusoids, 5400 s period, random phases per seed). Every second each
// head sees 6 stars within 8 deg of its boresight (5" noise), through its TRUE (deformed) attitude.
// The same inputs go through three pipelines that differ only in the relative matrices handed to
// Wahba: none (ground), the seed's one-axis IBA correction, the filtered three-axis deformation.
// The joint attitude (reference head 1) is compared with the truth.
#include "boresight/core/pipeline.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

namespace boresight::core {
namespace {

using test::Rng;

constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;
constexpr int kSeeds = 4;            // Monte Carlo runs (different noise and deformation phases)
constexpr double kSpanS = 5400.0;    // one orbit per run
constexpr double kWarmupS = 900.0;   // the filter's start (6 tau) is not scored
constexpr double kBlockS = 300.0;    // batch-means block for the standard errors (2 tau)
constexpr int kStarsPerHead = 6;

struct ChainStats {
  // per mode: sum of squared error per axis (S1), sum NEES, per-block mean squared error (3-D)
  Vec3 ss = Vec3::Zero();
  double nees = 0, trP = 0;
  long n = 0;
  std::vector<double> block_ms;
  double block_acc = 0;
  int block_n = 0;
};

const char* kModeName[3] = {"none", "one-axis (seed)", "three-axis filtered"};

void runChain(std::uint64_t seed, std::array<ChainStats, 3>& st, bool blind_head2 = false) {
  Rng rng(seed);
  std::uniform_real_distribution<double> uphase(0, 2 * kPi), u(-1, 1);
  const Vec3 amp = Vec3(20.0, -15.0, 25.0) * kRadPerArcsec;
  const Vec3 ph(uphase(rng), uphase(rng), uphase(rng));
  const double w_def = 2 * kPi / 5400.0;
  const double w_orb = 2 * kPi / 5640.0;
  const Quat q_I_B0 = test::randomQuat(rng);
  PipelineConfig pc;
  pc.heads = test::graceLikeHeads(3);
  pc.use_accelerometer = false;
  std::array<std::unique_ptr<Pipeline>, 3> p;
  const RelativeCorrection modes[3] = {RelativeCorrection::kNone, RelativeCorrection::kIbaOneAxis,
                                       RelativeCorrection::kFilteredThreeAxis};
  for (int m = 0; m < 3; ++m) {
    pc.wahba_correction = modes[m];
    p[static_cast<std::size_t>(m)] = std::make_unique<Pipeline>();
    ASSERT_EQ(p[static_cast<std::size_t>(m)]->configure(pc), Status::kOk);
  }
  const HeadSetConfig& H = pc.heads;
  const Quat q0_12 = H.head[0].q_Si_B * H.head[1].q_Si_B.conjugate();
  const int epochs = static_cast<int>(2 * kSpanS);
  for (int i = 0; i < epochs; ++i) {
    const double t_s = 0.5 * i;
    const TimeUs t = kT0 + static_cast<TimeUs>(i) * 500000;
    const Quat q_I_B = q_I_B0 * quatExp(Vec3(0, -w_orb * t_s, 0));
    const Vec3 delta(amp.x() * std::sin(w_def * t_s + ph.x()), amp.y() * std::sin(w_def * t_s + ph.y()),
                     amp.z() * std::sin(w_def * t_s + ph.z()));
    const Quat q_I_S1 = q_I_B * H.head[0].q_Si_B.conjugate();
    const Quat truth[3] = {q_I_S1, q_I_S1 * quatExp(delta) * q0_12, q_I_B * H.head[2].q_Si_B.conjugate()};
    const bool h2_blind = blind_head2 && t_s > 2500 && t_s < 3100;
    HeadEpoch he;
    he.t = t;
    for (int k = 0; k < 3; ++k) {
      if (k == 1 && h2_blind) continue;
      HeadSample& s = he.sample[static_cast<std::size_t>(he.n++)];
      s.head_id = H.head[static_cast<std::size_t>(k)].id;
      s.q_I_Si = test::noisyHead(rng, truth[k], H.head[static_cast<std::size_t>(k)]);
    }
    for (auto& pp : p) ASSERT_EQ(pp->stepHeads(he), Status::kOk);
    PipelineRow row;
    for (auto& pp : p)
      while (pp->popRow(row)) {
      }
    if (i % 2) continue;  // stars at 1 Hz
    StarEpoch se;
    se.t = t + 1000;  // the star solution of the epoch, just after the head samples
    for (int k = 0; k < 3; ++k) {
      if (k == 1 && h2_blind) continue;
      const HeadConfig& h = H.head[static_cast<std::size_t>(k)];
      for (int j = 0; j < kStarsPerHead; ++j) {
        const Vec3 s_true = (h.boresight_Si + 0.14 * Vec3(u(rng), u(rng), 0)).normalized();
        StarObservation& o = se.star[static_cast<std::size_t>(se.n++)];
        o.head_id = h.id;
        o.r_I = truth[k] * s_true;
        o.s_Sk = (s_true + test::randomVec(rng, h.sigma_star_rad)).normalized();
      }
    }
    for (int m = 0; m < 3; ++m) {
      Pipeline& pp = *p[static_cast<std::size_t>(m)];
      ASSERT_EQ(pp.stepStars(se), Status::kOk);
      if (t_s < kWarmupS) continue;
      const WahbaSolution& sol = pp.wahba().output();
      const Vec3 e = quatLog(q_I_S1.conjugate() * sol.q_I_SR);
      ChainStats& c = st[static_cast<std::size_t>(m)];
      c.ss += e.cwiseProduct(e);
      c.nees += e.dot(sol.P_SR.inverse() * e);
      c.trP += sol.P_SR.trace();
      ++c.n;
      c.block_acc += e.squaredNorm();
      if (++c.block_n == static_cast<int>(kBlockS)) {
        c.block_ms.push_back(c.block_acc / c.block_n);
        c.block_acc = 0;
        c.block_n = 0;
      }
    }
  }
}

/// Mean and standard error (batch means) of the block mean squares of a minus those of b.
void diffStats(const ChainStats& a, const ChainStats& b, double& mean, double& se) {
  const std::size_t n = std::min(a.block_ms.size(), b.block_ms.size());
  double s = 0, s2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = a.block_ms[i] - b.block_ms[i];
    s += d;
    s2 += d * d;
  }
  mean = s / static_cast<double>(n);
  se = std::sqrt((s2 / static_cast<double>(n) - mean * mean) / static_cast<double>(n - 1));
}

TEST(StarChain, ThreeAxisFilteredCorrectionBeatsNoneAndOneAxisAgainstTruth) {
  std::array<ChainStats, 3> st;
  for (int s = 0; s < kSeeds; ++s) {
    runChain(81 + static_cast<std::uint64_t>(s), st);
    if (HasFatalFailure()) return;
  }
  std::printf("joint attitude (head-1 frame) minus truth, %d runs x %.0f s at 1 Hz (%ld epochs per mode):\n", kSeeds,
              kSpanS - kWarmupS, st[0].n);
  for (int m = 0; m < 3; ++m) {
    const ChainStats& c = st[static_cast<std::size_t>(m)];
    const Vec3 rms = (c.ss / static_cast<double>(c.n)).cwiseSqrt() * kArcsecPerRad;
    std::printf("  %-20s RMS x/y/z %.2f / %.2f / %.2f\", 3-D %.2f\", sqrt(mean tr P_SR) %.2f\", mean NEES %.2f\n",
                kModeName[m], rms.x(), rms.y(), rms.z(), rms.norm(), std::sqrt(c.trP / static_cast<double>(c.n)) * kArcsecPerRad,
                c.nees / static_cast<double>(c.n));
  }
  const ChainStats& three = st[2];
  // (a), (b): the three-axis mean square error is below the others' by more than 3 standard errors of
  // the difference (batch means over 300 s blocks, which carry the filter's correlation)
  for (int m = 0; m < 2; ++m) {
    double d, se;
    diffStats(st[static_cast<std::size_t>(m)], three, d, se);
    std::printf("  %s minus three-axis: mean square %.2f arcsec^2 (standard error %.2f)\n", kModeName[m],
                d * kArcsecPerRad * kArcsecPerRad, se * kArcsecPerRad * kArcsecPerRad);
    EXPECT_GT(d, 3 * se) << kModeName[m];
  }
  // the covariance is consistent with the actual errors: mean NEES of 3 dof. The star noise is new
  // every epoch, the relative-matrix error is correlated over ~tau (150 s): about 4 x 4500 / 150 = 120
  // independent samples of that part, so the mean has a 1-sigma of ~0.25: band [2.2, 3.8]
  const double nees = three.nees / static_cast<double>(three.n);
  EXPECT_GT(nees, 2.2);
  EXPECT_LT(nees, 3.8);
}

TEST(StarChain, HeadTwoBlindForTenMinutesKeepsTheChainConsistent) {
  // Head 2 gives neither samples nor stars for 600 s mid-orbit; the held correction comes back with the
  // head, its covariance grown by the hold drift. The chain goes on and stays consistent.
  std::array<ChainStats, 3> st;
  runChain(91, st, true);
  if (HasFatalFailure()) return;
  const ChainStats& three = st[2];
  const double nees = three.nees / static_cast<double>(three.n);
  std::printf("head 2 blind 600 s: three-axis 3-D RMS %.2f\", mean NEES %.2f; none %.2f\"\n",
              std::sqrt(three.ss.sum() / static_cast<double>(three.n)) * kArcsecPerRad, nees,
              std::sqrt(st[0].ss.sum() / static_cast<double>(st[0].n)) * kArcsecPerRad);
  EXPECT_LT(three.ss.sum(), 0.25 * st[0].ss.sum());
  EXPECT_GT(nees, 2.0);  // one run: wider band than above
  EXPECT_LT(nees, 4.5);
}

}  // namespace
}  // namespace boresight::core

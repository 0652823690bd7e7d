// Thermal correction and relative attitude: a known relative rotation injected between two heads is
// recovered (IBA deviation, correction matrix, three-axis deformation, pair mean) to the noise level;
// a head's dropout does not move the fused attitude beyond its covariance.
#include "boresight/core/head_fusion.h"
#include "boresight/core/relative_attitude.h"
#include "boresight/core/thermal.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

namespace boresight::core {
namespace {

using test::Rng;

constexpr double kChi2_3dof_999 = 16.27;  // 99.9 % quantile of chi2 with 3 degrees of freedom

struct Scenario {
  HeadSetConfig heads = test::graceLikeHeads(3);
  Vec3 delta_S1 = Vec3::Zero();  // true deformation of head 2 relative to head 1, in S1
  // true heads: C_I_S1 = C_I_B C_B_S1, C_I_S2 = C_I_S1 Exp(delta) C0_12, C_I_S3 nominal
  ValidHeads epoch(Rng& rng, TimeUs t, const Quat& q_I_B) const {
    ValidHeads v;
    v.t = t;
    const Quat q_I_S1 = q_I_B * heads.head[0].q_Si_B.conjugate();
    const Quat q0_12 = heads.head[0].q_Si_B * heads.head[1].q_Si_B.conjugate();
    const Quat truth[3] = {q_I_S1, q_I_S1 * quatExp(delta_S1) * q0_12, q_I_B * heads.head[2].q_Si_B.conjugate()};
    for (int k = 0; k < 3; ++k) {
      const auto u = static_cast<std::size_t>(k);
      v.q_I_Si[u] = test::noisyHead(rng, truth[k], heads.head[u]);
      v.sigma_scale[u] = 1.0;
      v.mask |= 1u << k;
    }
    return v;
  }
};

TEST(Thermal, InjectedRelativeRotationIsRecovered) {
  constexpr int kTrials = 20;    // independent injected rotations
  constexpr int kEpochs = 2000;  // epochs per trial
  Rng rng(31);
  double third_gain_sum = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    Scenario sc;
    sc.delta_S1 = test::randomVec(rng, 30.0 * kRadPerArcsec);
    BoresightMonitor mon;
    ASSERT_EQ(mon.configure(sc.heads), Status::kOk);
    RelativeAttitudeMeans means;
    ASSERT_EQ(means.configure(sc.heads), Status::kOk);
    const Mat3 C0 = mon.groundRelative(0, 1);
    const Vec3 b1 = sc.heads.head[0].boresight_Si, b2 = sc.heads.head[1].boresight_Si;
    const double alpha_true = std::atan2(b1.cross(so3Exp(sc.delta_S1) * C0 * b2).norm(), b1.dot(so3Exp(sc.delta_S1) * C0 * b2));
    double corrected_angle_sum = 0, dev_sq = 0;
    for (int e = 0; e < kEpochs; ++e) {
      const ValidHeads v = sc.epoch(rng, 1000 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
      ASSERT_EQ(mon.step(v), Status::kOk);
      ASSERT_EQ(means.step(v), Status::kOk);
      const PairDeformation& d = mon.pair(0, 1);
      ASSERT_TRUE(d.valid);
      const Vec3 v2 = d.T_Si * C0 * b2;
      const double corrected = std::atan2(b1.cross(v2).norm(), b1.dot(v2));
      EXPECT_NEAR(corrected, d.iba_rad, 1e-12);  // by construction T restores the measured angle
      corrected_angle_sum += corrected;
      dev_sq += std::pow(d.iba_dev_rad - (alpha_true - d.iba_ground_rad), 2);
    }
    const PairDeformation& last = mon.pair(0, 1);
    const double iba_sigma = std::sqrt(last.n_iba_Si.dot(last.cov_delta_Si * last.n_iba_Si));
    // the corrected matrices give the true angle to the noise of a mean (4 sigma)
    EXPECT_NEAR(corrected_angle_sum / kEpochs, alpha_true, 4 * iba_sigma / std::sqrt(kEpochs)) << "trial " << trial;
    // the single-epoch IBA scatter matches its model (2000 epochs: 3 % sigma of a variance)
    EXPECT_NEAR(std::sqrt(dev_sq / kEpochs) / iba_sigma, 1.0, 0.1);
    // three-axis deformation: chi2 of the mean against the truth
    const DeformationMean dm = mon.mean(0, 1);
    ASSERT_TRUE(dm.valid);
    const Vec3 err = dm.delta_Si - sc.delta_S1;
    EXPECT_LT(err.dot(dm.cov_Si.inverse() * err), kChi2_3dof_999) << "trial " << trial;
    // the IBA senses n . delta
    EXPECT_NEAR(dm.iba_dev_mean_rad, last.n_iba_Si.dot(sc.delta_S1), 4 * iba_sigma / std::sqrt(kEpochs) + 1e-9);
    // the pair mean recovers C_S1_S2 = Exp(delta) C0
    const PairMean pm = means.mean(0, 1);
    ASSERT_TRUE(pm.valid);
    EXPECT_EQ(pm.n, static_cast<std::uint64_t>(kEpochs));
    const Vec3 e_S2 = quatLog(Quat(Mat3(so3Exp(sc.delta_S1) * C0)).conjugate() * pm.q_Si_Sj);
    EXPECT_LT(e_S2.dot(pm.cov_mean_Sj.inverse() * e_S2), kChi2_3dof_999) << "trial " << trial;
    // the model spread agrees with the data spread (trace, 10 %)
    EXPECT_NEAR(pm.spread_Sj.trace() / (pm.cov_mean_Sj.trace() * kEpochs), 1.0, 0.1);
    // closure of the three means over the same epochs: far inside its (upper-bound) covariance
    const ClosureCheck cc = means.closure(0, 1, 2);
    ASSERT_TRUE(cc.valid);
    EXPECT_LT(cc.chi2, 1.0);
    // how much the full relative rotation adds to the IBA: information about the two other axes
    const Mat3 W = dm.cov_Si.inverse();
    third_gain_sum += W.trace() / last.n_iba_Si.dot(W * last.n_iba_Si);
  }
  std::printf("three-axis deformation: total information / IBA-axis information = %.2f (mean of %d trials)\n",
              third_gain_sum / kTrials, kTrials);
}

TEST(Thermal, ClosureDetectsAnInconsistentHead) {
  // Head 3's samples are rotated by 100" about its boresight at the epochs without head 2 (every
  // other epoch): the mean (1,3) takes half of that, (1,2) and (2,3) none, and the closure must show
  // about 50" where the consistent case shows nothing.
  for (bool inconsistent : {false, true}) {
    Rng rng(32);
    Scenario sc;
    RelativeAttitudeMeans means;
    ASSERT_EQ(means.configure(sc.heads), Status::kOk);
    for (int e = 0; e < 2000; ++e) {
      ValidHeads v = sc.epoch(rng, 1000 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
      if (e % 2) {
        v.mask &= ~2u;
        if (inconsistent) v.q_I_Si[2] = v.q_I_Si[2] * quatExp(100 * kRadPerArcsec * sc.heads.head[2].boresight_Si);
      }
      ASSERT_EQ(means.step(v), Status::kOk);
    }
    const ClosureCheck cc = means.closure(0, 1, 2);
    ASSERT_TRUE(cc.valid);
    if (inconsistent) {
      EXPECT_NEAR(cc.angle_rad * kArcsecPerRad, 50.0, 5.0);
      EXPECT_GT(cc.chi2, 100.0);
    } else {
      EXPECT_LT(cc.angle_rad * kArcsecPerRad, 5.0);
      EXPECT_LT(cc.chi2, kChi2_3dof_999);
    }
  }
}

TEST(Thermal, HeadDropoutDoesNotMoveTheFusedAttitudeBeyondItsCovariance) {
  constexpr int kRuns = 5000;  // Monte Carlo epochs, each fused with 3 heads and with one dropped
  Rng rng(33);
  const HeadSetConfig heads = test::graceLikeHeads(3);
  HeadFusion all, drop;
  ASSERT_EQ(all.configure(heads), Status::kOk);
  ASSERT_EQ(drop.configure(heads), Status::kOk);
  double chi2_sum = 0;
  int outliers = 0, outside_own = 0;
  Scenario sc;
  for (int r = 0; r < kRuns; ++r) {
    ValidHeads v = sc.epoch(rng, 1000 + static_cast<TimeUs>(r) * 500000, test::randomQuat(rng));
    ASSERT_EQ(all.step(v), Status::kOk);
    v.mask &= ~(1u << (r % 3));  // Sun blinding of one head
    ASSERT_EQ(drop.step(v), Status::kOk);
    const Vec3 d = quatLog(all.output().q_I_B.conjugate() * drop.output().q_I_B);
    // nested least squares: the change has covariance P_drop - P_all
    const Mat3 C = drop.output().P_B - all.output().P_B;
    const double chi2 = d.dot(C.inverse() * d);
    chi2_sum += chi2;
    outliers += chi2 > kChi2_3dof_999 ? 1 : 0;
    outside_own += d.dot(drop.output().P_B.inverse() * d) > kChi2_3dof_999 ? 1 : 0;
  }
  EXPECT_NEAR(chi2_sum / kRuns, 3.0, 0.3);
  EXPECT_LE(outliers, 20);     // expected 5 of 5000
  EXPECT_LE(outside_own, 20);  // the jump relative to the remaining heads' own covariance: at most as often
  std::printf("dropout: mean chi2 %.3f (3 expected), beyond 99.9 %%: %d vs P_drop-P_all, %d vs P_drop, of %d\n",
              chi2_sum / kRuns, outliers, outside_own, kRuns);
}

}  // namespace
}  // namespace boresight::core

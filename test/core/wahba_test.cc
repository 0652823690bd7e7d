// Multi-head Wahba: attitude from the star vectors of all heads through the ground (or corrected)
// relative matrices; selection of at most kMaxStars well-distributed stars; covariance check.
#include "boresight/core/wahba.h"

#include "core_test_util.h"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>

namespace boresight::core {
namespace {

using test::Rng;

// Stars within a 8 deg half-cone about each head's boresight, noisy in the head frame.
StarEpoch makeStars(Rng& rng, const HeadSetConfig& heads, const Quat& q_I_B, int per_head, TimeUs t,
                    const Quat& extra_S2 = Quat::Identity()) {
  StarEpoch e;
  e.t = t;
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < heads.n_heads; ++k) {
    const HeadConfig& h = heads.head[static_cast<std::size_t>(k)];
    Quat q_I_Si = q_I_B * h.q_Si_B.conjugate();
    if (k == 1) q_I_Si = q_I_Si * extra_S2;  // a deformation of head 2 not in the ground matrices
    for (int j = 0; j < per_head && e.n < kMaxStarInputs; ++j) {
      const Vec3 s_true = (h.boresight_Si + 0.14 * Vec3(u(rng), u(rng), 0)).normalized();
      StarObservation& o = e.star[static_cast<std::size_t>(e.n++)];
      o.head_id = h.id;
      o.r_I = q_I_Si * s_true;
      o.s_Sk = (s_true + test::randomVec(rng, h.sigma_star_rad)).normalized();
    }
  }
  return e;
}

TEST(Wahba, RecoversAttitudeWithConsistentCovariance) {
  constexpr int kRuns = 2000;  // Monte Carlo epochs
  Rng rng(41);
  WahbaConfig cfg;
  cfg.heads = test::graceLikeHeads(3);
  MultiHeadWahba w;
  ASSERT_EQ(w.configure(cfg), Status::kOk);
  double chi2 = 0;
  for (int r = 0; r < kRuns; ++r) {
    const Quat q_I_B = test::randomQuat(rng);
    const StarEpoch e = makeStars(rng, cfg.heads, q_I_B, 6, 1000 + static_cast<TimeUs>(r) * 500000);
    ASSERT_EQ(w.step(e), Status::kOk);
    const WahbaSolution& s = w.output();
    EXPECT_EQ(s.stars_used, 18);
    const Quat q_I_S1 = q_I_B * cfg.heads.head[0].q_Si_B.conjugate();
    const Vec3 err = quatLog(q_I_S1.conjugate() * s.q_I_SR);
    chi2 += err.dot(s.P_SR.inverse() * err);
    EXPECT_LT(angleBetween(s.q_I_B, q_I_B), 1e-4);
  }
  // the error is consistent with the covariance (mean chi2 of 3 dof; 2000 runs: sigma 0.055)
  EXPECT_NEAR(chi2 / kRuns, 3.0, 0.3);
}

TEST(Wahba, SelectsAtMostKMaxStarsWellDistributed) {
  constexpr int kRuns = 200;
  Rng rng(42);
  WahbaConfig cfg;
  cfg.heads = test::graceLikeHeads(3);
  MultiHeadWahba w;
  ASSERT_EQ(w.configure(cfg), Status::kOk);
  double ratio_sum = 0;
  int wins = 0;
  Rng pick_rng(142);  // the random subsets
  for (int r = 0; r < kRuns; ++r) {
    const StarEpoch e = makeStars(rng, cfg.heads, test::randomQuat(rng), kMaxStarsPerHead, 1000 + static_cast<TimeUs>(r) * 500000);
    ASSERT_EQ(e.n, 3 * kMaxStarsPerHead);
    ASSERT_EQ(w.step(e), Status::kOk);
    const WahbaSolution& s = w.output();
    EXPECT_EQ(s.stars_in, 3 * kMaxStarsPerHead);
    EXPECT_EQ(s.stars_used, kMaxStars);
    // every head contributes: a selection from one head only would lose the roll information
    int per_head[3] = {0, 0, 0};
    for (int j = 0; j < s.stars_used; ++j) ++per_head[e.star[static_cast<std::size_t>(s.used[static_cast<std::size_t>(j)])].head_id - 1];
    for (int k = 0; k < 3; ++k) EXPECT_GE(per_head[k], 3) << "run " << r;
    // against a random subset of the same size (seeded shuffle of all inputs; it holds stars of every
    // head, checked): the greedy selection keeps more information in the weakest direction
    std::array<int, 3 * kMaxStarsPerHead> perm{};
    for (std::size_t j = 0; j < perm.size(); ++j) perm[j] = static_cast<int>(j);
    std::shuffle(perm.begin(), perm.end(), pick_rng);
    int rnd_heads[3] = {0, 0, 0};
    Mat3 sel = Mat3::Zero(), rnd = Mat3::Zero();
    for (int j = 0; j < kMaxStars; ++j) {
      const auto u = static_cast<std::size_t>(s.used[static_cast<std::size_t>(j)]);
      const Vec3 v = w.output().q_I_SR.conjugate() * e.star[u].r_I;
      sel += Mat3::Identity() - v * v.transpose();
      const auto ur = static_cast<std::size_t>(perm[static_cast<std::size_t>(j)]);
      ++rnd_heads[e.star[ur].head_id - 1];
      const Vec3 v2 = w.output().q_I_SR.conjugate() * e.star[ur].r_I;
      rnd += Mat3::Identity() - v2 * v2.transpose();
    }
    for (int k = 0; k < 3; ++k) ASSERT_GE(rnd_heads[k], 1) << "run " << r << ": the random subset misses head " << k + 1;
    const double lmin_sel = Eigen::SelfAdjointEigenSolver<Mat3>(sel).eigenvalues()(0);
    const double lmin_rnd = Eigen::SelfAdjointEigenSolver<Mat3>(rnd).eigenvalues()(0);
    wins += lmin_sel > lmin_rnd ? 1 : 0;
    ratio_sum += lmin_sel / lmin_rnd;
  }
  std::printf("selection: smallest information eigenvalue %.2fx that of a random subset of %d (mean of %d), larger in %d runs\n",
              ratio_sum / kRuns, kMaxStars, kRuns, wins);
  EXPECT_GT(ratio_sum / kRuns, 1.1);  // measured 1.19 (seed 142, 200 runs); one run's ratio scatters by ~0.1
  EXPECT_GE(wins, kRuns * 95 / 100);
}

TEST(Wahba, CorrectedRelativeMatrixRemovesAHeadDeformation) {
  Rng rng(43);
  WahbaConfig cfg;
  cfg.heads = test::graceLikeHeads(3);
  MultiHeadWahba ground, corrected;
  ASSERT_EQ(ground.configure(cfg), Status::kOk);
  ASSERT_EQ(corrected.configure(cfg), Status::kOk);
  const Quat extra = quatExp(Vec3(60, -40, 20) * kRadPerArcsec);
  const Mat3 C_S1_S2_true = (cfg.heads.head[0].q_Si_B * cfg.heads.head[1].q_Si_B.conjugate() * extra).toRotationMatrix();
  ASSERT_EQ(corrected.setRelative(1, C_S1_S2_true), Status::kOk);
  double rg = 0, rc = 0;
  for (int r = 0; r < 200; ++r) {
    const StarEpoch e = makeStars(rng, cfg.heads, test::randomQuat(rng), 8, 1000 + static_cast<TimeUs>(r) * 500000, extra);
    ASSERT_EQ(ground.step(e), Status::kOk);
    ASSERT_EQ(corrected.step(e), Status::kOk);
    rg += ground.output().residual_rms_rad;
    rc += corrected.output().residual_rms_rad;
  }
  EXPECT_LT(rc, 0.6 * rg);
}

TEST(Wahba, TooFewOrCollinearStarsAreRejected) {
  WahbaConfig cfg;
  cfg.heads = test::graceLikeHeads(3);
  MultiHeadWahba w;
  ASSERT_EQ(w.configure(cfg), Status::kOk);
  StarEpoch e;
  e.t = 1;
  e.n = 1;
  e.star[0].head_id = 1;
  EXPECT_EQ(w.step(e), Status::kTooFewStars);
  e.t = 2;
  e.n = 3;  // three copies of one direction: collinear
  e.star[1] = e.star[0];
  e.star[2] = e.star[0];
  EXPECT_EQ(w.step(e), Status::kTooFewStars);
  EXPECT_EQ(w.health().count(Status::kTooFewStars), 2u);
}

}  // namespace
}  // namespace boresight::core

// The joint white levels of the head axes (noise/joint_white.h) against draws of known truth:
//  - Monte Carlo on the GRACE-FO geometry (config/gracefo.yaml, three heads) at the realistic
//    preset's levels, started from the platform file's ideal levels: every level within 3 sigma in at
//    least 95 % of 200 runs, and the normalised error squared of the 9 levels inside its 95 % bounds
//    (the overlapping differences' information counted right; with it counted as K independent
//    differences the NEES is 1.5 times too large and this fails);
//  - a geometry that cannot separate the heads (two heads whose axes are parallel) flags every axis
//    not determined and still fits what the data do determine (the sums of the parallel axes).
#include <boresight/io/core_config.h>
#include <boresight/model/stats.h>
#include <boresight/noise/joint_white.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace boresight;

namespace {

/// The sum of d d^T over the overlapping first differences of N epochs of r = G n, n ~ N(0, diag(s)).
Eigen::MatrixXd diffSum(const Eigen::MatrixXd& G, const Eigen::VectorXd& s, int N, std::mt19937_64& rng, double& K) {
  std::normal_distribution<double> nd;
  const Eigen::Index m = G.rows();
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd prev(m), n(m);
  K = 0;
  for (int k = 0; k < N; ++k) {
    for (Eigen::Index a = 0; a < m; ++a) n[a] = std::sqrt(s[a]) * nd(rng);
    const Eigen::VectorXd r = G * n;
    if (k > 0) {
      const Eigen::VectorXd d = r - prev;
      S += d * d.transpose();
      ++K;
    }
    prev = r;
  }
  return S;
}

}  // namespace

TEST(JointWhite, GraceFoGeometryRecoversEveryLevelWithConsistentSigmas) {
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(BORESIGHT_SOURCE_DIR "/config/gracefo.yaml", pc, &err)) << err;
  const noise::HeadSeriesGeometry g = noise::headSeriesGeometry(pc.pipeline.heads);
  ASSERT_EQ(g.heads, 3);
  // the attitude cancels: 9 series, 6 independent combinations
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(g.G);
  EXPECT_LT(svd.singularValues()[6], 1e-9 * svd.singularValues()[0]);
  EXPECT_GT(svd.singularValues()[5], 1e-3 * svd.singularValues()[0]);
  Eigen::VectorXd truth(9), start(9);
  const double cross[3] = {2.29, 1.69, 2.32}, about[3] = {21.1, 30.8, 29.9};
  for (int h = 0; h < 3; ++h) {
    truth.segment<3>(3 * h) << cross[h] * cross[h], cross[h] * cross[h], about[h] * about[h];
    start.segment<3>(3 * h) << 36, 36, 48 * 48;
  }
  constexpr int kRuns = 200;
  std::mt19937_64 rng(20261126);
  std::array<int, 9> inside{};
  double nees_sum = 0;
  int converged = 0;
  for (int run = 0; run < kRuns; ++run) {
    double K = 0;
    const Eigen::MatrixXd S = diffSum(g.G, truth, 3000, rng, K);
    const noise::JointWhite jw = noise::fitJointWhite(S, K, g.G, start);
    if (!jw.converged) continue;
    ++converged;
    for (int a = 0; a < 9; ++a) {
      ASSERT_TRUE(jw.determined[static_cast<std::size_t>(a)]) << "axis " << a;
      inside[static_cast<std::size_t>(a)] += std::abs(jw.variance[a] - truth[a]) <= 3 * std::sqrt(jw.cov(a, a));
    }
    const Eigen::VectorXd e = jw.variance - truth;
    nees_sum += e.dot(jw.cov.ldlt().solve(e));
  }
  EXPECT_EQ(converged, kRuns);
  for (int a = 0; a < 9; ++a) EXPECT_GE(inside[static_cast<std::size_t>(a)], 0.95 * kRuns) << "axis " << a;
  // the mean of 200 NEES of 9 dimensions: chi-square(9 * 200) / 200, two-sided 95 %
  // (upper-tail probabilities: 0.975 gives the lower bound)
  const double lo = model::stats::chi2Quantile(0.975, 9.0 * kRuns) / kRuns, hi = model::stats::chi2Quantile(0.025, 9.0 * kRuns) / kRuns;
  const double nees = nees_sum / converged;
  std::printf("joint white levels, %d runs: mean NEES %.3f (95 %% bounds %.3f .. %.3f)\n", converged, nees, lo, hi);
  EXPECT_GT(nees, lo);
  EXPECT_LT(nees, hi);
}

TEST(JointWhite, ParallelAxesAreFlaggedNotDeterminedAndTheirSumsFitted) {
  // Two heads, the second turned 90 degrees about x: head 2's x axis is head 1's, its z head 1's y
  // (about), its y head 1's z. The relative attitude shows only the sums of parallel axes' variances.
  core::HeadSetConfig hs;
  hs.n_heads = 2;
  for (int i = 0; i < 2; ++i) {
    auto& h = hs.head[static_cast<std::size_t>(i)];
    h.id = i + 1;
    h.boresight_Si = Vec3::UnitZ();
    h.sigma_cross_rad = 6 / kArcsecPerRad;
    h.sigma_roll_rad = 48 / kArcsecPerRad;
  }
  hs.head[1].q_Si_B = Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()));
  const noise::HeadSeriesGeometry g = noise::headSeriesGeometry(hs);
  Eigen::VectorXd truth(6), start(6);
  truth << 4, 9, 400, 1, 16, 900;
  start << 36, 36, 2304, 36, 36, 2304;
  std::mt19937_64 rng(7);
  double K = 0;
  const Eigen::MatrixXd S = diffSum(g.G, truth, 20000, rng, K);
  const noise::JointWhite jw = noise::fitJointWhite(S, K, g.G, start);
  ASSERT_TRUE(jw.converged) << jw.message;
  for (int a = 0; a < 6; ++a) EXPECT_FALSE(jw.determined[static_cast<std::size_t>(a)]) << "axis " << a;
  // what the data determine: head 1 x + head 2 x, head 1 y + head 2 about, head 1 about + head 2 y
  const double sums[3][3] = {{jw.variance[0] + jw.variance[3], truth[0] + truth[3], 0},
                             {jw.variance[1] + jw.variance[5], truth[1] + truth[5], 0},
                             {jw.variance[2] + jw.variance[4], truth[2] + truth[4], 0}};
  for (const auto& s : sums) EXPECT_NEAR(s[0], s[1], 0.05 * s[1]);
}

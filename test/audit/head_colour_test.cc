// The heads' slow noise through their pair residuals (src/audit/head_colour.h): the filter whitens
// pair rows jointly across pairs and in time, the restricted likelihood does not take what the
// profiled columns carry for noise, and the fit finds a head's slow error where it is.
#include "head_colour.h"

#include <boresight/model/rotation.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using namespace boresight;
using audit::detail::HeadColourData;
using audit::detail::HeadColourFilter;
using audit::detail::HeadColourModel;
using audit::detail::PairBlock;

constexpr double kAs = kRadPerArcsec;

/// Three heads looking in different directions (GRACE-FO-like tilts), 2.5"/25" white per sample,
/// 4 samples per 2 s bin.
HeadColourModel threeHeads() {
  HeadColourModel m;
  m.heads = 3;
  m.C_B_S[0] = model::quatExp(Vec3(0.0, 0.8, 0.3)).toRotationMatrix();
  m.C_B_S[1] = model::quatExp(Vec3(0.9, -0.5, 0.0)).toRotationMatrix();
  m.C_B_S[2] = model::quatExp(Vec3(-0.7, 0.1, 1.2)).toRotationMatrix();
  return m;
}

struct Series {
  std::vector<PairBlock> blocks;
  Eigen::VectorXd y;
  Eigen::MatrixXd X;  ///< a constant per pair component (6 columns)
};

/// Pair rows (1-2, 1-3) every 2 s for `span` s; head errors white plus the slow part of `truth`, and a
/// constant offset `offset` on head 2 (B frame); blocks of one head missing now and then.
Series simulate(const HeadColourModel& truth, double span, const Vec3& offset, std::uint64_t seed, bool two_heads = false,
                double offset_from = 0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Series s;
  const Vec3 white_S(2.5 * kAs / 2, 2.5 * kAs / 2, 25 * kAs / 2);  // per 2 s bin of 4 samples
  std::array<Vec3, 3> x;
  for (int k = 0; k < 3; ++k)
    x[k] = Vec3(truth.sigma_cross[k] * n01(rng), truth.sigma_cross[k] * n01(rng), truth.sigma_about[k] * n01(rng));
  std::vector<double> y;
  int row = 0;
  for (double t = 0; t < span; t += 2) {
    const double phi = std::exp(-2.0 / truth.tau_s);
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        const double sg = a < 2 ? truth.sigma_cross[k] : truth.sigma_about[k];
        x[k][a] = phi * x[k][a] + std::sqrt(1 - phi * phi) * sg * n01(rng);
      }
    std::array<Vec3, 3> e;
    std::array<Mat3, 3> cov;
    for (int k = 0; k < 3; ++k) {
      const Vec3 w(white_S[0] * n01(rng), white_S[1] * n01(rng), white_S[2] * n01(rng));
      e[k] = truth.C_B_S[k] * (x[k] + w);
      cov[k] = truth.C_B_S[k] * white_S.cwiseAbs2().asDiagonal() * truth.C_B_S[k].transpose();
    }
    if (t >= offset_from) e[1] += offset;
    const bool drop3 = two_heads || std::fmod(t, 1800.0) < 60;  // head 3 missing one minute in 30
    PairBlock b;
    b.t = t;
    b.mask = drop3 ? 3u : 7u;
    b.n = drop3 ? 3 : 6;
    b.row0 = row;
    b.held = static_cast<int>(t / 900) % 2 == 1 && t < span - 900;
    b.S = Eigen::MatrixXd::Zero(b.n, b.n);
    for (int i = 0; i < b.n / 3; ++i)
      for (int j = 0; j < b.n / 3; ++j) b.S.block<3, 3>(3 * i, 3 * j) = cov[0] + (i == j ? cov[static_cast<std::size_t>(i + 1)] : Mat3::Zero());
    for (int i = 0; i < b.n / 3; ++i)
      for (int a = 0; a < 3; ++a) y.push_back(e[static_cast<std::size_t>(i + 1)][a] - e[0][a]);
    row += b.n;
    s.blocks.push_back(b);
  }
  s.y = Eigen::Map<Eigen::VectorXd>(y.data(), static_cast<Eigen::Index>(y.size()));
  s.X = Eigen::MatrixXd::Zero(row, 6);
  for (const auto& b : s.blocks)
    for (int r = 0; r < b.n; ++r) s.X(b.row0 + r, r) = 1;
  return s;
}

/// The fit's data; the profiled columns are the six constants and, last, a column of zeros (the
/// constants of a pair that never has rows, as pair 2-3 when head 1 is always there).
HeadColourData merged(const Series& s, double superbin) {
  return audit::detail::mergeForFit(
      s.blocks, 7,
      [&](const PairBlock& b, Eigen::MatrixXd& v) {
        v.leftCols(6) = s.X.middleRows(b.row0, b.n);
        v.col(6).setZero();
        v.col(7) = s.y.segment(b.row0, b.n);
      },
      superbin);
}

TEST(HeadColour, ARestrictedFitDoesNotTakeAProfiledOffsetForSlowNoise) {
  HeadColourModel truth = threeHeads();  // white only
  const Series s = simulate(truth, 7200, Vec3(10, -4, 2) * kAs, 5);
  const HeadColourData d = merged(s, 18);
  EXPECT_EQ(d.B.cols(), 6);  // the span of the profiled columns, the zero column adding nothing
  const auto fit = audit::detail::fitHeadColour(d, truth);
  EXPECT_LT(fit.m2ll_white - fit.m2ll, 20.0) << fit.model.describe();
  // the likelihood does not move with the offset: the same data without it
  const Series s0 = simulate(truth, 7200, Vec3::Zero(), 5);
  HeadColourModel slow = truth;
  slow.sigma_cross = {2 * kAs, 2 * kAs, 2 * kAs};
  slow.sigma_about = {2 * kAs, 2 * kAs, 2 * kAs};
  slow.tau_s = 7000;
  EXPECT_NEAR(audit::detail::remlM2ll(slow, d), audit::detail::remlM2ll(slow, merged(s0, 18)), 1e-6);
}

TEST(HeadColour, TheFitFindsTheSlowErrorOnTheHeadThatHasIt) {
  HeadColourModel truth = threeHeads();
  truth.sigma_cross[1] = 1.0 * kAs;  // head 2 only: 1" on the cross-boresight axes, none about, 600 s
  truth.sigma_about[1] = 0.0;         // (not isotropic: the head's axes must map right)
  truth.tau_s = 600;
  const HeadColourData d = merged(simulate(truth, 21600, Vec3::Zero(), 7), 54);
  const auto fit = audit::detail::fitHeadColour(d, threeHeads());
  const auto& m = fit.model;
  SCOPED_TRACE(m.describe());
  EXPECT_GT(fit.m2ll_white - fit.m2ll, 100.0);
  EXPECT_NEAR(m.sigma_cross[1] / kAs, 1.0, 0.35);
  EXPECT_LT(m.sigma_about[1] / kAs, 0.5);
  EXPECT_LT(m.sigma_cross[0] / kAs, 0.3);
  EXPECT_LT(m.sigma_cross[2] / kAs, 0.3);
  EXPECT_GT(m.tau_s, 250.0);
  EXPECT_LT(m.tau_s, 1500.0);
}

/// The statistic of a step of head 1 at mid-span (in both pairs of every block), by generalised least
/// squares through the filter of `m`, on pair rows whose slow noise is `truth`'s: chi-square with 3
/// degrees of freedom when m is the truth.
double stepStatistic(const HeadColourModel& truth, const HeadColourModel& m, std::uint64_t seed) {
  const Series s = simulate(truth, 7200, Vec3::Zero(), seed);
  HeadColourFilter kf(m, 4);
  Eigen::Matrix4d G = Eigen::Matrix4d::Zero();
  for (const auto& b : s.blocks) {
    Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(b.n, 4);
    if (b.t >= 3600)
      for (int i = 0; i < b.n / 3; ++i) rows.block<3, 3>(3 * i, 0) = -Mat3::Identity();  // rho = e_o - e_1
    rows.col(3) = s.y.segment(b.row0, b.n);
    kf.whiten(b, rows);
    G += rows.transpose() * rows;
  }
  const Eigen::Vector3d g = G.block<3, 1>(0, 3);
  return g.dot(G.topLeftCorner<3, 3>().ldlt().solve(g));
}

TEST(HeadColour, ThroughTheTrueModelAStepStatisticIsChiSquare) {
  // Head 1's slow error is in both pairs of a block: through the filter of the true model the step
  // statistic is chi-square(3) (mean 3) over 40 draws; the white model reads the slow error as steps.
  HeadColourModel truth = threeHeads();
  truth.sigma_cross = {1.0 * kAs, 1.0 * kAs, 1.0 * kAs};
  truth.sigma_about = {1.0 * kAs, 1.0 * kAs, 1.0 * kAs};
  truth.tau_s = 600;
  const HeadColourModel white = threeHeads();
  double with_truth = 0, with_white = 0;
  const int draws = 40;
  for (int i = 0; i < draws; ++i) {
    with_truth += stepStatistic(truth, truth, 100 + static_cast<std::uint64_t>(i)) / draws;
    with_white += stepStatistic(truth, white, 100 + static_cast<std::uint64_t>(i)) / draws;
  }
  std::printf("mean step statistic over %d draws (chi-square(3): 3): true model %.2f, white %.2f\n", draws, with_truth, with_white);
  EXPECT_GT(with_truth, 3 * 0.65);  // the mean of 40 chi-square(3) draws: sd 0.39
  EXPECT_LT(with_truth, 3 * 1.4);
  EXPECT_GT(with_white, 3 * 3.0);
}

TEST(HeadColour, TwoHeadsFitTheirPairsSlowNoise) {
  // One pair: only the difference of the two heads' slow errors is seen, so the split between them is
  // not determined, but the fit runs, finds the colour and whitens.
  HeadColourModel truth = threeHeads();
  truth.sigma_cross[1] = 1.0 * kAs;
  truth.sigma_about[1] = 1.0 * kAs;
  const Series s = simulate(truth, 21600, Vec3::Zero(), 9, true);
  const HeadColourData d = audit::detail::mergeForFit(
      s.blocks, 3,
      [&](const PairBlock& b, Eigen::MatrixXd& v) {
        v.leftCols(3) = s.X.block(b.row0, 0, b.n, 3);
        v.col(3) = s.y.segment(b.row0, b.n);
      },
      54);
  HeadColourModel two = threeHeads();
  two.heads = 2;
  const auto fit = audit::detail::fitHeadColour(d, two);
  EXPECT_TRUE(std::isfinite(fit.m2ll) && std::isfinite(fit.m2ll_white));
  EXPECT_GT(fit.m2ll_white - fit.m2ll, 100.0) << fit.model.describe();
  EXPECT_EQ(fit.params, 5);
}

TEST(HeadColour, FourHeadsFindTheSlowErrorOnTheFourth) {
  // Four heads (the core's capacity), every one present: pairs (1, o) for o = 2..4, nine rows a bin; a
  // 1" slow error on head 4 only.
  HeadColourModel truth = threeHeads();
  truth.heads = 4;
  truth.C_B_S[3] = model::quatExp(Vec3(0.3, -1.1, 0.6)).toRotationMatrix();
  truth.sigma_cross[3] = 1.0 * kAs;
  truth.sigma_about[3] = 1.0 * kAs;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01;
  const Vec3 white_S(2.5 * kAs / 2, 2.5 * kAs / 2, 25 * kAs / 2);
  std::vector<PairBlock> blocks;
  std::vector<double> y;
  Vec3 x = Vec3::Zero();
  for (double t = 0; t < 21600; t += 2) {
    const double phi = std::exp(-2.0 / truth.tau_s);
    for (int a = 0; a < 3; ++a) x[a] = phi * x[a] + std::sqrt(1 - phi * phi) * kAs * n01(rng);
    std::array<Vec3, 4> e;
    std::array<Mat3, 4> cov;
    for (int k = 0; k < 4; ++k) {
      const Vec3 w(white_S[0] * n01(rng), white_S[1] * n01(rng), white_S[2] * n01(rng));
      e[k] = truth.C_B_S[k] * ((k == 3 ? x : Vec3::Zero()) + w);
      cov[k] = truth.C_B_S[k] * white_S.cwiseAbs2().asDiagonal() * truth.C_B_S[k].transpose();
    }
    PairBlock b;
    b.t = t;
    b.mask = 15u;
    b.n = 9;
    b.row0 = static_cast<int>(y.size());
    b.S = Eigen::MatrixXd::Zero(9, 9);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b.S.block<3, 3>(3 * i, 3 * j) = cov[0] + (i == j ? cov[static_cast<std::size_t>(i + 1)] : Mat3::Zero());
    for (int i = 1; i < 4; ++i)
      for (int a = 0; a < 3; ++a) y.push_back(e[static_cast<std::size_t>(i)][a] - e[0][a]);
    blocks.push_back(b);
  }
  const HeadColourData d = audit::detail::mergeForFit(
      blocks, 9,
      [&](const PairBlock& b, Eigen::MatrixXd& v) {
        v.leftCols(9).setIdentity();  // a constant per pair component
        for (int r = 0; r < b.n; ++r) v(r, 9) = y[static_cast<std::size_t>(b.row0 + r)];
      },
      54);
  HeadColourModel start = truth;
  start.sigma_cross.fill(0);
  start.sigma_about.fill(0);
  const auto fit = audit::detail::fitHeadColour(d, start);
  SCOPED_TRACE(fit.model.describe());
  EXPECT_EQ(fit.params, 9);
  EXPECT_GT(fit.m2ll_white - fit.m2ll, 100.0);
  EXPECT_NEAR(fit.model.sigma_cross[3] / kAs, 1.0, 0.35);
  for (int k = 0; k < 3; ++k) EXPECT_LT(fit.model.sigma_cross[static_cast<std::size_t>(k)] / kAs, 0.3);
}


TEST(HeadColour, StepReductionsAreTheLeastSquaresOfAStepFromEachTime) {
  // Head 2 steps by (6, -4, 0)" at 2000 s (in a fitting block: 1800-2700 s); white noise. The step's signature in the pair rows is the
  // constant of pair 1-2 (its first three columns) from the step on.
  HeadColourModel truth = threeHeads();
  const Series s = simulate(truth, 7200, Vec3(6, -4, 0) * kAs, 11, false, 2000);
  const HeadColourData d = merged(s, 18);
  std::vector<double> taus;
  for (double tau = 180; tau < 7000; tau += 18) taus.push_back(tau);
  const double wf = 1.3;
  const Eigen::MatrixXd M = d.X.leftCols(3);
  const std::vector<double> red = audit::detail::stepReductions(wf, d, M, taus);
  ASSERT_EQ(red.size(), taus.size());
  // the same, dense: every block whitened by its covariance, the step columns masked, the reduction
  // beyond the profiled basis
  for (std::size_t j = 0; j < taus.size(); j += 37) {
    const int r = static_cast<int>(d.B.cols()), w = r + 4;
    Eigen::MatrixXd A(d.rows, w);
    for (const auto& b : d.blocks) {
      Eigen::MatrixXd rows(b.n, w);
      rows.leftCols(r) = d.B.middleRows(b.row0, b.n);
      rows.middleCols(r, 3) = b.t >= taus[j] ? Eigen::MatrixXd(M.middleRows(b.row0, b.n)) : Eigen::MatrixXd::Zero(b.n, 3);
      rows.col(w - 1) = d.y.segment(b.row0, b.n);
      const Eigen::MatrixXd S = wf * b.S;
      S.llt().matrixL().solveInPlace(rows);
      A.middleRows(b.row0, b.n) = rows;
    }
    const Eigen::MatrixXd X = A.leftCols(w - 1);
    const Eigen::VectorXd yv = A.col(w - 1);
    const auto rss = [&](const Eigen::MatrixXd& Xs) {
      const Eigen::VectorXd beta = Xs.completeOrthogonalDecomposition().solve(yv);
      return (yv - Xs * beta).squaredNorm();
    };
    const double expect = rss(X.leftCols(r)) - rss(X);
    EXPECT_NEAR(red[j], expect, 1e-7 * std::max(1.0, expect)) << "tau " << taus[j];
  }
  // the largest at a boundary next to the step, and far above chi-square(3)
  const auto jb = static_cast<std::size_t>(std::max_element(red.begin(), red.end()) - red.begin());
  EXPECT_NEAR(taus[jb], 2000, 18);
  EXPECT_GT(red[jb], 500.0);
}

TEST(HeadColour, AStepTakenForSlowNoiseComesBackWhenTheNoiseIsRefittedBesideIt) {
  // A step of (12, -9)" on head 2 in white noise: with only the constants profiled, the fit finds slow
  // noise (a long correlation time, a level of the step's size); with the step profiled as well and the
  // noise refitted, the ordinary likelihood ratio is far above chi-square(3). On slow noise without a
  // step, the ratio at the same time is larger than chi-square(3) (eight noise parameters refitted on a
  // few correlation times: over 40 spans its mean was 5.0, 2 above the 0.1 % point): half of it is
  // what the step scan compares with chi-square(3) (Analyser::stepScan), and that must hold.
  const auto ratio = [](const Series& s) {
    HeadColourData d = merged(s, 18);
    d.reml = false;
    const auto null = audit::detail::fitHeadColour(d, threeHeads());
    d.X.conservativeResize(Eigen::NoChange, 10);
    for (const auto& b : d.blocks) d.X.middleRows(b.row0, b.n).rightCols(3) = b.t >= 2952 ? Eigen::MatrixXd(d.X.middleRows(b.row0, b.n).leftCols(3)) : Eigen::MatrixXd::Zero(b.n, 3);
    audit::detail::setBasis(d, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
    const auto alt = audit::detail::fitHeadColour(d, threeHeads());
    return std::make_pair(null, null.m2ll - alt.m2ll);
  };
  const auto [null, lr] = ratio(simulate(threeHeads(), 7200, Vec3(12, -9, 0) * kAs, 13, false, 2950));
  EXPECT_GT(null.m2ll_white - null.m2ll, 50.0) << "the step no longer looks like slow noise: " << null.model.describe();
  EXPECT_GT(lr, 200.0) << null.model.describe();
  HeadColourModel slow = threeHeads();
  slow.sigma_cross = {1 * kAs, 1 * kAs, 1 * kAs};
  slow.sigma_about = {1 * kAs, 1 * kAs, 1 * kAs};
  slow.tau_s = 600;
  double sum = 0;
  constexpr int kSpans = 12;
  for (std::uint64_t seed = 21; seed < 21 + kSpans; ++seed) {
    const double l = ratio(simulate(slow, 7200, Vec3::Zero(), seed)).second;
    EXPECT_LT(l / 2, 16.3) << "seed " << seed;  // chi-square(3) at 0.1 %
    EXPECT_GT(l, -1e-6) << "seed " << seed;
    sum += l;
  }
  EXPECT_LT(sum / kSpans / 2, 3.0 + 3 * std::sqrt(6.0 / kSpans)) << "half the ratio's mean (chi-square(3): 3 +- 0.7)";
}

}  // namespace

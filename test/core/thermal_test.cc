// Thermal correction and relative attitude: a known relative rotation injected between two heads is
// recovered (IBA deviation, correction matrix, three-axis deformation, pair mean) to the noise level;
// a head's dropout does not move the fused attitude beyond its covariance.
#include "boresight/core/fixed_ldlt.h"
#include "boresight/core/head_fusion.h"
#include "boresight/core/relative_attitude.h"
#include "boresight/core/thermal.h"

#include "core_test_util.h"

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>
#include <cmath>
#include <cstdio>

namespace boresight::core {
namespace {

using test::Rng;

constexpr double kChi2_3dof_999 = 16.27;
constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;  // 99.9 % quantile of chi2 with 3 degrees of freedom

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
    Vec3 resid_sum = Vec3::Zero();
    const Mat3 D_true = so3Exp(sc.delta_S1);
    for (int e = 0; e < kEpochs; ++e) {
      const ValidHeads v = sc.epoch(rng, 1000 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
      ASSERT_EQ(mon.step(v), Status::kOk);
      ASSERT_EQ(means.step(v), Status::kOk);
      const PairDeformation& d = mon.pair(0, 1);
      ASSERT_TRUE(d.valid);
      const Vec3 v2 = d.T_Si() * C0 * b2;
      corrected_angle_sum += std::atan2(b1.cross(v2).norm(), b1.dot(v2));
      dev_sq += std::pow(d.iba_dev_rad - (alpha_true - d.iba_ground_rad), 2);
      // what T leaves of the injected deformation: Log(T^T Exp(delta_true))
      resid_sum += so3Log(d.T_Si().transpose() * D_true);
    }
    const PairDeformation& last = mon.pair(0, 1);
    const double iba_sigma = std::sqrt(last.n_iba_Si.dot(last.cov_delta_Si * last.n_iba_Si));
    // T removes the IBA-axis component of the injected rotation and leaves the two others (truth:
    // delta - (n . delta) n), to the noise of a mean (4 sigma; the residual is noisy along n only)
    const Vec3 n = last.n_iba_Si;
    const Vec3 resid = resid_sum / kEpochs;
    EXPECT_NEAR(n.dot(resid), 0.0, 4 * iba_sigma / std::sqrt(kEpochs)) << "trial " << trial;
    const Vec3 perp_true = sc.delta_S1 - n.dot(sc.delta_S1) * n;
    EXPECT_LT((resid - n.dot(resid) * n - perp_true).norm(), 1e-3 * kRadPerArcsec + 0.01 * perp_true.norm()) << "trial " << trial;
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

// An orbit-periodic three-axis deformation of head 2 relative to head 1 (in S1), tens of arcsec.
struct OrbitDeformation {
  Vec3 amp = Vec3(20.0, -15.0, 25.0) * kRadPerArcsec;
  Vec3 phase = Vec3(0.3, 1.9, 4.0);
  double period_s = 5400.0;
  Vec3 at(double t_s) const {
    const double w = 2 * kPi / period_s;
    return Vec3(amp.x() * std::sin(w * t_s + phase.x()), amp.y() * std::sin(w * t_s + phase.y()),
                amp.z() * std::sin(w * t_s + phase.z()));
  }
};

TEST(Thermal, FilterTimeConstantTradeOff) {
  // Two orbits at 2 Hz, the same noisy epochs through monitors with different time constants. The
  // filtered deformation is compared with the injected truth (not with anything the monitor
  // computes): the error is noise (falls with tau) plus lag (grows with tau).
  constexpr int kEpochs = 2 * 5400 * 2;
  constexpr double kSkipS = 1000.0;  // warm-up of the slowest filter
  const double tau_grid[] = {10, 30, 60, 100, 150, 300, 600};
  constexpr int kT = sizeof(tau_grid) / sizeof(tau_grid[0]);
  constexpr int kN = 2 * kT;  // both models
  double taus[kN];
  DeformationModel models[kN];
  for (int i = 0; i < kN; ++i) {
    taus[i] = tau_grid[i % kT];
    models[i] = i < kT ? DeformationModel::kLevel : DeformationModel::kLinear;
  }
  Rng rng(34);
  Scenario sc;
  const OrbitDeformation def;
  std::array<BoresightMonitor, kN> mon;
  for (int i = 0; i < kN; ++i) {
    DeformationFilterConfig fc;
    fc.tau_s = taus[i];
    fc.model = models[i];
    ASSERT_EQ(mon[static_cast<std::size_t>(i)].configure(sc.heads, fc), Status::kOk);
  }
  std::array<double, kN> ss{}, nees{};
  double raw_ss = 0, truth_ss = 0;
  int n = 0;
  for (int e = 0; e < kEpochs; ++e) {
    const double t_s = 0.5 * e;
    sc.delta_S1 = def.at(t_s);
    const ValidHeads v = sc.epoch(rng, kT0 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
    for (auto& m : mon) ASSERT_EQ(m.step(v), Status::kOk);
    if (t_s < kSkipS) continue;
    ++n;
    raw_ss += (mon[0].pair(0, 1).delta_Si - sc.delta_S1).squaredNorm();
    truth_ss += sc.delta_S1.squaredNorm();
    for (int i = 0; i < kN; ++i) {
      const FilteredDeformation f = mon[static_cast<std::size_t>(i)].filtered(0, 1);
      ASSERT_TRUE(f.valid);
      const Vec3 err = f.delta_Si - sc.delta_S1;
      ss[static_cast<std::size_t>(i)] += err.squaredNorm();
      nees[static_cast<std::size_t>(i)] += err.dot(f.cov_Si.inverse() * err);
    }
  }
  std::printf("deformation filter (orbit-periodic 20/15/25\", 5400 s; 3-D RMS of filtered - truth):\n");
  std::printf("  raw one-epoch delta %.2f\", truth %.2f\"\n", std::sqrt(raw_ss / n) * kArcsecPerRad,
              std::sqrt(truth_ss / n) * kArcsecPerRad);
  double best = 1e9, at_default = 0, nees_default = 0;
  for (int i = 0; i < kN; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double rms = std::sqrt(ss[u] / n);
    std::printf("  %s tau %5.0f s: RMS %.2f\", mean NEES (noise covariance only) %.2f\n",
                models[i] == DeformationModel::kLevel ? "level " : "linear", taus[i], rms * kArcsecPerRad, nees[u] / n);
    best = std::min(best, rms);
    if (taus[i] == DeformationFilterConfig{}.tau_s && models[i] == DeformationFilterConfig{}.model) {
      at_default = rms;
      nees_default = nees[u] / n;
    }
  }
  ASSERT_GT(at_default, 0) << "the default time constant is one of the grid";
  // the default is near the best of the grid (within 15 %) and the filter tracks the cycle: far below
  // both the one-epoch noise and the deformation itself
  EXPECT_LT(at_default, 1.15 * best);
  EXPECT_LT(at_default, 0.1 * std::sqrt(raw_ss / n));
  EXPECT_LT(at_default, 0.25 * std::sqrt(truth_ss / n));
  // and its covariance describes the error (lag included): mean NEES of 3 dof; the errors are
  // correlated over ~tau, so 8800 s / 150 s ~ 60 independent samples: 1-sigma of the mean ~0.3,
  // band [2, 4.5]; the level filter at the same error shows 5-37
  EXPECT_GT(nees_default, 2.0);
  EXPECT_LT(nees_default, 4.5);
}

TEST(Thermal, FilteredDeformationIsHeldOrPredictedWhileAHeadIsBlind) {
  Rng rng(35);
  Scenario sc;
  sc.delta_S1 = Vec3(20, -10, 30) * kRadPerArcsec;  // constant here: the hold must keep it
  BoresightMonitor mon;
  ASSERT_EQ(mon.configure(sc.heads), Status::kOk);
  for (int e = 0; e < 2000; ++e) ASSERT_EQ(mon.step(sc.epoch(rng, kT0 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng))), Status::kOk);
  const FilteredDeformation before = mon.filtered(0, 1);
  ASSERT_TRUE(before.valid);
  EXPECT_LT((before.delta_Si - sc.delta_S1).norm(), 4.0 * std::sqrt(before.cov_Si.trace()));
  // head 2 blind for 600 s
  TimeUs t = kT0 + 2000 * 500000;
  for (int e = 0; e < 1200; ++e, t += 500000) {
    ValidHeads v = sc.epoch(rng, t, test::randomQuat(rng));
    v.mask &= ~2u;
    ASSERT_EQ(mon.step(v), Status::kOk);
  }
  const FilteredDeformation held = mon.filtered(0, 1);
  EXPECT_EQ(held.delta_Si, before.delta_Si);
  EXPECT_EQ(held.t, before.t);
  Mat3 C, Q, C_then, Q_then;
  ASSERT_EQ(mon.relativeFor(0, 1, RelativeCorrection::kFilteredThreeAxis, before.t, C_then, Q_then), Status::kOk);
  ASSERT_EQ(mon.relativeFor(0, 1, RelativeCorrection::kFilteredThreeAxis, t, C, Q), Status::kOk);
  EXPECT_TRUE(C.isApprox(C_then, 1e-15));
  const double g = DeformationFilterConfig{}.hold_drift_rad_per_s * toSeconds(t - before.t);
  EXPECT_NEAR(Q.trace() - Q_then.trace(), 3 * g * g, 1e-6 * Q.trace());
  // the held matrix is the injected truth to its covariance
  const Mat3 C_true = so3Exp(sc.delta_S1) * mon.groundRelative(0, 1);
  EXPECT_LT(so3Log(C_true * C.transpose()).norm(), 4.0 * std::sqrt(Q_then.trace()));
  // reversed order: C_S2_S1 and its covariance in S2
  Mat3 Cr, Qr;
  ASSERT_EQ(mon.relativeFor(1, 0, RelativeCorrection::kFilteredThreeAxis, t, Cr, Qr), Status::kOk);
  EXPECT_TRUE(Cr.isApprox(C.transpose(), 1e-15));
  EXPECT_NEAR(Qr.trace(), Q.trace(), 1e-9 * Q.trace());
  // a prediction replaces the held value until the pair is seen again
  const Vec3 pred = Vec3(5, 5, 5) * kRadPerArcsec;
  ASSERT_EQ(mon.setPredictedDeformation(0, 1, t, pred, Mat3::Identity() * 1e-12), Status::kOk);
  EXPECT_EQ(mon.setPredictedDeformation(1, 0, t, pred, Mat3::Identity()), Status::kInvalidConfig);
  EXPECT_EQ(mon.setPredictedDeformation(0, 1, t, Vec3::Constant(std::nan("")), Mat3::Identity()), Status::kNonFinite);
  ASSERT_EQ(mon.relativeFor(0, 1, RelativeCorrection::kFilteredThreeAxis, t, C, Q), Status::kOk);
  EXPECT_LT(so3Log(C * mon.groundRelative(0, 1).transpose() ).isApprox(pred, 1e-12) ? 0 : 1, 1);
  EXPECT_TRUE(mon.filtered(0, 1).predicted);
  ASSERT_EQ(mon.step(sc.epoch(rng, t + 500000, test::randomQuat(rng))), Status::kOk);
  EXPECT_FALSE(mon.filtered(0, 1).predicted);
  EXPECT_LT((mon.filtered(0, 1).delta_Si - sc.delta_S1).norm(), 4.0 * std::sqrt(mon.filtered(0, 1).cov_Si.trace()));
}

TEST(Thermal, ASingularPairCovarianceIsCountedAndLeavesTheFilterAlone) {
  // sigma_scale 0 on both heads of a pair: the pair's covariance is zero, its information undefined
  Rng rng(36);
  Scenario sc;
  BoresightMonitor mon;
  ASSERT_EQ(mon.configure(sc.heads), Status::kOk);
  for (int e = 0; e < 100; ++e) ASSERT_EQ(mon.step(sc.epoch(rng, kT0 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng))), Status::kOk);
  const FilteredDeformation before = mon.filtered(0, 1);
  ValidHeads v = sc.epoch(rng, kT0 + 100 * 500000, test::randomQuat(rng));
  v.sigma_scale[0] = 0;
  v.sigma_scale[1] = 0;
  ASSERT_EQ(mon.step(v), Status::kOk);
  EXPECT_EQ(mon.health().count(Status::kNumericalFailure), 1u);  // pair (0, 1) only: (0, 2), (1, 2) have one head left
  EXPECT_EQ(mon.filtered(0, 1).delta_Si, before.delta_Si);
  EXPECT_EQ(mon.filtered(0, 1).t, before.t);
  DeformationFilterConfig bad;
  bad.tau_s = 0;
  EXPECT_EQ(mon.configure(sc.heads, bad), Status::kInvalidConfig);
  bad.tau_s = 100;
  bad.hold_drift_rad_per_s = std::nan("");
  EXPECT_EQ(mon.configure(sc.heads, bad), Status::kInvalidConfig);
}

TEST(Thermal, IbaWithoutAtan2EqualsTheAtan2AngleOnBothBranches) {
  // The monitor's IBA (series of asin(sin(alpha - alpha0)) below |sin d| = 0.01, atan2 above) against
  // the atan2 angle between the boresights, per pair, for relative rotations from 1e-9 to 0.5 rad
  // (3 000 epochs, log-uniform magnitudes, random axes: both branches, and the boundary).
  Rng rng(39);
  Scenario sc;
  BoresightMonitor mon;
  ASSERT_EQ(mon.configure(sc.heads), Status::kOk);
  std::uniform_real_distribution<double> lg(-9, std::log10(0.5));
  auto angle = [](const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); };
  int small = 0, large = 0;
  double worst = 0;
  for (int e = 0; e < 3000; ++e) {
    ValidHeads v = sc.epoch(rng, kT0 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
    v.q_I_Si[1] = v.q_I_Si[1] * quatExp(test::randomVec(rng, 1.0).normalized() * std::pow(10.0, lg(rng)));
    ASSERT_EQ(mon.step(v), Status::kOk);
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) {
        const PairDeformation& d = mon.pair(a, b);
        ASSERT_TRUE(d.valid);
        const Vec3& ba = sc.heads.head[static_cast<std::size_t>(a)].boresight_Si;
        const Vec3& bb = sc.heads.head[static_cast<std::size_t>(b)].boresight_Si;
        const Quat q_ab = v.q_I_Si[static_cast<std::size_t>(a)].conjugate() * v.q_I_Si[static_cast<std::size_t>(b)];
        const double alpha = angle(ba, q_ab * bb);
        const double alpha0 = angle(ba, mon.groundRelative(a, b) * bb);
        EXPECT_NEAR(d.iba_rad, alpha, 4e-15) << "epoch " << e << " pair " << a << b;
        EXPECT_NEAR(d.iba_dev_rad, alpha - alpha0, 4e-15) << "epoch " << e << " pair " << a << b;
        EXPECT_NEAR(d.iba_ground_rad, d.iba_rad - d.iba_dev_rad, 1e-15);
        worst = std::max(worst, std::abs(d.iba_dev_rad - (alpha - alpha0)));
        (std::abs(std::sin(d.iba_dev_rad)) < 1e-2 ? small : large) += 1;
      }
  }
  std::printf("IBA without atan2: %d small-branch, %d atan2-branch pair epochs, worst |d - d_atan2| %.1e rad\n",
              small, large, worst);
  EXPECT_GT(small, 1000);
  EXPECT_GT(large, 500);
}

TEST(Thermal, FixedSizeLdltMatchesEigenAndRejectsIndefiniteMatrices) {
  // The filter's 6x6 solve (fixed_ldlt.h, no pivoting) against Eigen's pivoted LDLT on 2 000 random
  // SPD matrices shaped like the filter's normal equations (blocks scaled by 1 and up to 1e4: a time
  // axis in seconds), condition numbers up to ~1e8: M^-1 y and the first three columns of M^-1.
  Rng rng(38);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> lg(0, 4);
  using M6 = Eigen::Matrix<double, 6, 6>;
  using V6 = Eigen::Matrix<double, 6, 1>;
  double worst = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    M6 A;
    for (int i = 0; i < 36; ++i) A(i / 6, i % 6) = n01(rng);
    V6 sc;
    for (int i = 0; i < 6; ++i) sc[i] = i < 3 ? 1.0 : std::pow(10.0, lg(rng));
    const M6 M = sc.asDiagonal() * (A * A.transpose() + 1e-3 * M6::Identity()) * sc.asDiagonal();
    V6 y;
    for (int i = 0; i < 6; ++i) y[i] = n01(rng);
    M6 L;
    V6 D;
    ASSERT_TRUE(ldltFactor<6>(M, L, D)) << trial;
    const Eigen::LDLT<M6> ref(M);
    V6 x = y;
    ldltSolveInPlace<6>(L, D, x);
    const V6 xr = ref.solve(y);
    const double cond = 1.0 / ref.rcond();
    worst = std::max(worst, (x - xr).norm() / xr.norm() / cond);
    EXPECT_LT((x - xr).norm(), 1e-14 * cond * xr.norm()) << trial;
    for (int c = 0; c < 3; ++c) {
      V6 e = V6::Zero();
      e[c] = 1.0;
      ldltSolveInPlace<6>(L, D, e);
      const V6 er = ref.solve(V6::Unit(c));
      EXPECT_LT((e - er).norm(), 1e-14 * cond * er.norm()) << trial << " column " << c;
    }
    EXPECT_LT((L * D.asDiagonal() * L.transpose() - M).norm(), 1e-14 * M.norm()) << trial;
  }
  std::printf("fixed LDLT vs Eigen LDLT: max |dx|/|x|/cond = %.2e\n", worst);
  // not positive definite: a zero, a negative and a NaN pivot are refused
  M6 S = M6::Identity();
  S(4, 4) = 0;
  M6 L;
  V6 D;
  EXPECT_FALSE(ldltFactor<6>(S, L, D));
  S(4, 4) = 1;
  S(2, 5) = S(5, 2) = 2;  // minor [[1 2][2 1]]: indefinite
  EXPECT_FALSE(ldltFactor<6>(S, L, D));
  S(2, 5) = S(5, 2) = 0;
  S(0, 0) = std::nan("");
  EXPECT_FALSE(ldltFactor<6>(S, L, D));
  S(0, 0) = 1;
  EXPECT_TRUE(ldltFactor<6>(S, L, D));
}

TEST(Thermal, FilteredDeformationEqualsABruteForceWeightedFit) {
  // The recursive filter against a direct weighted least-squares fit over every stored epoch
  // (weights exp(-(t - t_k) / tau) W_k, level + rate at the last epoch, covariance R N R^T), across
  // re-anchorings (every 600 s), a 700 s gap of head 2, varying sigma scales and the first epochs
  // (too few for a line: the level).
  Rng rng(37);
  Scenario sc;
  const OrbitDeformation def;
  DeformationFilterConfig fc;
  BoresightMonitor mon;
  ASSERT_EQ(mon.configure(sc.heads, fc), Status::kOk);
  const Mat3 C0 = mon.groundRelative(0, 1);
  const HeadConfig& h1 = sc.heads.head[0];
  const HeadConfig& h2 = sc.heads.head[1];
  struct Ep {
    double t;
    Mat3 W;
    Vec3 d;
  };
  std::vector<Ep> eps;
  std::uniform_real_distribution<double> scale(0.5, 2.0);
  int checked = 0;
  for (int e = 0; e < 4000; ++e) {
    const double t_s = 0.5 * e;
    sc.delta_S1 = def.at(t_s);
    ValidHeads v = sc.epoch(rng, kT0 + static_cast<TimeUs>(e) * 500000, test::randomQuat(rng));
    if (t_s > 1000 && t_s < 1700) v.mask &= ~2u;
    if (e % 7 == 0) v.sigma_scale[1] = scale(rng);
    ASSERT_EQ(mon.step(v), Status::kOk);
    const PairDeformation& pd = mon.pair(0, 1);
    if (pd.valid) {
      const double sa = v.sigma_scale[0], sb = v.sigma_scale[1];
      const Mat3 cov = sa * sa * headCovariance(h1.sigma_cross_rad, h1.sigma_roll_rad, h1.boresight_Si) +
                       sb * sb * C0 * headCovariance(h2.sigma_cross_rad, h2.sigma_roll_rad, h2.boresight_Si) * C0.transpose();
      eps.push_back({t_s, cov.inverse(), pd.delta_Si});
    }
    if (!(e < 20 || e % 397 == 0 || e == 3999)) continue;
    const FilteredDeformation f = mon.filtered(0, 1);
    ASSERT_TRUE(f.valid);
    const double t_last = eps.back().t;
    EXPECT_EQ(f.t, kT0 + static_cast<TimeUs>(std::llround(t_last * 1e6)));
    Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero(), N = M;
    Eigen::Matrix<double, 6, 1> y = Eigen::Matrix<double, 6, 1>::Zero();
    double ws = 0, w2s = 0;
    for (const Ep& k : eps) {
      const double w = std::exp(-(t_last - k.t) / fc.tau_s), s = k.t - t_last;
      Eigen::Matrix<double, 3, 6> H;  // delta_k = level + s rate
      H << Mat3::Identity(), s * Mat3::Identity();
      M += w * H.transpose() * k.W * H;
      N += w * w * H.transpose() * k.W * H;
      y += w * H.transpose() * k.W * k.d;
      ws += w;
      w2s += w * w;
    }
    Vec3 level;
    Mat3 cov;
    if (ws * ws / w2s > 8.0) {
      const Eigen::Matrix<double, 6, 6> Mi = M.inverse();
      level = (Mi * y).head<3>();
      cov = (Mi * N * Mi).topLeftCorner<3, 3>();
    } else {  // the level alone
      const Mat3 Mi = M.topLeftCorner<3, 3>().inverse();
      level = Mi * y.head<3>();
      cov = Mi * N.topLeftCorner<3, 3>() * Mi;
    }
    EXPECT_LT((f.delta_Si - level).norm(), 1e-6 * kRadPerArcsec + 1e-8 * level.norm()) << "epoch " << e;
    EXPECT_LT((f.cov_Si - cov).norm(), 1e-7 * cov.norm()) << "epoch " << e;
    EXPECT_NEAR(f.n_eff, ws * ws / w2s, 1e-9 * f.n_eff);
    ++checked;
  }
  EXPECT_GT(checked, 25);
  // reset() forgets the filter
  mon.reset();
  EXPECT_FALSE(mon.filtered(0, 1).valid);
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

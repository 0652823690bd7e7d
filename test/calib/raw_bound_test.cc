// The raw-data Cramer-Rao bound (calib/raw_bound.h) against closed forms and against an independent
// batch computation of the same linear model.
//
// Closed form: a body oscillating about x with angle a sin(W t) over T seconds (whole periods). A common
// mounting error e makes the heads' angular acceleration differ from the accelerometer's by alpha x e,
// amplitude a W^2 |e_perp|, so the information on e_y and e_z is a^2 T / S with
//   S = S_head(f) + S_acc(f) / W^4,
// the one-sided densities at f = W / 2 pi of the head's attitude noise and of the accelerometer's noise
// (rad^2/Hz and (rad/s^2)^2/Hz), and e_x (about the only excited axis) is not determined.
#include <boresight/calib/raw_bound.h>
#include <boresight/calib/raw_bound_sim.h>
#include <boresight/core/rotation.h>
#include <boresight/model/stats.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace boresight::calib {
namespace {

constexpr double kPi = 3.14159265358979323846;

RawBoundConfig oneHead(const model::NoiseModel& head_noise, const model::NoiseModel& acc_noise) {
  RawBoundConfig c;
  RawBoundHead h;
  h.noise = {head_noise, head_noise, head_noise};
  c.heads.push_back(h);
  c.acc_noise = {acc_noise, acc_noise, acc_noise};
  c.acc_interval_s = 0.1;
  return c;
}

struct Oscillation {
  Vec3 axis = Vec3::UnitX();
  double a = 2e-3, period = 100, start = 0, duration = 0;
  Vec3 alpha(double t) const {
    if (t < start || t >= start + duration) return Vec3::Zero();
    const double W = 2 * kPi / period;
    return -a * W * W * std::sin(W * (t - start)) * axis;
  }
  Vec3 rate(double t) const {
    if (t < start || t >= start + duration) return Vec3::Zero();
    const double W = 2 * kPi / period;
    return a * W * std::cos(W * (t - start)) * axis;
  }
};

/// Accelerometer at 10 Hz, heads at 2 Hz, over [0, span); the sample at t stands for [t, t + 0.1).
RawBoundResult drive(RawBound& b, const std::vector<Oscillation>& osc, double span, std::size_t heads,
                     const Vec3& w0 = Vec3::Zero()) {
  for (long k = 0; k * 0.1 < span; ++k) {
    const double t = static_cast<double>(k) * 0.1;
    Vec3 alpha = Vec3::Zero(), w = w0;
    for (const auto& o : osc) {
      alpha += o.alpha(t + 0.05);
      w += o.rate(t + 0.05);
    }
    b.accel(t, alpha, w);
    if (k % 5 == 0)
      for (std::size_t i = 0; i < heads; ++i) b.head(t, i);
  }
  return b.result();
}

double closedFormSigma(double a, double period, double span, double s_head, double s_acc) {
  const double W = 2 * kPi / period;
  return std::sqrt((s_head + s_acc / std::pow(W, 4)) / (a * a * span));
}

struct Regime {
  const char* name;
  double head_sigma, acc_sigma;
};

TEST(RawBound, SinusoidMatchesTheClosedFormInEveryNoiseRegime) {
  const Regime regimes[] = {{"head-limited", 1.2e-5, 1e-9}, {"accelerometer-limited", 1e-7, 1e-6}, {"both", 1.2e-5, 8e-8}};
  const double span = 4000, a = 2e-3, period = 100;
  for (const auto& r : regimes) {
    SCOPED_TRACE(r.name);
    RawBound b(oneHead(model::NoiseModel::white(r.head_sigma), model::NoiseModel::white(r.acc_sigma)));
    Oscillation o;
    o.a = a;
    o.period = period;
    o.duration = span;
    const RawBoundResult res = drive(b, {o}, span, 1);
    const double expect = closedFormSigma(a, period, span, 2 * r.head_sigma * r.head_sigma / 2.0,
                                          2 * r.acc_sigma * r.acc_sigma / 10.0);
    EXPECT_NEAR(res.head_sigma_rad[0](1) / expect, 1.0, 0.03) << res.head_sigma_rad[0](1) << " vs " << expect;
    EXPECT_NEAR(res.head_sigma_rad[0](2) / expect, 1.0, 0.03) << res.head_sigma_rad[0](2) << " vs " << expect;
    // About the excited axis: nothing.
    EXPECT_FALSE(std::isfinite(res.head_sigma_rad[0](0)) && res.head_sigma_rad[0](0) < 1e3 * expect)
        << res.head_sigma_rad[0](0);
    EXPECT_EQ(res.head_samples[0], 8000u);
    EXPECT_EQ(res.acc_gaps, 0u);
  }
}

TEST(RawBound, ColouredNoiseEntersThroughItsDensityAtTheExcitation) {
  const double span = 4000, a = 2e-3, period = 100, f = 1 / period;
  model::NoiseModel head = model::NoiseModel::white(4e-6);
  head.add(model::NoiseTerm::gaussMarkov(2e-5, 30));
  model::NoiseModel acc = model::NoiseModel::white(2e-8);
  acc.add(model::NoiseTerm::gaussMarkov(2e-7, 200));
  RawBound b(oneHead(head, acc));
  Oscillation o;
  o.a = a;
  o.period = period;
  o.duration = span;
  const RawBoundResult res = drive(b, {o}, span, 1);
  const double expect = closedFormSigma(a, period, span, head.psdContinuous(f, 0.5), acc.psdContinuous(f, 0.1));
  const double white_only = closedFormSigma(a, period, span, 2 * 4e-6 * 4e-6 / 2.0, 2 * 2e-8 * 2e-8 / 10.0);
  ASSERT_GT(expect, 2 * white_only);  // the colour matters here, the accelerometer's as much as the head's
  ASSERT_GT(acc.psdContinuous(f, 0.1) / std::pow(2 * kPi * f, 4), 0.5 * head.psdContinuous(f, 0.5));
  EXPECT_NEAR(res.head_sigma_rad[0](1) / expect, 1.0, 0.04) << res.head_sigma_rad[0](1) << " vs " << expect;
  EXPECT_NEAR(res.head_sigma_rad[0](2) / expect, 1.0, 0.04) << res.head_sigma_rad[0](2) << " vs " << expect;
}

TEST(RawBound, OneExcitedAxisLeavesItsRotationUndeterminedTwoDetermineAll) {
  RawBoundConfig c = oneHead(model::NoiseModel::white(1.2e-5), model::NoiseModel::white(1e-8));
  // A second head, boresight along body y (mounting: a rotation about x by 90 deg).
  RawBoundHead h2 = c.heads[0];
  h2.id = 2;
  h2.R_axes_B << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  c.heads.push_back(h2);
  const Vec3 orbit_rate(0, -1.1e-3, 0);
  Oscillation ox, oy;
  ox.duration = oy.duration = 1500;
  oy.axis = Vec3::UnitY();
  oy.start = 1500;
  {
    RawBound b(c);
    const RawBoundResult r = drive(b, {ox}, 1500, 2, orbit_rate);
    EXPECT_LT(r.common_sigma_rad(1), 1e-3);
    EXPECT_GT(r.common_sigma_rad(2), 1e3 * r.common_sigma_rad(1));
    EXPECT_GT(std::abs(r.common_axes_B.col(2).dot(Vec3::UnitX())), 0.999);
    // The relative alignment needs no excitation: the heads see it directly.
    EXPECT_LT(r.relative_sigma_rad[1].maxCoeff(), 1e-5);
    EXPECT_TRUE(r.unobservable_B.empty());  // no threshold: the weak direction is still counted
    EXPECT_GT(r.head_sigma_rad[0].maxCoeff(), 1e3 * r.common_sigma_rad(1));  // and blurs the head axes
  }
  {
    // With an observability threshold (calibrate's --unobservable-sigma, 3600"): the rotation about x is
    // reported not observable and held at its nominal value, the other two common directions and every
    // head axis keep their small sigmas.
    RawBoundConfig ct = c;
    ct.options.unobservable_sigma_rad = 3600 * kRadPerArcsec;
    RawBound b(ct);
    const RawBoundResult r = drive(b, {ox}, 1500, 2, orbit_rate);
    ASSERT_EQ(r.unobservable_B.size(), 1u);
    EXPECT_GT(std::abs(r.unobservable_B[0].dot(Vec3::UnitX())), 0.999);
    for (std::size_t i = 0; i < 2; ++i) EXPECT_LT(r.head_sigma_rad[i].maxCoeff(), 1e-3) << "head " << i;
    EXPECT_LT(r.common_sigma_rad(1), 1e-3);
  }
  {
    RawBound b(c);
    const RawBoundResult r = drive(b, {ox, oy}, 3000, 2, orbit_rate);
    EXPECT_LT(r.common_sigma_rad(2), 1e-3);
    EXPECT_TRUE(r.unobservable_B.empty());
    for (std::size_t i = 0; i < 2; ++i) EXPECT_LT(r.head_sigma_rad[i].maxCoeff(), 1e-3);
  }
}

TEST(RawBound, UniformRotationAloneDeterminesNoCommonDirection) {
  RawBound b(oneHead(model::NoiseModel::white(1.2e-5), model::NoiseModel::white(1e-8)));
  const RawBoundResult r = drive(b, {}, 3000, 1, Vec3(0, -1.1e-3, 0));
  for (int k = 0; k < 3; ++k) EXPECT_GT(r.common_sigma_rad(k), 1.0) << k;
}

/// Every transition and observation, for the batch computation.
struct Recorder : RawBoundRecorder {
  struct Obs {
    std::size_t state;
    Eigen::VectorXd h, d;
    double r;
  };
  std::vector<Eigen::MatrixXd> T, Q, G;
  std::vector<Obs> obs;
  void transition(const Eigen::MatrixXd& t, const Eigen::MatrixXd& q, const Eigen::MatrixXd& g) override {
    T.push_back(t);
    Q.push_back(q);
    G.push_back(g);
  }
  void observation(const Eigen::VectorXd& h, const Eigen::VectorXd& d, double r) override {
    obs.push_back({T.size(), h, d, r});
  }
};

TEST(RawBound, KalmanInformationEqualsTheBatchSolutionOfTheSameModel) {
  // Two heads, coloured noise everywhere, every optional parameter, an accelerometer gap, a head dropout.
  model::NoiseModel hn = model::NoiseModel::white(6e-6);
  hn.add(model::NoiseTerm::gaussMarkov(8e-6, 12));
  model::NoiseModel an = model::NoiseModel::white(3e-8);
  an.add(model::NoiseTerm::gaussMarkov(2e-8, 40));
  RawBoundConfig c = oneHead(hn, an);
  RawBoundHead h2 = c.heads[0];
  h2.id = 2;
  h2.R_axes_B = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  h2.noise[2] = model::NoiseModel::white(5e-5);
  c.heads.push_back(h2);
  c.C_A_B = Eigen::AngleAxisd(0.3, Vec3(0, 1, 1).normalized()).toRotationMatrix();
  c.options.scale = c.options.time_offset = true;
  c.options.harmonics = 1;
  c.options.orbit_rate_rad_s = 2 * kPi / 60;
  ASSERT_EQ(c.validate(), "");
  RawBound b(c);
  Recorder rec;
  b.setRecorder(&rec);
  const double span = 12;
  for (long k = 0; k * 0.1 < span; ++k) {
    const double t = static_cast<double>(k) * 0.1;
    if (k > 40 && k < 63) continue;  // an accelerometer gap of 2.2 s
    const Vec3 alpha(3e-5 * std::sin(0.9 * t), 2e-5 * std::cos(1.7 * t), 1e-5 * std::sin(2.3 * t + 1));
    const Vec3 w(1e-4 * std::cos(0.9 * t), -1.1e-3, 4e-5 * std::sin(t));
    b.accel(t, alpha, w);
    if (k % 5 == 0) {
      b.head(t, 0);
      if (k < 80 || k > 95) b.head(t + 0.05 * (k % 2), 1);  // a dropout; head 2 sometimes 50 ms late
    }
  }
  const RawBoundResult r = b.result();
  EXPECT_EQ(r.acc_gaps, 1u);

  // Batch: unknowns x_0 .. x_M (states) and theta; normal matrix of prior, transitions, observations,
  // in long double (in double, this normal matrix loses four digits at this accelerometer noise).
  const auto n = static_cast<Eigen::Index>(b.stateSize()), p = static_cast<Eigen::Index>(b.parameterCount());
  const auto M = static_cast<Eigen::Index>(rec.T.size());
  const Eigen::Index N = (M + 1) * n + p;
  using ML = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  ML A = ML::Zero(N, N);
  const Eigen::VectorXd v0 = b.initialVariance();
  for (Eigen::Index k = 0; k < n; ++k)
    if (v0(k) > 0) A(k, k) += 1 / v0(k);
  for (Eigen::Index k = 0; k < M; ++k) {
    // r = x_{k+1} - T x_k - G theta, weight Q^-1: rows [ -T  I  -G ].
    ML L = ML::Zero(n, N);
    L.block(0, k * n, n, n) = -rec.T[static_cast<std::size_t>(k)].cast<long double>();
    L.block(0, (k + 1) * n, n, n) = ML::Identity(n, n);
    L.rightCols(p) = -rec.G[static_cast<std::size_t>(k)].cast<long double>();
    const ML W = rec.Q[static_cast<std::size_t>(k)].cast<long double>().inverse();
    A += L.transpose() * W * L;
  }
  for (const auto& o : rec.obs) {
    Eigen::Matrix<long double, Eigen::Dynamic, 1> l = Eigen::Matrix<long double, Eigen::Dynamic, 1>::Zero(N);
    l.segment(static_cast<Eigen::Index>(o.state) * n, n) = o.h.cast<long double>();
    l.tail(p) = o.d.cast<long double>();
    A += l * l.transpose() / o.r;
  }
  const Eigen::Index nx = (M + 1) * n;
  // Scale before the Schur complement (units differ by orders of magnitude).
  Eigen::Matrix<long double, Eigen::Dynamic, 1> s = A.diagonal().cwiseSqrt().cwiseInverse();
  const ML As = s.asDiagonal() * A * s.asDiagonal();
  const ML Xs = As.topLeftCorner(nx, nx).ldlt().solve(As.topRightCorner(nx, p));
  const ML Is = As.bottomRightCorner(p, p) - As.bottomLeftCorner(p, nx) * Xs;
  const Eigen::Matrix<long double, Eigen::Dynamic, 1> sp = s.tail(p).cwiseInverse();
  const Eigen::MatrixXd batch = (sp.asDiagonal() * Is * sp.asDiagonal()).cast<double>();

  ASSERT_EQ(r.information.rows(), p);
  double worst = 0;
  for (Eigen::Index i = 0; i < p; ++i)
    for (Eigen::Index j = 0; j < p; ++j)
      worst = std::max(worst, std::abs(r.information(i, j) - batch(i, j)) / std::sqrt(batch(i, i) * batch(j, j)));
  EXPECT_LT(worst, 1e-6) << "largest normalised difference";
  for (Eigen::Index i = 0; i < p; ++i) EXPECT_GT(batch(i, i), 0) << r.names[static_cast<std::size_t>(i)];
}

TEST(RawBound, AConstantInertialRotationOfTheTrajectoryIsInvisibleToTheAccelerometer) {
  // The body turns at the orbit rate; rotating the whole trajectory by a constant inertial delta gives
  // phi(t) = C_B_I(t) delta = Exp(-w t) delta in B, phi' = -w x phi: the accelerometer sees nothing, so
  // the model's noise-free transitions must carry this state unchanged in form.
  RawBound b(oneHead(model::NoiseModel::white(1e-5), model::NoiseModel::white(1e-8)));
  Recorder rec;
  b.setRecorder(&rec);
  const Vec3 w(0, -1.1e-3, 0);
  for (long k = 0; k <= 6000; ++k) {
    b.accel(static_cast<double>(k) * 0.1, Vec3::Zero(), w);
    if (k % 5 == 0) b.head(static_cast<double>(k) * 0.1, 0);
  }
  ASSERT_EQ(rec.T.size(), 1200u);
  const Vec3 delta(1e-3, 2e-3, -1.5e-3);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(6);
  x.head<3>() = delta;
  x.tail<3>() = -w.cross(delta);
  for (const auto& T : rec.T) x = T.topLeftCorner(6, 6) * x;
  const double t = 600;
  const Vec3 expect = Eigen::AngleAxisd(-w.norm() * t, w.normalized()).toRotationMatrix() * delta;
  EXPECT_LT((x.head<3>() - expect).norm(), 1e-3 * delta.norm()) << x.head<3>().transpose() << " vs " << expect.transpose();
  EXPECT_LT((x.tail<3>() + w.cross(expect)).norm(), 1e-3 * w.norm() * delta.norm());
}

/// Runs a simulation once into the bound at the truth and the recorded data.
RawData runWithBound(sim::Simulator& simu, const RawBoundConfig& cfg, bool aberration_in_data, RawBoundResult& at_truth) {
  RawBound truth_bound(cfg);
  RawBoundSimSink bound_sink(truth_bound, simu);
  RawDataSimSink rec(simu, aberration_in_data);
  sim::TeeSink tee;
  tee.add(&bound_sink);
  tee.add(&rec);
  simu.run(tee);
  at_truth = truth_bound.result();
  return rec.data;
}

/// The short calibration scenario without its orbit-periodic deformation and the stars' aberration.
sim::Scenario shortScenarioInsideTheModel() {
  sim::Scenario sc;
  std::string err;
  EXPECT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo_calibration_short.yaml", sc, &err)) << err;
  sc.effects.erase(std::remove_if(sc.effects.begin(), sc.effects.end(),
                                  [&](const model::EffectSpec& e) { return e.name == "thermal_periodic" || e.name == "aberration"; }),
                   sc.effects.end());
  return sc;
}

/// The short calibration scenario (5-deg manoeuvres about each axis, 860 s) without its orbit-periodic
/// head deformation (over 860 s a constant the truth's constant term does not include), the aberration
/// either left out or in the data with its observer velocity for the estimator to remove, and the
/// accelerometer's 15 ms time offset estimated. Injected: 411-853" per head axis in the datum.
void shortSpanWithinTheBound(bool aberration_in_data, bool holes = false) {
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo_calibration_short.yaml", sc, &err)) << err;
  sc.effects.erase(std::remove_if(sc.effects.begin(), sc.effects.end(),
                                  [&](const model::EffectSpec& e) {
                                    return e.name == "thermal_periodic" || (!aberration_in_data && e.name == "aberration");
                                  }),
                   sc.effects.end());
  sim::Simulator simu;
  ASSERT_TRUE(simu.init(sc, 1, 860, &err)) << err;
  RawBoundOptions opt;
  opt.scale = true;
  opt.time_offset = true;
  const RawBoundConfig cfg = rawBoundConfig(simu.heads(), simu.accel(), opt);
  RawBoundResult at_truth;
  const RawData recorded = runWithBound(simu, cfg, aberration_in_data, at_truth);
  RawData data = recorded;
  if (holes) {
    // Holes, never bridged: every head out for 12 samples (6 s) at each of the first manoeuvre's twelve
    // angular-acceleration peaks (60 s + 10 s + 20 s k, 72 s in all, 8 % of the span), the
    // accelerometer out for 4 s at a peak of the second, head 1 out for 2 minutes, the accelerometer's
    // first 5 s missing (the span starts with heads only), and a minute with no data at all (a
    // telemetry outage: heads and accelerometer, 500-560 s).
    const auto outage = [](double t) { return t >= 500.0 && t < 560.0; };
    const auto acc_out = [&](const RawData::Acc& e) { return outage(e.t_s) || e.t_s < 5.0 || (e.t_s >= 448.0 && e.t_s < 452.0); };
    const auto head_out = [&](const RawData::Head& e) {
      if (outage(e.t_s)) return true;
      for (int k = 0; k < 12; ++k) {
        const double c = 70.0 + 20.0 * k;
        if (e.t_s >= c - 3.0 && e.t_s < c + 3.0) return true;
      }
      return e.head == 0 && e.t_s >= 600.0 && e.t_s < 720.0;
    };
    data.acc.erase(std::remove_if(data.acc.begin(), data.acc.end(), acc_out), data.acc.end());
    data.heads.erase(std::remove_if(data.heads.begin(), data.heads.end(), head_out), data.heads.end());
  }
  const RawEstimate est = estimateRaw(cfg, data, simu.accel().config().bias_rad_s2, 2);
  if (holes) {
    // Against the same span without them. The holes sit where the information is (the peaks), so the
    // sigmas grow (never shrink) and the estimate moves; for nested efficient estimates the change has
    // variance sigma_holes^2 - sigma_full^2: it must be consistent with that, not invented by a bridge.
    const RawEstimate full = estimateRaw(cfg, recorded, simu.accel().config().bias_rad_s2, 2);
    EXPECT_GE(est.bound.acc_gaps, 3u);  // the 4 s gap, the outage and the 5 s start are counted
    double worst_sigma = 0, worst_z = 0;
    for (std::size_t i = 0; i < simu.heads().size(); ++i) {
      const Vec3 d = cfg.heads[i].axes_Si * (est.mounting_rad[i] - full.mounting_rad[i]);
      for (int j = 0; j < 3; ++j) {
        const double sh = est.bound.head_sigma_rad[i](j), sf = full.bound.head_sigma_rad[i](j);
        EXPECT_GE(sh, sf) << "head " << i << " axis " << j;
        worst_sigma = std::max(worst_sigma, std::abs(d(j)) / sh);
        worst_z = std::max(worst_z, std::abs(d(j)) / std::sqrt(std::max(sh * sh - sf * sf, 1e-6 * sh * sh)));
      }
    }
    std::printf("largest change against the span without holes: %.2f sigma, %.2f of its own sd\n", worst_sigma, worst_z);
    EXPECT_LT(worst_z, 4.0);
  }
  EXPECT_EQ(est.passes, 2);
  EXPECT_LT(est.head_samples_rejected, 5u);
  EXPECT_NEAR(est.chi2_per_obs, 1.0, 0.1);  // the residuals fit the noise model
  EXPECT_NEAR(est.time_offset_s, 0.015, 0.001);
  std::printf("chi2 per observation %.3f, rejected %llu\n", est.chi2_per_obs, static_cast<unsigned long long>(est.head_samples_rejected));
  for (std::size_t i = 0; i < simu.heads().size(); ++i) {
    const auto& h = simu.heads()[i];
    const Vec3 e = cfg.heads[i].axes_Si * (est.mounting_rad[i] - trueErrorInDatum(h, simu.accel()));
    for (int j = 0; j < 3; ++j) {
      const double s_est = est.bound.head_sigma_rad[i](j), s_truth = at_truth.head_sigma_rad[i](j);
      std::printf("head %d axis %d: error %7.2f\"  sigma %5.2f\" (bound at truth %5.2f\")  z %+.2f\n", h.config().id, j,
                  e(j) / kRadPerArcsec, s_est / kRadPerArcsec, s_truth / kRadPerArcsec, e(j) / s_est);
      EXPECT_LT(std::abs(e(j)), 4 * s_est) << "head " << h.config().id << " axis " << j;
      // The bound at the truth saw every sample; with holes the sigma may only be larger.
      if (holes) EXPECT_GE(s_est / s_truth, 0.95) << "head " << h.config().id << " axis " << j;
      else EXPECT_NEAR(s_est / s_truth, 1.0, 0.2) << "head " << h.config().id << " axis " << j;
    }
  }
  // The relative alignment (head i against head 1, head i's axes), known to some 0.1" from the heads
  // alone: where an unmodelled effect shows first (the aberration differs between heads by arcseconds).
  const auto headError = [&](std::size_t i) {
    return Vec3(cfg.heads[i].axes_Si * (est.mounting_rad[i] - trueErrorInDatum(simu.heads()[i], simu.accel())));
  };
  const Vec3 d1 = headError(0);
  for (std::size_t i = 1; i < simu.heads().size(); ++i) {
    const Vec3 rel = headError(i) - cfg.heads[i].R_axes_B * cfg.heads[0].R_axes_B.transpose() * d1;
    for (int j = 0; j < 3; ++j) {
      const double s = est.bound.relative_sigma_rad[i](j);
      std::printf("relative head %d axis %d: error %6.3f\"  sigma %5.3f\"\n", simu.heads()[i].config().id, j, rel(j) / kRadPerArcsec,
                  s / kRadPerArcsec);
      EXPECT_LT(std::abs(rel(j)), 4 * s) << "relative, head " << simu.heads()[i].config().id << " axis " << j;
    }
  }
}

TEST(RawEstimator, ShortSpanRecoversTheMountingsWithinTheBoundsSigmas) { shortSpanWithinTheBound(false); }

TEST(RawEstimator, AberrationRemovedWithTheObserverVelocityLeavesTheSameAccuracy) { shortSpanWithinTheBound(true); }

TEST(RawEstimator, GapsAtTheAccelerationPeaksAndDropoutsAreHolesNotErrors) { shortSpanWithinTheBound(true, true); }

/// The short calibration span (white noise as simulated), the estimator told a wrong white level: head 2
/// cross-boresight 2x the truth, head 3 about the boresight 0.5x. The variance components of the second
/// pass find the factors (1/4 and 4) from the data, the third pass applies them: the sigmas come back to
/// the bound at the truth and chi-square per degree of freedom to 1. Without them the sigmas stay off by
/// the told factor (the test's own control). The score blocks' covariance (60 s blocks) agrees with
/// the model's when the model is right
/// (20 s blocks: the sandwich needs blocks well beyond the parameters' count).
TEST(RawEstimator, VarianceComponentsTakeTheNoiseLevelsFromTheData) {
  sim::Scenario sc = shortScenarioInsideTheModel();
  std::string err;
  sim::Simulator simu;
  ASSERT_TRUE(simu.init(sc, 2, 860, &err)) << err;
  RawBoundOptions opt;
  opt.score_block_s = 20;  // 43 blocks for 16 parameters
  opt.scale = true;
  opt.time_offset = true;  // the scenario's accelerometer tags are 15 ms late
  const RawBoundConfig cfg = rawBoundConfig(simu.heads(), simu.accel(), opt);
  RawBoundResult at_truth;
  const RawData recorded = runWithBound(simu, cfg, false, at_truth);
  RawBoundConfig told = cfg;
  for (int j = 0; j < 2; ++j) told.heads[1].noise[static_cast<std::size_t>(j)] = model::NoiseModel::white(2 * std::sqrt(cfg.heads[1].noise[0].whiteVariance()));
  told.heads[2].noise[2] = model::NoiseModel::white(0.5 * std::sqrt(cfg.heads[2].noise[2].whiteVariance()));
  const Vec3 bias0 = simu.accel().config().bias_rad_s2;
  const RawEstimate est = estimateRaw(told, recorded, bias0, 3);
  RawBoundConfig told_no_vce = told;
  told_no_vce.options.variance_components = false;
  const RawEstimate fixed = estimateRaw(told_no_vce, recorded, bias0, 3);
  const RawEstimate right = estimateRaw(cfg, recorded, bias0, 2);
  ASSERT_EQ(est.variance_factor.size(), 3u);
  std::printf("variance factors applied: head 2 cross %.3f (expected 0.25), head 3 about %.3f (expected 4), head 1 %.3f/%.3f\n",
              est.variance_factor[1][0], est.variance_factor[2][1], est.variance_factor[0][0], est.variance_factor[0][1]);
  // A variance from n samples scatters by sqrt(2 / n) (n > 1000 per group here); 15 % allows the
  // estimate's own redundancy approximation.
  EXPECT_NEAR(est.variance_factor[1][0] / 0.25, 1.0, 0.15);
  EXPECT_NEAR(est.variance_factor[2][1] / 4.0, 1.0, 0.15);
  EXPECT_NEAR(est.variance_factor[0][0], 1.0, 0.15);
  EXPECT_NEAR(est.variance_factor[0][1], 1.0, 0.15);
  for (std::size_t i = 0; i < 3; ++i)
    for (int g = 0; g < 2; ++g) {
      EXPECT_NEAR(est.chi2_per_dof[i][static_cast<std::size_t>(g)], 1.0, 0.1) << "head " << i << " group " << g;
      EXPECT_EQ(fixed.variance_factor[i][static_cast<std::size_t>(g)], 1.0);
    }
  EXPECT_NEAR(fixed.chi2_per_dof[1][0], 0.25, 0.05);  // what the data say about the told level, unapplied
  double worst = 0, worst_fixed = 0, ratio_robust = 0;
  for (std::size_t i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double b = at_truth.head_sigma_rad[i](j);
      worst = std::max(worst, std::abs(std::log(est.bound.head_sigma_rad[i](j) / b)));
      worst_fixed = std::max(worst_fixed, std::abs(std::log(fixed.bound.head_sigma_rad[i](j) / b)));
      ratio_robust += right.robust_head_sigma_rad[i](j) / right.bound.head_sigma_rad[i](j) / 9;
    }
  std::printf("largest sigma / bound: %.3f with the variance components, %.3f without; score blocks over model %.3f (%zu blocks)\n",
              std::exp(worst), std::exp(worst_fixed), ratio_robust, right.score_blocks);
  EXPECT_LT(worst, std::log(1.25));
  EXPECT_GT(worst_fixed, std::log(1.25));
  EXPECT_GE(right.score_blocks, 40u);
  EXPECT_NEAR(ratio_robust, 1.0, 0.3);
}

/// The noise fits of the third pass run one per head axis on options.threads threads: the estimate is
/// the one-thread estimate to the bit (each fit the same arithmetic whichever thread runs it), and the
/// fitted models are the same.
TEST(RawEstimator, TheNoiseFitsOnTwoThreadsGiveTheOneThreadEstimateToTheBit) {
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo_calibration_short.yaml", sc, &err)) << err;
  sim::Simulator simu;
  ASSERT_TRUE(simu.init(sc, 3, 860, &err)) << err;
  RawBoundOptions opt;
  opt.fit_noise = true;
  opt.time_offset = true;
  const RawBoundConfig one = rawBoundConfig(simu.heads(), simu.accel(), opt);
  RawBoundResult at_truth;
  const RawData recorded = runWithBound(simu, one, false, at_truth);
  RawBoundConfig two = one;
  two.options.threads = 2;
  const Vec3 bias0 = simu.accel().config().bias_rad_s2;
  const RawEstimate a = estimateRaw(one, recorded, bias0, 3), b = estimateRaw(two, recorded, bias0, 3);
  ASSERT_EQ(a.fitted_noise.size(), 3u);
  ASSERT_EQ(b.fitted_noise.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(a.mounting_rad[i], b.mounting_rad[i]) << "head " << i;
    EXPECT_EQ(a.bound.head_sigma_rad[i], b.bound.head_sigma_rad[i]) << "head " << i;
    for (std::size_t j = 0; j < 3; ++j) EXPECT_EQ(a.fitted_noise[i][j].describe(), b.fitted_noise[i][j].describe()) << i << " " << j;
  }
  EXPECT_EQ(a.time_offset_s, b.time_offset_s);
  EXPECT_EQ(a.chi2_per_obs, b.chi2_per_obs);
}

/// The noise fit must see the noise, not what the model in use leaves of it: the short span with a
/// coloured head error (power law f^-1 between 5 mHz and 50 mHz, 6" per cross axis, 30" about the
/// boresight), the estimator told that very model. Fitted to the innovations, the colour the filter
/// already took out of them was found white, and the third pass then used white noise alone (on a
/// realistic day: NEES per degree of freedom 3000 instead of 3). Fitted to the data less the trajectory's
/// prediction, every head axis keeps most of its coloured variance.
TEST(RawEstimator, TheNoiseFitSeesTheColourTheModelInUseAlreadyHas) {
  sim::Scenario sc = shortScenarioInsideTheModel();
  std::string err;
  ASSERT_TRUE(sim::addEffectArgs(sc, {"coloured_noise:sensor=all,cross_arcsec=6,about_arcsec=30,alpha=1,f_lo_hz=0.005,f_hi_hz=0.05"}, &err))
      << err;
  sim::Simulator simu;
  ASSERT_TRUE(simu.init(sc, 4, 860, &err)) << err;
  RawBoundOptions opt;
  opt.fit_noise = true;
  opt.time_offset = true;
  const RawBoundConfig cfg = rawBoundConfig(simu.heads(), simu.accel(), opt);
  RawBoundResult at_truth;
  const RawData recorded = runWithBound(simu, cfg, false, at_truth);
  const RawEstimate est = estimateRaw(cfg, recorded, simu.accel().config().bias_rad_s2, 3);
  ASSERT_EQ(est.fitted_noise.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t j = 0; j < 3; ++j) {
      const model::NoiseModel& told = cfg.heads[i].noise[j];
      const model::NoiseModel& fit = est.fitted_noise[i][j];
      const double told_colour = told.variance() - told.whiteVariance(), fit_colour = fit.variance() - fit.whiteVariance();
      std::printf("head %zu axis %zu: told %s, fitted %s\n", i + 1, j, told.describe(1 / kRadPerArcsec, "\"").c_str(),
                  fit.describe(1 / kRadPerArcsec, "\"").c_str());
      ASSERT_GT(told_colour, 0.0);
      EXPECT_GT(fit_colour, 0.3 * told_colour) << "head " << i + 1 << " axis " << j;
    }
}

// Noise slower than the span resolves cannot be fitted: the data cannot tell it from a constant mounting
// error. Stated in the model given to the estimator, it stays beside the fitted model and widens each
// head axis's sigma as a constant error of that size would (tau 1e5 s over 860 s: a constant).
TEST(RawEstimator, NoiseTooSlowForTheSpanIsKeptFromTheStatedModel) {
  sim::Scenario sc = shortScenarioInsideTheModel();
  std::string err;
  sim::Simulator simu;
  ASSERT_TRUE(simu.init(sc, 4, 860, &err)) << err;
  RawBoundOptions opt;
  opt.fit_noise = true;
  RawBoundConfig cfg = rawBoundConfig(simu.heads(), simu.accel(), opt);
  RawBoundResult at_truth;
  const RawData recorded = runWithBound(simu, cfg, false, at_truth);
  const double slow = 2 * kRadPerArcsec, tau = 1e5;
  for (auto& h : cfg.heads)
    for (auto& m : h.noise) m.add(model::NoiseTerm::gaussMarkov(slow, tau));
  const RawEstimate kept = estimateRaw(cfg, recorded, simu.accel().config().bias_rad_s2, 3);
  cfg.options.keep_slow_noise = false;
  const RawEstimate dropped = estimateRaw(cfg, recorded, simu.accel().config().bias_rad_s2, 3);
  ASSERT_EQ(kept.fitted_noise.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t j = 0; j < 3; ++j) {
      const auto has_slow = [&](const model::NoiseModel& m) {
        for (const auto& t : m.terms)
          if (t.kind == model::NoiseKind::GaussMarkov && t.tau_s == tau && std::abs(t.sigma - slow) < 1e-12) return true;
        return false;
      };
      EXPECT_TRUE(has_slow(kept.fitted_noise[i][j])) << "head " << i + 1 << " axis " << j;
      EXPECT_FALSE(has_slow(dropped.fitted_noise[i][j])) << "head " << i + 1 << " axis " << j;
      const double sk = kept.bound.head_sigma_rad[i](static_cast<Eigen::Index>(j));
      const double sd = dropped.bound.head_sigma_rad[i](static_cast<Eigen::Index>(j));
      const double added = std::sqrt(std::max(sk * sk - sd * sd, 0.0));
      std::printf("head %zu axis %zu: sigma %.2f\" kept, %.2f\" dropped: %.2f\" added in quadrature\n", i + 1, j,
                  sk / kRadPerArcsec, sd / kRadPerArcsec, added / kRadPerArcsec);
      EXPECT_NEAR(added, slow, 0.25 * slow) << "head " << i + 1 << " axis " << j;
    }
}

TEST(RawBound, RefusesAConfigurationWithoutWhiteNoise) {
  RawBoundConfig c = oneHead(model::NoiseModel::white(1e-5), model::NoiseModel::white(1e-8));
  EXPECT_EQ(c.validate(), "");
  c.heads[0].noise[1] = model::NoiseModel();
  c.heads[0].noise[1].add(model::NoiseTerm::gaussMarkov(1e-5, 10));
  EXPECT_NE(c.validate().find("no white noise"), std::string::npos);
  c = oneHead(model::NoiseModel::white(1e-5), model::NoiseModel::white(1e-8));
  c.options.harmonics = 2;
  EXPECT_NE(c.validate().find("orbit rate"), std::string::npos);
}

}  // namespace
}  // namespace boresight::calib

namespace boresight::calib {
namespace {

/// Sum over seeds of the mountings' NEES (9 head axes per seed) on 3 h of the calibration day with one
/// manoeuvre about z alone, scale and time offset estimated; and the names the estimates held.
std::pair<double, std::vector<std::string>> zOnlyNees(double scale_hold_sigma, const std::vector<std::uint64_t>& seeds) {
  sim::Scenario sc;
  std::string err;
  EXPECT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo_calibration.yaml", sc, &err)) << err;
  sc.effects.erase(std::remove_if(sc.effects.begin(), sc.effects.end(),
                                  [&](const model::EffectSpec& e) { return e.name == "thermal_periodic" || e.name == "aberration"; }),
                   sc.effects.end());
  sim::Manoeuvre z;
  z.amplitude_rad = Vec3(0, 0, 1.0 * kRadPerDeg);
  z.period_s = 100;
  z.start_s = 1800;
  z.duration_s = 1000;
  sc.attitude.manoeuvres = {z};
  double nees = 0;
  std::vector<std::string> held;
  for (const std::uint64_t seed : seeds) {
    sim::Simulator simu;
    EXPECT_TRUE(simu.init(sc, seed, 10800, &err)) << err;
    RawBoundOptions opt;
    opt.scale = opt.time_offset = true;
    opt.scale_hold_sigma = scale_hold_sigma;
    const RawBoundConfig cfg = rawBoundConfig(simu.heads(), simu.accel(), opt);
    RawBoundResult at_truth;
    const RawData data = runWithBound(simu, cfg, false, at_truth);
    const RawEstimate est = estimateRaw(cfg, data, simu.accel().config().bias_rad_s2, 3);
    Eigen::VectorXd e(9);
    for (std::size_t i = 0; i < 3; ++i)
      e.segment<3>(static_cast<Eigen::Index>(3 * i)) = cfg.heads[i].axes_Si * (est.mounting_rad[i] - trueErrorInDatum(simu.heads()[i], simu.accel()));
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(est.bound.covariance.topLeftCorner(9, 9));
    double n = 0;
    for (Eigen::Index k = 0; k < 9; ++k)
      if (es.eigenvalues()(k) > 1e-12 * es.eigenvalues().maxCoeff()) n += std::pow(es.eigenvectors().col(k).dot(e), 2) / es.eigenvalues()(k);
    std::printf("seed %llu, scale_hold_sigma %g: NEES %.1f (9 dof), scale (%.4f, %.4f, %.4f), held:", static_cast<unsigned long long>(seed),
                scale_hold_sigma, n, est.scale.x(), est.scale.y(), est.scale.z());
    for (const auto& h : est.bound.held) std::printf(" %s", h.c_str());
    std::printf("\n");
    nees += n;
    held = est.bound.held;
  }
  return {nees, held};
}

TEST(RawEstimator, AScaleFactorTheSpanDoesNotDetermineIsHeldNotFollowedAway) {
  // One manoeuvre about z in 3 h: the accelerometer axes without angular acceleration say nothing about
  // their scale. Held (the default), the mountings' NEES over three seeds stays inside chi-square's
  // 99.9 % point for 27 degrees of freedom; followed where the noise takes them (14 % seen), the
  // linearisation there puts the mountings several sigma off and the same NEES is far beyond it.
  const std::vector<std::uint64_t> seeds = {10, 11, 12};
  const double limit = model::stats::chi2Quantile(0.001, 27.0);
  const auto [held_nees, held] = zOnlyNees(1e-2, seeds);
  EXPECT_LT(held_nees, limit);
  EXPECT_FALSE(held.empty());
  for (const auto& h : held) EXPECT_EQ(h.rfind("acc_scale.", 0), 0u) << h;
  const auto [free_nees, none] = zOnlyNees(std::numeric_limits<double>::infinity(), seeds);
  EXPECT_TRUE(none.empty());
  EXPECT_GT(free_nees, limit) << "the control: without the hold the scale factors wander";
}

}  // namespace
}  // namespace boresight::calib

// Each effect switched on alone changes what it should and nothing else.
//
// Every test runs the GRACE-FO scenario twice with the same seed, without and with one effect. The
// random streams are counter-based (model/random.h), so unaffected sensors must be BIT-identical and
// the affected sensor must differ exactly by the effect's model.
#include "sim_test_util.h"

#include <boresight/model/ephemeris.h>

#include <algorithm>
#include <numeric>
#include <set>

namespace boresight {
namespace {

using simtest::Capture;
using simtest::gracefo;
using simtest::run;
using simtest::withEffects;

constexpr std::uint64_t kSeed = 42;

/// Heads not in `changed` and (unless acc_changed) the accelerometer are bit-identical.
void expectUnchangedExcept(const Capture& a, const Capture& b, const std::vector<int>& changed, bool acc_changed) {
  for (int id : {1, 2, 3}) {
    if (std::find(changed.begin(), changed.end(), id) != changed.end()) continue;
    const auto ha = a.head(id), hb = b.head(id);
    ASSERT_EQ(ha.size(), hb.size()) << "head " << id;
    for (std::size_t i = 0; i < ha.size(); ++i) {
      ASSERT_EQ(ha[i].tag, hb[i].tag) << "head " << id;
      ASSERT_TRUE(simtest::sameQuat(ha[i].q_I_Si, hb[i].q_I_Si)) << "head " << id << " sample " << i;
      ASSERT_EQ(ha[i].nstars, hb[i].nstars);
    }
  }
  if (!acc_changed) {
    ASSERT_EQ(a.acc.size(), b.acc.size());
    for (std::size_t i = 0; i < a.acc.size(); ++i) {
      ASSERT_EQ(a.acc[i].tag, b.acc[i].tag);
      ASSERT_EQ(a.acc[i].ang_A, b.acc[i].ang_A) << "acc sample " << i;
    }
  }
  ASSERT_EQ(a.orb.size(), b.orb.size());
}

TEST(SimEffects, CleanRunIsDeterministicAndSeedMatters) {
  const auto sc = gracefo();
  auto a = run(sc, kSeed, 300), b = run(sc, kSeed, 300), c = run(sc, kSeed + 1, 300);
  expectUnchangedExcept(a->cap, b->cap, {}, false);
  ASSERT_FALSE(a->cap.head(1).empty());
  EXPECT_FALSE(simtest::sameQuat(a->cap.head(1)[5].q_I_Si, c->cap.head(1)[5].q_I_Si));
}

TEST(SimEffects, RelativeMisalignmentRotatesOneHeadByTheConfiguredAngles) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 600);
  auto eff = run(withEffects(sc, {"relative_misalignment:sensor=2,x_arcsec=30,y_arcsec=-20,z_arcsec=10"}), kSeed, 600);
  expectUnchangedExcept(base->cap, eff->cap, {2}, false);
  const auto a = base->cap.head(2), b = eff->cap.head(2);
  ASSERT_EQ(a.size(), b.size());
  // q_meas' = q_I_B q_Si_B^-1 Exp(-phi) Exp(n): the head-frame difference is -phi (noise-conjugated).
  const Vec3 phi = Vec3(30, -20, 10) * kRadPerArcsec;
  for (std::size_t i = 0; i < a.size(); i += 37) {
    const Vec3 d = simtest::rotBetween(a[i].q_I_Si, b[i].q_I_Si);
    EXPECT_LT((d + phi).norm() * kArcsecPerRad, 0.05) << i;
  }
}

TEST(SimEffects, ThermalPeriodicMovesInterBoresightAnglesAtTheConfiguredHarmonicOnly) {
  const auto sc = gracefo();
  const double orbit_s = 5700;
  auto base = run(sc, kSeed, orbit_s);
  auto eff = run(withEffects(sc, {"thermal_periodic:sensor=2,harmonic=2,x_arcsec=8,y_arcsec=-6,z_arcsec=20,phase_deg=30"}),
                 kSeed, orbit_s);
  expectUnchangedExcept(base->cap, eff->cap, {2}, false);
  // Inter-boresight angle 1-2 at common epochs (equal tags); difference effect - baseline.
  const auto b1 = base->cap.head(1), b2 = base->cap.head(2), e1 = eff->cap.head(1), e2 = eff->cap.head(2);
  std::map<TimeUs, Quat> mb2, me2;
  for (const auto& s : b2) mb2[s.tag] = s.q_I_Si;
  for (const auto& s : e2) me2[s.tag] = s.q_I_Si;
  std::vector<double> u, d_iba, d_iba13;
  for (std::size_t i = 0; i < b1.size(); ++i) {
    auto ib = mb2.find(b1[i].tag), ie = me2.find(e1[i].tag);
    if (ib == mb2.end() || ie == me2.end()) continue;
    u.push_back(eff->sim.context(b1[i].t_true_s).arg_lat_rad);
    d_iba.push_back((simtest::iba(e1[i].q_I_Si, ie->second) - simtest::iba(b1[i].q_I_Si, ib->second)) * kArcsecPerRad);
  }
  ASSERT_GT(u.size(), 5000u);
  const auto amp = simtest::harmonicAmplitudes(u, d_iba, 5);
  // Expected amplitude: dIBA = -(b x b1_S2) . phi / sin(IBA) ... computed here from the true mountings.
  const auto& h1 = eff->sim.heads()[0];
  const auto& h2 = eff->sim.heads()[1];
  const Vec3 b = Vec3::UnitZ();
  const Vec3 b1_S2 = (h2.qSiBTrue() * h1.qSiBTrue().conjugate()) * b;  // head 1 boresight in S2
  const double alpha = std::atan2(b.cross(b1_S2).norm(), b.dot(b1_S2));
  const Vec3 g = b.cross(b1_S2) / std::sin(alpha);  // dIBA/dphi (head-frame rotation of head 2, sign aside)
  const double expected = std::abs(g.dot(Vec3(8, -6, 20)));
  std::printf("thermal_periodic n=2: IBA 1-2 harmonic amplitudes [arcsec]:");
  for (double x : amp) std::printf(" %.4f", x);
  std::printf("  (expected %.4f at n=2)\n", expected);
  EXPECT_NEAR(amp[2], expected, 0.02 * expected + 0.01);
  for (int k : {0, 1, 3, 4, 5}) EXPECT_LT(amp[static_cast<std::size_t>(k)], 0.01 * expected + 0.005) << "harmonic " << k;
}

TEST(SimEffects, ThermalAmplitudeFollowsBetaAngleModulation) {
  // beta_gain scales the amplitude by 1 + g (cos(beta) - cos(beta_ref)); check via the model directly.
  model::HeadEffects e = model::headEffectsFor(
      {[] {
        model::EffectSpec s;
        std::string err;
        EXPECT_TRUE(model::parseEffectArg("thermal_periodic:sensor=1,x_arcsec=10,beta_gain=0.5,beta_ref_deg=60", s, &err)) << err;
        return s;
      }()},
      1);
  model::OrbitContext c;
  c.arg_lat_rad = 0;
  c.beta_rad = 60 * kRadPerDeg;
  EXPECT_NEAR(model::headSystematicRotVec(e, c).x() * kArcsecPerRad, 10.0, 1e-9);
  c.beta_rad = 0;
  EXPECT_NEAR(model::headSystematicRotVec(e, c).x() * kArcsecPerRad, 10.0 * (1 + 0.5 * (1 - 0.5)), 1e-9);
}

TEST(SimEffects, DriftGrowsLinearlyAndStepJumpsOnce) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 1200);
  auto drift = run(withEffects(sc, {"drift:sensor=3,z_arcsec_per_day=8640,start_s=200"}), kSeed, 1200);
  auto step = run(withEffects(sc, {"step:sensor=1,x_arcsec=15,at_s=500"}), kSeed, 1200);
  expectUnchangedExcept(base->cap, drift->cap, {3}, false);
  expectUnchangedExcept(base->cap, step->cap, {1}, false);
  const auto a3 = base->cap.head(3), d3 = drift->cap.head(3);
  ASSERT_EQ(a3.size(), d3.size());
  for (std::size_t i = 0; i < a3.size(); i += 53) {
    const double t = a3[i].t_true_s;
    const double expect = t > 200 ? 0.1 * (t - 200) : 0.0;  // 8640"/day = 0.1"/s
    EXPECT_NEAR(-simtest::rotBetween(a3[i].q_I_Si, d3[i].q_I_Si).z() * kArcsecPerRad, expect, 0.05) << t;
  }
  const auto a1 = base->cap.head(1), s1 = step->cap.head(1);
  ASSERT_EQ(a1.size(), s1.size());
  for (std::size_t i = 0; i < a1.size(); i += 41) {
    const double expect = a1[i].t_true_s >= 500 ? 15.0 : 0.0;
    EXPECT_NEAR(-simtest::rotBetween(a1[i].q_I_Si, s1[i].q_I_Si).x() * kArcsecPerRad, expect, 0.05);
  }
}

TEST(SimEffects, AnisotropicNoiseChangesOnlyTheNoiseAboutTheBoresight) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 900);
  auto eff = run(withEffects(sc, {"anisotropic_noise:sensor=1,about_arcsec=120"}), kSeed, 900);
  expectUnchangedExcept(base->cap, eff->cap, {1}, false);
  const auto a = base->cap.head(1), b = eff->cap.head(1);
  ASSERT_EQ(a.size(), b.size());
  double sa = 0, sb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Vec3 ra = simtest::rotBetween(a[i].q_I_Si_expected, a[i].q_I_Si);
    const Vec3 rb = simtest::rotBetween(b[i].q_I_Si_expected, b[i].q_I_Si);
    // Cross-boresight noise identical, about-boresight noise scaled by 120/48.
    EXPECT_NEAR(ra.x(), rb.x(), 1e-3 * kRadPerArcsec);
    EXPECT_NEAR(ra.y(), rb.y(), 1e-3 * kRadPerArcsec);
    EXPECT_NEAR(rb.z(), ra.z() * 120.0 / 48.0, 1e-3 * kRadPerArcsec);
    sa += ra.z() * ra.z();
    sb += rb.z() * rb.z();
  }
  EXPECT_NEAR(std::sqrt(sb / sa), 2.5, 1e-3);
}

TEST(SimEffects, HeadTimeOffsetShiftsTheTruthBehindTheTags) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 300);
  auto eff = run(withEffects(sc, {"time_offset:sensor=2,offset_ms=120"}), kSeed, 300);
  expectUnchangedExcept(base->cap, eff->cap, {2}, false);
  const auto a = base->cap.head(2), b = eff->cap.head(2);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].tag, b[i].tag);
    EXPECT_NEAR(a[i].t_true_s - b[i].t_true_s, 0.120, 1e-9);
  }
}

/// Star-sensor angular acceleration (body frame, from head 1 via its true mounting) vs the
/// accelerometer's (rotated to B): the lag of the cross-correlation peak, seconds.
double crossCorrelationLag(const simtest::Run& r) {
  const auto h = r.cap.head(1);
  const Quat q_S_B = r.sim.heads()[0].qSiBTrue();
  const double dt = 0.5;
  std::vector<double> t;
  std::vector<Vec3> a_star;
  for (std::size_t k = 1; k + 1 < h.size(); ++k) {
    const double d1 = toSeconds(h[k].tag - h[k - 1].tag), d2 = toSeconds(h[k + 1].tag - h[k].tag);
    if (std::abs(d1 - dt) > 1e-3 || std::abs(d2 - dt) > 1e-3) continue;  // skip across gaps
    const Quat q0 = h[k - 1].q_I_Si * q_S_B, q1 = h[k].q_I_Si * q_S_B, q2 = h[k + 1].q_I_Si * q_S_B;
    const Vec3 w01 = model::quatLog(q0.conjugate() * q1) / d1, w12 = model::quatLog(q1.conjugate() * q2) / d2;
    t.push_back(toSeconds(h[k].tag));
    a_star.push_back((w12 - w01) / (0.5 * (d1 + d2)));
  }
  const Mat3 C_B_A = r.sim.accel().config().C_A_B.transpose();
  const Vec3 bias = r.sim.accel().config().bias_rad_s2;
  std::vector<double> ta;
  std::vector<Vec3> a_acc;
  for (const auto& s : r.cap.acc) {
    ta.push_back(toSeconds(s.tag));
    a_acc.push_back(C_B_A * (s.ang_A - bias));
  }
  auto interp = [&](double x) -> Vec3 {
    auto it = std::upper_bound(ta.begin(), ta.end(), x);
    if (it == ta.begin() || it == ta.end()) return Vec3::Zero();
    const std::size_t j = static_cast<std::size_t>(it - ta.begin());
    const double f = (x - ta[j - 1]) / (ta[j] - ta[j - 1]);
    return (1 - f) * a_acc[j - 1] + f * a_acc[j];
  };
  // Correlation on a lag grid; the peak of a band-limited signal is broad (and linear interpolation
  // of the 10 Hz series adds small kinks), so the peak is the vertex of a least-squares parabola
  // over +-0.5 s around the grid maximum.
  const double step = 0.01;
  std::vector<double> lags, cc;
  for (int i = -200; i <= 200; ++i) {
    const double lag = i * step;
    double c = 0;
    for (std::size_t k = 10; k + 10 < t.size(); ++k) c += a_star[k].dot(interp(t[k] + lag));
    lags.push_back(lag);
    cc.push_back(c);
  }
  const auto imax = static_cast<std::size_t>(std::max_element(cc.begin(), cc.end()) - cc.begin());
  Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < lags.size(); ++i) {
    const double x = lags[i] - lags[imax];
    if (std::abs(x) > 0.5 + 1e-9) continue;
    const Eigen::Vector3d f(1, x, x * x);
    N += f * f.transpose();
    rhs += f * cc[i];
  }
  const Eigen::Vector3d p = N.ldlt().solve(rhs);
  double best_lag = lags[imax] - p(1) / (2 * p(2));
  return best_lag;
}

TEST(SimEffects, AccTimeOffsetMovesTheStarSensorAccelerometerCrossCorrelationPeak) {
  auto sc = gracefo();
  // Calibration manoeuvres at two periods give a strong, broadband angular acceleration, and the
  // heads are made quiet: the test is about the time tags, not about noise (a noisy version of this
  // comparison is the audit's job).
  sim::Manoeuvre m1, m2;
  m1.amplitude_rad = Vec3(0.2, 0.3, 0.4) * kRadPerDeg;
  m1.period_s = 40;
  m1.start_s = 20;
  m1.duration_s = 1160;
  m2.amplitude_rad = Vec3(0.05, 0.03, 0.04) * kRadPerDeg;
  m2.period_s = 9;
  m2.start_s = 20;
  m2.duration_s = 1160;
  sc.attitude.manoeuvres = {m1, m2};
  for (auto& h : sc.heads) {
    h.sigma_cross_rad = 0.1 * kRadPerArcsec;
    h.sigma_roll_rad = 0.8 * kRadPerArcsec;
  }
  auto base = run(sc, kSeed, 1200);
  auto eff = run(withEffects(sc, {"time_offset:sensor=acc,offset_ms=250"}), kSeed, 1200);
  expectUnchangedExcept(base->cap, eff->cap, {}, true);
  const double lag0 = crossCorrelationLag(*base), lag1 = crossCorrelationLag(*eff);
  std::printf("cross-correlation peak: clean %.4f s, with time_offset acc 250 ms %.4f s\n", lag0, lag1);
  EXPECT_NEAR(lag0, 0.0, 0.010);
  EXPECT_NEAR(lag1 - lag0, 0.250, 0.010);
}

TEST(SimEffects, AccBiasScaleMisalignmentFollowTheModel) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 300);
  auto bias = run(withEffects(sc, {"acc_bias:x=1e-6,y=-2e-6,z=3e-7"}), kSeed, 300);
  auto scale = run(withEffects(sc, {"acc_scale:x=0.01,y=-0.02,z=0.03"}), kSeed, 300);
  auto mis = run(withEffects(sc, {"acc_misalignment:x_arcsec=100,y_arcsec=-50,z_arcsec=200"}), kSeed, 300);
  for (const auto* r : {bias.get(), scale.get(), mis.get()}) expectUnchangedExcept(base->cap, r->cap, {1, 2, 3}, true);
  for (const auto* r : {bias.get(), scale.get(), mis.get()}) expectUnchangedExcept(base->cap, r->cap, {}, true);
  const Mat3 C = sc.acc.C_A_B;
  const Mat3 R = model::quatExp(Vec3(100, -50, 200) * kRadPerArcsec).toRotationMatrix();
  ASSERT_EQ(base->cap.acc.size(), bias->cap.acc.size());
  for (std::size_t i = 0; i < base->cap.acc.size(); i += 7) {
    const auto& a = base->cap.acc[i];
    EXPECT_LT((bias->cap.acc[i].ang_A - a.ang_A - Vec3(1e-6, -2e-6, 3e-7)).norm(), 1e-15);
    const Vec3 aA = C * a.a_B_true;
    EXPECT_LT((scale->cap.acc[i].ang_A - a.ang_A - Vec3(0.01, -0.02, 0.03).cwiseProduct(aA)).norm(), 1e-15);
    EXPECT_LT((mis->cap.acc[i].ang_A - a.ang_A - (R - Mat3::Identity()) * aA).norm(), 1e-15);
  }
}

TEST(SimEffects, AberrationDisplacesBoresightsByVelocityOverC) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 600);
  auto eff = run(withEffects(sc, {"aberration:sensor=all"}), kSeed, 600);
  expectUnchangedExcept(base->cap, eff->cap, {1, 2, 3}, false);
  const auto a = base->cap.head(1), b = eff->cap.head(1);
  ASSERT_EQ(a.size(), b.size());
  double max_shift = 0;
  for (std::size_t i = 0; i < a.size(); i += 31) {
    const auto ctx = eff->sim.context(a[i].t_true_s);
    const Vec3 v = ctx.v_earth_I + ctx.v_sat_I;
    const Vec3 ba = a[i].q_I_Si * Vec3::UnitZ(), bb = b[i].q_I_Si * Vec3::UnitZ();
    const Vec3 expected = (v - v.dot(ba) * ba) / model::kSpeedOfLight;  // towards the velocity
    EXPECT_LT((bb - ba - expected).norm() * kArcsecPerRad, 0.01);
    // No roll about the boresight.
    EXPECT_LT(std::abs(simtest::rotBetween(a[i].q_I_Si, b[i].q_I_Si).z()) * kArcsecPerRad, 0.01);
    max_shift = std::max(max_shift, (bb - ba).norm() * kArcsecPerRad);
  }
  EXPECT_GT(max_shift, 5.0);
  EXPECT_LT(max_shift, 26.0);  // 20.5" annual + 5.2" orbital at most
}

TEST(SimEffects, OutliersAndSignFlipsTouchOnlyTheirSamples) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 1800);
  auto out = run(withEffects(sc, {"outliers:sensor=3,rate=0.01,arcsec=500"}), kSeed, 1800);
  auto flip = run(withEffects(sc, {"sign_flips:sensor=1,rate=0.02"}), kSeed, 1800);
  expectUnchangedExcept(base->cap, out->cap, {3}, false);
  expectUnchangedExcept(base->cap, flip->cap, {1}, false);
  const auto a3 = base->cap.head(3), o3 = out->cap.head(3);
  ASSERT_EQ(a3.size(), o3.size());
  std::size_t n_out = 0;
  for (std::size_t i = 0; i < a3.size(); ++i) {
    const double ang = simtest::rotBetween(a3[i].q_I_Si, o3[i].q_I_Si).norm() * kArcsecPerRad;
    if (o3[i].outlier) {
      ++n_out;
      EXPECT_NEAR(ang, 500.0, 1.0);
    } else {
      EXPECT_TRUE(simtest::sameQuat(a3[i].q_I_Si, o3[i].q_I_Si));
    }
  }
  // Binomial: N p +- 5 sigma.
  const double np = 0.01 * static_cast<double>(a3.size());
  EXPECT_NEAR(static_cast<double>(n_out), np, 5 * std::sqrt(np));
  const auto a1 = base->cap.head(1), f1 = flip->cap.head(1);
  std::size_t n_flip = 0;
  for (std::size_t i = 0; i < a1.size(); ++i) {
    if (f1[i].sign_flipped) {
      ++n_flip;
      EXPECT_EQ(f1[i].q_I_Si.coeffs(), -a1[i].q_I_Si.coeffs());
    } else {
      EXPECT_TRUE(simtest::sameQuat(a1[i].q_I_Si, f1[i].q_I_Si));
    }
  }
  const double np1 = 0.02 * static_cast<double>(a1.size());
  EXPECT_NEAR(static_cast<double>(n_flip), np1, 5 * std::sqrt(np1));
}

TEST(SimEffects, GapsAndDropoutsRemoveSamplesAndNothingElse) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 3600);
  auto gap = run(withEffects(sc, {"gaps:sensor=acc,at_s=100,duration_s=50", "head_dropout:sensor=2,at_s=600,duration_s=300"}),
                 kSeed, 3600);
  expectUnchangedExcept(base->cap, gap->cap, {2}, true);
  std::map<TimeUs, Vec3> g;
  for (const auto& s : gap->cap.acc) g[s.tag] = s.ang_A;
  std::size_t missing = 0;
  for (const auto& s : base->cap.acc) {
    const double t = toSeconds(s.tag - sc.start);
    auto it = g.find(s.tag);
    if (t >= 100 && t < 150) {
      EXPECT_TRUE(it == g.end());
      ++missing;
    } else {
      ASSERT_TRUE(it != g.end()) << t;
      EXPECT_EQ(it->second, s.ang_A);
    }
  }
  EXPECT_EQ(missing, 500u);
  std::map<TimeUs, Quat> h2;
  for (const auto& s : gap->cap.head(2)) h2[s.tag] = s.q_I_Si;
  for (const auto& s : base->cap.head(2)) {
    const double t = toSeconds(s.tag - sc.start);
    const bool present = h2.count(s.tag) > 0;
    EXPECT_EQ(present, !(t >= 600 && t < 900)) << t;
    if (present) {
      EXPECT_TRUE(simtest::sameQuat(h2[s.tag], s.q_I_Si));
    }
  }
  // Random gaps: expected missing fraction per_day * mean_s / 86400 (here 48 * 60 / 86400 = 3.3 %).
  auto rnd = run(withEffects(sc, {"gaps:sensor=1,per_day=48,mean_s=60"}), kSeed, 86400.0 / 4);
  const auto& st = rnd->sim.stats();
  const double frac = static_cast<double>(st.head_missing[0]) /
                      static_cast<double>(st.head_missing[0] + st.head_samples[0] + st.head_blinded_sun[0] +
                                          st.head_blinded_earth[0] + st.head_blinded_moon[0]);
  std::printf("random gaps: missing fraction %.4f (expected about %.4f; 12 gaps expected in the span)\n", frac,
              48 * 60 / 86400.0);
  EXPECT_GT(frac, 0.003);
  EXPECT_LT(frac, 0.12);
  EXPECT_EQ(st.head_missing[1], 0u);
}

TEST(SimEffects, TwoDriftsOnOneHeadBothActWithTheirOwnStarts) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 600);
  auto two = run(withEffects(sc, {"drift:sensor=3,z_arcsec_per_day=8640,start_s=100",
                                  "drift:sensor=3,x_arcsec_per_day=17280,start_s=400"}), kSeed, 600);
  expectUnchangedExcept(base->cap, two->cap, {3}, false);
  const auto a = base->cap.head(3), b = two->cap.head(3);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); i += 29) {
    const double t = a[i].t_true_s;
    const Vec3 expect(t > 400 ? 0.2 * (t - 400) : 0.0, 0.0, t > 100 ? 0.1 * (t - 100) : 0.0);  // arcsec
    const Vec3 d = -simtest::rotBetween(a[i].q_I_Si, b[i].q_I_Si) * kArcsecPerRad;
    EXPECT_LT((d - expect).norm(), 0.05) << t;
  }
}

TEST(SimEffects, CrossNoiseChangesOnlyTheCrossBoresightNoise) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 600);
  auto eff = run(withEffects(sc, {"cross_noise:sensor=2,cross_arcsec=2.4"}), kSeed, 600);
  expectUnchangedExcept(base->cap, eff->cap, {2}, false);
  const auto a = base->cap.head(2), b = eff->cap.head(2);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Vec3 ra = simtest::rotBetween(a[i].q_I_Si_expected, a[i].q_I_Si);
    const Vec3 rb = simtest::rotBetween(b[i].q_I_Si_expected, b[i].q_I_Si);
    EXPECT_NEAR(rb.x(), ra.x() * 2.4 / 6.0, 1e-3 * kRadPerArcsec);
    EXPECT_NEAR(rb.y(), ra.y() * 2.4 / 6.0, 1e-3 * kRadPerArcsec);
    EXPECT_NEAR(rb.z(), ra.z(), 1e-3 * kRadPerArcsec);
  }
}

TEST(SimEffects, TimeOffsetAllShiftsEveryHeadAndNotTheAccelerometer) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 120);
  auto eff = run(withEffects(sc, {"time_offset:sensor=all,offset_ms=80"}), kSeed, 120);
  expectUnchangedExcept(base->cap, eff->cap, {1, 2, 3}, false);
  for (int id : {1, 2, 3}) {
    const auto a = base->cap.head(id), b = eff->cap.head(id);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i].t_true_s - b[i].t_true_s, 0.080, 1e-9);
  }
}

TEST(SimEffects, ClockDriftMakesTheTagErrorGrowAtItsRate) {
  const auto sc = gracefo();
  auto base = run(sc, kSeed, 300);
  auto eff = run(withEffects(sc, {"clock_drift:sensor=1,rate_ppm=500,offset_ms=10,start_s=100",
                                  "clock_drift:sensor=acc,rate_ppm=-800"}), kSeed, 300);
  expectUnchangedExcept(base->cap, eff->cap, {1}, true);
  const auto a = base->cap.head(1), b = eff->cap.head(1);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].tag, b[i].tag);  // the tags are the receiver's: unchanged
    const double t_true = b[i].t_true_s, t_tag = a[i].t_true_s;
    EXPECT_NEAR(t_tag - t_true, 0.010 + 500e-6 * (t_true - 100), 1e-9) << i;
  }
  ASSERT_EQ(base->cap.acc.size(), eff->cap.acc.size());
  for (std::size_t i = 0; i < base->cap.acc.size(); i += 11) {
    const double t_tag = base->cap.acc[i].t_true_s, t_true = eff->cap.acc[i].t_true_s;
    EXPECT_NEAR(t_tag - t_true, -800e-6 * t_true, 1e-6) << i;  // integer microseconds
  }
}

TEST(SimEffects, TwoOutlierSpecsAreTwoProcessesAndTheFirstIsUnchanged) {
  const auto sc = gracefo();
  auto one = run(withEffects(sc, {"outliers:sensor=2,rate=0.02,arcsec=300"}), kSeed, 900);
  auto two = run(withEffects(sc, {"outliers:sensor=2,rate=0.02,arcsec=300", "outliers:sensor=2,rate=0.05,arcsec=900"}), kSeed, 900);
  expectUnchangedExcept(one->cap, two->cap, {2}, false);
  const auto a = one->cap.head(2), b = two->cap.head(2);
  ASSERT_EQ(a.size(), b.size());
  std::size_t n1 = 0, n2 = 0, only_second = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    n1 += a[i].outlier;
    n2 += b[i].outlier;
    if (a[i].outlier) {
      EXPECT_TRUE(b[i].outlier) << i;
    } else if (b[i].outlier) {
      ++only_second;
      EXPECT_NEAR(simtest::rotBetween(a[i].q_I_Si, b[i].q_I_Si).norm() * kArcsecPerRad, 900.0, 1.0);
    } else {
      EXPECT_TRUE(simtest::sameQuat(a[i].q_I_Si, b[i].q_I_Si));
    }
  }
  const double N = static_cast<double>(a.size()), p2 = 1 - 0.98 * 0.95;
  EXPECT_NEAR(static_cast<double>(n1), 0.02 * N, 5 * std::sqrt(0.02 * N));
  EXPECT_NEAR(static_cast<double>(n2), p2 * N, 5 * std::sqrt(p2 * N));
  EXPECT_GT(only_second, 0u);
  EXPECT_EQ(two->sim.stats().head_outliers[1], n2);
}

TEST(SimEffects, ASecondGapOrFlipSpecAddsAProcessAndKeepsTheFirst) {
  const auto sc = gracefo();
  auto one = run(withEffects(sc, {"gaps:sensor=2,per_day=3000,mean_s=4", "sign_flips:sensor=2,rate=0.02"}), kSeed, 900);
  auto two = run(withEffects(sc, {"gaps:sensor=2,per_day=3000,mean_s=4", "sign_flips:sensor=2,rate=0.02",
                                  "gaps:sensor=2,per_day=1500,mean_s=20", "sign_flips:sensor=2,rate=0.03"}),
                 kSeed, 900);
  expectUnchangedExcept(one->cap, two->cap, {2}, false);
  std::map<TimeUs, const sim::HeadSampleOut*> b;
  for (const auto& x : two->cap.heads)
    if (x.head == 2) b[x.tag] = &x;
  std::size_t gone = 0, extra_flips = 0;
  for (const auto& x : one->cap.heads) {
    if (x.head != 2) continue;
    auto it = b.find(x.tag);
    if (it == b.end()) {
      ++gone;  // missing only through the second gap process
      continue;
    }
    if (x.sign_flipped) {
      EXPECT_TRUE(it->second->sign_flipped) << x.tag;  // the first flip process is unchanged
    }
    extra_flips += !x.sign_flipped && it->second->sign_flipped;
  }
  // Every sample missing in the one-spec run is missing in the two-spec run, and the second process
  // removes more (expected fraction 1500/86400*20 = 35 % of what remains).
  EXPECT_EQ(one->cap.head(2, false).size(), b.size() + gone);
  EXPECT_GT(gone, 50u);
  EXPECT_GT(extra_flips, 5u);
  const auto& st1 = one->sim.stats();
  const auto& st2 = two->sim.stats();
  EXPECT_EQ(st2.head_missing[1], st1.head_missing[1] + gone);
}

TEST(SimEffects, EffectArgumentsAreValidated) {
  model::EffectSpec s;
  std::string err;
  EXPECT_FALSE(model::parseEffectArg("thermal_periodc:sensor=1", s, &err));
  EXPECT_NE(err.find("unknown effect"), std::string::npos) << err;
  EXPECT_FALSE(model::parseEffectArg("thermal_periodic:sensor=1,harmonic=1.5", s, &err));
  EXPECT_NE(err.find("'harmonic'"), std::string::npos) << err;
  EXPECT_FALSE(model::parseEffectArg("acc_bias:sensor=2,x=1e-6", s, &err));
  EXPECT_NE(err.find("accelerometer only"), std::string::npos) << err;
  EXPECT_FALSE(model::parseEffectArg("step:sensor=1,x_arcsec=3", s, &err));
  EXPECT_NE(err.find("'at_s': required"), std::string::npos) << err;
  EXPECT_FALSE(model::parseEffectArg("outliers:sensor=1,rate=abc", s, &err));
  EXPECT_NE(err.find("not a finite number"), std::string::npos) << err;
  EXPECT_FALSE(model::parseEffectArg("drift:sensor=1,speed=3", s, &err));
  EXPECT_NE(err.find("unknown parameter"), std::string::npos) << err;
  EXPECT_TRUE(model::parseEffectArg("aberration", s, &err)) << err;
  EXPECT_EQ(s.sensor, "all");
  auto sc = gracefo();
  EXPECT_FALSE(sim::addEffectArgs(sc, {"step:sensor=7,at_s=3"}, &err));
  EXPECT_NE(err.find("no head 7"), std::string::npos) << err;
  // Every catalogue entry has a unique canonical name.
  std::set<std::string> names;
  for (const auto& e : model::effectCatalogue()) EXPECT_TRUE(names.insert(e.name).second) << e.name;
  EXPECT_EQ(names.size(), 21u);
}

}  // namespace
}  // namespace boresight

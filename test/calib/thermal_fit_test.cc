// The thermal harmonic model (issue 8 item 3): an injected 1st- and 3rd-harmonic deformation of heads 2
// and 3 relative to head 1 is recovered within 3 sigma; the beta modulation is reported as not determined
// on a day; the core's prediction during a 20-minute blinding of a head beats holding the last correction.
#include <boresight/calib/thermal_fit.h>
#include <boresight/core/pipeline.h>
#include <boresight/core/rotation.h>
#include <boresight/model/orbit_context.h>
#include <boresight/sim/orbit.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "three_heads.h"

#include <cmath>
#include <cstdio>
#include <random>

namespace boresight {
namespace {

using core::HeadEpoch;
using core::HeadSetConfig;

constexpr double kT0 = 738849600.0;  // 2023-06-01 00:00 GPS
constexpr double kAs = kRadPerArcsec;

HeadSetConfig graceLikeHeads() { return testutil::threeTiltedHeads(); }

/// The injected truth: deformation of slot k relative to slot 0, in S1, rad, at u.
struct Truth {
  // [slot][axis]: constant, 1st harmonic cos/sin, 3rd harmonic cos/sin (arcsec)
  double c[3][3] = {{0, 0, 0}, {20, -10, 35}, {-15, 8, -25}};
  double a1[3][3] = {{0, 0, 0}, {12, -7, 30}, {6, 9, -20}};
  double b1[3][3] = {{0, 0, 0}, {-5, 10, 15}, {-8, 4, 10}};
  double a3[3][3] = {{0, 0, 0}, {3, 4, -6}, {-4, 2, 5}};
  double b3[3][3] = {{0, 0, 0}, {4, -3, 8}, {2, -5, -6}};
  Vec3 delta(int k, double u) const {
    Vec3 d;
    for (int a = 0; a < 3; ++a)
      d(a) = (c[k][a] + a1[k][a] * std::cos(u) + b1[k][a] * std::sin(u) + a3[k][a] * std::cos(3 * u) +
              b3[k][a] * std::sin(3 * u)) * kAs;
    return d;
  }
};

sim::CircularOrbit makeOrbit() {
  sim::OrbitConfig c;
  c.raan_rad = 0.4;
  c.arg_lat0_rad = 0.3;
  return sim::CircularOrbit(c, kT0);
}

/// A head epoch at t with the given true deformations of slots 1, 2 relative to slot 0 (in S1, rad) and
/// head noise (GRACE model), body slowly turning.
HeadEpoch makeEpochWith(std::mt19937_64& rng, const HeadSetConfig& h, const std::array<Vec3, 3>& delta, double t_s,
                        std::uint32_t mask = 7u) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Quat q_I_B = core::quatExp(Vec3(0.3, -0.2, 1.1e-3 * (t_s - kT0)));
  const Quat q_I_S0 = q_I_B * h.head[0].q_Si_B.conjugate();
  HeadEpoch e;
  e.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  for (int k = 0; k < 3; ++k) {
    if (!((mask >> k) & 1u)) continue;
    const auto i = static_cast<std::size_t>(k);
    const Quat q_C0 = h.head[0].q_Si_B * h.head[i].q_Si_B.conjugate();  // C_S1_Sk^0
    const Quat q_true = k == 0 ? q_I_S0 : q_I_S0 * core::quatExp(delta[i]) * q_C0;
    const Vec3 b = h.head[i].boresight_Si, e1 = b.unitOrthogonal(), e2 = b.cross(e1);
    const Vec3 eps = h.head[i].sigma_cross_rad * (n(rng) * e1 + n(rng) * e2) + h.head[i].sigma_roll_rad * n(rng) * b;
    core::HeadSample& s = e.sample[static_cast<std::size_t>(e.n++)];
    s.head_id = k + 1;
    s.q_I_Si = (q_true * core::quatExp(eps)).normalized();
  }
  return e;
}

HeadEpoch makeEpoch(std::mt19937_64& rng, const HeadSetConfig& h, const Truth& tr, double u, double t_s,
                    std::uint32_t mask = 7u) {
  return makeEpochWith(rng, h, {Vec3::Zero(), tr.delta(1, u), tr.delta(2, u)}, t_s, mask);
}

io::GnvRecord inertialRecord(const sim::Orbit& o, double t_s) {
  Vec3 r, v;
  o.posVel(t_s, r, v);
  io::GnvRecord g;
  g.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  g.coord_ref = 'I';
  for (int a = 0; a < 3; ++a) {
    g.pos[a] = r(a);
    g.vel[a] = v(a);
  }
  return g;
}

/// A day of head epochs every `step_s` and orbit records every 10 s (GNI1B-like); u of each epoch.
struct Day {
  std::vector<HeadEpoch> epochs;
  std::vector<io::GnvRecord> orbit;
};
Day makeDay(std::uint64_t seed, double span_s, double step_s, const Truth& tr) {
  std::mt19937_64 rng(seed);
  const HeadSetConfig h = graceLikeHeads();
  const sim::CircularOrbit o = makeOrbit();
  Day d;
  for (double t = kT0; t <= kT0 + span_s + 10; t += 10) d.orbit.push_back(inertialRecord(o, t));
  for (double t = kT0 + 0.25; t < kT0 + span_s; t += step_s) d.epochs.push_back(makeEpoch(rng, h, tr, o.state(t).arg_lat_rad, t));
  return d;
}

const Day& theDay() {
  static const Day d = makeDay(7, 86400.0, 4.0, Truth{});
  return d;
}

TEST(ThermalFit, RecoversInjectedFirstAndThirdHarmonicsWithinThreeSigma) {
  const Truth tr;
  calib::ThermalFitConfig cfg;  // harmonics 1, 2, 3
  const calib::ThermalFitResult r = calib::fitThermal(graceLikeHeads(), cfg, theDay().epochs, theDay().orbit);
  std::printf("%s", calib::formatThermalFit(r).c_str());
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_NE(r.datum_note.find("head 1 (slot 0) is the datum"), std::string::npos);
  EXPECT_NEAR(r.revolutions, 86400.0 / 5660.0, 0.3);
  ASSERT_EQ(r.heads.size(), 2u);
  // Every estimate (2 heads x 3 axes x (constant + 3 harmonics x cos, sin) = 42) against the truth, in
  // sigmas. Each must be within 3 sigma, except for the chance exceedances of 42 normal variables: at most
  // one beyond 3 sigma (two or more: 0.6 % for honest sigmas) and none beyond 4 sigma (0.3 % for all 42);
  // and per head the joint chi2 of the 21 coefficients with their full covariance below its 99.9 % point.
  int checked = 0, beyond3 = 0;
  double worst = 0, sum_z2 = 0;
  for (const calib::ThermalHeadFit& h : r.heads) {
    ASSERT_TRUE(h.determined) << h.reason;
    EXPECT_EQ(h.datum_id, 1);
    const int k = h.slot;
    ASSERT_EQ(h.n_params, 21);
    Eigen::VectorXd e(21);
    for (int a = 0; a < 3; ++a) {
      const calib::ThermalAxisFit& A = h.axis[static_cast<std::size_t>(a)];
      auto check = [&](int j, double est, double sig, double truth, const char* what) {
        ASSERT_GT(sig, 0.0);
        e(7 * a + j) = est - truth;
        const double z = (est - truth) / sig;
        worst = std::max(worst, std::fabs(z));
        sum_z2 += z * z;
        if (std::fabs(z) >= 3.0) {
          ++beyond3;
          std::printf("  beyond 3 sigma: head %d axis %d %s: %.2f +- %.2f against %.2f (%.2f sigma)\n", h.id, a, what, est,
                      sig, truth, z);
        }
        EXPECT_LT(std::fabs(z), 4.0) << "head " << h.id << " axis " << a << " " << what << ": " << est << " +- " << sig
                                     << " against " << truth;
        ++checked;
      };
      check(0, A.constant_arcsec, A.sigma_constant_arcsec, tr.c[k][a], "constant");
      ASSERT_EQ(A.terms.size(), 3u);
      check(1, A.terms[0].cos_arcsec, A.terms[0].sigma_cos_arcsec, tr.a1[k][a], "1/rev cos");
      check(2, A.terms[0].sin_arcsec, A.terms[0].sigma_sin_arcsec, tr.b1[k][a], "1/rev sin");
      check(3, A.terms[1].cos_arcsec, A.terms[1].sigma_cos_arcsec, 0.0, "2/rev cos (not injected)");
      check(4, A.terms[1].sin_arcsec, A.terms[1].sigma_sin_arcsec, 0.0, "2/rev sin (not injected)");
      check(5, A.terms[2].cos_arcsec, A.terms[2].sigma_cos_arcsec, tr.a3[k][a], "3/rev cos");
      check(6, A.terms[2].sin_arcsec, A.terms[2].sigma_sin_arcsec, tr.b3[k][a], "3/rev sin");
      // the sigmas are small against the amplitudes (the test is not passed by huge sigmas)
      EXPECT_LT(A.terms[0].sigma_cos_arcsec, 1.0);
      // the residual falls to the noise the head model predicts
      EXPECT_LT(A.rms_after_arcsec, A.rms_before_arcsec);
      EXPECT_NEAR(A.rms_after_arcsec / A.noise_rms_arcsec, 1.0, 0.05);
    }
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> C(
        h.covariance_arcsec2.data(), 21, 21);
    const double chi2 = e.dot(C.ldlt().solve(e));
    std::printf("head %d: joint chi2 of the 21 coefficients against the truth %.1f (99.9 %% point of chi2(21): 46.8)\n",
                h.id, chi2);
    EXPECT_LT(chi2, 46.8);
    EXPECT_NEAR(h.chi2_per_dof, 1.0, 0.05);
  }
  EXPECT_LE(beyond3, 1);
  std::printf("%d estimates checked: %d beyond 3 sigma, worst %.2f sigma, mean z^2 %.2f\n", checked, beyond3, worst,
              sum_z2 / checked);
}

/// Collects the simulator's head samples into core head epochs (one per common tag; blinded heads are
/// absent) and its orbit samples into GNI1B-like records.
struct SimCollector : sim::SimSink {
  std::vector<HeadEpoch> epochs;
  std::vector<io::GnvRecord> records;
  HeadEpoch cur;
  void head(const sim::HeadSampleOut& h) override {
    if (cur.n > 0 && h.tag != cur.t) flush();
    cur.t = h.tag;
    if (h.blind != sim::kBlindNone || cur.n >= core::kMaxHeads) return;
    core::HeadSample& s = cur.sample[static_cast<std::size_t>(cur.n++)];
    s.head_id = h.head;
    s.q_I_Si = h.q_I_Si;
  }
  void orbit(const sim::OrbitSampleOut& o) override {
    io::GnvRecord g;
    g.t = o.t;
    g.coord_ref = 'I';
    for (int a = 0; a < 3; ++a) {
      g.pos[a] = o.r_I(a);
      g.vel[a] = o.v_I(a);
    }
    records.push_back(g);
  }
  void flush() {
    if (cur.n > 0) epochs.push_back(cur);
    cur = HeadEpoch{};
  }
};

TEST(ThermalFit, RecoversTheSimulatorsThermalPeriodicEffect) {
  // the simulator's GRACE-FO-like scenario with only two effects: head 2 a 1st harmonic, head 3 a 3rd
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo.yaml", sc, &err)) << err;
  sc.effects.clear();
  ASSERT_TRUE(sim::addEffectArgs(sc,
                                 {"thermal_periodic:sensor=2,harmonic=1,x_arcsec=20,y_arcsec=-12,z_arcsec=30,phase_deg=40",
                                  "thermal_periodic:sensor=3,harmonic=3,x_arcsec=-8,y_arcsec=10,z_arcsec=15,phase_deg=-70"},
                                 &err))
      << err;
  const double span_s = 4 * 3600.0;
  sim::Simulator simulator;
  ASSERT_TRUE(simulator.init(sc, 5, span_s, &err)) << err;
  SimCollector col;
  simulator.run(col);
  col.flush();
  ASSERT_GT(col.epochs.size(), 20000u);
  ASSERT_GT(col.records.size(), 100u);
  HeadSetConfig h;
  h.n_heads = 3;
  for (int k = 0; k < 3; ++k) {
    h.head[static_cast<std::size_t>(k)].id = sc.heads[static_cast<std::size_t>(k)].id;
    h.head[static_cast<std::size_t>(k)].q_Si_B = sc.heads[static_cast<std::size_t>(k)].q_Si_B;
  }
  const calib::ThermalFitResult r = calib::fitThermal(h, {}, col.epochs, col.records);
  std::printf("%s", calib::formatThermalFit(r).c_str());
  ASSERT_TRUE(r.ok) << r.error;
  // truth in head 1's frame: the simulator rotates head k by phi_k = amp cos(n u + phase) in Sk
  // (C_Sk_B = Exp(phi_k) C_Sk_B^true), so C_S1_Sk = M Exp(-phi_k) and delta_k = -C_S1_Sk^0 phi_k to first
  // order (the mounting errors make the rest: < 1e-4 of the amplitude)
  struct Inj {
    int slot, harm;
    Vec3 amp;
    double phase_deg;
  } inj[2] = {{1, 1, Vec3(20, -12, 30), 40}, {2, 3, Vec3(-8, 10, 15), -70}};
  int checked = 0, beyond3 = 0;
  double worst = 0;
  for (const Inj& in : inj) {
    const calib::ThermalHeadFit& hf = r.heads[static_cast<std::size_t>(in.slot - 1)];
    ASSERT_TRUE(hf.determined) << hf.reason;
    const Mat3 C0 = core::groundRelative(h, 0, in.slot);
    const Vec3 tc = -C0 * in.amp * std::cos(in.phase_deg * kRadPerDeg);  // cos(n u) coefficient
    const Vec3 ts = C0 * in.amp * std::sin(in.phase_deg * kRadPerDeg);   // sin(n u) coefficient
    for (int a = 0; a < 3; ++a)
      for (const calib::ThermalHarmonicTerm& t : hf.axis[static_cast<std::size_t>(a)].terms) {
        const double want_c = t.harmonic == in.harm ? tc(a) : 0.0, want_s = t.harmonic == in.harm ? ts(a) : 0.0;
        for (const double z : {(t.cos_arcsec - want_c) / t.sigma_cos_arcsec, (t.sin_arcsec - want_s) / t.sigma_sin_arcsec}) {
          worst = std::max(worst, std::fabs(z));
          beyond3 += std::fabs(z) >= 3.0 ? 1 : 0;
          EXPECT_LT(std::fabs(z), 4.0) << "head " << hf.id << " axis " << a << " harmonic " << t.harmonic;
          ++checked;
        }
        if (t.harmonic == in.harm) {
          EXPECT_NEAR(t.cos_arcsec, want_c, 4 * t.sigma_cos_arcsec);
          EXPECT_LT(t.sigma_cos_arcsec, 0.1 * in.amp.norm());  // a real recovery, not a wide sigma
        }
      }
  }
  std::printf("simulator (%.0f h, %zu epochs): %d harmonic coefficients checked, %d beyond 3 sigma, worst %.2f sigma\n",
              span_s / 3600.0, col.epochs.size(), checked, beyond3, worst);
  EXPECT_LE(beyond3, 1);  // 36 coefficients: two or more beyond 3 sigma has a 0.5 % chance for honest sigmas
}

TEST(ThermalFit, BetaModulationIsNotDeterminedOnADay) {
  const calib::ThermalFitResult r = calib::fitThermal(graceLikeHeads(), {}, theDay().epochs, theDay().orbit);
  ASSERT_TRUE(r.ok) << r.error;
  std::printf("%s\n", r.beta_note.c_str());
  EXPECT_FALSE(r.beta_determined);
  EXPECT_NE(r.beta_note.find("not determined"), std::string::npos);
  EXPECT_LT(r.beta_max_deg - r.beta_min_deg, 3.0);
  for (const calib::ThermalHeadFit& h : r.heads) {
    EXPECT_FALSE(h.beta_determined);
    for (const calib::ThermalAxisFit& A : h.axis) EXPECT_TRUE(A.beta_terms.empty());
  }
  EXPECT_FALSE(r.coreModel().beta_terms);
}

TEST(ThermalFit, BetaModulationIsFittedWhenTheSpanLetsBetaMove) {
  // 40 days, one head epoch a minute: beta moves by tens of degrees. Head 2's 1st harmonic grows with
  // cos(beta): amplitude A (1 + g (cos(beta) - cos(beta_0))), beta_0 the first epoch's, g = 0.8; head 3
  // has a 3rd harmonic without beta modulation.
  const HeadSetConfig h = graceLikeHeads();
  const sim::CircularOrbit o = makeOrbit();
  const double span_s = 40 * 86400.0, g = 0.8;
  const Vec3 A1c = Vec3(15, -8, 25) * kAs, A1s = Vec3(-6, 9, 12) * kAs, A3c = Vec3(5, -4, 7) * kAs, A3s = Vec3(-3, 6, 2) * kAs;
  const double cos_beta0 = std::cos(o.state(kT0 + 0.25).beta_rad);
  std::mt19937_64 rng(17);
  calib::ThermalCollector c;
  std::string err;
  ASSERT_TRUE(c.configure(h, {}, &err)) << err;
  for (double t = kT0; t <= kT0 + span_s + 30; t += 30) c.pushOrbit(inertialRecord(o, t));
  for (double t = kT0 + 0.25; t < kT0 + span_s; t += 60) {
    const sim::OrbitState s = o.state(t);
    const double m = 1 + g * (std::cos(s.beta_rad) - cos_beta0), u = s.arg_lat_rad;
    c.pushHeads(makeEpochWith(rng, h,
                              {Vec3::Zero(), m * (A1c * std::cos(u) + A1s * std::sin(u)),
                               A3c * std::cos(3 * u) + A3s * std::sin(3 * u)},
                              t));
  }
  const calib::ThermalFitResult r = c.fit();
  std::printf("%s", calib::formatThermalFit(r).c_str());
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_TRUE(r.beta_determined) << r.beta_note;
  EXPECT_GT(r.beta_max_deg - r.beta_min_deg, 10.0);
  EXPECT_TRUE(r.coreModel().beta_terms);
  int checked = 0, beyond3 = 0;
  double worst = 0;
  for (const calib::ThermalHeadFit& hf : r.heads) {
    ASSERT_TRUE(hf.determined) << hf.reason;
    EXPECT_TRUE(hf.beta_determined);
    for (int a = 0; a < 3; ++a) {
      const calib::ThermalAxisFit& ax = hf.axis[static_cast<std::size_t>(a)];
      ASSERT_EQ(ax.beta_terms.size(), 3u);
      for (int n = 0; n < 3; ++n) {
        const calib::ThermalHarmonicTerm& t = ax.terms[static_cast<std::size_t>(n)];
        const calib::ThermalHarmonicTerm& tb = ax.beta_terms[static_cast<std::size_t>(n)];
        double wc = 0, ws = 0, wbc = 0, wbs = 0;
        if (hf.slot == 1 && t.harmonic == 1) {
          wc = A1c(a) / kAs;
          ws = A1s(a) / kAs;
          wbc = g * wc;
          wbs = g * ws;
        }
        if (hf.slot == 2 && t.harmonic == 3) {
          wc = A3c(a) / kAs;
          ws = A3s(a) / kAs;
        }
        const double z[4] = {(t.cos_arcsec - wc) / t.sigma_cos_arcsec, (t.sin_arcsec - ws) / t.sigma_sin_arcsec,
                             (tb.cos_arcsec - wbc) / tb.sigma_cos_arcsec, (tb.sin_arcsec - wbs) / tb.sigma_sin_arcsec};
        for (double zi : z) {
          worst = std::max(worst, std::fabs(zi));
          beyond3 += std::fabs(zi) >= 3.0 ? 1 : 0;
          EXPECT_LT(std::fabs(zi), 4.0) << "head " << hf.id << " axis " << a << " harmonic " << t.harmonic;
          ++checked;
        }
        if (hf.slot == 1 && t.harmonic == 1) {
          EXPECT_LT(tb.sigma_cos_arcsec, 0.2 * std::fabs(wbc) + 0.5);
        }
      }
    }
  }
  std::printf("beta over %.0f days: %d coefficients checked, %d beyond 3 sigma, worst %.2f sigma\n", span_s / 86400,
              checked, beyond3, worst);
  EXPECT_LE(beyond3, 1);  // 72 coefficients: two or more beyond 3 sigma has a 1.7 % chance for honest sigmas
}

TEST(ThermalFit, RefusesTooShortASpanAndBadConfiguration) {
  // 40 minutes: less than a revolution
  const Day d = makeDay(3, 2400.0, 2.0, Truth{});
  const calib::ThermalFitResult r = calib::fitThermal(graceLikeHeads(), {}, d.epochs, d.orbit);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("revolutions"), std::string::npos) << r.error;
  // no orbit at all
  const calib::ThermalFitResult r2 = calib::fitThermal(graceLikeHeads(), {}, d.epochs, {});
  EXPECT_FALSE(r2.ok);
  EXPECT_NE(r2.error.find("no orbit records"), std::string::npos) << r2.error;
  EXPECT_EQ(r2.epochs_without_orbit, d.epochs.size());
  calib::ThermalFitConfig bad;
  bad.harmonics = {1, 1};
  const calib::ThermalFitResult r3 = calib::fitThermal(graceLikeHeads(), bad, d.epochs, d.orbit);
  EXPECT_FALSE(r3.ok);
  EXPECT_NE(r3.error.find("distinct"), std::string::npos) << r3.error;
  HeadSetConfig one = graceLikeHeads();
  one.n_heads = 1;
  EXPECT_FALSE(calib::fitThermal(one, {}, d.epochs, d.orbit).ok);
}

TEST(ThermalFit, InterleavedStreamsAndEarthFixedOrbitGiveTheSameFit) {
  // the same day, the orbit as Earth-fixed GNV1B records, pushed interleaved with the head epochs
  const Day& d = theDay();
  calib::ThermalCollector c;
  std::string err;
  ASSERT_TRUE(c.configure(graceLikeHeads(), {}, &err)) << err;
  const sim::CircularOrbit o = makeOrbit();
  std::size_t j = 0;
  for (const io::GnvRecord& gi : d.orbit) {
    while (j < d.epochs.size() && d.epochs[j].t <= gi.t) c.pushHeads(d.epochs[j++]);
    const double t = toSeconds(gi.t), th = model::earthRotationAngle(t);
    Mat3 C_E_I;
    C_E_I << std::cos(th), std::sin(th), 0, -std::sin(th), std::cos(th), 0, 0, 0, 1;
    const Vec3 rE = C_E_I * Vec3(gi.pos[0], gi.pos[1], gi.pos[2]);
    const Vec3 vE = C_E_I * Vec3(gi.vel[0], gi.vel[1], gi.vel[2]) - Vec3(0, 0, model::kEarthRotationRate_rad_s).cross(rE);
    io::GnvRecord ge = gi;
    ge.coord_ref = 'E';
    for (int a = 0; a < 3; ++a) {
      ge.pos[a] = rE(a);
      ge.vel[a] = vE(a);
    }
    c.pushOrbit(ge);
  }
  while (j < d.epochs.size()) c.pushHeads(d.epochs[j++]);
  const calib::ThermalFitResult r = c.fit();
  const calib::ThermalFitResult ref = calib::fitThermal(graceLikeHeads(), {}, d.epochs, d.orbit);
  ASSERT_TRUE(r.ok && ref.ok);
  EXPECT_TRUE(r.u_from_earth_fixed);
  EXPECT_EQ(r.epochs_without_orbit, 0u);
  EXPECT_EQ(r.heads[0].epochs, ref.heads[0].epochs);
  for (std::size_t i = 0; i < 2; ++i)
    for (int a = 0; a < 3; ++a)
      for (int n = 0; n < 3; ++n) {
        EXPECT_NEAR(r.heads[i].axis[a].terms[n].cos_arcsec, ref.heads[i].axis[a].terms[n].cos_arcsec, 1e-6);
        EXPECT_NEAR(r.heads[i].axis[a].terms[n].sin_arcsec, ref.heads[i].axis[a].terms[n].sin_arcsec, 1e-6);
      }
}

TEST(ThermalPredictor, PairPredictionsComposeExactly) {
  const Truth tr;
  const HeadSetConfig h = graceLikeHeads();
  core::ThermalHarmonicModel m;
  m.n_harmonics = 2;
  m.order = {1, 3};
  for (int k = 1; k < 3; ++k) {
    core::ThermalHeadModel& hm = m.head[static_cast<std::size_t>(k)];
    hm.valid = true;
    for (int a = 0; a < 3; ++a) {
      hm.constant_rad(a) = tr.c[k][a] * kAs;
      hm.cos_rad[0](a) = tr.a1[k][a] * kAs;
      hm.sin_rad[0](a) = tr.b1[k][a] * kAs;
      hm.cos_rad[1](a) = tr.a3[k][a] * kAs;
      hm.sin_rad[1](a) = tr.b3[k][a] * kAs;
    }
  }
  core::ThermalPredictor p;
  ASSERT_EQ(p.configure(h, m), core::Status::kOk);
  for (double u = -3; u < 3; u += 0.37) {
    // truth: C_Sa_Sb = C_Sa_S1 C_S1_Sb with C_S1_Sk = Exp(delta_k) C0_1k
    const Mat3 C12 = core::so3Exp(tr.delta(1, u)) * core::groundRelative(h, 0, 1);
    const Mat3 C13 = core::so3Exp(tr.delta(2, u)) * core::groundRelative(h, 0, 2);
    const Mat3 D23 = C12.transpose() * C13 * core::groundRelative(h, 1, 2).transpose();
    Vec3 d;
    Mat3 P;
    ASSERT_EQ(p.predictPair(1, 2, u, 1.0, d, P), core::Status::kOk);
    EXPECT_LT((d - core::so3Log(D23)).norm(), 1e-12);
    ASSERT_EQ(p.predictPair(0, 2, u, 1.0, d, P), core::Status::kOk);
    EXPECT_LT((d - tr.delta(2, u)).norm(), 1e-15);
  }
  // bad input
  Vec3 d;
  Mat3 P;
  EXPECT_EQ(p.predictPair(2, 1, 0.0, 1.0, d, P), core::Status::kInvalidConfig);
  EXPECT_EQ(p.predictPair(0, 1, std::nan(""), 1.0, d, P), core::Status::kNonFinite);
  core::ThermalHarmonicModel bad = m;
  bad.order[1] = 0;
  EXPECT_EQ(p.configure(h, bad), core::Status::kInvalidConfig);
  bad = m;
  bad.head[0].valid = true;  // the datum has no model
  EXPECT_EQ(p.configure(h, bad), core::Status::kInvalidConfig);
  bad = m;
  bad.head[1].cos_rad[0](0) = std::nan("");
  EXPECT_EQ(p.configure(h, bad), core::Status::kInvalidConfig);
  // orbit input: extrapolation limit, time order, NaN
  ASSERT_EQ(p.configure(h, m), core::Status::kOk);
  double u = 0, cb = 0;
  EXPECT_FALSE(p.orbitAt(0, u, cb));
  EXPECT_EQ(p.stepOrbit(10 * kUsPerSecond, 1.0, 1e-3, 0.2), core::Status::kOk);
  EXPECT_TRUE(p.orbitAt(40 * kUsPerSecond, u, cb));
  EXPECT_NEAR(u, 1.03, 1e-12);
  EXPECT_NEAR(cb, std::cos(0.2), 1e-15);
  EXPECT_FALSE(p.orbitAt(71 * kUsPerSecond, u, cb));  // beyond max_orbit_age_s (60 s)
  EXPECT_EQ(p.stepOrbit(5 * kUsPerSecond, 1.0, 1e-3, 0.2), core::Status::kTimeBackwards);
  EXPECT_EQ(p.stepOrbit(20 * kUsPerSecond, std::nan(""), 1e-3, 0.2), core::Status::kNonFinite);
}

/// Error of the relative matrix Wahba would use for the pair (0, 2) against the truth, arcsec (3-D).
Vec3 relativeError(const core::Pipeline& p, const HeadSetConfig& h, const Truth& tr, double u, TimeUs t) {
  Mat3 C, Q;
  p.monitor().relativeFor(0, 2, core::RelativeCorrection::kFilteredThreeAxis, t, C, Q);
  const Mat3 C_true = core::so3Exp(tr.delta(2, u)) * core::groundRelative(h, 0, 2);
  return core::so3Log(C * C_true.transpose()) / kAs;
}

/// One way of correcting the pair (1,3) while head 3 is blind, and its error against the truth.
struct BlindRun {
  const char* name;
  bool model;
  core::ThermalPredictionMode mode;
  double sum2 = 0, sum2_cross = 0, max = 0;
  int n = 0;
  double rms() const { return std::sqrt(sum2 / n); }
};

/// The 3 hours after the fitted day at 2 Hz through the core pipeline with orbit input at 1 Hz; head 3
/// (slot 2) blind for three 20-minute windows (different phases of the orbit). Errors of the relative
/// matrix Wahba would use for the pair (1,3) over the blind epochs, for each run.
void runBlinding(const calib::ThermalFitResult& fit, const Truth& tr, BlindRun (&runs)[3], const char* title) {
  const HeadSetConfig h = graceLikeHeads();
  const sim::CircularOrbit o = makeOrbit();
  const double start = kT0 + 86400.0 + 600.0;
  const double blind_from[3] = {3600.0, 3600.0 + 2700.0, 3600.0 + 5100.0};
  for (BlindRun& run : runs) {
    core::PipelineConfig pc;
    pc.heads = h;
    pc.use_accelerometer = false;
    core::Pipeline p;
    ASSERT_EQ(p.configure(pc), core::Status::kOk);
    if (run.model) {
      ASSERT_EQ(p.setThermalModel(fit.coreModel(run.mode)), core::Status::kOk);
    }
    std::mt19937_64 rng(11);
    for (int i = 0; i < 2 * 3 * 3600; ++i) {
      const double t = start + 0.5 * i, rel = t - start;
      const sim::OrbitState s = o.state(t);
      bool blind = false;
      for (double b : blind_from) blind = blind || (rel >= b && rel < b + 1200.0);
      if (i % 2 == 0) {  // orbit input at 1 Hz
        model::OrbitSample os;
        ASSERT_TRUE(model::orbitSampleFromInertial(static_cast<TimeUs>(std::llround(t * 1e6)), s.r_I, s.v_I, os));
        ASSERT_EQ(p.stepOrbit(os.t, os.u_rad, os.u_rate_rad_s, os.beta_rad), core::Status::kOk);
      }
      const HeadEpoch e = makeEpoch(rng, h, tr, s.arg_lat_rad, t, blind ? 3u : 7u);
      p.stepHeads(e);
      core::PipelineRow row;
      while (p.popRow(row)) {
      }
      if (blind) {
        const Vec3 err = relativeError(p, h, tr, s.arg_lat_rad, e.t);
        // 3-D, and the x, y axes of S1 (head 1's boresight is its z: roll-free part)
        run.sum2 += err.squaredNorm();
        run.sum2_cross += err.head<2>().squaredNorm();
        run.max = std::max(run.max, err.norm());
        ++run.n;
      }
    }
    EXPECT_TRUE(p.monitor().filtered(0, 2).valid);
    EXPECT_EQ(p.monitor().filtered(0, 2).predicted, false);  // head 3 seen again at the end: prediction cleared
  }
  std::printf("%s: 20-minute blindings of head 3 (3 windows, %d epochs), error of the pair (1,3) correction:\n", title,
              runs[0].n);
  for (const BlindRun& r : runs)
    std::printf("  %-16s RMS %.2f\" (x,y of S1: %.2f\"), max %.2f\"\n", r.name, r.rms(), std::sqrt(r.sum2_cross / r.n),
                r.max);
}

TEST(ThermalPipeline, PredictionDuringATwentyMinuteBlindingBeatsHoldingTheLastCorrection) {
  // the model from the day before
  const calib::ThermalFitResult fit = calib::fitThermal(graceLikeHeads(), {}, theDay().epochs, theDay().orbit);
  ASSERT_TRUE(fit.ok) << fit.error;
  BlindRun runs[3] = {{"hold (no model)", false, core::ThermalPredictionMode::kAbsolute},
                      {"model, absolute", true, core::ThermalPredictionMode::kAbsolute},
                      {"model, anchored", true, core::ThermalPredictionMode::kAnchored}};
  runBlinding(fit, Truth{}, runs, "same deformation as in the fitted day");
  EXPECT_LT(runs[1].rms(), 0.25 * runs[0].rms());
  EXPECT_LT(runs[2].rms(), 0.5 * runs[0].rms());
}

TEST(ThermalPipeline, AnchoredPredictionFollowsAChangeOfTheConstantSinceTheFit) {
  // after the fitted day the relative alignment of head 3 jumps by (15, -15, 25)": the absolute model
  // is off by that much, the anchored one takes the level from the monitor's filter before the blinding
  const calib::ThermalFitResult fit = calib::fitThermal(graceLikeHeads(), {}, theDay().epochs, theDay().orbit);
  ASSERT_TRUE(fit.ok) << fit.error;
  Truth moved;
  moved.c[2][0] += 15;
  moved.c[2][1] -= 15;
  moved.c[2][2] += 25;
  BlindRun runs[3] = {{"hold (no model)", false, core::ThermalPredictionMode::kAbsolute},
                      {"model, absolute", true, core::ThermalPredictionMode::kAbsolute},
                      {"model, anchored", true, core::ThermalPredictionMode::kAnchored}};
  runBlinding(fit, moved, runs, "constant moved by 33\" since the fit");
  EXPECT_GT(runs[1].rms(), 25.0);  // the absolute model carries the old constant
  EXPECT_LT(runs[2].rms(), 0.5 * runs[0].rms());
  EXPECT_LT(runs[2].rms(), 0.25 * runs[1].rms());
}

}  // namespace
}  // namespace boresight

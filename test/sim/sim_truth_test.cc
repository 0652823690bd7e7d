// truth.yaml round trip: a short run with several effects (two of one kind among them) is written and
// read back; every effect spec equals the simulated one and every sensor parameter and realised event
// agrees with the simulator's. Bad files give "PATH:LINE: key 'k': reason".
#include "sim_test_util.h"
#include "test_files.h"

#include <boresight/model/stochastic.h>
#include <boresight/sim/truth.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace boresight {
namespace {

namespace fs = std::filesystem;

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void put(const std::string& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << p;
}

constexpr double kRel = 1e-14;  // unit conversions (arcsec, deg) on the way out and back

void expectNearVec(const Vec3& a, const Vec3& b, const char* what) {
  EXPECT_LE((a - b).norm(), kRel * std::max(1e-300, b.norm()) + 1e-300) << what;
}

/// Terms equal (levels through arcseconds and back: relative 1e-14).
void expectSameModel(const model::NoiseModel& a, const model::NoiseModel& b, const char* what) {
  ASSERT_EQ(a.terms.size(), b.terms.size()) << what;
  for (std::size_t k = 0; k < a.terms.size(); ++k) {
    model::NoiseTerm x = a.terms[k];
    EXPECT_NEAR(x.sigma, b.terms[k].sigma, kRel * b.terms[k].sigma) << what;
    x.sigma = b.terms[k].sigma;
    EXPECT_EQ(x, b.terms[k]) << what << " term " << k;
  }
}

struct TruthRun {
  fs::path dir;
  std::unique_ptr<simtest::Run> r;
  std::string path;
};

/// `name`: a directory of its own per test (ctest runs the tests of this file in parallel).
TruthRun writeOne(const std::string& name) {
  TruthRun t;
  t.dir = testutil::makeTempDir("boresight_sim_truth_" + name);
  auto sc = simtest::gracefo();
  sc.mounting_error_sigma_rad = 7 * kRadPerArcsec;  // a drawn part on top of the configured errors
  sc.heads[1].tag_drift_ppm = 12.5;
  sc.heads[2].tag_jitter_us = 17;
  sc.acc.tag_drift_ppm = -60;
  sim::Manoeuvre m;
  m.amplitude_rad = Vec3(0.1, 0.2, 0.3) * kRadPerDeg;
  m.period_s = 40;
  m.start_s = 10;
  m.duration_s = 120;
  sc.attitude.manoeuvres = {m};
  sc = simtest::withEffects(
      sc, {"drift:sensor=1,x_arcsec_per_day=40,start_s=50", "drift:sensor=1,z_arcsec_per_day=-20,start_s=150",
           "outliers:sensor=2,rate=0.02,arcsec=250", "outliers:sensor=all,rate=0.01", "sign_flips:sensor=3,rate=0.03",
           "gaps:sensor=3,per_day=2000,mean_s=5", "gaps:sensor=3,per_day=800,mean_s=12,at_s=100,duration_s=7",
           "gaps:sensor=acc,per_day=3000,mean_s=3", "head_dropout:sensor=1,at_s=200,duration_s=20",
           "cross_noise:sensor=all,cross_arcsec=2.4", "anisotropic_noise:sensor=2,about_arcsec=20",
           "anisotropic_noise:sensor=2,about_arcsec=15", "clock_drift:sensor=all,rate_ppm=3,offset_ms=1",
           "clock_drift:sensor=acc,rate_ppm=-2", "time_offset:sensor=all,offset_ms=30",
           "time_offset:sensor=acc,offset_ms=-15", "thermal_periodic:sensor=2,harmonic=2,y_arcsec=4,beta_gain=0.5",
           "acc_bias:x=1e-7,z=-2e-7", "acc_scale:y=0.001", "acc_misalignment:z_arcsec=30", "aberration:sensor=all,orbital=0",
           "coloured_noise:sensor=1,cross_arcsec=1.5,about_arcsec=4,tau_s=300",
           "coloured_noise:sensor=all,cross_arcsec=0.5,alpha=1.2,f_lo_hz=1e-4,f_hi_hz=0.1",
           "thermal_wander:sensor=3,cross_arcsec=2,tau_s=5000", "fov_error:sensor=2,arcsec=3",
           "fov_error:sensor=2,arcsec=1,order=5", "acc_coloured_noise:x=1e-8,y=2e-8,alpha=1,f_lo_hz=1e-3,f_hi_hz=1",
           "acc_bias_wander:z=3e-9,tau_s=1e5"});
  t.r = simtest::run(sc, 21, 300);
  t.path = (t.dir / "truth.yaml").string();
  std::string err;
  EXPECT_TRUE(sim::writeTruthYaml(t.path, t.r->sim, {"--effect x"}, {"a.txt", "b.txt"}, &err)) << err;
  return t;
}

TEST(SimTruth, WrittenTruthReadsBackIntoTheSameSpecsAndParameters) {
  auto w = writeOne("roundtrip");
  const sim::Simulator& s = w.r->sim;
  const sim::Scenario& sc = s.scenario();
  sim::TruthFile t;
  std::string err;
  ASSERT_TRUE(sim::readTruthYaml(w.path, t, &err)) << err;

  EXPECT_EQ(t.seed, 21u);
  EXPECT_EQ(t.satellite, sc.satellite);
  EXPECT_EQ(t.start, sc.start);
  EXPECT_EQ(t.duration_s, 300.0);
  EXPECT_EQ(t.effect_args, std::vector<std::string>{"--effect x"});
  EXPECT_EQ(t.files, (std::vector<std::string>{"a.txt", "b.txt"}));

  // Every spec, exactly.
  ASSERT_EQ(t.effects.size(), sc.effects.size());
  for (std::size_t i = 0; i < sc.effects.size(); ++i) {
    const auto &a = t.effects[i], &b = sc.effects[i];
    EXPECT_EQ(a.kind, b.kind) << i;
    EXPECT_EQ(a.name, b.name) << i;
    EXPECT_EQ(a.sensor, b.sensor) << i;
    EXPECT_EQ(a.origin, b.origin) << i;
    EXPECT_EQ(a.values, b.values) << i << " " << b.name;
  }
  // ...so the effects rebuilt from them are the simulated ones.
  for (const auto& h : s.heads()) {
    const model::HeadEffects e = model::headEffectsFor(t.effects, h.config().id);
    EXPECT_EQ(model::headParams(e), model::headParams(h.effects()));
    EXPECT_EQ(e.outliers.size(), h.effects().outliers.size());
    EXPECT_EQ(e.random_gaps.size(), h.effects().random_gaps.size());
    EXPECT_EQ(e.cross_sigma_rad, h.effects().cross_sigma_rad);
    EXPECT_EQ(e.about_sigma_rad, h.effects().about_sigma_rad);
  }

  // Orbit and attitude.
  EXPECT_NEAR(t.orbit.altitude_m, sc.orbit.altitude_m, 1e-6);
  EXPECT_NEAR(t.orbit.inclination_rad, sc.orbit.inclination_rad, 1e-15);
  EXPECT_NEAR(t.orbit.raan_rad, sc.orbit.raan_rad, 1e-15);
  EXPECT_EQ(t.orbit.j2_nodal_precession, sc.orbit.j2_nodal_precession);
  EXPECT_NEAR(t.mounting_error_sigma_rad, sc.mounting_error_sigma_rad, 1e-20);
  expectNearVec(t.attitude.deadband_rad, sc.attitude.deadband_rad, "deadband");
  expectNearVec(t.attitude.inertia_kg_m2, sc.attitude.inertia_kg_m2, "inertia");
  EXPECT_NEAR(t.attitude.min_on_s, sc.attitude.min_on_s, 1e-15);
  ASSERT_EQ(t.attitude.manoeuvres.size(), 1u);
  expectNearVec(t.attitude.manoeuvres[0].amplitude_rad, sc.attitude.manoeuvres[0].amplitude_rad, "manoeuvre");
  EXPECT_EQ(t.attitude.manoeuvres[0].period_s, 40.0);
  EXPECT_EQ(t.thruster_pulses, s.stats().thruster_pulses);
  EXPECT_EQ(t.max_abs_alpha, s.stats().max_abs_alpha);

  // Heads.
  ASSERT_EQ(t.heads.size(), s.heads().size());
  std::uint64_t runs_seen = 0;
  for (std::size_t i = 0; i < s.heads().size(); ++i) {
    const auto& h = s.heads()[i];
    const auto& c = h.config();
    const sim::TruthHead* th = t.head(c.id);
    ASSERT_NE(th, nullptr);
    EXPECT_EQ(th->config.q_Si_B.coeffs(), c.q_Si_B.coeffs());
    EXPECT_EQ(th->q_Si_B_true.coeffs(), h.qSiBTrue().coeffs());
    expectNearVec(th->config.mounting_error_rad, c.mounting_error_rad, "mounting error");
    EXPECT_NE(c.mounting_error_rad, sc.heads[i].mounting_error_rad);  // the drawn part is in it
    expectNearVec(th->relative_misalignment_rad, h.effects().misalignment_rad, "relative misalignment");
    EXPECT_EQ(th->config.boresight_Si, c.boresight_Si);
    EXPECT_NEAR(th->sigma_cross_rad, h.sigmaCross(), kRel * h.sigmaCross());
    EXPECT_NEAR(th->sigma_about_rad, h.sigmaAbout(), kRel * h.sigmaAbout());
    EXPECT_NEAR(th->config.sigma_cross_rad, c.sigma_cross_rad, kRel * c.sigma_cross_rad);
    EXPECT_NEAR(th->config.sigma_roll_rad, c.sigma_roll_rad, kRel * c.sigma_roll_rad);
    EXPECT_NEAR(th->config.sigma_star_rad, c.sigma_star_rad, kRel * c.sigma_star_rad);
    EXPECT_EQ(th->config.rate_hz, c.rate_hz);
    EXPECT_EQ(th->config.tag_offset_us, c.tag_offset_us);
    EXPECT_EQ(th->config.tag_jitter_us, c.tag_jitter_us);
    EXPECT_EQ(th->config.tag_drift_ppm, c.tag_drift_ppm);
    EXPECT_NEAR(th->config.fov_half_angle_rad, c.fov_half_angle_rad, 1e-15);
    EXPECT_NEAR(th->config.earth_exclusion_rad, c.earth_exclusion_rad, 1e-15);
    EXPECT_EQ(th->config.limiting_mag, c.limiting_mag);
    EXPECT_EQ(th->time_offset_s, h.effects().time_offset_s);
    ASSERT_EQ(th->clock_drifts.size(), h.effects().clock_drifts.size());
    for (std::size_t k = 0; k < th->clock_drifts.size(); ++k) {
      EXPECT_EQ(th->clock_drifts[k].rate_ppm, h.effects().clock_drifts[k].rate_ppm);
      EXPECT_EQ(th->clock_drifts[k].offset_s, h.effects().clock_drifts[k].offset_s);
      EXPECT_EQ(th->clock_drifts[k].start_s, h.effects().clock_drifts[k].start_s);
    }
    const auto& st = s.stats();
    EXPECT_EQ(th->samples, st.head_samples[i]);
    EXPECT_EQ(th->missing, st.head_missing[i]);
    EXPECT_EQ(th->outliers, st.head_outliers[i]);
    EXPECT_EQ(th->sign_flips, st.head_sign_flips[i]);
    EXPECT_EQ(th->blinded_earth, st.head_blinded_earth[i]);
    EXPECT_EQ(th->missing_runs, st.head_missing_run_count[i]);
    ASSERT_EQ(th->missing_intervals.size(), st.head_missing_runs[i].size());
    for (std::size_t k = 0; k < th->missing_intervals.size(); ++k) {
      EXPECT_EQ(th->missing_intervals[k].start_s, st.head_missing_runs[i][k].start_s);
      EXPECT_EQ(th->missing_intervals[k].end_s, st.head_missing_runs[i][k].end_s);
    }
    runs_seen += th->missing_runs;
    EXPECT_NEAR(th->outlier_probability, model::OutlierSampler(h.effects().outliers, 0, 0).probability(), 1e-16);
    EXPECT_NEAR(th->expected_random_missing_fraction, model::expectedMissingFraction(h.effects().random_gaps), 1e-16);
    // The coloured effects: models, fields and the realised RMS.
    expectSameModel(th->coloured_cross, h.effects().coloured_cross, "coloured cross");
    expectSameModel(th->coloured_about, h.effects().coloured_about, "coloured about");
    expectSameModel(th->wander_cross, h.effects().wander_cross, "wander cross");
    expectSameModel(th->wander_about, h.effects().wander_about, "wander about");
    ASSERT_EQ(th->fov_fields.size(), h.fovFields().size());
    for (std::size_t k = 0; k < th->fov_fields.size(); ++k) {
      const auto &a = th->fov_fields[k], &b = h.fovFields()[k];
      EXPECT_EQ(a.order, b.order);
      EXPECT_NEAR(a.rms_rad, b.rms_rad, kRel * b.rms_rad);
      ASSERT_EQ(a.cx.size(), b.cx.size());
      for (std::size_t j = 0; j < a.cx.size(); ++j) {
        EXPECT_NEAR(a.cx[j], b.cx[j], kRel * b.rms_rad);
        EXPECT_NEAR(a.cy[j], b.cy[j], kRel * b.rms_rad);
      }
    }
    const auto rms = [&](const Vec3& ss) { return Vec3((ss / static_cast<double>(st.head_samples[i])).cwiseSqrt()); };
    expectNearVec(th->coloured_rms_rad, h.effects().hasColoured() ? rms(st.head_coloured_ss[i]) : Vec3::Zero(), "coloured rms");
    expectNearVec(th->wander_rms_rad, h.effects().hasWander() ? rms(st.head_wander_ss[i]) : Vec3::Zero(), "wander rms");
    expectNearVec(th->fov_rms_rad, h.hasFovError() ? rms(st.head_fov_ss[i]) : Vec3::Zero(), "fov rms");
    expectNearVec(th->fov_mean_rad, h.hasFovError() ? Vec3(st.head_fov_sum[i] / static_cast<double>(st.head_samples[i])) : Vec3::Zero(),
                  "fov mean");
  }
  // Which heads carry what: coloured noise on all (two terms on head 1), the wander on head 3, the
  // fields on head 2, and each realised.
  EXPECT_EQ(t.head(1)->coloured_cross.terms.size(), 2u);
  EXPECT_EQ(t.head(2)->coloured_cross.terms.size(), 1u);
  EXPECT_TRUE(t.head(2)->coloured_about.empty());
  EXPECT_EQ(t.head(3)->wander_cross.terms.size(), 1u);
  EXPECT_TRUE(t.head(1)->wander_cross.empty());
  EXPECT_EQ(t.head(2)->fov_fields.size(), 2u);
  EXPECT_EQ(t.head(2)->fov_fields[1].order, 5);
  EXPECT_GT(t.head(2)->fov_rms_rad.norm(), 0);
  EXPECT_GT(t.head(3)->wander_rms_rad.x(), 0);
  EXPECT_GT(t.head(1)->coloured_rms_rad.z(), 0);
  // The events are there to compare: head 1's dropout is one run [200, 220); heads 2 (two outlier
  // processes) and 3 (flips, gaps) have hits.
  const sim::TruthHead* h1 = t.head(1);
  ASSERT_EQ(h1->missing_runs, 1u);
  EXPECT_NEAR(h1->missing_intervals[0].start_s, 200.0, 0.5);
  EXPECT_NEAR(h1->missing_intervals[0].end_s, 220.0, 0.5);
  EXPECT_EQ(h1->missing, 40u);
  EXPECT_GT(t.head(2)->outliers, 0u);
  EXPECT_GT(t.head(3)->sign_flips, 0u);
  EXPECT_GT(t.head(3)->missing_runs, 1u);
  EXPECT_GT(runs_seen, 2u);
  // Head 3: the missing runs cover exactly the missing samples (2 Hz: a run of k samples lasts k/2 s,
  // up to the head's +-17 us tag jitter at both ends).
  double covered = 0;
  for (const auto& r : t.head(3)->missing_intervals) covered += r.end_s - r.start_s;
  EXPECT_NEAR(covered, 0.5 * static_cast<double>(t.head(3)->missing), 2 * 17e-6 * static_cast<double>(t.head(3)->missing_runs));

  // Accelerometer.
  const auto& a = s.accel();
  EXPECT_EQ(t.acc.config.C_A_B, a.config().C_A_B);
  EXPECT_LT((t.acc.C_B_A_true - a.C_A_B_true().transpose()).norm(), 1e-16);
  expectNearVec(t.acc.misalignment_rad, a.effects().misalignment_rad, "acc misalignment");
  EXPECT_EQ(t.acc.injected_bias_rad_s2, a.effects().bias_rad_s2);
  EXPECT_EQ(t.acc.config.bias_rad_s2, a.config().bias_rad_s2);
  EXPECT_EQ(t.acc.scale, a.effects().scale);
  EXPECT_EQ(t.acc.config.white_rad_s2, a.config().white_rad_s2);
  EXPECT_EQ(t.acc.config.lowfreq_rad_s2, a.config().lowfreq_rad_s2);
  EXPECT_EQ(t.acc.config.lowfreq_tau_s, a.config().lowfreq_tau_s);
  EXPECT_EQ(t.acc.config.lin_white_m_s2, a.config().lin_white_m_s2);
  EXPECT_EQ(t.acc.config.tag_offset_us, a.config().tag_offset_us);
  EXPECT_EQ(t.acc.config.tag_drift_ppm, -60.0);
  EXPECT_EQ(t.acc.time_offset_s, a.effects().time_offset_s);
  EXPECT_EQ(t.acc.time_offset_s, -0.015);
  ASSERT_EQ(t.acc.clock_drifts.size(), 1u);
  EXPECT_EQ(t.acc.clock_drifts[0].rate_ppm, -2.0);
  EXPECT_EQ(t.acc.samples, s.stats().acc_samples);
  EXPECT_EQ(t.acc.missing, s.stats().acc_missing);
  EXPECT_EQ(t.acc.missing_runs, s.stats().acc_missing_run_count);
  EXPECT_GT(t.acc.missing_runs, 0u);
  EXPECT_EQ(t.acc.missing_intervals.size(), s.stats().acc_missing_runs.size());
  for (std::size_t k = 0; k < 3; ++k) {
    expectSameModel(t.acc.coloured[k], a.effects().coloured[k], "acc coloured");
    expectSameModel(t.acc.bias_wander[k], a.effects().bias_wander[k], "acc bias wander");
  }
  EXPECT_EQ(t.acc.coloured[0].terms.size(), 1u);
  EXPECT_TRUE(t.acc.coloured[2].empty());
  EXPECT_EQ(t.acc.bias_wander[2].terms.size(), 1u);
  const Vec3 acc_n = Vec3::Constant(static_cast<double>(s.stats().acc_samples));
  expectNearVec(t.acc.coloured_rms_rad_s2, s.stats().acc_coloured_ss.cwiseQuotient(acc_n).cwiseSqrt(), "acc coloured rms");
  expectNearVec(t.acc.bias_wander_rms_rad_s2, s.stats().acc_bias_wander_ss.cwiseQuotient(acc_n).cwiseSqrt(), "acc wander rms");
  EXPECT_GT(t.acc.bias_wander_rms_rad_s2.z(), 0);
  fs::remove_all(w.dir);
}

TEST(SimTruth, BadTruthFilesNameTheFileAndTheKey) {
  auto w = writeOne("bad");
  const std::string good = slurp(w.path);
  auto expectError = [&](const std::string& from, const std::string& to, const std::string& want) {
    std::string text = good;
    const auto p = text.find(from);
    ASSERT_NE(p, std::string::npos) << from;
    text.replace(p, from.size(), to);
    const std::string bad = (w.dir / "bad_truth.yaml").string();
    put(bad, text);
    sim::TruthFile t;
    std::string err;
    EXPECT_FALSE(sim::readTruthYaml(bad, t, &err)) << from;
    EXPECT_NE(err.find(bad + ":"), std::string::npos) << err;
    EXPECT_NE(err.find(want), std::string::npos) << err;
  };
  expectError("      star_arcsec: 5\n", "", "key 'heads[0].noise.star_arcsec': missing");
  expectError("  lowfreq_tau_s: 2000", "  lowfreq_tau_s: long", "key 'accelerometer.lowfreq_tau_s': 'long' is not a finite number");
  expectError("    rate: 0.029999999999999999", "    rate: 3", "key 'effects[4]': --effect: effect sign_flips: key 'rate': must be a probability");
  expectError("name: cross_noise", "name: cross_nois", "unknown effect");
  expectError("    q_Si_B_true: [", "    q_Si_B_true: [0.5, ", "key 'heads[0].q_Si_B_true': expected a list of 4 numbers");
  expectError("kind: gauss_markov", "kind: pink", "key 'heads[0].coloured_noise.cross[0].kind': expected gauss_markov, power_law or white");
  expectError("- order: 5", "- order: 4", "key 'heads[1].fov_error.fields[1].cx_arcsec': expected 14 coefficients for order 4");
  sim::TruthFile t;
  std::string err;
  EXPECT_FALSE(sim::readTruthYaml((w.dir / "absent.yaml").string(), t, &err));
  EXPECT_NE(err.find("absent.yaml: cannot open"), std::string::npos) << err;
  fs::remove_all(w.dir);
}

}  // namespace
}  // namespace boresight

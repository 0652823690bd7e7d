// Files written by the simulator read back through the io readers with identical values; runs are
// deterministic for a seed; scenarios are validated with FILE:LINE: key 'k': reason messages.
#include "sim_test_util.h"
#include "test_files.h"

#include <boresight/io/lcm_log.h>
#include <boresight/sim/output.h>

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace boresight {
namespace {

namespace fs = std::filesystem;
using simtest::gracefo;

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Written {
  fs::path dir;
  simtest::Capture cap;
  std::vector<std::string> files;
  std::unique_ptr<sim::Simulator> sim;
};

/// The simulate pipeline (as the command runs it) with a capture sink alongside.
std::unique_ptr<Written> simulateTo(const sim::Scenario& sc, std::uint64_t seed, double duration, const std::string& name,
                                    std::size_t chunk_note = 0) {
  (void)chunk_note;
  auto w = std::make_unique<Written>();
  w->dir = testutil::makeTempDir("boresight_sim_io_" + name);
  w->sim = std::make_unique<sim::Simulator>();
  std::string err;
  EXPECT_TRUE(w->sim->init(sc, seed, duration, &err)) << err;
  sim::Level1Sink l1;
  sim::LcmSink log;
  sim::TeeSink tee;
  EXPECT_TRUE(l1.open(w->dir.string(), sc, &err)) << err;
  EXPECT_TRUE(log.open((w->dir / "sim.lcmlog").string(), &err)) << err;
  tee.add(&l1);
  tee.add(&log);
  tee.add(&w->cap);
  w->sim->run(tee);
  EXPECT_TRUE(l1.close(&err)) << err;
  EXPECT_TRUE(log.close(&err)) << err;
  w->files = l1.files();
  const std::string qsa = (w->dir / sim::productFileName("QSA1B", sc)).string();
  EXPECT_TRUE(sim::writeQsa1b(qsa, *w->sim, &err)) << err;
  w->files.push_back(qsa);
  EXPECT_TRUE(sim::writeTruthYaml((w->dir / "truth.yaml").string(), *w->sim, {}, w->files, &err)) << err;
  return w;
}

TEST(SimIo, Level1FilesAndLcmLogReadBackIdentical) {
  auto sc = simtest::withEffects(gracefo(), {"sign_flips:sensor=1,rate=0.05", "outliers:sensor=2,rate=0.01"});
  // 3600 s: more than one 16384-record chunk of SCA1A and ACC1A, so chunk joins are exercised.
  auto w = simulateTo(sc, 5, 3600, "roundtrip");
  const char sat = sc.satellite;

  const auto sca = io::readProduct<io::Sca1aRecord>(w->files[0]);
  ASSERT_TRUE(sca.ok) << sca.error;
  EXPECT_EQ(sca.rejected_count, 0u);
  std::vector<io::Sca1aRecord> expect_sca;
  for (const auto& h : w->cap.heads)
    if (!h.blind) expect_sca.push_back(sim::toSca1a(h, sat));
  ASSERT_EQ(sca.records.size(), expect_sca.size());
  ASSERT_GT(sca.records.size(), 16384u);
  for (std::size_t i = 0; i < expect_sca.size(); ++i) ASSERT_TRUE(sca.records[i] == expect_sca[i]) << "SCA1A record " << i;
  ASSERT_TRUE(sca.header.declared_records.has_value());
  EXPECT_EQ(*sca.header.declared_records, static_cast<std::int64_t>(expect_sca.size()));
  EXPECT_EQ(sca.header.satellite, sat);

  const auto acc = io::readProduct<io::FlaggedRecord>(w->files[1]);
  ASSERT_TRUE(acc.ok) << acc.error;
  EXPECT_EQ(acc.rejected_count, 0u);
  ASSERT_EQ(acc.records.size(), w->cap.acc.size());
  ASSERT_GT(acc.records.size(), 16384u);
  for (std::size_t i = 0; i < acc.records.size(); ++i)
    ASSERT_TRUE(acc.records[i] == sim::toAcc1a(w->cap.acc[i], sat)) << "ACC1A record " << i;
  EXPECT_EQ(*acc.header.declared_records, static_cast<std::int64_t>(acc.records.size()));
  // The angular acceleration columns carry the simulated values bit for bit.
  EXPECT_EQ(acc.records[100].value[io::acc_bits::kAngY], w->cap.acc[100].ang_A.y());

  const auto gnv = io::readProduct<io::GnvRecord>(w->files[2]);
  ASSERT_TRUE(gnv.ok) << gnv.error;
  ASSERT_EQ(gnv.records.size(), w->cap.orb.size());
  ASSERT_EQ(gnv.records.size(), 3600u);
  for (std::size_t i = 0; i < gnv.records.size(); ++i)
    ASSERT_TRUE(gnv.records[i] == sim::toGnv1b(w->cap.orb[i], sat)) << "GNV1B record " << i;

  // SCV1A: every star vector of every head epoch, in order, values bit for bit
  ASSERT_EQ(w->files.size(), 5u);  // SCA1A ACC1A GNV1B SCV1A QSA1B
  const auto scv = io::readProduct<io::ScvRecord>(w->files[3]);
  ASSERT_TRUE(scv.ok) << scv.error;
  EXPECT_EQ(scv.rejected_count, 0u);
  {
    std::vector<io::ScvRecord> expect, one;
    for (const auto& v : w->cap.sv) {
      sim::toScv1a(v, sat, one);
      expect.insert(expect.end(), one.begin(), one.end());
    }
    ASSERT_GT(expect.size(), 3u * 360u);  // 3 heads x 360 ten-second epochs, at least one star each
    ASSERT_EQ(scv.records.size(), expect.size());
    for (std::size_t i = 0; i < expect.size(); ++i) ASSERT_TRUE(scv.records[i] == expect[i]) << "SCV1A record " << i;
  }

  const auto qsa = io::readProduct<io::QsaRecord>(w->files[4]);
  ASSERT_TRUE(qsa.ok) << qsa.error;
  ASSERT_EQ(qsa.records.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    double q[4];
    quatToScalarFirst(sc.heads[i].q_Si_B, q);
    EXPECT_EQ(qsa.records[i].sensor, sc.heads[i].id);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(qsa.records[i].q[k], q[k]);
  }

  // LCM log: the same samples in the same order, values bit for bit.
  io::LcmLogReader rd;
  std::string err;
  ASSERT_TRUE(rd.open((w->dir / "sim.lcmlog").string(), &err)) << err;
  io::HeadSample hs;
  io::AccelSample as;
  std::size_t ih = 0, ia = 0, is = 0, io_ = 0;
  std::vector<const sim::HeadSampleOut*> delivered;
  for (const auto& h : w->cap.heads)
    if (!h.blind) delivered.push_back(&h);
  for (;;) {
    const auto k = rd.next(hs, as);
    if (k == io::LcmLogReader::Kind::End) break;
    ASSERT_NE(k, io::LcmLogReader::Kind::Skipped);  // every message is of a type the reader knows
    if (k == io::LcmLogReader::Kind::Head) {
      ASSERT_LT(ih, delivered.size());
      const auto& e = *delivered[ih++];
      EXPECT_EQ(hs.utime, e.tag);
      EXPECT_EQ(hs.head_id, e.head);
      double q[4];
      quatToScalarFirst(e.q_I_Si, q);
      for (int j = 0; j < 4; ++j) ASSERT_EQ(hs.q[j], q[j]);
      EXPECT_EQ(hs.star_count, e.nstars);
    } else if (k == io::LcmLogReader::Kind::Stars) {
      ASSERT_LT(is, w->cap.sv.size());
      const auto& e = w->cap.sv[is];
      const io::StarVectors& m = rd.stars();
      EXPECT_EQ(m.utime, e.tag);
      EXPECT_EQ(m.head_id, e.head);
      EXPECT_EQ(m.seq, static_cast<std::int32_t>(is));
      ASSERT_EQ(m.n_stars, e.n);
      for (int j = 0; j < e.n; ++j) {
        EXPECT_EQ(m.star_id[j], e.star[static_cast<std::size_t>(j)].hip);
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(m.s_head[j][c], e.star[static_cast<std::size_t>(j)].s_Si[c]);
          ASSERT_EQ(m.r_inertial[j][c], e.star[static_cast<std::size_t>(j)].r_I[c]);
        }
      }
      ++is;
    } else if (k == io::LcmLogReader::Kind::Orbit) {  // inertial, as GNI1B
      ASSERT_LT(io_, w->cap.orb.size());
      const auto& e = w->cap.orb[io_++];
      const io::OrbitSample& m = rd.orbit();
      EXPECT_EQ(m.utime, e.t);
      EXPECT_EQ(m.frame, 'I');
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(m.r_m[c], e.r_I[c]);
        ASSERT_EQ(m.v_m_s[c], e.v_I[c]);
      }
    } else {
      ASSERT_LT(ia, w->cap.acc.size());
      const auto& e = w->cap.acc[ia++];
      EXPECT_EQ(as.utime, e.tag);
      for (int j = 0; j < 3; ++j) ASSERT_EQ(as.ang_accel[j], e.ang_A[j]);
    }
  }
  EXPECT_EQ(ih, delivered.size());
  EXPECT_EQ(ia, w->cap.acc.size());
  EXPECT_EQ(is, w->cap.sv.size());
  // The orbit travels as ORBIT messages, one per sample; no other channel, nothing undecodable.
  EXPECT_EQ(io_, w->cap.orb.size());
  EXPECT_GT(w->cap.orb.size(), 0u);
  EXPECT_EQ(rd.unknownChannel(), 0u);
  EXPECT_EQ(rd.decodeFailures(), 0u);

  // truth.yaml: the true mounting of each head and the injected effects.
  const YAML::Node t = YAML::LoadFile((w->dir / "truth.yaml").string());
  EXPECT_EQ(t["seed"].as<std::uint64_t>(), 5u);
  ASSERT_EQ(t["heads"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    double q[4];
    quatToScalarFirst(w->sim->heads()[i].qSiBTrue(), q);
    for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(t["heads"][i]["q_Si_B_true"][k].as<double>(), q[k]);
    EXPECT_NEAR(t["heads"][i]["mounting_error_arcsec"][2].as<double>(), sc.heads[i].mounting_error_rad.z() * kArcsecPerRad, 1e-9);
  }
  ASSERT_EQ(t["effects"].size(), 2u);
  EXPECT_EQ(t["effects"][0]["name"].as<std::string>(), "sign_flips");
  EXPECT_EQ(t["effects"][0]["rate"].as<double>(), 0.05);
  EXPECT_EQ(t["heads"][0]["sign_flips"].as<std::uint64_t>(), w->sim->stats().head_sign_flips[0]);
  fs::remove_all(w->dir);
}

TEST(SimIo, SameSeedSameBytesOtherSeedOtherBytes) {
  const auto sc = gracefo();
  auto a = simulateTo(sc, 77, 300, "det_a"), b = simulateTo(sc, 77, 300, "det_b"), c = simulateTo(sc, 78, 300, "det_c");
  for (std::size_t i = 0; i < a->files.size(); ++i) {
    const auto fa = slurp(a->files[i]), fb = slurp(b->files[i]);
    EXPECT_FALSE(fa.empty());
    EXPECT_EQ(fa, fb) << a->files[i];
  }
  EXPECT_EQ(slurp((a->dir / "sim.lcmlog").string()), slurp((b->dir / "sim.lcmlog").string()));
  EXPECT_NE(slurp(a->files[0]), slurp(c->files[0]));
  for (auto* w : {a.get(), b.get(), c.get()}) fs::remove_all(w->dir);
}

TEST(SimIo, EveryCommittedScenarioLoadsAndRuns) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(simtest::sourceDir() + "/config")) {
    const std::string name = e.path().filename().string();
    if (name.rfind("sim_", 0) != 0 || e.path().extension() != ".yaml") continue;
    sim::Scenario sc;
    std::string err;
    ASSERT_TRUE(sim::loadScenario(e.path().string(), sc, &err)) << err;
    sim::Simulator s;
    ASSERT_TRUE(s.init(sc, 1, 30, &err)) << name << ": " << err;
    simtest::Capture cap;
    s.run(cap);
    EXPECT_EQ(cap.acc.size(), 300u) << name;
    ++n;
  }
  EXPECT_GE(n, 2u);
}

TEST(SimIo, NoisePresetLayersStackOnAnyScenario) {
  const std::string dir = simtest::sourceDir() + "/config";
  sim::Scenario g, r, audit, ar, cal, cr;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(dir + "/sim_gracefo.yaml", g, &err)) << err;
  ASSERT_TRUE(sim::loadScenario(dir + "/sim_gracefo_realistic.yaml", r, &err)) << err;
  ASSERT_TRUE(sim::loadScenario(dir + "/sim_audit.yaml", audit, &err)) << err;
  ASSERT_TRUE(sim::loadScenario(dir + "/sim_audit_realistic.yaml", ar, &err)) << err;
  ASSERT_TRUE(sim::loadScenario(dir + "/sim_gracefo_calibration.yaml", cal, &err)) << err;
  // The preset on a scenario that injects effects: appended, not replaced.
  ASSERT_TRUE(sim::parseScenario("base: [sim_gracefo_calibration.yaml, preset_realistic.yaml]\n", "cal_real.yaml", dir, cr, &err))
      << err;
  EXPECT_EQ(r.file, dir + "/sim_gracefo_realistic.yaml");
  const double measured[3][2] = {{2.29, 21.1}, {1.69, 30.8}, {2.32, 29.9}};
  for (const auto* s : {&r, &ar, &cr}) {
    ASSERT_EQ(s->heads.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_NEAR(s->heads[i].sigma_cross_rad * kArcsecPerRad, measured[i][0], 1e-12);
      EXPECT_NEAR(s->heads[i].sigma_roll_rad * kArcsecPerRad, measured[i][1], 1e-12);
    }
  }
  // Everything else is the scenario's: mountings (with and without errors), duration, accelerometer.
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(r.heads[i].q_Si_B.coeffs(), g.heads[i].q_Si_B.coeffs());
    EXPECT_EQ(r.heads[i].mounting_error_rad, g.heads[i].mounting_error_rad);
    EXPECT_EQ(ar.heads[i].mounting_error_rad, audit.heads[i].mounting_error_rad);
    EXPECT_EQ(r.heads[i].tag_offset_us, g.heads[i].tag_offset_us);
    EXPECT_EQ(r.heads[i].sigma_star_rad, g.heads[i].sigma_star_rad);
  }
  EXPECT_EQ(ar.duration_s, audit.duration_s);
  EXPECT_EQ(ar.acc.bias_rad_s2, audit.acc.bias_rad_s2);
  EXPECT_EQ(r.acc.white_rad_s2, g.acc.white_rad_s2);
  EXPECT_EQ(ar.output.star_vectors_interval_s, 0.0);
  // The preset's five effects, after the scenario's own.
  ASSERT_EQ(r.effects.size(), g.effects.size() + 5);
  ASSERT_EQ(cr.effects.size(), cal.effects.size() + 5);
  ASSERT_GT(cal.effects.size(), 0u);
  for (std::size_t i = 0; i < cal.effects.size(); ++i) EXPECT_EQ(cr.effects[i].values, cal.effects[i].values);
  const std::vector<std::string> names = {"coloured_noise", "fov_error", "thermal_wander", "acc_coloured_noise", "acc_bias_wander"};
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(cr.effects[cal.effects.size() + i].name, names[i]);
    EXPECT_EQ(cr.effects[cal.effects.size() + i].origin, "preset_realistic.yaml: add_effects[" + std::to_string(i) + "]");
  }
  // `effects` in the file that lists the layers still replaces the whole list.
  sim::Scenario only;
  ASSERT_TRUE(sim::parseScenario("base: [sim_gracefo.yaml, preset_realistic.yaml]\neffects: [{name: step, sensor: 1, at_s: 5}]\n",
                                 "x.yaml", dir, only, &err))
      << err;
  ASSERT_EQ(only.effects.size(), 1u);
  EXPECT_EQ(only.heads[0].sigma_cross_rad, r.heads[0].sigma_cross_rad);
  // The layer alone is not a scenario (no heads); errors name the file, the line and the key.
  EXPECT_FALSE(sim::loadScenario(dir + "/preset_realistic.yaml", only, &err));
  sim::Scenario bad;
  EXPECT_FALSE(sim::parseScenario("base: [sim_gracefo.yaml, sim_audit.yaml]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("b.yaml:1: key 'base[1]': the layer does not apply:"), std::string::npos) << err;
  EXPECT_NE(err.find("cannot have a base of its own"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: [sim_gracefo.yaml, nothere.yaml]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("nothere.yaml: cannot open"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: []\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("key 'base'"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: sim_gracefo.yaml\nhead_overrides: [{id: 7, noise_cross_arcsec: 1}]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("b.yaml:2: key 'head_overrides[0].id': no head 7"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: sim_gracefo.yaml\nhead_overrides: [{noise_cross_arcsec: 1}]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("key 'head_overrides[0].id': required"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: sim_gracefo.yaml\nhead_overrides: [{id: 1, noise_cros_arcsec: 1}]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("key 'head_overrides[0].noise_cros_arcsec': unknown key"), std::string::npos) << err;
  EXPECT_FALSE(sim::parseScenario("base: sim_gracefo.yaml\nadd_effects: [{name: fov_error, sensor: 1}]\n", "b.yaml", dir, bad, &err));
  EXPECT_NE(err.find("b.yaml: add_effects[0]: effect fov_error: key 'arcsec': required"), std::string::npos) << err;
}

std::string parseError(const std::string& yaml) {
  sim::Scenario sc;
  std::string err;
  EXPECT_FALSE(sim::parseScenario(yaml, "bad.yaml", simtest::sourceDir() + "/config", sc, &err)) << yaml;
  return err;
}

TEST(SimIo, ScenarioErrorsNameFileLineKeyAndReason) {
  const std::string base = slurp(simtest::sourceDir() + "/config/sim_gracefo.yaml");
  sim::Scenario ok;
  std::string err;
  ASSERT_TRUE(sim::parseScenario(base, "good.yaml", simtest::sourceDir() + "/config", ok, &err)) << err;
  EXPECT_EQ(ok.heads.size(), 3u);
  EXPECT_NEAR(ok.orbit.altitude_m, 490e3, 1e-6);
  EXPECT_NEAR(ok.heads[0].sigma_roll_rad * kArcsecPerRad, 48, 1e-9);
  EXPECT_EQ(ok.acc.C_A_B, accToBodyDefault().transpose());

  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = base;
    const auto p = s.find(from);
    EXPECT_NE(p, std::string::npos) << from;
    return s.replace(p, from.size(), to);
  };
  std::string e = parseError(replace("  altitude_km: 490", "  altitude_km: high"));
  EXPECT_NE(e.find("bad.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("key 'orbit.altitude_km': expected a number"), std::string::npos) << e;
  e = parseError(replace("  inclination_deg: 89.0", "  inclination_deg: 200"));
  EXPECT_NE(e.find("key 'orbit.inclination_deg': value 200 outside [0, 180]"), std::string::npos) << e;
  e = parseError(replace("  altitude_km: 490", "  altitude_kn: 490"));
  EXPECT_NE(e.find("key 'orbit.altitude_kn': unknown key"), std::string::npos) << e;
  e = parseError(replace("  noise_cross_arcsec: 6 ", "  noise_cross_arcsec: [6] "));
  EXPECT_NE(e.find("key 'head_defaults.noise_cross_arcsec'"), std::string::npos) << e;
  e = parseError(replace("effects: []", "effects:\n  - {name: thermal_periodic, sensor: 2, harmonic: 0}"));
  EXPECT_NE(e.find("effects[0]: effect thermal_periodic: key 'harmonic'"), std::string::npos) << e;
  e = parseError(replace("effects: []", "effects:\n  - {name: step, sensor: 5, at_s: 3}"));
  EXPECT_NE(e.find("no head 5"), std::string::npos) << e;
  e = parseError(replace("    - [0, 0, 1]\n    - [1, 0, 0]", "    - [0, 0, 2]\n    - [1, 0, 0]"));
  EXPECT_NE(e.find("key 'accelerometer.C_B_A': expected a 3x3 proper rotation"), std::string::npos) << e;
  e = parseError(replace("  - id: 2", "  - id: 1"));
  EXPECT_NE(e.find("duplicate head id"), std::string::npos) << e;
  e = parseError(replace("start: \"2023-06-01T00:00:00\"", "start: \"2023-13-01\""));
  EXPECT_NE(e.find("key 'start'"), std::string::npos) << e;
  e = parseError("orbit: [1, 2\n");
  EXPECT_NE(e.find("YAML syntax"), std::string::npos) << e;
  // Line numbers point at the offending line.
  const std::string bad = replace("  altitude_km: 490", "  altitude_km: high");
  std::size_t line = 1;
  for (std::size_t i = 0; i < bad.find("altitude_km: high"); ++i) line += bad[i] == '\n';
  EXPECT_NE(parseError(bad).find("bad.yaml:" + std::to_string(line) + ":"), std::string::npos);
}

}  // namespace
}  // namespace boresight

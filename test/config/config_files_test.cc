// Configuration files: the committed files load; unknown or misspelt keys are errors with file:line
// and the nearest known key; scenario overlays; the one accelerometer rotation C_B_A; calendar dates;
// the platform file's noise section (the old per-head sigma keys name its place), `base:` platform
// files and the ideal preset config/gracefo_ideal.yaml.
#include <boresight/io/config_keys.h>
#include <boresight/io/core_config.h>
#include <boresight/model/overlay.h>
#include <boresight/io/time_format.h>
#include <boresight/sim/scenario.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace boresight {
namespace {

const std::string kConfigDir = std::string(BORESIGHT_SOURCE_DIR) + "/config";

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Writes text to a file in the test's temporary directory and returns its path.
std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "config_test_" + name;
  std::ofstream(path) << text;
  return path;
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << "test fixture: '" << from << "' not in the file";
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

int lineOfText(const std::string& text, const std::string& what) {
  const auto p = text.find(what);
  if (p == std::string::npos) return -1;
  int line = 1;
  for (std::size_t i = 0; i < p; ++i) line += text[i] == '\n';
  return line;
}

TEST(ConfigKeys, NearestKeyIsATypoDistanceAway) {
  const std::vector<std::string> known = {"sigma_cross_arcsec", "sigma_roll_arcsec", "sigma_star_arcsec", "id"};
  EXPECT_EQ(io::nearestKey("sigma_cros_arcsec", known), "sigma_cross_arcsec");
  EXPECT_EQ(io::nearestKey("sigma_rol_arcsec", known), "sigma_roll_arcsec");
  EXPECT_EQ(io::nearestKey("completely_else", known), "");
  EXPECT_EQ(io::editDistance("kitten", "sitting"), 3u);
  EXPECT_NE(io::unknownKeyMessage("zzz", known).find("known here: sigma_cross_arcsec"), std::string::npos);
}

TEST(PlatformConfig, CommittedFileLoads) {
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc, &err)) << err;
  EXPECT_EQ(pc.pipeline.heads.n_heads, 3);
  EXPECT_TRUE(pc.mounting_from_qsa1b);
  EXPECT_EQ(pc.mounting_uncertainty_arcsec, 360.0);
  EXPECT_TRUE(pc.pipeline.C_B_A.isApprox(accToBodyDefault()));
  // The noise of the real excerpts: 2" across, 25" about the boresight, 5" per star direction; the
  // accelerometer's white levels per A axis.
  for (int s = 0; s < 3; ++s) {
    const auto& h = pc.pipeline.heads.head[static_cast<std::size_t>(s)];
    EXPECT_NEAR(h.sigma_cross_rad * kArcsecPerRad, 2.0, 1e-12);
    EXPECT_NEAR(h.sigma_roll_rad * kArcsecPerRad, 25.0, 1e-12);
    EXPECT_NEAR(h.sigma_star_rad * kArcsecPerRad, 5.0, 1e-12);
    for (int a = 0; a < model::kHeadAxes; ++a)
      EXPECT_EQ(pc.noise_in_use.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].source,
                kConfigDir + "/gracefo.yaml noise.head_defaults");
  }
  EXPECT_EQ(pc.noise_in_use.accWhiteSigma(0), 1.5e-7);
  EXPECT_EQ(pc.noise_in_use.accWhiteSigma(1), 3.0e-8);
  EXPECT_EQ(pc.noise_in_use.accWhiteSigma(2), 5.0e-8);
  EXPECT_EQ(pc.noise_in_use.acc[2].source, kConfigDir + "/gracefo.yaml noise.accelerometer");
}

TEST(PlatformConfig, IdealPresetIsTheSamePlatformWithTheSimulatorsNoise) {
  io::PlatformConfig real, ideal;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", real, &err)) << err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo_ideal.yaml", ideal, &err)) << err;
  // the noise the simulator's scenarios carry, bit for bit what the heads had before the noise section
  for (int s = 0; s < 3; ++s) {
    const auto& h = ideal.pipeline.heads.head[static_cast<std::size_t>(s)];
    EXPECT_EQ(h.sigma_cross_rad, 6.0 * kRadPerArcsec);
    EXPECT_EQ(h.sigma_roll_rad, 48.0 * kRadPerArcsec);
    EXPECT_EQ(h.sigma_star_rad, 5.0 * kRadPerArcsec);
    EXPECT_EQ(ideal.noise_in_use.head[static_cast<std::size_t>(s)][0].source, kConfigDir + "/gracefo_ideal.yaml noise.head_defaults");
  }
  sim::Scenario sc;
  ASSERT_TRUE(sim::loadScenario(kConfigDir + "/sim_gracefo.yaml", sc, &err)) << err;
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(ideal.noise_in_use.accWhiteSigma(a), sc.acc.white_rad_s2[a]) << a;  // method A's default weights
    const auto& gm = ideal.noise_in_use.acc[static_cast<std::size_t>(a)].noise.model.markovTerms();
    ASSERT_EQ(gm.size(), 1u);
    EXPECT_NEAR(std::sqrt(gm[0].var), sc.acc.lowfreq_rad_s2[a], 1e-20);
    EXPECT_EQ(gm[0].tau_s, sc.acc.lowfreq_tau_s);
  }
  for (const auto& h : sc.heads) {
    EXPECT_EQ(h.sigma_cross_rad, ideal.pipeline.heads.head[0].sigma_cross_rad);
    EXPECT_EQ(h.sigma_roll_rad, ideal.pipeline.heads.head[0].sigma_roll_rad);
  }
  // everything else is the base's
  EXPECT_EQ(ideal.platform, real.platform);
  EXPECT_EQ(ideal.mounting_from_qsa1b, real.mounting_from_qsa1b);
  EXPECT_EQ(ideal.pipeline.heads.n_heads, real.pipeline.heads.n_heads);
  for (int s = 0; s < 3; ++s) {
    EXPECT_EQ(ideal.pipeline.heads.head[static_cast<std::size_t>(s)].id, real.pipeline.heads.head[static_cast<std::size_t>(s)].id);
    EXPECT_EQ(ideal.pipeline.heads.head[static_cast<std::size_t>(s)].boresight_Si, real.pipeline.heads.head[static_cast<std::size_t>(s)].boresight_Si);
  }
  EXPECT_EQ(ideal.pipeline.crn_attitude.length_s, real.pipeline.crn_attitude.length_s);
  EXPECT_EQ(ideal.pipeline.crn_acc.fs_hz, real.pipeline.crn_acc.fs_hz);
  EXPECT_EQ(ideal.pipeline.C_B_A, real.pipeline.C_B_A);
  EXPECT_EQ(ideal.pipeline.wahba_correction, real.pipeline.wahba_correction);
  EXPECT_EQ(ideal.pipeline.deformation.tau_s, real.pipeline.deformation.tau_s);
  EXPECT_EQ(ideal.pipeline.heads.relative_time_constant_s, real.pipeline.heads.relative_time_constant_s);
  EXPECT_EQ(ideal.file, kConfigDir + "/gracefo_ideal.yaml");
}

TEST(PlatformConfig, MisspeltKeyIsAnErrorWithLineAndNearestKey) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  const std::string bad = replaced(base, "    cross_x: [{kind: white", "    cros_x: [{kind: white");
  const std::string path = writeTemp("misspelt.yaml", bad);
  io::PlatformConfig pc;
  std::string err;
  ASSERT_FALSE(io::loadPlatformConfig(path, pc, &err));
  const int line = lineOfText(bad, "cros_x");
  EXPECT_NE(err.find(path + ":" + std::to_string(line) + ":"), std::string::npos) << err;
  EXPECT_NE(err.find("noise.head_defaults.cros_x"), std::string::npos) << err;
  EXPECT_NE(err.find("did you mean 'cross_x'"), std::string::npos) << err;
}

TEST(PlatformConfig, OldSigmaKeysSayWhereTheValueMoved) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  struct Case {
    std::string key, moved;
  } cases[] = {{"sigma_cross_arcsec", "noise.head_defaults.cross_x and .cross_y"},
               {"sigma_roll_arcsec", "noise.head_defaults.about_boresight"},
               {"sigma_star_arcsec", "noise.head_defaults.star_direction"}};
  for (const auto& c : cases) {
    const std::string bad = replaced(base, "    - id: 2\n      boresight: [0, 0, 1]\n",
                                     "    - id: 2\n      boresight: [0, 0, 1]\n      " + c.key + ": 6.0\n");
    const std::string path = writeTemp("old_sigma.yaml", bad);
    io::PlatformConfig pc;
    std::string err;
    ASSERT_FALSE(io::loadPlatformConfig(path, pc, &err)) << c.key;
    EXPECT_NE(err.find(path + ":" + std::to_string(lineOfText(bad, c.key)) + ": key 'heads.list[1]." + c.key +
                       "': the head noise levels moved to the noise section: " + c.moved),
              std::string::npos)
        << err;
  }
}

TEST(PlatformConfig, NoiseSectionErrors) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  io::PlatformConfig pc;
  std::string err;
  // every axis needs a model
  std::string bad = replaced(base, "    star_direction: [{kind: white, sigma_arcsec: 5.0}]", "");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("no_star.yaml", bad), pc, &err));
  EXPECT_NE(err.find("key 'noise': no noise model for head 1 star_direction"), std::string::npos) << err;
  bad = replaced(base, "    z: [{kind: white, sigma_rad_s2: 5.0e-8}]", "");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("no_acc_z.yaml", bad), pc, &err));
  EXPECT_NE(err.find("no noise model for accelerometer z"), std::string::npos) << err;
  // per-head entries name configured heads
  bad = replaced(base, "  heads: []", "  heads: [{id: 4, about_boresight: [{kind: white, sigma_arcsec: 30}]}]");
  std::string path = writeTemp("head4.yaml", bad);
  EXPECT_FALSE(io::loadPlatformConfig(path, pc, &err));
  EXPECT_NE(err.find(path + ":" + std::to_string(lineOfText(bad, "heads: [{id: 4")) + ": key 'noise.heads[0].id': head 4 is not in heads.list"),
            std::string::npos) << err;
  // validity spans are an overlay's
  bad = replaced(base, "  heads: []", "  heads: [{id: 3, about_boresight: [{kind: white, sigma_arcsec: 30}], valid_from: \"2023-06-01\"}]");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("valid.yaml", bad), pc, &err));
  EXPECT_NE(err.find("key 'noise.heads[0].valid_from': validity spans belong in a model overlay"), std::string::npos) << err;
  // a key twice
  bad = replaced(base, "    cross_y: [{kind: white, sigma_arcsec: 2.0}]\n",
                 "    cross_y: [{kind: white, sigma_arcsec: 2.0}]\n    cross_y: [{kind: white, sigma_arcsec: 3.0}]\n");
  path = writeTemp("twice.yaml", bad);
  EXPECT_FALSE(io::loadPlatformConfig(path, pc, &err));
  EXPECT_NE(err.find(path + ":" + std::to_string(lineOfText(bad, "cross_y: [{kind: white, sigma_arcsec: 3.0}]")) +
                     ": key 'noise.head_defaults.cross_y': given twice"),
            std::string::npos) << err;
  // NaN
  bad = replaced(base, "sigma_arcsec: 25.0}", "sigma_arcsec: .nan}");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("nan.yaml", bad), pc, &err));
  EXPECT_NE(err.find("key 'noise.head_defaults.about_boresight[0].sigma_arcsec': not a finite number"), std::string::npos) << err;
}

TEST(PlatformConfig, PerHeadNoiseOverridesTheDefaults) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  const std::string text = replaced(base, "  heads: []",
                                    "  heads: [{id: 3, cross_x: [{kind: white, sigma_arcsec: 1.0}, {kind: gauss_markov, "
                                    "sigma_arcsec: 2.0, tau_s: 600}], about_boresight: [{kind: white, sigma_arcsec: 31}]}]");
  const std::string path = writeTemp("per_head.yaml", text);
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(path, pc, &err)) << err;
  // head 3: cross x total 1 + 4 = 5 arcsec^2, y 4: RMS sqrt(4.5); about 31
  EXPECT_NEAR(pc.pipeline.heads.head[2].sigma_cross_rad * kArcsecPerRad, std::sqrt(4.5), 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[2].sigma_roll_rad * kArcsecPerRad, 31.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[1].sigma_roll_rad * kArcsecPerRad, 25.0, 1e-12);
  EXPECT_EQ(pc.noise_in_use.head[2][2].source, path + " noise.heads[id 3]");
  EXPECT_EQ(pc.noise_in_use.head[2][1].source, path + " noise.head_defaults");
}

TEST(PlatformConfig, BaseFileOverlayKeepsWhatItDoesNotGive) {
  const std::string dir = kConfigDir;
  io::PlatformConfig pc;
  std::string err;
  // relative to the file's own directory, or absolute
  const std::string path = writeTemp("based.yaml", "base: " + dir + "/gracefo.yaml\nthermal:\n  tau_s: 300\n"
                                                   "noise:\n  head_defaults:\n    about_boresight: [{kind: white, sigma_arcsec: 30}]\n");
  ASSERT_TRUE(io::loadPlatformConfig(path, pc, &err)) << err;
  EXPECT_EQ(pc.pipeline.deformation.tau_s, 300.0);
  EXPECT_EQ(pc.pipeline.heads.n_heads, 3);
  EXPECT_TRUE(pc.mounting_from_qsa1b);
  EXPECT_NEAR(pc.pipeline.heads.head[0].sigma_roll_rad * kArcsecPerRad, 30.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[0].sigma_cross_rad * kArcsecPerRad, 2.0, 1e-12);  // the base's axis
  EXPECT_EQ(pc.noise_in_use.head[0][2].source, path + " noise.head_defaults");
  EXPECT_EQ(pc.noise_in_use.head[0][0].source, dir + "/gracefo.yaml noise.head_defaults");
  EXPECT_EQ(pc.file, path);
  // explicit mountings from an overlay's head list
  const std::string expl = writeTemp("explicit.yaml", "base: " + dir + "/gracefo.yaml\nheads:\n  mounting: explicit\n  list:\n"
                                                      "    - {id: 1, q_Si_B: [1, 0, 0, 0]}\n");
  ASSERT_TRUE(io::loadPlatformConfig(expl, pc, &err)) << err;
  EXPECT_FALSE(pc.mounting_from_qsa1b);
  EXPECT_EQ(pc.pipeline.heads.n_heads, 1);
  EXPECT_EQ(pc.mounting_source[0], expl + " heads.list[0].q_Si_B");
  // errors in the overlay name the overlay's line; a base that does not load names the base key
  const std::string typo = writeTemp("typo.yaml", "base: " + dir + "/gracefo.yaml\nthermal:\n  tau: 300\n");
  EXPECT_FALSE(io::loadPlatformConfig(typo, pc, &err));
  EXPECT_NE(err.find(typo + ":3: key 'thermal.tau': unknown key; did you mean 'tau_s'?"), std::string::npos) << err;
  const std::string missing = writeTemp("missing_base.yaml", "platform: x\nbase: no_such_platform.yaml\n");
  EXPECT_FALSE(io::loadPlatformConfig(missing, pc, &err));
  EXPECT_NE(err.find(missing + ":2: key 'base': the base platform file does not load: "), std::string::npos) << err;
  EXPECT_NE(err.find("no_such_platform.yaml: cannot open"), std::string::npos) << err;
  const std::string loop = writeTemp("loop.yaml", "base: config_test_loop.yaml\n");
  EXPECT_FALSE(io::loadPlatformConfig(loop, pc, &err));
  EXPECT_NE(err.find("deeper than 4"), std::string::npos) << err;
}

TEST(PlatformConfig, UnknownKeysAtEveryLevel) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  struct Case {
    std::string from, to, key;
  } cases[] = {
      {"platform: GRACE-FO", "platfrom: GRACE-FO", "platfrom"},
      {"  unit_norm_tolerance:", "  unit_norm_tolerence:", "heads.unit_norm_tolerence"},
      {"  bandwidth_hz: 0.1          # B, Hz", "  bandwith_hz: 0.1          # B, Hz", "crn_attitude.bandwith_hz"},
      {"  use: true", "  used: true", "accelerometer.used"},
  };
  for (const auto& c : cases) {
    const std::string path = writeTemp("unknown.yaml", replaced(base, c.from, c.to));
    io::PlatformConfig pc;
    std::string err;
    EXPECT_FALSE(io::loadPlatformConfig(path, pc, &err)) << c.key;
    EXPECT_NE(err.find("key '" + c.key + "': unknown key"), std::string::npos) << err;
  }
}

TEST(PlatformConfig, BadValuesNameLineAndReason) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  const std::string bad = replaced(base, "C_B_A: [[0, 0, 1], [1, 0, 0], [0, 1, 0]]", "C_B_A: [[0, 0, 1], [1, 0, 0], [0, 2, 0]]");
  const std::string path = writeTemp("badrot.yaml", bad);
  io::PlatformConfig pc;
  std::string err;
  ASSERT_FALSE(io::loadPlatformConfig(path, pc, &err));
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(bad, "C_B_A: [[")) + ":"), std::string::npos) << err;
  EXPECT_NE(err.find("not a rotation matrix"), std::string::npos) << err;
  const std::string dup = writeTemp("dup.yaml", replaced(base, "    - id: 2", "    - id: 1"));
  EXPECT_FALSE(io::loadPlatformConfig(dup, pc, &err));
  EXPECT_NE(err.find("duplicate head id 1"), std::string::npos) << err;
  const std::string neg = writeTemp("neg_unc.yaml", replaced(base, "mounting_uncertainty_arcsec: 360", "mounting_uncertainty_arcsec: -5"));
  EXPECT_FALSE(io::loadPlatformConfig(neg, pc, &err));
  EXPECT_NE(err.find("heads.mounting_uncertainty_arcsec"), std::string::npos) << err;
}

TEST(PlatformConfig, BlindingConesForEveryHeadAndPerHead) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc, &err)) << err;
  for (int s = 0; s < 3; ++s) {
    const auto& h = pc.pipeline.heads.head[static_cast<std::size_t>(s)];
    EXPECT_NEAR(h.sun_exclusion_rad / kRadPerDeg, 35.0, 1e-12);
    EXPECT_NEAR(h.earth_exclusion_rad / kRadPerDeg, 15.0, 1e-12);
    EXPECT_NEAR(h.moon_exclusion_rad / kRadPerDeg, 10.0, 1e-12);
  }
  // a head's own cones over the common ones (the keys it leaves out keep the common values)
  const std::string own = replaced(base, "    - id: 2\n", "    - id: 2\n      blinding_deg: {sun: 50}\n");
  ASSERT_NE(own, base);
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("own_cones.yaml", own), pc, &err)) << err;
  EXPECT_NEAR(pc.pipeline.heads.head[1].sun_exclusion_rad / kRadPerDeg, 50.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[1].earth_exclusion_rad / kRadPerDeg, 15.0, 1e-12);
  EXPECT_NEAR(pc.pipeline.heads.head[0].sun_exclusion_rad / kRadPerDeg, 35.0, 1e-12);
  // out of range and unknown keys: file, line, reason
  const std::string bad = replaced(base, "blinding_deg: {sun: 35,", "blinding_deg: {sun: 235,");
  ASSERT_NE(bad, base);
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("bad_cones.yaml", bad), pc, &err));
  EXPECT_NE(err.find("heads.blinding_deg.sun"), std::string::npos) << err;
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(bad, "blinding_deg: {sun: 235")) + ":"), std::string::npos) << err;
  EXPECT_NE(err.find("0..180"), std::string::npos) << err;
  const std::string typo = replaced(base, "blinding_deg: {sun: 35,", "blinding_deg: {sunn: 35,");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("typo_cones.yaml", typo), pc, &err));
  EXPECT_NE(err.find("sunn"), std::string::npos) << err;
  // an overlay without a head list: its cones for every head of the base, the keys it leaves out kept
  const std::string over = writeTemp("over_cones.yaml", "base: " + kConfigDir + "/gracefo.yaml\nheads:\n  blinding_deg: {moon: 20}\n");
  ASSERT_TRUE(io::loadPlatformConfig(over, pc, &err)) << err;
  for (int s = 0; s < 3; ++s) {
    EXPECT_NEAR(pc.pipeline.heads.head[static_cast<std::size_t>(s)].moon_exclusion_rad / kRadPerDeg, 20.0, 1e-12);
    EXPECT_NEAR(pc.pipeline.heads.head[static_cast<std::size_t>(s)].sun_exclusion_rad / kRadPerDeg, 35.0, 1e-12);
  }
}

TEST(PlatformConfig, DataEventRatesWithPerHeadOverridesAndErrorsWithTheirLine) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(kConfigDir + "/gracefo.yaml", pc, &err)) << err;
  EXPECT_EQ(pc.events.headDropoutsPerDay(1), 0.0);  // none given: none expected
  EXPECT_EQ(pc.events.epoch_gaps_per_day, 0.0);
  const std::string ev =
      replaced(replaced(replaced(replaced(base, "head_dropouts_per_day: 0 ", "head_dropouts_per_day: 2.5 "), "epoch_gaps_per_day: 0 ",
                                 "epoch_gaps_per_day: 1 "),
                        "acc_gaps_per_day: 0 ", "acc_gaps_per_day: 0.5 "),
               "heads: []                  # per-head", "heads: [{id: 3, dropouts_per_day: 12}]  # per-head");
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("events.yaml", ev), pc, &err)) << err;
  EXPECT_EQ(pc.events.headDropoutsPerDay(1), 2.5);
  EXPECT_EQ(pc.events.headDropoutsPerDay(3), 12.0);
  EXPECT_EQ(pc.events.epoch_gaps_per_day, 1.0);
  EXPECT_EQ(pc.events.acc_gaps_per_day, 0.5);
  EXPECT_TRUE(std::isnan(pc.events.head_dropout_max_s));  // null: no limit
  const std::string lim = replaced(ev, "epoch_gap_max_s: null", "epoch_gap_max_s: 120");
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("events_lim.yaml", lim), pc, &err)) << err;
  EXPECT_EQ(pc.events.epoch_gap_max_s, 120.0);
  const std::string zero = replaced(ev, "acc_gap_max_s: null", "acc_gap_max_s: 0");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("events_zero.yaml", zero), pc, &err));
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(zero, "acc_gap_max_s: 0")) + ": key 'data_events.acc_gap_max_s'"), std::string::npos) << err;
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("events.yaml", ev), pc, &err)) << err;
  // an overlay keeps what it does not give; a head list given replaces the base's
  const std::string ev_path = writeTemp("events_base.yaml", ev);
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("events_over.yaml", "base: " + ev_path + "\ndata_events:\n  epoch_gaps_per_day: 4\n"), pc, &err)) << err;
  EXPECT_EQ(pc.events.epoch_gaps_per_day, 4.0);
  EXPECT_EQ(pc.events.headDropoutsPerDay(3), 12.0);
  EXPECT_EQ(pc.events.headDropoutsPerDay(2), 2.5);
  // a negative rate, an unknown key, a head not in the list: file, line and reason
  const std::string neg = replaced(ev, "head_dropouts_per_day: 2.5", "head_dropouts_per_day: -1");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("events_neg.yaml", neg), pc, &err));
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(neg, "head_dropouts_per_day: -1")) + ": key 'data_events.head_dropouts_per_day'"),
            std::string::npos) << err;
  EXPECT_NE(err.find("outside [0,"), std::string::npos) << err;
  const std::string typo = replaced(ev, "acc_gaps_per_day: 0.5", "acc_gap_per_day: 0.5");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("events_typo.yaml", typo), pc, &err));
  EXPECT_NE(err.find("acc_gap_per_day"), std::string::npos) << err;
  const std::string nohead = replaced(ev, "{id: 3, dropouts_per_day: 12}", "{id: 7, dropouts_per_day: 12}");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("events_nohead.yaml", nohead), pc, &err));
  EXPECT_NE(err.find("head 7 is not in heads.list"), std::string::npos) << err;
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(nohead, "heads: [{id: 7")) + ":"), std::string::npos) << err;
}

TEST(PlatformConfig, ThermalSectionReachesThePipeline) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  const std::string changed = replaced(replaced(base, "wahba_correction: filtered_three_axis", "wahba_correction: iba_one_axis"),
                                       "tau_s: 150 ", "tau_s: 300 ");
  io::PlatformConfig pc;
  std::string err;
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("thermal.yaml", changed), pc, &err)) << err;
  EXPECT_EQ(pc.pipeline.wahba_correction, core::RelativeCorrection::kIbaOneAxis);
  EXPECT_EQ(pc.pipeline.deformation.tau_s, 300.0);
  const std::string nominal = replaced(base, "fusion_alignment: running_means", "fusion_alignment: nominal");
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("nominal.yaml", nominal), pc, &err)) << err;
  EXPECT_EQ(pc.pipeline.fusion_alignment, core::FusionAlignment::kNominal);
  const std::string tau = replaced(base, "relative_time_constant_s: 16200", "relative_time_constant_s: 5400");
  ASSERT_TRUE(io::loadPlatformConfig(writeTemp("tau.yaml", tau), pc, &err)) << err;
  EXPECT_EQ(pc.pipeline.heads.relative_time_constant_s, 5400.0);
  const std::string bad = replaced(base, "wahba_correction: filtered_three_axis", "wahba_correction: three_axis");
  EXPECT_FALSE(io::loadPlatformConfig(writeTemp("thermal_bad.yaml", bad), pc, &err));
  EXPECT_NE(err.find(":" + std::to_string(lineOfText(bad, "wahba_correction: three")) + ": key 'thermal.wahba_correction'"),
            std::string::npos) << err;
}

TEST(Scenario, OldAccelerometerKeyNamesTheNewOne) {
  const std::string base = slurp(kConfigDir + "/sim_gracefo.yaml");
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::parseScenario(base, "base.yaml", kConfigDir, sc, &err)) << err;
  EXPECT_TRUE(sc.acc.C_A_B.isApprox(accToBodyDefault().transpose()));
  EXPECT_FALSE(sim::parseScenario(replaced(base, "  C_B_A:", "  C_A_B:"), "old.yaml", kConfigDir, sc, &err));
  EXPECT_NE(err.find("key 'accelerometer.C_A_B': unknown key; did you mean 'C_B_A'?"), std::string::npos) << err;
}

TEST(Scenario, CalibrationDayIsAnOverlayOfTheBase) {
  sim::Scenario base, cal;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(kConfigDir + "/sim_gracefo.yaml", base, &err)) << err;
  ASSERT_TRUE(sim::loadScenario(kConfigDir + "/sim_gracefo_calibration.yaml", cal, &err)) << err;
  // what the overlay changes
  EXPECT_EQ(base.attitude.manoeuvres.size(), 0u);
  EXPECT_EQ(cal.attitude.manoeuvres.size(), 12u);
  EXPECT_EQ(base.effects.size(), 0u);
  EXPECT_EQ(cal.effects.size(), 6u);
  // what it keeps
  ASSERT_EQ(cal.heads.size(), base.heads.size());
  for (std::size_t i = 0; i < base.heads.size(); ++i) {
    EXPECT_EQ(cal.heads[i].id, base.heads[i].id);
    EXPECT_TRUE(cal.heads[i].q_Si_B.isApprox(base.heads[i].q_Si_B));
    EXPECT_EQ(cal.heads[i].mounting_error_rad, base.heads[i].mounting_error_rad);
    EXPECT_EQ(cal.heads[i].sigma_roll_rad, base.heads[i].sigma_roll_rad);
  }
  EXPECT_EQ(cal.start, base.start);
  EXPECT_EQ(cal.orbit.altitude_m, base.orbit.altitude_m);
  EXPECT_EQ(cal.acc.bias_rad_s2, base.acc.bias_rad_s2);
  EXPECT_EQ(cal.star_catalogue, base.star_catalogue);
  EXPECT_EQ(cal.file, kConfigDir + "/sim_gracefo_calibration.yaml");
}

TEST(Scenario, OverlayReplacesValuesAndReportsErrorsInItsOwnFile) {
  const std::string dir = kConfigDir;
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::parseScenario("base: sim_gracefo.yaml\norbit:\n  altitude_km: 500\nheads:\n  - id: 4\n",
                                 "ov.yaml", dir, sc, &err)) << err;
  EXPECT_NEAR(sc.orbit.altitude_m, 500e3, 1e-6);
  EXPECT_NEAR(sc.orbit.inclination_rad / kRadPerDeg, 89.0, 1e-12);  // kept from the base
  ASSERT_EQ(sc.heads.size(), 1u);  // a list replaces the base's
  EXPECT_EQ(sc.heads[0].id, 4);
  EXPECT_NEAR(sc.heads[0].sigma_roll_rad * kArcsecPerRad, 48, 1e-9);  // the base's head defaults

  EXPECT_FALSE(sim::parseScenario("base: sim_gracefo.yaml\norbit:\n  altitude_kms: 500\n", "ov.yaml", dir, sc, &err));
  EXPECT_NE(err.find("ov.yaml:3: key 'orbit.altitude_kms': unknown key; did you mean 'altitude_km'?"), std::string::npos)
      << err;
  EXPECT_FALSE(sim::parseScenario("base: no_such_file.yaml\n", "ov.yaml", dir, sc, &err));
  EXPECT_NE(err.find("ov.yaml:1: key 'base'"), std::string::npos) << err;
  EXPECT_NE(err.find("cannot open"), std::string::npos) << err;
  // a loop of overlays stops
  const std::string loop = writeTemp("loop.yaml", "base: config_test_loop.yaml\n");
  EXPECT_FALSE(sim::loadScenario(loop, sc, &err));
  EXPECT_NE(err.find("deeper than 4"), std::string::npos) << err;
}

TEST(TimeFormat, CalendarRoundTrip) {
  TimeUs t = 0;
  ASSERT_TRUE(io::parseGpsCalendar("2000-01-01T12:00:00", t));
  EXPECT_EQ(t, 0);
  ASSERT_TRUE(io::parseGpsCalendar("2023-06-01T00:00:00", t));
  EXPECT_EQ(t, 738849600LL * kUsPerSecond);
  EXPECT_EQ(io::formatDate(t), "2023-06-01");
  ASSERT_TRUE(io::parseGpsCalendar("1999-12-31 23:59:59.5", t));
  EXPECT_EQ(io::formatTime(t), "1999-12-31 23:59:59.500000");
  for (TimeUs u : {-1LL, 0LL, 86399999999LL, 738849600123456LL, -4000000000000000LL}) {
    TimeUs back = 0;
    ASSERT_TRUE(io::parseGpsCalendar(io::formatTime(u), back)) << io::formatTime(u);
    EXPECT_EQ(back, u) << io::formatTime(u);
  }
  EXPECT_FALSE(io::parseGpsCalendar("2023-13-01", t));
  EXPECT_FALSE(io::parseGpsCalendar("2023-06-01T25:00:00", t));
  EXPECT_FALSE(io::parseGpsCalendar("2023-06-01T10:00:00 junk", t));
}

}  // namespace
}  // namespace boresight

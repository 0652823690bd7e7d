// Configuration files: the committed files load; unknown or misspelt keys are errors with file:line
// and the nearest known key; scenario overlays; the one accelerometer rotation C_B_A; calendar dates.
#include <boresight/io/config_keys.h>
#include <boresight/io/core_config.h>
#include <boresight/io/time_format.h>
#include <boresight/sim/scenario.h>

#include <gtest/gtest.h>

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
  EXPECT_TRUE(pc.pipeline.C_B_A.isApprox(accToBodyDefault()));
}

TEST(PlatformConfig, MisspeltKeyIsAnErrorWithLineAndNearestKey) {
  const std::string base = slurp(kConfigDir + "/gracefo.yaml");
  const std::string bad = replaced(base, "      sigma_cross_arcsec: 6.0        #", "      sigma_cros_arcsec: 6.0        #");
  const std::string path = writeTemp("misspelt.yaml", bad);
  io::PlatformConfig pc;
  std::string err;
  ASSERT_FALSE(io::loadPlatformConfig(path, pc, &err));
  const int line = lineOfText(bad, "sigma_cros_arcsec");
  EXPECT_NE(err.find(path + ":" + std::to_string(line) + ":"), std::string::npos) << err;
  EXPECT_NE(err.find("heads.list[0].sigma_cros_arcsec"), std::string::npos) << err;
  EXPECT_NE(err.find("did you mean 'sigma_cross_arcsec'"), std::string::npos) << err;
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

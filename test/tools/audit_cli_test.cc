// boresight audit, run as a user would: help, usage errors (exit 2), bad inputs (exit 1, file:line:
// reason), and a few simulated minutes through `boresight simulate` then `boresight audit` (Level-1 and
// the LCM log) writing report.md, audit.json with the keys, and the plots.
#include <boresight/audit/run.h>

#include "test_files.h"

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

namespace {

using testutil::CliRun;
CliRun run(const std::string& args) { return testutil::runProgram(BORESIGHT_CLI, args); }
// The data below are simulated with the ideal noise preset (config/sim_gracefo.yaml: white 6"/48"
// heads): the platform file with that noise.
const std::string kConfig = " --config " BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml ";

/// Three simulated minutes with a hidden relative misalignment of head 2, once per test program.
const std::string& simulated() {
  static const std::string dir = [] {
    const std::string d = testutil::makeTempDir("audit_cli_sim");
    CliRun s = run("simulate --scenario " BORESIGHT_SOURCE_DIR "/config/sim_gracefo.yaml --seed 11 --duration 180 --out " +
                   d + " --quiet --effect relative_misalignment:sensor=2,x_arcsec=40,y_arcsec=-25");
    EXPECT_EQ(s.status, 0) << s.out;
    return d;
  }();
  return dir;
}

}  // namespace

TEST(AuditCli, Help) {
  CliRun h = run("audit --help");
  EXPECT_EQ(h.status, 0);
  EXPECT_NE(h.out.find("usage: boresight audit --config FILE INPUT... --out DIR"), std::string::npos) << h.out;
  EXPECT_NE(h.out.find("--truth"), std::string::npos);
  EXPECT_NE(run("--help").out.find("  audit "), std::string::npos);  // listed among the commands
}

TEST(AuditCli, UsageErrorsAreExitTwoWithTheReason) {
  CliRun a = run("audit" + kConfig + "--out x");  // no input
  EXPECT_EQ(a.status, 2) << a.out;
  EXPECT_NE(a.out.find("boresight audit: inputs is required"), std::string::npos) << a.out;
  CliRun b = run("audit" + kConfig + "in.txt --out x --false-alarm 3");
  EXPECT_EQ(b.status, 2) << b.out;
  EXPECT_NE(b.out.find("--false-alarm"), std::string::npos) << b.out;
  CliRun c = run("audit" + kConfig + "in.txt --out x --holdout-blocks 0");
  EXPECT_EQ(c.status, 2) << c.out;
  CliRun d = run("audit" + kConfig + "in.txt --out --quiet");  // --out without its value
  EXPECT_EQ(d.status, 2) << d.out;
  EXPECT_NE(d.out.find("looks like an option"), std::string::npos) << d.out;
}

TEST(AuditCli, BadInputsAreExitOneWithFileLineAndReason) {
  const std::string dir = testutil::makeTempDir("audit_cli_bad");
  ASSERT_TRUE(testutil::writeFile(dir + "/garbage.txt", "no header here\n"));
  CliRun a = run("audit" + kConfig + dir + "/garbage.txt --out " + dir + "/o");
  EXPECT_EQ(a.status, 1) << a.out;
  EXPECT_NE(a.out.find(dir + "/garbage.txt:1: wrong header"), std::string::npos) << a.out;
  CliRun b = run("audit" + kConfig + dir + "/missing_SCA1A.txt --out " + dir + "/o");
  EXPECT_EQ(b.status, 1) << b.out;
  EXPECT_NE(b.out.find(dir + "/missing_SCA1A.txt"), std::string::npos) << b.out;
  // An output folder that cannot be made is said before the replay.
  CliRun c = run("audit" + kConfig + dir + "/garbage.txt --out " + dir + "/garbage.txt/out");
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find(dir + "/garbage.txt/out: cannot create the folder"), std::string::npos) << c.out;
  // A truth file that is not one.
  const std::string& sim = simulated();
  ASSERT_TRUE(testutil::writeFile(dir + "/truth.yaml", "seed: 1\nheads: [\n"));
  CliRun d = run("audit" + kConfig + sim + "/SCA1A_2023-06-01_C_04.txt " + sim + "/QSA1B_2023-06-01_C_04.txt --out " +
                 dir + "/o --truth " + dir + "/truth.yaml");
  EXPECT_EQ(d.status, 1) << d.out;
  EXPECT_NE(d.out.find(dir + "/truth.yaml:"), std::string::npos) << d.out;
  // A truth file that does not exist.
  CliRun e = run("audit" + kConfig + sim + "/SCA1A_2023-06-01_C_04.txt " + sim + "/QSA1B_2023-06-01_C_04.txt --out " +
                 dir + "/o --truth " + dir + "/missing_truth.yaml");
  EXPECT_EQ(e.status, 1) << e.out;
  EXPECT_NE(e.out.find(dir + "/missing_truth.yaml"), std::string::npos) << e.out;
  EXPECT_NE(e.out.find("cannot open"), std::string::npos) << e.out;
}

TEST(AuditCli, TruthYamlReadsBackTheInjectedEffectsAndMountings) {
  const std::string& sim = simulated();
  boresight::audit::Truth t;
  std::string err;
  ASSERT_TRUE(boresight::audit::readTruthFile(sim + "/truth.yaml", t, &err)) << err;
  ASSERT_EQ(t.effects.size(), 1u);
  EXPECT_EQ(t.effects[0].name, "relative_misalignment");
  EXPECT_EQ(t.effects[0].sensor, "2");
  EXPECT_DOUBLE_EQ(t.effects[0].get("x_arcsec"), 40.0);
  EXPECT_DOUBLE_EQ(t.effects[0].get("y_arcsec"), -25.0);
  // Every head's constant mounting error, as truth.yaml says it (arcsec -> rad).
  const YAML::Node y = YAML::LoadFile(sim + "/truth.yaml");
  ASSERT_EQ(t.mounting_error_rad.size(), y["heads"].size());
  for (const auto& h : y["heads"]) {
    const int id = h["id"].as<int>();
    ASSERT_TRUE(t.mounting_error_rad.count(id)) << id;
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(t.mounting_error_rad.at(id)[a] * 206264.80624709636, h["mounting_error_arcsec"][a].as<double>(), 1e-9);
  }
}

TEST(AuditCli, SimulatedMinutesGiveReportJsonAndPlotsFromLevel1AndFromTheLog) {
  const std::string& sim = simulated();
  const std::string out = testutil::makeTempDir("audit_cli_out");
  const std::string s = sim + "/";
  CliRun a = run("audit" + kConfig + s + "SCA1A_2023-06-01_C_04.txt " + s + "ACC1A_2023-06-01_C_04.txt " + s +
                 "QSA1B_2023-06-01_C_04.txt " + s + "GNV1B_2023-06-01_C_04.txt " + s + "SCV1A_2023-06-01_C_04.txt --truth " +
                 s + "truth.yaml --out " + out + "/l1");
  ASSERT_EQ(a.status, 0) << a.out;
  std::printf("%s", a.out.c_str());
  EXPECT_NE(a.out.find("SCV1A is not an input of audit"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("orbit context"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("findings:"), std::string::npos) << a.out;
  EXPECT_TRUE(std::filesystem::exists(out + "/l1/report.md"));
  const nlohmann::json j = nlohmann::json::parse(testutil::slurp(out + "/l1/audit.json"));
  for (const char* k : {"baseline", "effects", "named_causes", "not_explained", "ambiguous", "extended", "gain", "gains",
                        "truth"})
    EXPECT_TRUE(j.contains(k)) << k;
  for (const char* k : {"family", "unit", "rms_before", "rms_after", "heldout_rms_before", "heldout_rms_after",
                        "delta_bic"})
    EXPECT_TRUE(j["gain"].contains(k)) << k;
  EXPECT_FALSE(j["effects"].empty());
  for (const auto& e : j["effects"])
    for (const char* k : {"name", "sensor", "statistic", "threshold", "p_value", "detected", "params"})
      EXPECT_TRUE(e.contains(k)) << k;
  EXPECT_GT(j["baseline"]["orbit_samples"].get<int>(), 0);
  // Every plot the command lists exists.
  const std::string md = testutil::slurp(out + "/l1/report.md");
  for (std::size_t p = md.find("]("); p != std::string::npos; p = md.find("](", p + 2)) {
    const std::string f = md.substr(p + 2, md.find(')', p) - p - 2);
    EXPECT_TRUE(std::filesystem::exists(out + "/l1/" + f)) << f;
  }
  // The simulator's LCM log carries the same samples: the same audit.
  CliRun b = run("audit" + kConfig + s + "sim.lcmlog " + s + "QSA1B_2023-06-01_C_04.txt " + s +
                 "GNV1B_2023-06-01_C_04.txt --quiet --out " + out + "/lcm");
  ASSERT_EQ(b.status, 0) << b.out;
  const nlohmann::json k = nlohmann::json::parse(testutil::slurp(out + "/lcm/audit.json"));
  EXPECT_EQ(k["baseline"]["head_epochs"], j["baseline"]["head_epochs"]);
  EXPECT_EQ(k["named_causes"].size(), j["named_causes"].size());
  for (std::size_t i = 0; i < k["named_causes"].size() && i < j["named_causes"].size(); ++i)
    EXPECT_EQ(k["named_causes"][i]["name"], j["named_causes"][i]["name"]);
}

/// Damaged records are used or rejected, never dropped silently: the audit still runs, and says per source
/// how many it rejected and why, with file and line, on the terminal and in report.md.
TEST(AuditCli, DamagedRecordsAreCountedAndLocated) {
  const std::string& sim = simulated();
  const std::string dir = testutil::makeTempDir("audit_cli_damaged");
  std::string text = testutil::slurp(sim + "/SCA1A_2023-06-01_C_04.txt");
  const std::size_t body = text.find("# End of YAML header");
  ASSERT_NE(body, std::string::npos);
  // lines 40 and 41 after the header: one made unreadable, one cut short
  std::size_t b = body;
  int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(body), '\n'));
  for (int k = 0; k < 40; ++k) b = text.find('\n', b) + 1, ++line;
  std::size_t e = text.find('\n', b);
  text.replace(b, e - b, "not a record");
  b = text.find('\n', b) + 1;
  e = text.find('\n', b);
  text.replace(b, e - b, text.substr(b, (e - b) / 3));
  const std::string sca = dir + "/SCA1A_2023-06-01_C_04.txt";
  ASSERT_TRUE(testutil::writeFile(sca, text));
  CliRun a = run("audit" + kConfig + sca + " " + sim + "/QSA1B_2023-06-01_C_04.txt --out " + dir + "/o");
  ASSERT_EQ(a.status, 0) << a.out;
  EXPECT_NE(a.out.find("+ 2 rejected"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("rejected " + sca + ":" + std::to_string(line) + ":"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("rejected " + sca + ":" + std::to_string(line + 1) + ":"), std::string::npos) << a.out;
  const std::string md = testutil::slurp(dir + "/o/report.md");
  EXPECT_NE(md.find(sca + ":" + std::to_string(line) + ":"), std::string::npos);
}

// ---- the model overlay ---------------------------------------------------------------------------

TEST(AuditCli, AnOverlayWithAnUnknownVersionOrKeyIsRefusedWithFileAndLine) {
  const std::string& sim = simulated();
  const std::string dir = testutil::makeTempDir("audit_cli_bad_overlay");
  const std::string in = sim + "/SCA1A_2023-06-01_C_04.txt " + sim + "/QSA1B_2023-06-01_C_04.txt";
  ASSERT_TRUE(testutil::writeFile(dir + "/v.yaml", "boresight_overlay: 0\nwritten_by: x\n"));
  CliRun a = run("audit" + kConfig + in + " --overlay " + dir + "/v.yaml --out " + dir + "/o");
  EXPECT_EQ(a.status, 1) << a.out;
  EXPECT_NE(a.out.find(dir + "/v.yaml:1: key 'boresight_overlay': unsupported version 0"), std::string::npos) << a.out;
  ASSERT_TRUE(testutil::writeFile(dir + "/k.yaml", "boresight_overlay: 1\nwritten_by: x\nmountings:\n"
                                                   "  - {head: 1, q_Si_B: [1, 0, 0, 0], datum: ground, epoch: \"2023-06-01\",\n"
                                                   "     sigma_arcsec: [1, 1, 1], valid_form: \"2023-06-01\"}\n"));
  CliRun b = run("audit" + kConfig + in + " --overlay " + dir + "/k.yaml --out " + dir + "/o");
  EXPECT_EQ(b.status, 1) << b.out;
  EXPECT_NE(b.out.find(dir + "/k.yaml:5: key 'mountings[0].valid_form': unknown key; did you mean 'valid_from'?"),
            std::string::npos) << b.out;
}

/// The noise levels the audit tests against come from the overlay: simulated 6"/48" heads audited
/// with the real excerpts' 2"/25" (config/gracefo.yaml) have their noise named; the same with an
/// overlay that says 6"/48" do not, and audit.json says where the noise came from.
TEST(AuditCli, TheOverlaysNoiseIsTheLevelTheNoiseTestsCompareWith) {
  const std::string& sim = simulated();
  const std::string dir = testutil::makeTempDir("audit_cli_overlay");
  const std::string real_levels = " --config " BORESIGHT_SOURCE_DIR "/config/gracefo.yaml ";
  const std::string in = sim + "/SCA1A_2023-06-01_C_04.txt " + sim + "/QSA1B_2023-06-01_C_04.txt --quiet";
  ASSERT_TRUE(testutil::writeFile(dir + "/ideal.yaml", "boresight_overlay: 1\nwritten_by: audit_cli_test\nnoise:\n"
                                                       "  head_defaults:\n"
                                                       "    cross_x: [{kind: white, sigma_arcsec: 6}]\n"
                                                       "    cross_y: [{kind: white, sigma_arcsec: 6}]\n"
                                                       "    about_boresight: [{kind: white, sigma_arcsec: 48}]\n"
                                                       "thermal:\n  datum_head: 1\n  heads: []\n"));
  auto noiseNamed = [](const nlohmann::json& j) {
    int n = 0;
    for (const auto& e : j["named_causes"]) n += e["name"] == "cross_noise" || e["name"] == "anisotropic_noise";
    return n;
  };
  CliRun a = run("audit" + real_levels + in + " --out " + dir + "/real");
  ASSERT_EQ(a.status, 0) << a.out;
  const nlohmann::json ja = nlohmann::json::parse(testutil::slurp(dir + "/real/audit.json"));
  EXPECT_GT(noiseNamed(ja), 0) << "6\"/48\" data against a 2\"/25\" model: the noise must be named";
  EXPECT_TRUE(ja["model_in_use"]["overlay"].is_null());
  CliRun b = run("audit" + real_levels + in + " --overlay " + dir + "/ideal.yaml --out " + dir + "/ov");
  ASSERT_EQ(b.status, 0) << b.out;
  const nlohmann::json jb = nlohmann::json::parse(testutil::slurp(dir + "/ov/audit.json"));
  EXPECT_EQ(noiseNamed(jb), 0) << "with the data's own levels from the overlay, nothing to name";
  EXPECT_NE(b.out.find("head 1: cross_x white 6\", cross_y white 6\", about_boresight white 48\" ("), std::string::npos) << b.out;
  EXPECT_NE(b.out.find("not applied: thermal: boresight audit does not apply thermal terms"), std::string::npos) << b.out;
  const auto& m = jb["model_in_use"];
  EXPECT_EQ(m["overlay"]["file"], dir + "/ideal.yaml");
  for (const auto& n : m["noise"]) {
    if (n["axis"] == "cross_x" || n["axis"] == "about_boresight") {
      EXPECT_EQ(n["source"], "overlay " + dir + "/ideal.yaml noise.head_defaults") << n.dump();
    }
  }
  for (const auto& h : m["heads"]) EXPECT_NEAR(h["sigma_about_arcsec"].get<double>(), 48.0, 1e-9);
  EXPECT_NE(testutil::slurp(dir + "/ov/report.md").find("overlay " + dir + "/ideal.yaml"), std::string::npos);
}

// boresight audit, run as a user would: help, usage errors (exit 2), bad inputs (exit 1, file:line:
// reason), and a few simulated minutes through `boresight simulate` then `boresight audit` (Level-1 and
// the LCM log) writing report.md, audit.json with the keys, and the plots.
#include <boresight/audit/extension.h>
#include <boresight/audit/run.h>
#include <boresight/audit/simulated.h>
#include <boresight/core/rotation.h>
#include <boresight/io/core_config.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/stream/replay.h>

#include "test_files.h"

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
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

/// Simulates `duration_s` of `scenario` (with `effects`: " --effect ..." arguments) into DIR/sim and returns
/// the audit's four Level-1 inputs there (heads, accelerometer, QSA1B, GNV1B), space-separated.
std::string simulatedInputs(const std::string& dir, const std::string& scenario, int seed, int duration_s,
                            const std::string& effects = "") {
  CliRun s = run("simulate --scenario " + scenario + " --seed " + std::to_string(seed) + " --duration " + std::to_string(duration_s) +
                 " --out " + dir + "/sim --no-lcm --quiet" + effects);
  EXPECT_EQ(s.status, 0) << s.out;
  const std::string d = dir + "/sim/";
  return d + "SCA1A_2023-06-01_C_04.txt " + d + "ACC1A_2023-06-01_C_04.txt " + d + "QSA1B_2023-06-01_C_04.txt " + d +
         "GNV1B_2023-06-01_C_04.txt";
}

/// "name[sensor]" of every named cause in an audit.json.
std::vector<std::string> namedCauses(const nlohmann::json& j) {
  std::vector<std::string> v;
  for (const auto& e : j["named_causes"]) v.push_back(e["name"].get<std::string>() + "[" + e["sensor"].get<std::string>() + "]");
  return v;
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
  EXPECT_NE(b.out.find("applied: thermal: heads  relative to head 1 (harmonics none"), std::string::npos) << b.out;  // no terms
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

/// --write-model closes the loop (issue 20 item 4): two simulated hours with a hidden relative
/// misalignment of head 2 and an accelerometer bias, audited once; the named causes are written as a
/// model overlay (head 2's mounting, the accelerometer's bias) and the same files audited again with it
/// applied: nothing is named any more, and on the held-out blocks the configured model's residuals
/// shrink to what the first pass's fit left. The overlay's mounting is Exp(r) q_Si_B(nominal) with the
/// estimate r, and its bias the injected one within a few sigma.
TEST(AuditCli, WriteModelWritesTheNamedCausesAndTheSecondPassNamesNothing) {
  const std::string dir = testutil::makeTempDir("audit_cli_extension");
  const std::string in = simulatedInputs(dir, BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml", 7, 7200,
                                         " --effect relative_misalignment:sensor=2,x_arcsec=6,y_arcsec=-4"
                                         " --effect acc_bias:sensor=acc,x=3e-6,y=-2e-6,z=1e-6");
  const std::string d = dir + "/sim/";
  CliRun a = run("audit" + kConfig + in + " --out " + dir + "/out --write-model " + dir + "/model.yaml --quiet");
  ASSERT_EQ(a.status, 0) << a.out;
  std::printf("%s", a.out.substr(a.out.find("the extended model, applied")).c_str());
  const nlohmann::json j = nlohmann::json::parse(testutil::slurp(dir + "/out/audit.json"));
  // the first pass names both causes
  EXPECT_EQ(namedCauses(j), (std::vector<std::string>{"relative_misalignment[2]", "acc_bias[acc]"}));
  // the overlay carries them
  boresight::model::Overlay o;
  std::string err;
  ASSERT_TRUE(boresight::io::readOverlay(dir + "/model.yaml", o, &err)) << err;
  // every head's mounting, in the datum the heads define together (the fused attitude stays)
  ASSERT_EQ(o.mountings.size(), 3u);
  for (const auto& m : o.mountings) EXPECT_EQ(m.datum, boresight::model::MountingDatum::StarCameras);
  const auto& est = j["extended"];
  boresight::Vec3 r = boresight::Vec3::Zero();
  for (const auto& e : est)
    if (e["name"] == "relative_misalignment")
      for (int k = 0; k < 3; ++k) r[k] = e["params"][std::string(1, "xyz"[k]) + "_arcsec"]["value"].get<double>() * boresight::kRadPerArcsec;
  ASSERT_GT(r.norm(), 0);
  boresight::io::PlatformConfig pc;
  ASSERT_TRUE(boresight::io::loadPlatformConfig(BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml", pc, &err)) << err;
  // the nominal mountings from the simulated QSA1B (the platform file's mounting: qsa1b)
  boresight::stream::ReplayInputs ri;
  ASSERT_TRUE(boresight::stream::classifyInputs({d + "SCA1A_2023-06-01_C_04.txt", d + "QSA1B_2023-06-01_C_04.txt"}, ri, &err)) << err;
  ASSERT_TRUE(boresight::stream::prepareConfig(ri, {}, pc, &err)) << err;
  auto written = [&](int id) {
    for (const auto& m : o.mountings)
      if (m.head == id) return m.q_Si_B;
    ADD_FAILURE() << "no mounting for head " << id;
    return boresight::Quat::Identity();
  };
  // head 2 relative to heads 1 and 3 (which were not named) turned by Exp(r): C_S2_Sk = Exp(r) C0_S2_Sk
  const boresight::Quat q2_nominal = pc.pipeline.heads.head[1].q_Si_B;
  for (const int k : {0, 2}) {
    const boresight::Quat qk_nominal = pc.pipeline.heads.head[static_cast<std::size_t>(k)].q_Si_B;
    const boresight::Quat expected = boresight::core::quatExp(r) * q2_nominal * qk_nominal.conjugate();
    const boresight::Quat got = written(2) * written(k + 1).conjugate();
    EXPECT_LT(expected.angularDistance(got) * boresight::kArcsecPerRad, 0.01) << "head " << k + 1;
    EXPECT_GT((q2_nominal * qk_nominal.conjugate()).angularDistance(got) * boresight::kArcsecPerRad, 6.5);  // |(6, -4)| = 7.2"
  }
  ASSERT_TRUE(o.accelerometer && o.accelerometer->bias_rad_s2);
  const auto& b = *o.accelerometer->bias_rad_s2;
  const boresight::Vec3 truth(3e-6, -2e-6, 1e-6);
  for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(b.value[k] - truth[k]), 5 * b.sigma[k]) << k;
  // the second pass applied both and names nothing
  const auto& x = j["extension"];
  EXPECT_TRUE(x["still_named"].empty()) << x.dump(1);
  std::string applied;
  for (const auto& l : x["second_pass_model_in_use"]) applied += l.get<std::string>() + "\n";
  EXPECT_NE(applied.find("applied: mountings: heads 1, 2, 3"), std::string::npos) << applied;
  EXPECT_NE(applied.find("applied: accelerometer: bias"), std::string::npos) << applied;
  // held out: the configured model's residuals shrink to the fitted ones (angular acceleration: the
  // bias is most of them)
  bool seen_acc = false, seen_rel = false;
  for (const auto& f : x["families"]) {
    const double conf = f["heldout_rms_configured"], appl = f["heldout_rms_applied"], fit = f["heldout_rms_fitted"];
    if (f["family"] == "angular_acceleration") {
      seen_acc = true;
      EXPECT_LT(appl, 0.7 * conf);
      EXPECT_NEAR(appl / fit, 1.0, 0.02);
    }
    if (f["family"] == "relative") {
      seen_rel = true;
      EXPECT_LT(appl, conf);
      EXPECT_NEAR(appl / fit, 1.0, 0.01);
    }
  }
  EXPECT_TRUE(seen_acc && seen_rel) << x.dump(1);
  EXPECT_NE(testutil::slurp(dir + "/out/report.md").find("## The extended model, applied"), std::string::npos);
}

/// The configured slow noise is the colour test's null: six simulated hours with a Gauss-Markov head
/// error (test/audit/bench/sim_audit_gauss_markov.yaml) have coloured_noise named against the white
/// platform file; its --write-model overlay carries the fitted Gauss-Markov part, and the second pass
/// (that overlay applied) names nothing. The same overlay with the slow part's levels set 6x too small
/// or 3x too large is named again: the null is the configured colour, not whatever was fitted.
TEST(AuditCli, AnAppliedSlowNoiseModelIsTheNullAndAWrongOneIsNamed) {
  const std::string dir = testutil::makeTempDir("audit_cli_colour");
  const std::string in = simulatedInputs(dir, BORESIGHT_SOURCE_DIR "/test/audit/bench/sim_audit_gauss_markov.yaml", 9, 21600) + " --quiet";
  CliRun a = run("audit" + kConfig + in + " --out " + dir + "/out --write-model " + dir + "/model.yaml");
  ASSERT_EQ(a.status, 0) << a.out;
  const nlohmann::json j = nlohmann::json::parse(testutil::slurp(dir + "/out/audit.json"));
  bool coloured = false;
  for (const auto& e : j["named_causes"]) coloured = coloured || e["name"] == "coloured_noise";
  EXPECT_TRUE(coloured) << a.out;
  EXPECT_TRUE(j["extension"]["still_named"].empty()) << j["extension"].dump(1);
  // the same overlay with every slow level scaled
  const std::string m = testutil::slurp(dir + "/model.yaml");
  for (const double scale : {1.0 / 6, 3.0}) {
    std::string t = m;
    const std::string key = "kind: gauss_markov, sigma_arcsec: ";
    for (std::size_t p = t.find(key); p != std::string::npos; p = t.find(key, p + 1)) {
      const std::size_t v0 = p + key.size(), v1 = t.find(',', v0);
      t.replace(v0, v1 - v0, std::to_string(std::stod(t.substr(v0, v1 - v0)) * scale));
    }
    ASSERT_NE(t, m);
    const std::string ov = dir + "/scaled.yaml";
    ASSERT_TRUE(testutil::writeFile(ov, t));
    CliRun b = run("audit" + kConfig + in + " --overlay " + ov + " --out " + dir + "/scaled");
    ASSERT_EQ(b.status, 0) << b.out;
    const nlohmann::json jb = nlohmann::json::parse(testutil::slurp(dir + "/scaled/audit.json"));
    bool named = false;
    std::string note;
    for (const auto& e : jb["named_causes"])
      if (e["name"] == "coloured_noise") named = true, note = e["note"];
    EXPECT_TRUE(named) << "slow levels x" << scale << ":\n" << b.out;
    EXPECT_NE(note.find("against the configured slow noise"), std::string::npos) << note;
  }
}

/// A thermal harmonic closes the loop too: six simulated hours with a once-per-revolution deformation
/// of head 2 (6", -4" at 30 deg); the overlay's thermal terms (relative to the datum head, in its frame)
/// applied on the second pass as mountings that follow the argument of latitude leave nothing to name,
/// and the relative family's held-out residuals shrink to what the first pass's fit left.
TEST(AuditCli, WriteModelCarriesAThermalHarmonicAndTheSecondPassNamesNothing) {
  const std::string dir = testutil::makeTempDir("audit_cli_thermal");
  const std::string in = simulatedInputs(dir, BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml", 12, 21600,
                                         " --effect thermal_periodic:sensor=2,harmonic=1,x_arcsec=6,y_arcsec=-4,phase_deg=30") +
                         " --quiet";
  CliRun a = run("audit" + kConfig + in + " --out " + dir + "/out --write-model " + dir + "/model.yaml --simulate-model " +
                 BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml --simulate-seed 5");
  ASSERT_EQ(a.status, 0) << a.out;
  std::printf("%s", a.out.substr(a.out.find("the extended model, applied")).c_str());
  const nlohmann::json j = nlohmann::json::parse(testutil::slurp(dir + "/out/audit.json"));
  EXPECT_EQ(namedCauses(j), (std::vector<std::string>{"thermal_periodic[2]"}));
  boresight::model::Overlay o;
  std::string err;
  ASSERT_TRUE(boresight::io::readOverlay(dir + "/model.yaml", o, &err)) << err;
  ASSERT_TRUE(o.thermal.has_value());
  EXPECT_EQ(o.thermal->datum_head, 1);
  ASSERT_EQ(o.thermal->heads.size(), 1u);
  EXPECT_EQ(o.thermal->heads[0].head, 2);
  ASSERT_EQ(o.thermal->heads[0].harmonics.size(), 1u);
  const auto& h = o.thermal->heads[0].harmonics[0];
  EXPECT_EQ(h.harmonic, 1);
  // |C0 (c, s)| keeps the injected amplitude: sqrt(6^2 + 4^2) = 7.2"
  const double amp = std::sqrt(h.cos_rad.value.squaredNorm() + h.sin_rad.value.squaredNorm()) * boresight::kArcsecPerRad;
  EXPECT_NEAR(amp, 7.21, 0.5);
  const auto& x = j["extension"];
  EXPECT_TRUE(x["still_named"].empty()) << x.dump(1);
  bool seen = false;
  for (const auto& f : x["families"])
    if (f["family"] == "relative") {
      seen = true;
      const double conf = f["heldout_rms_configured"], appl = f["heldout_rms_applied"], fit = f["heldout_rms_fitted"];
      EXPECT_LT(appl, conf);
      EXPECT_NEAR(appl / fit, 1.0, 0.01);
    }
  EXPECT_TRUE(seen);
  std::string notes;
  for (const auto& l : x["second_pass_model_in_use"]) notes += l.get<std::string>() + "\n";
  EXPECT_NE(notes.find("applied: thermal: head 2 relative to head 1 (harmonics 1 per revolution)"), std::string::npos) << notes;

  // Closing the loop (--simulate-model): the extended model simulated (the overlay's thermal terms as
  // the simulation's truth) and audited like the data's second pass: nothing named in either, the
  // held-out RMS and every spectral band alike.
  const auto& sim = x["simulation"];
  ASSERT_TRUE(sim.is_object()) << x.dump(1);
  EXPECT_TRUE(sim["agrees"].get<bool>()) << sim.dump(1);
  EXPECT_TRUE(sim["named_data"].empty());
  EXPECT_TRUE(sim["named_simulation"].empty()) << sim.dump(1);
  ASSERT_FALSE(sim["bands"].empty());
  for (const auto& f : sim["families"]) EXPECT_NEAR(f["ratio"].get<double>(), 1.0, 0.05) << f.dump();
  std::string applied;
  for (const auto& l : sim["applied"]) applied += l.get<std::string>() + "\n";
  EXPECT_NE(applied.find("thermal: head 2 relative to head 1: 1 harmonic(s)"), std::string::npos) << applied;
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/model_simulation_spectrum_relative.svg"));
  {  // the plot says what its amplitude is in and where the orbit harmonics are
    const std::string svg = testutil::slurp(dir + "/out/model_simulation_spectrum_relative.svg");
    EXPECT_NE(svg.find("amplitude [arcsec]"), std::string::npos);
    EXPECT_NE(svg.find("orbit harmonics"), std::string::npos);
  }
  EXPECT_NE(testutil::slurp(dir + "/out/report.md").find("](model_simulation_spectrum_relative.svg)"), std::string::npos);
  // The simulation is of the model: its truth.yaml holds the overlay's harmonic as head 2's rotation
  // (x 6" at 30 deg, y -4" at 30 deg: per axis amplitude and phase), within the fit's sigma.
  const YAML::Node truth = YAML::LoadFile(dir + "/out/model_simulation/truth.yaml");
  double ax = 0, ay = 0, px = 0, py = 0;
  for (const auto& e : truth["effects"])
    if (e["name"].as<std::string>() == "thermal_periodic" && e["sensor"].as<std::string>() == "2") {
      if (e["x_arcsec"].as<double>() != 0) ax = e["x_arcsec"].as<double>(), px = e["phase_deg"].as<double>();
      if (e["y_arcsec"].as<double>() != 0) ay = e["y_arcsec"].as<double>(), py = e["phase_deg"].as<double>();
    }
  std::printf("simulation's truth, head 2 harmonic 1: %.2f\" at %.0f deg about x, %.2f\" at %.0f deg about y\n", ax, px, ay, py);
  EXPECT_NEAR(ax, 6.0, 0.3);
  EXPECT_NEAR(std::remainder(px - 30.0, 360.0), 0.0, 4.0);
  EXPECT_NEAR(ay, 4.0, 0.3);  // -4" at 30 deg is 4" at -150 deg
  EXPECT_NEAR(std::remainder(py + 150.0, 360.0), 0.0, 5.0);

  // The same comparison has power: the data audited with the configured model (the line left in)
  // against a simulation of the configured model (no line): the audit names the harmonic on the data
  // only, and the residual power of pair 1-2 in the band that holds 1/rev is several times the
  // simulation's (its band test, at a family-wise 1 % over 24 bands of 5 and more frequencies, is weaker
  // than the audit's own line test on 6 h; the 1/rev band of a longer span narrows).
  boresight::audit::RunRequest rq;
  rq.config = BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml";
  std::istringstream ins(in.substr(0, in.find(" --quiet")));
  for (std::string f; ins >> f;) rq.inputs.push_back(f);
  boresight::audit::RunOutput data_first, plain;
  ASSERT_TRUE(boresight::audit::runAudit(rq, data_first, &err)) << err;
  const std::string in2 = simulatedInputs(dir + "/plain", BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml", 5, 21600);
  rq.inputs.clear();
  std::istringstream ins2(in2);
  for (std::string f; ins2 >> f;) rq.inputs.push_back(f);
  ASSERT_TRUE(boresight::audit::runAudit(rq, plain, &err)) << err;
  const auto lacking = boresight::audit::compareWithSimulation(data_first.result, plain.result);
  std::string diff;
  for (const auto& l : lacking.lines()) diff += l + "\n";
  EXPECT_FALSE(lacking.agrees()) << diff;
  EXPECT_EQ(lacking.namedOnDataOnly(), std::vector<std::string>{"thermal_periodic[2] (relative)"}) << diff;
  double line_ratio = 0;
  for (const auto& b : lacking.bands)
    if (b.family == "relative" && b.lo <= 1.0 && b.hi > 1.0) line_ratio = std::max(line_ratio, b.ratio);
  std::printf("against a simulation of the configured model: the 1/rev band's power ratio %.3g\n%s", line_ratio, diff.c_str());
  EXPECT_GT(line_ratio, 5.0) << diff;
  // with the extended model (above) the same band is at the simulation's level
  double model_ratio = 0;
  for (const auto& b : sim["bands"])
    if (b["family"] == "relative" && b["lo"].get<double>() <= 1.0 && b["hi"].get<double>() > 1.0)
      model_ratio = std::max(model_ratio, b["ratio"].get<double>());
  EXPECT_GT(model_ratio, 0.0);
  EXPECT_LT(model_ratio, 3.0) << sim.dump(1);
}

/// The loop on gapped data: holes are not part of the instrument model, but they shape the residuals
/// (the CRN and the bins around a hole), so the simulation of the model leaves the data's holes at the
/// same seconds. Six hours with the thermal harmonic above, random gaps of every head (40 a day, 2
/// minutes mean), a 30-minute accelerometer gap and a 40-minute dropout of head 3. Without the holes
/// the angular-acceleration family's held-out RMS was 2.09x the simulation's and every gap was "named
/// on the data only - the model lacks it". Asserted: the holes are left in the simulation, the same
/// causes named on both, the families' held-out RMS agree (the angular-acceleration residual has a
/// kurtosis of 25-30 here, from the gap edges, which widens its tolerance to 7 %; simulation seeds 5,
/// 6, 7 gave ratios 1.059, 0.986, 0.989). The spectral bands are printed, not asserted: on seed 6 six
/// angular-acceleration bands between 2 and 20/rev differ (the simulation's power there varies 35x
/// between seeds: a few gap-edge rows carry it, and the band test counts independent frequencies as
/// if the residual were Gaussian).
TEST(AuditCli, TheLoopOnGappedDataLeavesTheDataHolesInTheSimulationOfTheModel) {
  const std::string dir = testutil::makeTempDir("audit_cli_gapped_loop");
  const std::string in = simulatedInputs(dir, BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml", 12, 21600,
                                         " --effect thermal_periodic:sensor=2,harmonic=1,x_arcsec=6,y_arcsec=-4,phase_deg=30"
                                         " --effect gaps:sensor=all,per_day=40,mean_s=120 --effect gaps:sensor=acc,at_s=9000,duration_s=1800"
                                         " --effect head_dropout:sensor=3,at_s=14000,duration_s=2400") +
                         " --quiet";
  CliRun a = run("audit" + kConfig + in + " --out " + dir + "/out --write-model " + dir + "/model.yaml --simulate-model " +
                 BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml --simulate-seed 5");
  ASSERT_EQ(a.status, 0) << a.out;
  std::printf("%s", a.out.substr(a.out.find("simulation of the extended model")).c_str());
  const nlohmann::json j = nlohmann::json::parse(testutil::slurp(dir + "/out/audit.json"));
  const auto& sim = j["extension"]["simulation"];
  const auto& holes = sim["data_gaps_replicated"];
  EXPECT_GE(holes["head"].get<int>(), 2) << "head 3's dropout and the single heads' runs";
  EXPECT_GE(holes["all_heads"].get<int>(), 1);
  EXPECT_GE(holes["accelerometer"].get<int>(), 1);
  const std::vector<std::string> named_data = sim["named_data"], named_sim = sim["named_simulation"];
  // the first pass names the gap processes; the overlay carries their rates (data_events), so the
  // second pass, and the simulation of the model, name none of them
  std::vector<std::string> first;
  for (const auto& e : j["named_causes"]) first.push_back(e["name"].get<std::string>() + "[" + e["sensor"].get<std::string>() + "]");
  EXPECT_NE(std::find(first.begin(), first.end(), "gaps[all]"), first.end());
  EXPECT_NE(std::find(first.begin(), first.end(), "gaps[acc]"), first.end());
  const std::string model_text = testutil::slurp(dir + "/model.yaml");
  EXPECT_NE(model_text.find("epoch_gaps_per_day: 8"), std::string::npos) << model_text;  // 2 runs in 6 h
  for (const auto& n : named_data) EXPECT_EQ(n.rfind("gaps", 0), std::string::npos) << n << ": carried, yet named again";
  EXPECT_EQ(named_data, named_sim) << "a cause named on the data only";
  int families = 0;
  for (const auto& f : sim["families"]) {
    EXPECT_TRUE(f["agrees"].get<bool>()) << f.dump();
    EXPECT_LE(std::abs(f["ratio"].get<double>() - 1.0), f["tolerance"].get<double>()) << f.dump();
    families += f["family"] == "relative" || f["family"] == "angular_acceleration";
  }
  EXPECT_EQ(families, 2);
}

/// The audit's thermal terms mean what method A's thermal fit means (two implementations, one overlay
/// form): four simulated hours of the calibration scenario (manoeuvres, a once-per-revolution
/// deformation of head 2; its aberration, head 3's harmonic and the beta modulation left out, which the
/// calibrate fit does not separate) through `boresight calibrate --write-model` and `boresight audit
/// --write-model`: head 2's first harmonic agrees within 3 sigma on every axis (cos and sin), in the
/// datum head's frame. With the audit's conversion sign flipped they differ by twice the amplitude.
TEST(AuditCli, TheAuditsThermalTermsAgreeWithCalibratesThermalFit) {
  const std::string dir = testutil::makeTempDir("audit_cli_thermal_cal");
  std::string sc;
  {
    std::istringstream in(testutil::slurp(BORESIGHT_SOURCE_DIR "/config/sim_gracefo_calibration.yaml"));
    for (std::string line; std::getline(in, line);) {
      if (line.find("name: aberration") != std::string::npos || line.find("sensor: 3, harmonic: 2") != std::string::npos) continue;
      if (line.rfind("base: ", 0) == 0) line = "base: " BORESIGHT_SOURCE_DIR "/config/" + line.substr(6);
      const auto b = line.find(", beta_gain: 0.3");
      if (b != std::string::npos) line.erase(b, std::string(", beta_gain: 0.3").size());
      sc += line + "\n";
    }
  }
  ASSERT_TRUE(testutil::writeFile(dir + "/scenario.yaml", sc));
  const std::string in = simulatedInputs(dir, dir + "/scenario.yaml", 1, 14400);
  CliRun c = run("calibrate" + kConfig + in + " --json " + dir + "/c.json --write-model " + dir + "/cal.yaml");
  ASSERT_EQ(c.status, 0) << c.out;
  CliRun a = run("audit" + kConfig + in + " --quiet --out " + dir + "/out --write-model " + dir + "/aud.yaml");
  ASSERT_EQ(a.status, 0) << a.out;
  auto harmonic1 = [](const std::string& path, int head) {
    boresight::model::Overlay o;
    std::string err;
    EXPECT_TRUE(boresight::io::readOverlay(path, o, &err)) << err;
    boresight::model::ThermalHarmonicEntry h;
    if (o.thermal)
      for (const auto& e : o.thermal->heads)
        if (e.head == head)
          for (const auto& x : e.harmonics)
            if (x.harmonic == 1) h = x;
    return h;
  };
  const auto hc = harmonic1(dir + "/cal.yaml", 2), ha = harmonic1(dir + "/aud.yaml", 2);
  ASSERT_GT(hc.cos_rad.value.norm() * boresight::kArcsecPerRad, 5.0) << "calibrate's fit has no first harmonic on head 2";
  for (int k = 0; k < 3; ++k) {
    const double sc_ = std::hypot(hc.cos_rad.sigma[k], ha.cos_rad.sigma[k]), ss = std::hypot(hc.sin_rad.sigma[k], ha.sin_rad.sigma[k]);
    EXPECT_LT(std::abs(hc.cos_rad.value[k] - ha.cos_rad.value[k]), 3 * sc_)
        << "cos axis " << k << ": calibrate " << hc.cos_rad.value[k] * boresight::kArcsecPerRad << "\", audit "
        << ha.cos_rad.value[k] * boresight::kArcsecPerRad << "\"";
    EXPECT_LT(std::abs(hc.sin_rad.value[k] - ha.sin_rad.value[k]), 3 * ss)
        << "sin axis " << k << ": calibrate " << hc.sin_rad.value[k] * boresight::kArcsecPerRad << "\", audit "
        << ha.sin_rad.value[k] * boresight::kArcsecPerRad << "\"";
  }
}

/// The platform file's data_events reach the audit's data-event tests: random dropouts of head 2 (about
/// one a minute) are named against the default (none expected) and not when the platform file expects
/// them at that rate, whose expected count the test then states.
TEST(AuditCli, DropoutsAtTheConfiguredRateAreNotNamed) {
  const std::string dir = testutil::makeTempDir("audit_cli_events");
  const std::string in = simulatedInputs(dir, BORESIGHT_SOURCE_DIR "/config/sim_gracefo.yaml", 4, 1800,
                                         " --effect gaps:sensor=2,per_day=1440,mean_s=4");
  auto gaps2 = [](const nlohmann::json& j) {
    for (const auto& e : j["effects"])
      if (e["name"] == "gaps" && e["sensor"] == "2") return e;
    return nlohmann::json();
  };
  CliRun a = run("audit" + kConfig + in + " --quiet --out " + dir + "/none");
  ASSERT_EQ(a.status, 0) << a.out;
  const nlohmann::json ja = nlohmann::json::parse(testutil::slurp(dir + "/none/audit.json"));
  const nlohmann::json ga = gaps2(ja);
  ASSERT_FALSE(ga.is_null()) << "head 2's random gaps are tested as a process";
  EXPECT_TRUE(ga["named"].get<bool>()) << ga.dump();
  const double runs = ga["statistic"].get<double>();
  EXPECT_GT(runs, 10);
  const std::string cfg = dir + "/events.yaml";
  ASSERT_TRUE(testutil::writeFile(cfg, "base: " BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml\n"
                                       "data_events:\n  heads: [{id: 2, dropouts_per_day: 1440}]\n"));
  CliRun b = run("audit --config " + cfg + " " + in + " --quiet --out " + dir + "/rate");
  ASSERT_EQ(b.status, 0) << b.out;
  const nlohmann::json jb = nlohmann::json::parse(testutil::slurp(dir + "/rate/audit.json"));
  const nlohmann::json gb = gaps2(jb);
  ASSERT_FALSE(gb.is_null());
  EXPECT_FALSE(gb["named"].get<bool>()) << gb.dump();
  EXPECT_EQ(gb["statistic"].get<double>(), runs);
  EXPECT_NE(gb["note"].get<std::string>().find("data_events: 1440 per day"), std::string::npos) << gb.dump();
  const auto na = namedCauses(ja);
  EXPECT_NE(std::find(na.begin(), na.end(), "gaps[2]"), na.end());
  const auto nb = namedCauses(jb);
  EXPECT_EQ(std::find(nb.begin(), nb.end(), "gaps[2]"), nb.end());

  // The loop: --write-model carries the named gap process as the expected rate (data_events), and the
  // same files audited with that overlay do not name it again.
  CliRun w = run("audit" + kConfig + in + " --quiet --out " + dir + "/w --write-model " + dir + "/model.yaml");
  ASSERT_EQ(w.status, 0) << w.out;
  boresight::model::Overlay ov;
  std::string err;
  ASSERT_TRUE(boresight::io::readOverlay(dir + "/model.yaml", ov, &err)) << err;
  ASSERT_TRUE(ov.data_events.has_value()) << testutil::slurp(dir + "/model.yaml");
  const double observed = ga["params"]["per_day"]["value"].get<double>();
  EXPECT_NEAR(ov.data_events->headDropoutsPerDay(2), observed, 1e-9 * observed);
  EXPECT_NEAR(observed, runs / 1800.0 * 86400, 0.05 * observed);
  EXPECT_EQ(ov.data_events->headDropoutsPerDay(1), 0.0);
  CliRun o = run("audit" + kConfig + in + " --quiet --out " + dir + "/ov --overlay " + dir + "/model.yaml");
  ASSERT_EQ(o.status, 0) << o.out;
  const nlohmann::json jo = nlohmann::json::parse(testutil::slurp(dir + "/ov/audit.json"));
  const auto no = namedCauses(jo);
  EXPECT_EQ(std::find(no.begin(), no.end(), "gaps[2]"), no.end()) << jo["model_in_use"].dump();
  EXPECT_FALSE(gaps2(jo)["named"].get<bool>());

  // At its rate but with runs longer than the longest expected (2 s): named; the loop raises that
  // longest to the longest seen, and the second pass does not name it.
  const std::string cfg_max = dir + "/events_max.yaml";
  ASSERT_TRUE(testutil::writeFile(cfg_max, "base: " BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml\n"
                                           "data_events:\n  heads: [{id: 2, dropouts_per_day: 1440}]\n  head_dropout_max_s: 2\n"));
  CliRun m = run("audit --config " + cfg_max + " " + in + " --quiet --out " + dir + "/max --write-model " + dir + "/model_max.yaml");
  ASSERT_EQ(m.status, 0) << m.out;
  const nlohmann::json jm = nlohmann::json::parse(testutil::slurp(dir + "/max/audit.json"));
  const nlohmann::json gm = gaps2(jm);
  EXPECT_TRUE(gm["named"].get<bool>()) << gm.dump();
  const double longest = gm["params"]["longest_s"]["value"].get<double>();
  EXPECT_GT(longest, 2.0);
  EXPECT_NE(gm["note"].get<std::string>().find("longer than the 2 s data_events expects at most"), std::string::npos) << gm.dump();
  boresight::model::Overlay om;
  ASSERT_TRUE(boresight::io::readOverlay(dir + "/model_max.yaml", om, &err)) << err;
  ASSERT_TRUE(om.data_events.has_value());
  EXPECT_NEAR(om.data_events->head_dropout_max_s, longest, 1e-9 * longest);
  EXPECT_TRUE(std::isnan(om.data_events->epoch_gap_max_s));  // no limit stays no limit
  CliRun m2 = run("audit --config " + cfg_max + " " + in + " --quiet --out " + dir + "/max2 --overlay " + dir + "/model_max.yaml");
  ASSERT_EQ(m2.status, 0) << m2.out;
  EXPECT_FALSE(gaps2(nlohmann::json::parse(testutil::slurp(dir + "/max2/audit.json")))["named"].get<bool>());
}

// An LCM log carries the orbit as ORBIT messages: the audit reads them from the same stream as the
// heads (the engine), so the log alone gives the audit the Level-1 files give - an orbit-periodic
// effect hidden in it is named. Before, the audit read only GNI1B / GNV1B files ahead of the replay, and
// on a log said "no orbit context": thermal_periodic was not even tested.
TEST(AuditCli, AnLcmLogsOrbitMessagesAreTheOrbitContext) {
  const std::string dir = testutil::makeTempDir("audit_cli_log_orbit");
  CliRun s = run("simulate --scenario " BORESIGHT_SOURCE_DIR "/config/sim_audit.yaml --seed 12 --duration 21600 --out " + dir +
                 "/sim --quiet --effect thermal_periodic:sensor=2,harmonic=1,x_arcsec=6,y_arcsec=-4,phase_deg=30");
  ASSERT_EQ(s.status, 0) << s.out;
  const std::string d = dir + "/sim/";
  CliRun l1 = run("audit" + kConfig + d + "SCA1A_2023-06-01_C_04.txt " + d + "ACC1A_2023-06-01_C_04.txt " + d +
                  "QSA1B_2023-06-01_C_04.txt " + d + "GNV1B_2023-06-01_C_04.txt --quiet --out " + dir + "/l1");
  ASSERT_EQ(l1.status, 0) << l1.out;
  CliRun lg = run("audit" + kConfig + d + "sim.lcmlog --out " + dir + "/log");
  ASSERT_EQ(lg.status, 0) << lg.out;
  EXPECT_NE(lg.out.find("orbit context: 21600 samples from the LCM log's ORBIT messages"), std::string::npos) << lg.out;
  const nlohmann::json a = nlohmann::json::parse(testutil::slurp(dir + "/l1/audit.json"));
  const nlohmann::json b = nlohmann::json::parse(testutil::slurp(dir + "/log/audit.json"));
  EXPECT_EQ(namedCauses(a), (std::vector<std::string>{"thermal_periodic[2]"}));
  EXPECT_EQ(namedCauses(b), namedCauses(a));
  EXPECT_EQ(b["baseline"]["orbit_samples"], a["baseline"]["orbit_samples"]);
  EXPECT_EQ(b["baseline"]["head_epochs"], a["baseline"]["head_epochs"]);
  // The same data, the orbit in two forms: the log's inertial ORBIT messages, the file's Earth-fixed
  // records rotated back by the Earth rotation angle, both rounded in text. The statistics that use the
  // orbit's velocity differ a little (aberration 0.2 % on this span), the rest less: 1 % for every test.
  ASSERT_EQ(b["effects"].size(), a["effects"].size());
  for (std::size_t i = 0; i < a["effects"].size(); ++i) {
    EXPECT_EQ(b["effects"][i]["name"], a["effects"][i]["name"]);
    EXPECT_NEAR(b["effects"][i]["statistic"].get<double>(), a["effects"][i]["statistic"].get<double>(),
                1e-2 * (1.0 + std::fabs(a["effects"][i]["statistic"].get<double>())))
        << a["effects"][i]["name"];
  }
}

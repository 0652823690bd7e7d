// The boresight program, run as a user would: help, bad usage, inspect (with JSON) and convert.
#include <boresight/io/level1.h>

#include "real_data.h"
#include "test_files.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

using namespace boresight::io;
using boresight::test::realFile;

namespace {

using testutil::CliRun;
CliRun run(const std::string& args) { return testutil::runProgram(BORESIGHT_CLI, args); }

std::string tempDir() { return testutil::makeTempDir("boresight_cli"); }

}  // namespace

TEST(Cli, HelpForEveryCommand) {
  CliRun top = run("--help");
  EXPECT_EQ(top.status, 0);
  for (const char* cmd : {"inspect", "convert", "process", "simulate", "plot"}) {
    if (top.out.find(std::string("  ") + cmd + " ") == std::string::npos) continue;  // not built
    CliRun r = run(std::string(cmd) + " --help");
    EXPECT_EQ(r.status, 0) << cmd;
    EXPECT_NE(r.out.find("sage: boresight " + std::string(cmd)), std::string::npos) << r.out;  // usage: or Usage:
  }
}

TEST(Cli, BadUsageIsExitTwoWithAReason) {
  CliRun r = run("inspect --no-such-option x");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("unknown option --no-such-option"), std::string::npos) << r.out;
  EXPECT_EQ(run("no-such-command").status, 2);
  EXPECT_EQ(run("convert a.txt").status, 2);  // neither --out nor --to-level1
}

TEST(Cli, InspectReportsRejectedLinesWithFileAndLine) {
  std::string dir = tempDir();
  std::string path = dir + "/SCA1A_2023-06-01_C_04.txt";
  {
    std::ofstream f(path);
    f << "header:\n  dimensions:\n    num_records: 5\n# End of YAML header\n";
    f << "738849600 29992 C 1 P 0.5 -0.5 0.5 -0.5 0 47 1 0 0 11000001 11000000\n";
    f << "738849600 29992 C 2 P 0.46 0.88 nan 0.068 0 52 2 0 0 11000001 11000000\n";
    f << "738849600 29992 C 3 P 0.12 0.18\n";
  }
  CliRun r = run("inspect " + path + " --json " + dir + "/out.json");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find(path + ":6: field 8 (quatjcoeff): non-finite number: 'nan'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(path + ":7: field 8 (quatjcoeff): missing"), std::string::npos) << r.out;
  YAML::Node j = YAML::LoadFile(dir + "/out.json");
  ASSERT_EQ(j["files"].size(), 1u);
  EXPECT_EQ(j["files"][0]["records"].as<int>(), 1);
  EXPECT_EQ(j["files"][0]["header_records"].as<int>(), 5);
  EXPECT_EQ(j["files"][0]["rejected"].size(), 2u);
  EXPECT_EQ(j["files"][0]["rejected"][0]["line"].as<int>(), 6);

  CliRun missing = run("inspect " + dir + "/SCA1A_missing.txt");
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.out.find("cannot open"), std::string::npos) << missing.out;
}

TEST(CliReal, InspectGraceFoHeadsAndQsa1b) {
  BORESIGHT_REQUIRE_REAL_DATA();
  std::string dir = tempDir();
  CliRun r = run("inspect " + realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt") + " " +
              realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt") + " --json " + dir + "/iba.json");
  ASSERT_EQ(r.status, 0) << r.out;
  std::printf("%s", r.out.c_str());
  YAML::Node j = YAML::LoadFile(dir + "/iba.json");
  ASSERT_EQ(j["files"].size(), 2u);
  EXPECT_EQ(j["files"][0]["product"].as<std::string>(), "SCA1A");
  EXPECT_EQ(j["files"][0]["records"].as<int>(), 100);
  EXPECT_EQ(j["files"][0]["satellite"].as<std::string>(), "C");
  EXPECT_DOUBLE_EQ(j["files"][0]["first_time"].as<double>(), 738849600.029992);
  ASSERT_EQ(j["pairs"].size(), 3u);
  for (const auto& p : j["pairs"]) {
    EXPECT_LT(p["iba_std_arcsec"].as<double>(), 8.0);
    EXPECT_GT(p["iba_mean_deg"].as<double>(), 80.0);
    EXPECT_LT(std::abs(p["iba_offset_arcsec"].as<double>()), 180.0);
    EXPECT_NEAR(p["iba_mean_deg"].as<double>() - p["iba_nominal_deg"].as<double>(),
                p["iba_offset_arcsec"].as<double>() / 3600.0, 1e-9);
  }
}

TEST(CliReal, ConvertToLcmAndBackKeepsWhatTheMessagesCarry) {
  BORESIGHT_REQUIRE_REAL_DATA();
  std::string dir = tempDir();
  std::string sca = realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt");
  std::string acc = realFile("gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt");
  CliRun a = run("convert " + sca + " " + acc + " --out " + dir + "/x.lcm");
  ASSERT_EQ(a.status, 0) << a.out;
  EXPECT_NE(a.out.find("100 star head samples, 100 accelerometer samples"), std::string::npos) << a.out;
  CliRun b = run("convert " + dir + "/x.lcm --to-level1 " + dir + "/l1");
  ASSERT_EQ(b.status, 0) << b.out;
  auto s0 = readProduct<Sca1aRecord>(sca);
  auto s1 = readProduct<Sca1aRecord>(dir + "/l1/SCA1A_2023-06-01_C_04.txt");
  ASSERT_TRUE(s1.ok) << s1.error;
  ASSERT_EQ(s0.records.size(), s1.records.size());
  // The log is in sensor-time order with heads by id at equal times: the same order as the file.
  for (std::size_t i = 0; i < s0.records.size(); ++i) {
    const auto &x = s0.records[i], &y = s1.records[i];
    EXPECT_EQ(x.t, y.t);
    EXPECT_EQ(x.head, y.head);
    EXPECT_EQ(x.nstars, y.nstars);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(x.q[k], y.q[k]);
  }
  auto a0 = readProduct<FlaggedRecord>(acc);
  auto a1 = readProduct<FlaggedRecord>(dir + "/l1/ACC1A_2023-06-01_C_04.txt");
  ASSERT_TRUE(a1.ok) << a1.error;
  ASSERT_EQ(a0.records.size(), a1.records.size());
  for (std::size_t i = 0; i < a0.records.size(); ++i) {
    EXPECT_EQ(a0.records[i].t, a1.records[i].t);
    for (int k = 0; k < 6; ++k) EXPECT_EQ(a0.records[i].value[k], a1.records[i].value[k]);
  }
}

TEST(CliReal, ProcessRealGraceFoAndCompareWithSca1b) {
  BORESIGHT_REQUIRE_REAL_DATA();
  std::string dir = tempDir();
  const std::string l1a = realFile("gracefo/2023-06-01_L1A/"), l1b = realFile("gracefo/2023-06-01_L1B/");
  CliRun r = run("process --config " BORESIGHT_SOURCE_DIR "/config/gracefo.yaml " + l1a + "SCA1A_2023-06-01_C_04.txt " +
                 l1a + "ACC1A_2023-06-01_C_04.txt " + realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt") +
                 " --out " + dir + "/p.csv --compare-sca1b " + l1b + "SCA1B_2023-06-01_C_04.txt --clk1b " + l1b +
                 "CLK1B_2023-06-01_C_04.txt");
  ASSERT_EQ(r.status, 0) << r.out;
  std::printf("%s", r.out.c_str());
  std::ifstream csv(dir + "/p.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("time_s,q0,q1,q2,q3,w_x,w_y,w_z,a_sc_x,a_sc_y,a_sc_z,a_acc_x,a_acc_y,a_acc_z,iba_12_deg,", 0), 0u)
      << header;
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    EXPECT_EQ(line.substr(line.size() - 2), ",3") << "all three heads fused: " << line;
  }
  EXPECT_GE(rows, 15);  // 16.5 s of 2 Hz heads, one row per second
  // The comparison is printed with its numbers whatever they are; the scatter must be small (the
  // fused attitude is consistent), the mean is a finding, not an assertion.
  EXPECT_NE(r.out.find("Fused attitude versus SCA1B"), std::string::npos);
  EXPECT_NE(r.out.find("smallest mean difference with the fused attitude taken at SCA1B time"), std::string::npos);
}

TEST(Cli, ProcessConfigErrorsNameFileAndKey) {
  std::string dir = tempDir();
  {
    std::ofstream f(dir + "/bad.yaml");
    f << "platform: x\nheads:\n  mounting: qsa1b\n  list:\n    - id: 1\n      sigma_roll_arcsec: -3\n";
  }
  CliRun r = run("process --config " + dir + "/bad.yaml x.txt --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find(dir + "/bad.yaml:6: key 'heads.list[0].sigma_roll_arcsec': must be > 0"), std::string::npos) << r.out;
}

TEST(CliReal, ProcessGivesTheSameRowsFromAnLcmLogAsFromLevel1) {
  BORESIGHT_REQUIRE_REAL_DATA();
  std::string dir = tempDir();
  const std::string l1a = realFile("gracefo/2023-06-01_L1A/");
  const std::string qsa = realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt");
  const std::string cfg = " --config " BORESIGHT_SOURCE_DIR "/config/gracefo.yaml ";
  ASSERT_EQ(run("convert " + l1a + "SCA1A_2023-06-01_C_04.txt " + l1a + "ACC1A_2023-06-01_C_04.txt --out " + dir +
                "/x.lcm").status, 0);
  CliRun a = run("process" + cfg + l1a + "SCA1A_2023-06-01_C_04.txt " + l1a + "ACC1A_2023-06-01_C_04.txt " + qsa +
                 " --out " + dir + "/a.csv");
  CliRun b = run("process" + cfg + dir + "/x.lcm " + qsa + " --out " + dir + "/b.csv");
  ASSERT_EQ(a.status, 0) << a.out;
  ASSERT_EQ(b.status, 0) << b.out;
  std::ifstream fa(dir + "/a.csv"), fb(dir + "/b.csv");
  std::stringstream sa, sb;
  sa << fa.rdbuf();
  sb << fb.rdbuf();
  EXPECT_GT(sa.str().size(), 1000u);
  EXPECT_EQ(sa.str(), sb.str());
}

TEST(Cli, PlotDrawsColumnsAndNamesMissingOnes) {
  std::string dir = tempDir();
  {
    std::ofstream f(dir + "/t.csv");
    f << "time_s,a,b\n";
    for (int i = 0; i < 50; ++i) f << 100 + i << "," << std::sin(i * 0.1) << "," << (i % 10 == 0 ? "" : "0.5") << "\n";
  }
  CliRun r = run("plot " + dir + "/t.csv --y a,b --relative-x --out " + dir + "/t.svg");
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream s(dir + "/t.svg");
  std::stringstream ss;
  ss << s.rdbuf();
  const std::string svg = ss.str();
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  // Series b has a gap every ten rows: its path restarts (several 'M' moves).
  std::size_t paths = 0, pos = 0;
  while ((pos = svg.find("<path", pos)) != std::string::npos) ++paths, ++pos;
  EXPECT_EQ(paths, 2u);
  CliRun bad = run("plot " + dir + "/t.csv --y nope --out " + dir + "/u.svg");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("no column 'nope'"), std::string::npos) << bad.out;
}

// ---- issue 7: CLI11 parsing, content recognition, streaming process ----

TEST(Cli, ValuesThatLookLikeOptionsAndBadNumbersAreErrors) {
  // "--config --out x.csv": --config has no value; it must not take "--out" as the path.
  CliRun r = run("process --config --out x.csv a.txt");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--config: value '--out' looks like an option"), std::string::npos) << r.out;
  CliRun n = run("inspect --max-rejected abc x.txt");
  EXPECT_EQ(n.status, 2) << n.out;
  EXPECT_NE(n.out.find("--max-rejected = abc"), std::string::npos) << n.out;
  CliRun neg = run("inspect --max-rejected -3 x.txt");
  EXPECT_EQ(neg.status, 2) << neg.out;
  CliRun c = run("convert a.txt --out");
  EXPECT_EQ(c.status, 2) << c.out;
  CliRun both = run("convert a.txt --out x.lcm --to-level1 d");
  EXPECT_EQ(both.status, 2) << both.out;
  CliRun la = run("process --config c.yaml --out o.csv --lookahead soon a.txt");
  EXPECT_EQ(la.status, 2) << la.out;
}

TEST(Cli, ConvertOfAGarbageLogFailsWithFileAndReason) {
  std::string dir = tempDir();
  { std::ofstream(dir + "/g.lcm") << "this is not an LCM log\n"; }
  CliRun r = run("convert " + dir + "/g.lcm --to-level1 " + dir + "/out");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(dir + "/g.lcm: not an LCM log"), std::string::npos) << r.out;
  // An empty log has nothing to convert: an error too, not a silent success.
  { std::ofstream(dir + "/empty.lcm").close(); }
  CliRun e = run("convert " + dir + "/empty.lcm --to-level1 " + dir + "/out");
  EXPECT_EQ(e.status, 1) << e.out;
  EXPECT_NE(e.out.find(dir + "/empty.lcm: no STAR_HEAD or ACCEL messages"), std::string::npos) << e.out;
  // Level-1 direction: garbage is named with its reason.
  CliRun l = run("convert " + dir + "/g.lcm --out " + dir + "/x.lcm");
  EXPECT_EQ(l.status, 1) << l.out;
  EXPECT_NE(l.out.find(dir + "/g.lcm:1: wrong header"), std::string::npos) << l.out;
}

TEST(Cli, ProcessStreamsTheSimulatorsOutputWhateverTheLogIsCalled) {
  std::string dir = tempDir();
  CliRun sim = run("simulate --scenario " BORESIGHT_SOURCE_DIR "/config/sim_gracefo.yaml --seed 3 --duration 150 --out " +
                   dir + " --quiet");
  ASSERT_EQ(sim.status, 0) << sim.out;
  const std::string cfg = " --config " BORESIGHT_SOURCE_DIR "/config/gracefo.yaml ";
  const std::string d = dir + "/";
  const std::string qsa = d + "QSA1B_2023-06-01_C_04.txt", gnv = d + "GNV1B_2023-06-01_C_04.txt";
  // Level-1, with an orbit file process does not need: listed as ignored, not an error.
  CliRun a = run("process" + cfg + d + "SCA1A_2023-06-01_C_04.txt " + d + "ACC1A_2023-06-01_C_04.txt " + qsa + " " + gnv +
                 " --out " + d + "a.csv");
  ASSERT_EQ(a.status, 0) << a.out;
  EXPECT_NE(a.out.find(gnv + ": GNV1B is not an input of process"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("ignored"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("+ 0 rejected"), std::string::npos) << a.out;
  // The simulator's sim.lcmlog (not ".lcm"): recognised by content; the same rows.
  CliRun b = run("process" + cfg + d + "sim.lcmlog " + qsa + " --out " + d + "b.csv");
  ASSERT_EQ(b.status, 0) << b.out;
  std::ifstream fa(d + "a.csv"), fb(d + "b.csv");
  std::stringstream sa, sb;
  sa << fa.rdbuf();
  sb << fb.rdbuf();
  EXPECT_GT(sa.str().size(), 10000u);
  EXPECT_EQ(sa.str(), sb.str());
  // Level-1 and LCM together would feed the core twice: refused with both names.
  CliRun mixed = run("process" + cfg + d + "sim.lcmlog " + d + "SCA1A_2023-06-01_C_04.txt " + qsa + " --out " + d + "c.csv");
  EXPECT_EQ(mixed.status, 1) << mixed.out;
  EXPECT_NE(mixed.out.find("sim.lcmlog is an LCM log and"), std::string::npos) << mixed.out;
  // inspect summarises the log too.
  CliRun i = run("inspect " + d + "sim.lcmlog");
  EXPECT_EQ(i.status, 0) << i.out;
  EXPECT_NE(i.out.find("LCM log"), std::string::npos) << i.out;
}

TEST(Cli, ProcessCompareSca1bFilesThatCannotBeReadAreErrors) {
  std::string dir = tempDir();
  CliRun sim = run("simulate --scenario " BORESIGHT_SOURCE_DIR "/config/sim_gracefo.yaml --seed 3 --duration 20 --out " +
                   dir + " --quiet --no-lcm");
  ASSERT_EQ(sim.status, 0) << sim.out;
  const std::string d = dir + "/";
  const std::string base = "process --config " BORESIGHT_SOURCE_DIR "/config/gracefo.yaml " + d +
                           "SCA1A_2023-06-01_C_04.txt " + d + "QSA1B_2023-06-01_C_04.txt --out " + d + "p.csv";
  // A missing SCA1B: exit 1 with the file and the reason (before the replay, nothing else printed).
  CliRun a = run(base + " --compare-sca1b " + d + "no_such_SCA1B.txt");
  EXPECT_EQ(a.status, 1) << a.out;
  EXPECT_NE(a.out.find(d + "no_such_SCA1B.txt:0: cannot open"), std::string::npos) << a.out;
  EXPECT_EQ(a.out.find("rows"), std::string::npos) << a.out;
  // A file that is not SCA1B.
  CliRun b = run(base + " --compare-sca1b " + d + "GNV1B_2023-06-01_C_04.txt");
  EXPECT_EQ(b.status, 1) << b.out;
  EXPECT_NE(b.out.find(d + "GNV1B_2023-06-01_C_04.txt:1: GNV1B is not an SCA1B product"), std::string::npos) << b.out;
  // Garbage: not a Level-1 product at all.
  { std::ofstream(d + "SCA1B_garbage.txt") << "no header here\n"; }
  CliRun c = run(base + " --compare-sca1b " + d + "SCA1B_garbage.txt");
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find(d + "SCA1B_garbage.txt:"), std::string::npos) << c.out;
  // A missing or wrong CLK1B, with a readable SCA1B (an empty one written through the library).
  auto sca1b = makeProduct<Sca1bRecord>(Product::SCA1B, 'C');
  std::string err;
  ASSERT_TRUE(writeProduct(d + "SCA1B_2023-06-01_C_04.txt", sca1b, &err)) << err;
  CliRun e = run(base + " --compare-sca1b " + d + "SCA1B_2023-06-01_C_04.txt --clk1b " + d + "no_such_CLK1B.txt");
  EXPECT_EQ(e.status, 1) << e.out;
  EXPECT_NE(e.out.find(d + "no_such_CLK1B.txt:0: cannot open"), std::string::npos) << e.out;
  CliRun f = run(base + " --compare-sca1b " + d + "SCA1B_2023-06-01_C_04.txt --clk1b " + d + "GNV1B_2023-06-01_C_04.txt");
  EXPECT_EQ(f.status, 1) << f.out;
  EXPECT_NE(f.out.find("GNV1B is not a CLK1B product"), std::string::npos) << f.out;
  // The readable (empty) SCA1B: the replay runs, the comparison says it found nothing, exit 0.
  CliRun g = run(base + " --compare-sca1b " + d + "SCA1B_2023-06-01_C_04.txt");
  EXPECT_EQ(g.status, 0) << g.out;
  EXPECT_NE(g.out.find("SCA1B comparison: no common epochs"), std::string::npos) << g.out;
}

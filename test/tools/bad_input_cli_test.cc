// Bad input never wins (issue 18): every case a new user found, run as that user ran it. Each test
// failed before the change it guards (see the commit messages for the breaks tried).
//   - no abort, no hang, no unbounded read: a directory as --config, /dev/zero as an input;
//   - one bad sample costs one sample: a missing SCA1A line, a wild time tag, every decimation;
//   - the physically impossible is refused with file:line and counted once;
//   - outputs never destroy inputs, and appear whole or not at all;
//   - every configuration error names file, line and key; NaN options and duplicated keys are errors.
#include <boresight/io/level1.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <sys/stat.h>
#include <unistd.h>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

using testutil::CliRun;
const std::string kSrc = BORESIGHT_SOURCE_DIR;
// The platform file of simulated data (the ideal noise preset, as every test on simulated data); the
// edited copies of platformWith() start from its base, config/gracefo.yaml (self-contained).
const std::string kConfig = kSrc + "/config/gracefo_ideal.yaml";
const std::string kBaseConfig = kSrc + "/config/gracefo.yaml";

CliRun run(const std::string& args) { return testutil::runProgram(BORESIGHT_CLI, args); }

struct Sim {
  std::string dir, sca, acc, qsa, gnv, lcm;
};

/// The short calibration scenario (three manoeuvres), 20 minutes, simulated once.
const Sim& sim() {
  static const Sim s = [] {
    Sim x;
    x.dir = testutil::makeTempDir("bad_input_sim");
    const CliRun r = run("simulate --scenario " + kSrc + "/config/sim_gracefo_calibration_short.yaml --seed 1 " +
                         "--duration 1200 --out " + x.dir + " --quiet");
    EXPECT_EQ(r.status, 0) << r.out;
    x.sca = x.dir + "/SCA1A_2023-06-01_C_04.txt";
    x.acc = x.dir + "/ACC1A_2023-06-01_C_04.txt";
    x.qsa = x.dir + "/QSA1B_2023-06-01_C_04.txt";
    x.gnv = x.dir + "/GNV1B_2023-06-01_C_04.txt";
    x.lcm = x.dir + "/sim.lcmlog";
    return x;
  }();
  return s;
}

/// A Level-1 file as (header text, data lines).
struct Lines {
  std::string header;
  std::vector<std::string> data;
};
Lines splitLevel1(const std::string& path) {
  const std::string t = testutil::slurp(path);
  Lines l;
  std::size_t end = t.find("# End of YAML header\n");
  std::size_t body = end != std::string::npos ? end + 21 : t.find("END OF HEADER");
  if (end == std::string::npos) body = t.find('\n', body) + 1;
  l.header = t.substr(0, body);
  std::istringstream in(t.substr(body));
  std::string line;
  while (std::getline(in, line)) l.data.push_back(line);
  return l;
}
std::string join(const Lines& l) {
  std::string s = l.header;
  for (const auto& d : l.data) s += d + "\n";
  return s;
}
std::vector<std::string> fields(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> f;
  std::string x;
  while (in >> x) f.push_back(x);
  return f;
}
std::string unfields(const std::vector<std::string>& f) {
  std::string s;
  for (const auto& x : f) s += (s.empty() ? "" : " ") + x;
  return s;
}

/// A copy of `path` under `name` in a fresh folder with data line k changed by `edit` (or removed when
/// edit returns an empty string).
template <typename Edit>
std::string damaged(const std::string& dir, const std::string& path, const std::string& name, std::size_t k, Edit edit) {
  Lines l = splitLevel1(path);
  EXPECT_LT(k, l.data.size());
  std::string e = edit(fields(l.data[k]));
  if (e.empty()) l.data.erase(l.data.begin() + static_cast<std::ptrdiff_t>(k));
  else l.data[k] = e;
  const std::string out = dir + "/" + name;
  EXPECT_TRUE(testutil::writeFile(out, join(l)));
  return out;
}

std::string copyTo(const std::string& dir, const std::string& path, const std::string& name) {
  const std::string out = dir + "/" + name;
  EXPECT_TRUE(testutil::writeFile(out, testutil::slurp(path)));
  return out;
}

/// config/gracefo.yaml with line `key: value` replaced (the first line holding `key:`).
std::string platformWith(const std::string& dir, const std::string& key, const std::string& line_text) {
  std::ifstream in(kBaseConfig);
  std::ostringstream o;
  std::string line;
  bool done = false;
  while (std::getline(in, line)) {
    if (!done && line.find(key + ":") != std::string::npos) {
      o << line_text << "\n";
      done = true;
      continue;
    }
    o << line << "\n";
  }
  EXPECT_TRUE(done) << key;
  const std::string p = dir + "/gracefo.yaml";
  EXPECT_TRUE(testutil::writeFile(p, o.str()));
  return p;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

/// "NAME: N read, M used, ..." of a replay summary line for a file.
std::string summaryLine(const std::string& out, const std::string& file) {
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(file + ": ", 0) == 0 && has(line, " read")) return line;
  return {};
}

}  // namespace

// ---- no abort, no hang, no unbounded read ----------------------------------------------------------

TEST(BadInputCli, ADirectoryAsConfigIsAnErrorNotAnAbort) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_cfgdir");
  const std::string cfg_dir = testutil::makeTempDir("bad_cfgdir_config");
  for (const std::string& cmd : {"process --out " + dir + "/o.csv", "calibrate --json " + dir + "/o.json",
                                "audit --quiet --out " + dir + "/audit"}) {
    const CliRun r = run(cmd + " --config " + cfg_dir + " " + s.sca + " " + s.acc + " " + s.qsa);
    EXPECT_EQ(r.status, 1) << cmd << "\n" << r.out;
    EXPECT_TRUE(has(r.out, cfg_dir + ": is a directory, not a platform configuration file")) << r.out;
    EXPECT_FALSE(has(r.out, "terminate")) << r.out;
  }
  EXPECT_NE(::access((dir + "/audit").c_str(), F_OK), 0) << "a failed audit left its output folder";
}

TEST(BadInputCli, EndlessInputsAreRefusedWithTheLimitTheyCrossed) {
  const std::string dir = testutil::makeTempDir("bad_endless");
  // Under a 1 GiB address-space limit: before the bounds these grew until killed or bad_alloc.
  auto limited = [](const std::string& args) {
    return testutil::runProgram("ulimit -v 1048576; " + std::string(BORESIGHT_CLI), args);
  };
  CliRun g = limited("ground --input /dev/zero --json " + dir + "/g.json");
  EXPECT_EQ(g.status, 1) << g.out;
  EXPECT_TRUE(has(g.out, "/dev/zero: more than 256 MiB (the limit for a ground measurement file)")) << g.out;
  CliRun i = limited("inspect /dev/zero");
  EXPECT_EQ(i.status, 1) << i.out;
  EXPECT_TRUE(has(i.out, "limit")) << i.out;
  ASSERT_TRUE(testutil::writeFile(dir + "/overlay.yaml", "base: /dev/zero\n"));
  CliRun sc = limited("simulate --scenario " + dir + "/overlay.yaml --seed 1 --duration 10 --out " + dir + "/sim");
  EXPECT_EQ(sc.status, 1) << sc.out;
  EXPECT_TRUE(has(sc.out, "/dev/zero: more than 4 MiB (the limit for a scenario file)")) << sc.out;
  EXPECT_NE(::access((dir + "/sim").c_str(), F_OK), 0) << "a failed simulate left its output folder";
  CliRun c = limited("process --config /dev/zero x --out " + dir + "/o.csv");
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_TRUE(has(c.out, "limit for a platform configuration file")) << c.out;
}

// ---- one bad sample costs one sample ----------------------------------------------------------------

TEST(BadInputCli, OneMissingSca1aLineDoesNotSpoilTheCalibration) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_missing");
  // One head, one epoch, in the middle of the manoeuvres: before, "observation 1 ... is not later
  // than the one before" and a refusal.
  std::size_t line = 0;
  {
    const Lines l = splitLevel1(s.sca);
    // Head 2 at the first tag after a point of the 10 s grid the CRN outputs on (seconds ending in 5
    // here): its filter then waits one sample longer than the other heads' (a line elsewhere costs less).
    for (std::size_t k = l.data.size() / 2; k < l.data.size(); ++k) {
      const auto f = fields(l.data[k]);
      if (f[3] == "2" && std::stoll(f[0]) % 10 == 5 && std::stoll(f[1]) < 500000) {
        line = k;
        break;
      }
    }
    ASSERT_GT(line, 0u);
  }
  const std::string sca = damaged(dir, s.sca, "SCA1A_2023-06-01_C_04.txt", line, [](auto) { return std::string(); });
  const CliRun r = run("calibrate --config " + kConfig + " " + sca + " " + s.acc + " " + s.qsa + " --json " + dir +
                       "/cal.json");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_FALSE(has(r.out, "not later than")) << r.out;
}

TEST(BadInputCli, OneTagFarAheadCostsOneSampleAndNotTheSpan) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_wildtag");
  // SCA1A line 1000 with a tag 1e8 s ahead: half the file was "late" and calibrate reported a span of
  // 1e8 s with exit 0.
  const std::string sca = damaged(dir, s.sca, "SCA1A_2023-06-01_C_04.txt", 1000, [](std::vector<std::string> f) {
    f[0] = std::to_string(std::stoll(f[0]) + 100000000LL);
    return unfields(f);
  });
  const CliRun r = run("calibrate --config " + kConfig + " " + sca + " " + s.acc + " " + s.qsa + " --json " + dir +
                       "/cal.json");
  EXPECT_EQ(r.status, 0) << r.out;
  const std::string line = summaryLine(r.out, sca);
  EXPECT_TRUE(has(line, ", 1 implausible value")) << r.out;
  EXPECT_FALSE(has(line, "late")) << line;
  EXPECT_TRUE(has(r.out, "span: 1199.5 s of head data")) << r.out;
  // The same damage in an LCM log (no file date to gate it): the assembler drops it as an outlier.
}

TEST(BadInputCli, EveryDecimationInTheAcceptedRangeWorks) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_decim");
  // 0.5, 1, 2, 4 and 5 s gave NaN residuals and solver logging before; the range starts at the head interval.
  for (const char* d : {"0.5", "1", "2", "3", "4", "5", "20"}) {
    const CliRun r = run("calibrate --config " + kConfig + " " + s.sca + " " + s.acc + " " + s.qsa + " --decimation " +
                         d + " --json " + dir + "/cal_" + d + ".json");
    EXPECT_EQ(r.status, 0) << "--decimation " << d << "\n" << r.out;
    EXPECT_FALSE(has(r.out, "nan")) << "--decimation " << d << "\n" << r.out;
    EXPECT_FALSE(has(r.out, "iter ")) << "--decimation " << d << ": solver logging\n" << r.out;
  }
  const CliRun below = run("calibrate --config " + kConfig + " " + s.sca + " " + s.acc + " " + s.qsa +
                           " --decimation 0.2 --json " + dir + "/x.json");
  EXPECT_EQ(below.status, 1) << below.out;
  EXPECT_TRUE(has(below.out, "decimation")) << below.out;
}

// ---- the physically impossible is refused, counted once ---------------------------------------------

TEST(BadInputCli, ImpossibleQsa1bAlignmentsAreRefusedWithTheirLine) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_qsa");
  auto runWith = [&](const std::string& qsa) {
    return run("process --config " + kConfig + " " + s.sca + " " + s.acc + " " + qsa + " --out " + dir + "/o.csv");
  };
  // Scaled by 2 (taken as is before), a component zeroed (angles 7900 sigma off, exit 0 before), NaN
  // ("give a QSA1B file" before), 1e308 ("core rejected the configuration: invalid_config" before).
  const std::vector<std::pair<std::string, std::function<std::string(std::vector<std::string>)>>> cases = {
      {"scaled", [](std::vector<std::string> f) {
         for (int k = 3; k < 7; ++k) f[std::size_t(k)] = std::to_string(2 * std::stod(f[std::size_t(k)]));
         return unfields(f);
       }},
      {"zeroed", [](std::vector<std::string> f) { f[4] = "0"; return unfields(f); }},
      {"nan", [](std::vector<std::string> f) { f[5] = "nan"; return unfields(f); }},
      {"huge", [](std::vector<std::string> f) { f[3] = "1e308"; return unfields(f); }}};
  for (const auto& [name, edit] : cases) {
    const std::string d = dir + "/" + name;
    ::mkdir(d.c_str(), 0777);
    const std::string qsa = damaged(d, s.qsa, "QSA1B_2023-06-01_C_04.txt", 1, edit);
    const CliRun r = runWith(qsa);
    EXPECT_EQ(r.status, 1) << name << "\n" << r.out;
    const Lines l = splitLevel1(qsa);
    const std::size_t line_no = static_cast<std::size_t>(std::count(l.header.begin(), l.header.end(), '\n')) + 2;
    EXPECT_TRUE(has(r.out, qsa + ":" + std::to_string(line_no) + ": ")) << name << "\n" << r.out;
    EXPECT_TRUE(has(r.out, "the mountings cannot be taken from it")) << name << "\n" << r.out;
    EXPECT_FALSE(has(r.out, "invalid_config")) << r.out;
  }
}

TEST(BadInputCli, AnAngularAccelerationOf1e308IsRejectedAndCountedNotProcessed) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_acc");
  const std::string acc = damaged(dir, s.acc, "ACC1A_2023-06-01_C_04.txt", 3000, [](std::vector<std::string> f) {
    f[10] = "1e308";  // ang_accl_y (bits 0-5 set: lin x y z, ang x y z after the 6 leading fields)
    return unfields(f);
  });
  const CliRun r = run("process --config " + kConfig + " " + s.sca + " " + acc + " " + s.qsa + " --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(summaryLine(r.out, acc), ", 1 implausible value")) << r.out;
  EXPECT_TRUE(has(r.out, "angular acceleration y = 1e+308 rad/s^2")) << r.out;
  EXPECT_FALSE(has(testutil::slurp(dir + "/o.csv"), "e+30")) << "a 1e308 sample reached the rows";
}

TEST(BadInputCli, AnOrbitRadiusOf1e30IsRejectedAndReported) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_gnv");
  const std::string gnv = damaged(dir, s.gnv, "GNV1B_2023-06-01_C_04.txt", 100, [](std::vector<std::string> f) {
    f[3] = "1e30";
    return unfields(f);
  });
  const CliRun r = run("calibrate --config " + kConfig + " " + s.sca + " " + s.acc + " " + s.qsa + " " + gnv +
                       " --json " + dir + "/c.json");
  EXPECT_EQ(r.status, 0) << r.out;
  const std::string line = summaryLine(r.out, gnv);
  EXPECT_TRUE(has(line, "1200 read, 1199 used, 1 implausible value")) << r.out;
  EXPECT_TRUE(has(r.out, "implausible: orbit radius 1e+30 m")) << r.out;
}

TEST(BadInputCli, APlatformHeadRateThatDiffersFromTheDataIsAnErrorWithBothRates) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_rate");
  const std::string cfg = platformWith(dir, "  fs_hz", "  fs_hz: 1.0");
  const CliRun r = run("process --config " + cfg + " " + s.sca + " " + s.acc + " " + s.qsa + " --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "each head is sampled every 0.5 s (2 Hz")) << r.out;
  EXPECT_TRUE(has(r.out, "crn_attitude.fs_hz is 1 Hz")) << r.out;
}

TEST(BadInputCli, CountsAddUpAFileTwiceAndNonUnitQuaternions) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_counts");
  // The same file twice: refused (every sample would count twice).
  CliRun r = run("process --config " + kConfig + " " + s.sca + " " + s.sca + " " + s.qsa + " --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "given twice")) << r.out;
  // Its content under another name: duplicates, not "more heads than kMaxHeads" counted as used.
  const std::string copy = copyTo(dir, s.sca, "SCA1A_2023-06-01_C_05.txt");
  r = run("process --config " + kConfig + " " + s.sca + " " + copy + " " + s.qsa + " --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_FALSE(has(r.out, "more heads than kMaxHeads")) << r.out;
  EXPECT_TRUE(has(summaryLine(r.out, copy), "duplicate (same head, same tag)")) << r.out;
  // Ten non-unit quaternions: counted in the file summary, once, not by the core instead.
  Lines l = splitLevel1(s.sca);
  for (std::size_t k = 500; k < 510; ++k) {
    auto f = fields(l.data[k]);
    for (int j = 5; j < 9; ++j) f[std::size_t(j)] = std::to_string(std::stod(f[std::size_t(j)]) * 1.01);
    l.data[k] = unfields(f);
  }
  const std::string sca = dir + "/SCA1A_2023-06-01_C_04.txt";
  ASSERT_TRUE(testutil::writeFile(sca, join(l)));
  r = run("process --config " + kConfig + " " + sca + " " + s.qsa + " --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(has(summaryLine(r.out, sca), ", 10 implausible value")) << r.out;
  EXPECT_FALSE(has(r.out, "non_unit_quaternion")) << r.out;
}

// ---- outputs never destroy inputs --------------------------------------------------------------------

TEST(BadInputCli, AnOutputOverAnInputIsRefusedBeforeAnythingIsWritten) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_outputs");
  const std::string sca = copyTo(dir, s.sca, "SCA1A_2023-06-01_C_04.txt");
  const std::string before = testutil::slurp(sca);
  CliRun r = run("process --config " + kConfig + " " + sca + " " + s.acc + " " + s.qsa + " --out " + sca);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "is also an input")) << r.out;
  r = run("calibrate --config " + kConfig + " " + sca + " " + s.acc + " " + s.qsa + " --json " + dir + "/../" +
          dir.substr(dir.find_last_of('/') + 1) + "/SCA1A_2023-06-01_C_04.txt");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(testutil::slurp(sca), before) << "an input was overwritten";
  r = run("process --config " + kConfig + " " + sca + " " + s.acc + " " + s.qsa + " --out " + dir + "/o.csv --stars-out " +
          dir + "/o.csv");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "name the same file")) << r.out;
  // A run that fails leaves the previous output, not half of a new one (or an empty one).
  ASSERT_TRUE(testutil::writeFile(dir + "/prev.csv", "previous\n"));
  Lines l = splitLevel1(s.sca);
  l.data.resize(3);
  for (auto& d : l.data) {
    auto f = fields(d);
    f[5] = "7";  // every quaternion implausible: no star sensor sample reaches the core
    d = unfields(f);
  }
  const std::string bad = dir + "/SCA1A_2023-06-03_C_04.txt";
  ASSERT_TRUE(testutil::writeFile(bad, join(l)));
  r = run("process --config " + kConfig + " " + bad + " " + s.qsa + " --out " + dir + "/prev.csv");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(testutil::slurp(dir + "/prev.csv"), "previous\n");
}

// ---- messages with a place -----------------------------------------------------------------------------

TEST(BadInputCli, ConfigurationErrorsNameFileLineAndKey) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_msgs");
  auto process = [&](const std::string& cfg) {
    return run("process --config " + cfg + " " + s.sca + " " + s.acc + " " + s.qsa + " --out " + dir + "/o.csv");
  };
  struct Case {
    std::string key, line, expect;
  };
  // "core rejected the configuration: invalid_config" with no place before.
  for (const Case& c : {Case{"output_period_s", "  output_period_s: 1e-9", "key 'crn_attitude.output_period_s'"},
                        Case{"unit_norm_tolerance", "  unit_norm_tolerance: 10", "key 'heads.unit_norm_tolerance'"},
                        Case{"relative_time_constant_s", "  relative_time_constant_s: .nan", "key 'heads.relative_time_constant_s'"},
                        Case{"bridge_fit", "  bridge_fit: spline", "key 'crn_attitude.bridge_fit'"}}) {
    const std::string cfg = platformWith(dir, c.key, c.line);
    const CliRun r = process(cfg);
    EXPECT_EQ(r.status, 1) << c.key << "\n" << r.out;
    EXPECT_TRUE(has(r.out, cfg + ":")) << r.out;
    EXPECT_TRUE(has(r.out, c.expect)) << r.out;
    EXPECT_FALSE(has(r.out, "invalid_config")) << r.out;
  }
  // A duplicated key: the first value won silently before.
  {
    std::ifstream in(kBaseConfig);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string t = ss.str();
    t.replace(t.find("platform:"), 9, "platform: A\nplatform:");
    ASSERT_TRUE(testutil::writeFile(dir + "/dup.yaml", t));
    const CliRun r = process(dir + "/dup.yaml");
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_TRUE(has(r.out, "key 'platform': given twice in this mapping (first at line")) << r.out;
  }
  // NaN passed the range checks of the options before.
  for (const char* opt : {"--lookahead nan"}) {
    const CliRun r = run("process --config " + kConfig + " " + s.sca + " " + s.qsa + " --out " + dir + "/o.csv " + opt);
    EXPECT_EQ(r.status, 2) << opt << "\n" << r.out;
    EXPECT_TRUE(has(r.out, "not a finite number")) << r.out;
  }
  for (const char* opt : {"--huber nan", "--plan-excitation nan", "--decimation inf"}) {
    const CliRun r = run("calibrate --config " + kConfig + " " + s.sca + " " + s.acc + " " + s.qsa + " --json " + dir +
                         "/o.json " + opt);
    EXPECT_EQ(r.status, 2) << opt << "\n" << r.out;
    EXPECT_TRUE(has(r.out, "not a finite number")) << r.out;
  }
  // A duplicated key in a scenario and in a ground measurement file.
  ASSERT_TRUE(testutil::writeFile(dir + "/sc.yaml", "base: " + kSrc + "/config/sim_gracefo.yaml\nseed: 1\nseed: 2\n"));
  CliRun r = run("simulate --scenario " + dir + "/sc.yaml --seed 1 --duration 10 --out " + dir + "/sim --quiet");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, dir + "/sc.yaml:3: key 'seed': given twice in this mapping (first at line 2)")) << r.out;
  ASSERT_EQ(run("simulate-ground --seed 1 --out " + dir + "/m.yaml").status, 0);
  std::string m = testutil::slurp(dir + "/m.yaml");
  m.replace(m.find("gravity_mps2:"), 13, "gravity_mps2: 9.8\ngravity_mps2:");
  ASSERT_TRUE(testutil::writeFile(dir + "/m2.yaml", m));
  r = run("ground --input " + dir + "/m2.yaml --json " + dir + "/g.json");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "key 'gravity_mps2': given twice in this mapping")) << r.out;
}

TEST(BadInputCli, LogsWithNothingToUseSaySo) {
  const std::string dir = testutil::makeTempDir("bad_empty");
  ASSERT_TRUE(testutil::writeFile(dir + "/empty.lcm", ""));
  const CliRun r = run("process --config " + kConfig + " " + dir + "/empty.lcm --out " + dir + "/o.csv");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "empty.lcm")) << r.out;
}

// ---- the model overlay and `boresight noise` (added on main after the cases above) ----------------

TEST(BadInputCli, TheModelOverlayIsReadBoundedAndChecked) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_overlay");
  auto process = [&](const std::string& overlay, const std::string& out = "") {
    return run("process --config " + kConfig + " --overlay " + overlay + " " + s.sca + " " + s.acc + " " + s.qsa +
               " --out " + (out.empty() ? dir + "/o.csv" : out));
  };
  // A directory and an endless input: refused with the reason, not read.
  const std::string ov_dir = testutil::makeTempDir("bad_overlay_dir");
  CliRun r = process(ov_dir);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, ov_dir + ": is a directory, not a model overlay")) << r.out;
  r = process("/dev/zero");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "/dev/zero: more than 4 MiB (the limit for a model overlay)")) << r.out;
  // A duplicated key anywhere in the tree, with its line and the first one's.
  const std::string ov = dir + "/ov.yaml";
  ASSERT_TRUE(testutil::writeFile(ov, "boresight_overlay: 1\nwritten_by: test\nnoise:\n  head_defaults:\n"
                                      "    cross_x: [{kind: white, sigma_arcsec: 6}]\n"
                                      "    cross_x: [{kind: white, sigma_arcsec: 7}]\n"));
  r = process(ov);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, ov + ":6: key 'noise.head_defaults.cross_x': given twice in this mapping (first at line 5)")) << r.out;
  // NaN as a level: refused with file, line and key.
  ASSERT_TRUE(testutil::writeFile(ov, "boresight_overlay: 1\nwritten_by: test\nnoise:\n  head_defaults:\n"
                                      "    cross_x: [{kind: white, sigma_arcsec: .nan}]\n"));
  r = process(ov);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, ov + ":5: key 'noise.head_defaults.cross_x")) << r.out;
  EXPECT_TRUE(has(r.out, "not a finite number")) << r.out;
  // An output over the overlay: refused before anything is written.
  ASSERT_TRUE(testutil::writeFile(ov, "boresight_overlay: 1\nwritten_by: test\nnoise:\n  head_defaults:\n"
                                      "    cross_x: [{kind: white, sigma_arcsec: 6}]\n"));
  const std::string before = testutil::slurp(ov);
  r = process(ov, ov);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "is also an input")) << r.out;
  r = run("calibrate --config " + kConfig + " --overlay " + ov + " " + s.sca + " " + s.acc + " " + s.qsa + " --json " +
          dir + "/c.json --write-model " + ov);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "--write-model " + ov + ": is also an input")) << r.out;
  EXPECT_EQ(testutil::slurp(ov), before) << "the overlay was overwritten";
}

TEST(BadInputCli, TheNoiseCommandRefusesNanOutputsOverInputsAndLeavesNoFolderWhenItFails) {
  const Sim& s = sim();
  const std::string dir = testutil::makeTempDir("bad_noise");
  const std::string ins = " " + s.sca + " " + s.acc + " " + s.qsa;
  for (const char* opt : {"--lookahead nan", "--acc-block inf"}) {
    const CliRun r = run("noise --config " + kConfig + ins + " --out " + dir + "/n " + opt);
    EXPECT_EQ(r.status, 2) << opt << "\n" << r.out;
    EXPECT_TRUE(has(r.out, "not a finite number")) << opt << "\n" << r.out;
  }
  // A directory as --config: an error with the reason, and no output folder left behind.
  const std::string cfg_dir = testutil::makeTempDir("bad_noise_cfg");
  CliRun r = run("noise --quiet --config " + cfg_dir + ins + " --out " + dir + "/failed");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, cfg_dir + ": is a directory, not a platform configuration file")) << r.out;
  EXPECT_NE(::access((dir + "/failed").c_str(), F_OK), 0) << "a failed noise run left its output folder";
  // An input in the output folder under a name noise writes (the overlay it compares with, kept as
  // DIR/overlay.yaml): refused, not overwritten.
  const std::string out = dir + "/out";
  ::mkdir(out.c_str(), 0777);
  const std::string ov = out + "/overlay.yaml";
  ASSERT_TRUE(testutil::writeFile(ov, "boresight_overlay: 1\nwritten_by: test\nnoise:\n  head_defaults:\n"
                                      "    cross_x: [{kind: white, sigma_arcsec: 6}]\n"));
  const std::string before = testutil::slurp(ov);
  r = run("noise --quiet --config " + kConfig + " --overlay " + ov + ins + " --out " + out);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(has(r.out, "--out " + ov + ": is also an input")) << r.out;
  EXPECT_EQ(testutil::slurp(ov), before);
}

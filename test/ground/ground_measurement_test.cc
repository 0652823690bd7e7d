// The measurement file: round trip, both angle conventions, and every kind of bad file gives
// "name:line: reason" (line of the offending node), never a crash.
#include <boresight/ground/measurement.h>
#include <boresight/ground/simulate.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

using namespace boresight;
using namespace boresight::ground;

const char* kName = "meas.yaml";

/// A valid file: one position, 5 targets, 3 accelerometer samples, written by the writer.
std::string validText() {
  SimConfig cfg;
  cfg.targets = 5;
  cfg.accel_samples = 3;
  Measurement m;
  SimTruth t;
  EXPECT_TRUE(simulateGround(cfg, m, t, nullptr));
  // A directory of its own: ctest runs this file's tests as parallel processes, and one fixed name
  // let one test delete the file another was reading.
  const std::filesystem::path dir = testutil::makeTempDir("boresight_ground_meas");
  const auto path = dir / "meas.yaml";
  EXPECT_TRUE(writeMeasurement(path.string(), m, nullptr));
  const std::string text = testutil::slurp(path.string());
  std::filesystem::remove_all(dir);
  return text;
}

/// 1-based line of the n-th (0-based) occurrence of `what`.
int lineOf(const std::string& text, const std::string& what, int n = 0) {
  std::size_t pos = 0;
  for (int i = 0; i <= n; ++i) {
    pos = text.find(what, i == 0 ? 0 : pos + 1);
    if (pos == std::string::npos) return -1;
  }
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

/// The whole line holding the n-th occurrence of `what`.
std::string lineText(const std::string& text, const std::string& what, int n = 0) {
  std::size_t pos = 0;
  for (int i = 0; i <= n; ++i) pos = text.find(what, i == 0 ? 0 : pos + 1);
  const std::size_t b = text.rfind('\n', pos) + 1, e = text.find('\n', pos);
  return text.substr(b, e - b);
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return text.replace(pos, from.size(), to);
}

std::string errorOf(const std::string& text) {
  Measurement m;
  std::string err;
  EXPECT_FALSE(parseMeasurement(text, kName, m, &err)) << "accepted a bad file";
  return err;
}

std::string at(int line) { return std::string(kName) + ":" + std::to_string(line) + ": "; }

TEST(GroundMeasurement, RoundTrip) {
  SimConfig cfg;
  cfg.targets = 7;
  cfg.accel_samples = 10;
  cfg.positions = 2;
  cfg.prism_faces = 2;
  Measurement m, back;
  SimTruth t;
  ASSERT_TRUE(simulateGround(cfg, m, t, nullptr));
  m.positions[1].name = "table \"B\" \\ 20 deg: tilted";
  const std::filesystem::path dir = testutil::makeTempDir("boresight_ground_rt");
  const auto path = dir / "rt.yaml";
  ASSERT_TRUE(writeMeasurement(path.string(), m, nullptr));
  std::string err;
  ASSERT_TRUE(loadMeasurement(path.string(), back, &err)) << err;
  std::filesystem::remove_all(dir);
  EXPECT_EQ(back.gravity_mps2, m.gravity_mps2);
  EXPECT_NEAR(back.q_s_t_design.angularDistance(m.q_s_t_design), 0, 1e-14);
  EXPECT_EQ(back.camera.width_px, 1024);
  EXPECT_EQ(back.positions[1].name, m.positions[1].name);
  ASSERT_EQ(back.positions.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    ASSERT_EQ(back.positions[k].targets.size(), 7u);
    ASSERT_EQ(back.positions[k].prisms.size(), 2u);
    ASSERT_EQ(back.positions[k].accel_mps2.size(), 10u);
    for (std::size_t i = 0; i < 7; ++i) {
      EXPECT_NEAR(back.positions[k].targets[i].az_rad, m.positions[k].targets[i].az_rad, 1e-13);
      EXPECT_NEAR(back.positions[k].targets[i].u_px, m.positions[k].targets[i].u_px, 1e-6);
      EXPECT_GT(back.positions[k].targets[i].line, 0);
    }
    EXPECT_NEAR((back.positions[k].accel_mps2[3] - m.positions[k].accel_mps2[3]).norm(), 0, 1e-9);
    EXPECT_NEAR((back.positions[k].prisms[1].axis_t - Vec3::UnitY()).norm(), 0, 1e-15);
  }
}

TEST(GroundMeasurement, SurveyorConventionsAreTheSameDirection) {
  // azimuth_cw_deg = -a, zenith_deg = 90 - e
  const std::string ok = validText();
  const std::string line = lineText(ok, "centroid_px");
  double a = 0, e = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "      - {azimuth_deg: %lf, elevation_deg: %lf", &a, &e), 2) << line;
  char cw[200];
  std::snprintf(cw, sizeof cw, "      - {azimuth_cw_deg: %.12f, zenith_deg: %.12f,", -a, 90.0 - e);
  const std::string head = line.substr(0, line.find("centroid_px"));
  const std::string text = replaced(ok, head, cw);
  Measurement m1, m2;
  std::string err;
  ASSERT_TRUE(parseMeasurement(ok, kName, m1, &err)) << err;
  ASSERT_TRUE(parseMeasurement(text, kName, m2, &err)) << err;
  EXPECT_NEAR(m1.positions[0].targets[0].az_rad, m2.positions[0].targets[0].az_rad, 1e-14);
  EXPECT_NEAR(m1.positions[0].targets[0].el_rad, m2.positions[0].targets[0].el_rad, 1e-14);
  EXPECT_NEAR(m2.positions[0].targets[0].az_rad, a * kRadPerDeg, 1e-14);
}

TEST(GroundMeasurement, BadFilesNameTheLine) {
  const std::string ok = validText();
  Measurement m;
  std::string err;
  ASSERT_TRUE(parseMeasurement(ok, kName, m, &err)) << err;

  // a missing key: the target's line
  {
    const std::string l = lineText(ok, "centroid_px", 1);
    const std::string t = replaced(ok, l, l.substr(0, l.find(", centroid_px")) + "}");
    EXPECT_EQ(errorOf(t).rfind(at(lineOf(ok, "centroid_px", 1)), 0), 0u) << errorOf(t);
    EXPECT_NE(errorOf(t).find("missing key 'centroid_px'"), std::string::npos) << errorOf(t);
  }
  // NaN and a word where a number belongs
  {
    const std::string l = lineText(ok, "centroid_px", 2);
    const std::string bad = l.substr(0, l.find("centroid_px")) + "centroid_px: [.nan, 10.0]}";
    const std::string e = errorOf(replaced(ok, l, bad));
    EXPECT_EQ(e.rfind(at(lineOf(ok, "centroid_px", 2)), 0), 0u) << e;
    EXPECT_NE(e.find("not a finite number"), std::string::npos) << e;
    const std::string e2 = errorOf(replaced(ok, "gravity_mps2: 9.80665", "gravity_mps2: nine"));
    EXPECT_EQ(e2.rfind(at(lineOf(ok, "gravity_mps2")), 0), 0u) << e2;
    EXPECT_NE(e2.find("'nine' is not a number"), std::string::npos) << e2;
  }
  // a centroid outside the detector (default 1024 x 1024) and inside a declared larger one
  {
    const std::string l = lineText(ok, "centroid_px", 3);
    const std::string bad = l.substr(0, l.find("centroid_px")) + "centroid_px: [1030.5, 10.0]}";
    const std::string t = replaced(ok, l, bad);
    const std::string e = errorOf(t);
    EXPECT_EQ(e.rfind(at(lineOf(ok, "centroid_px", 3)), 0), 0u) << e;
    EXPECT_NE(e.find("outside the detector"), std::string::npos) << e;
    std::string err2;
    EXPECT_TRUE(parseMeasurement(replaced(t, "detector_px: [1024, 1024]", "detector_px: [2048, 2048]"), kName, m, &err2))
        << err2;
    const std::string neg = l.substr(0, l.find("centroid_px")) + "centroid_px: [-0.5, 10.0]}";
    EXPECT_NE(errorOf(replaced(ok, l, neg)).find("outside the detector"), std::string::npos);
  }
  // an unknown (misspelt) key, both azimuth conventions at once
  {
    const std::string e = errorOf(replaced(ok, "elevation_deg", "elevation_dg"));
    EXPECT_EQ(e.rfind(at(lineOf(ok, "elevation_deg")), 0), 0u) << e;
    EXPECT_NE(e.find("unknown key 'elevation_dg'"), std::string::npos) << e;
    const std::string e2 = errorOf(replaced(ok, "{azimuth_deg: ", "{azimuth_cw_deg: 1, azimuth_deg: "));
    EXPECT_NE(e2.find("both azimuth_deg and azimuth_cw_deg"), std::string::npos) << e2;
  }
  // too few targets: the position's line
  {
    std::string t = ok;
    for (int i = 0; i < 2; ++i) {
      const std::string l = lineText(t, "centroid_px");
      t = replaced(t, l + "\n", "");
    }
    const std::string e = errorOf(t);
    EXPECT_EQ(e.rfind(at(lineOf(ok, "- name:")), 0), 0u) << e;
    EXPECT_NE(e.find("3 targets, at least 4 are needed"), std::string::npos) << e;
  }
  // targets on a line: every v the same
  {
    std::string t = ok;
    for (int i = 0; i < 5; ++i) {
      const std::string l = lineText(t, "centroid_px", i);
      const std::size_t c = l.find(", ", l.find("centroid_px"));
      t = replaced(t, l, l.substr(0, c) + ", 400.0]}");
    }
    const std::string e = errorOf(t);
    EXPECT_NE(e.find("on a line"), std::string::npos) << e;
    EXPECT_EQ(e.rfind(at(lineOf(ok, "- name:")), 0), 0u) << e;
  }
  // a control character in a position name (a NUL, escaped in YAML): refused with its line - it would
  // not survive the round trip (the fuzzer's finding: "position\0 1" came back as another name)
  {
    for (const char* esc : {"\\0", "\\n", "\\t"}) {
      const std::string e = errorOf(replaced(ok, "name: \"position 1\"", std::string("name: \"position") + esc + "1\""));
      EXPECT_EQ(e.rfind(at(lineOf(ok, "- name:")), 0), 0u) << e;
      EXPECT_NE(e.find("name: a control character in it"), std::string::npos) << e;
    }
  }
  // YAML syntax error, wrong shapes, quaternion, missing blocks
  {
    const std::string e = errorOf(replaced(ok, "principal_point_px: [", "principal_point_px: [["));
    EXPECT_EQ(e.rfind(std::string(kName) + ":", 0), 0u) << e;
    const std::string e2 = errorOf(replaced(ok, "design_q_s_t: [", "design_q_s_t: [0.5, "));
    EXPECT_EQ(e2.rfind(at(lineOf(ok, "design_q_s_t")), 0), 0u) << e2;
    const std::string e3 = errorOf(replaced(ok, "camera:", "kamera:"));
    EXPECT_NE(e3.find("unknown key 'kamera'"), std::string::npos) << e3;
    const std::string acc = lineText(ok, "- [", 0);
    const std::string e4 = errorOf(replaced(ok, acc, acc.substr(0, acc.rfind(',')) + "]"));
    EXPECT_EQ(e4.rfind(at(lineOf(ok, acc)), 0), 0u) << e4;
    EXPECT_NE(e4.find("expected a list of 3 numbers"), std::string::npos) << e4;
    EXPECT_FALSE(errorOf("").empty());
    EXPECT_FALSE(errorOf("[1, 2]").empty());
    EXPECT_NE(errorOf("gravity_mps2: 9.8\n").find("missing key 'camera'"), std::string::npos);
  }
  // a file that does not exist
  {
    Measurement mm;
    std::string e;
    EXPECT_FALSE(loadMeasurement("no/such/file.yaml", mm, &e));
    EXPECT_NE(e.find("cannot open"), std::string::npos);
  }
}

TEST(GroundMeasurement, TruncatedFilesNeverCrash) {
  // every prefix of a valid file (step 7 bytes) is either accepted or refused with a located message
  const std::string ok = validText();
  int refused = 0;
  for (std::size_t n = 0; n < ok.size(); n += 7) {
    Measurement m;
    std::string err;
    if (!parseMeasurement(ok.substr(0, n), kName, m, &err)) {
      ++refused;
      EXPECT_EQ(err.rfind(std::string(kName) + ":", 0), 0u) << err;
    }
  }
  EXPECT_GT(refused, 0);
}

// The accelerometer samples have their own reader (yaml-cpp reads the rest of the file): every YAML
// spelling of the list that reader takes gives the same samples, the line numbers of everything
// after the samples stay right, and the spellings it does not take are refused with a located
// message rather than read some other way.
TEST(GroundMeasurement, SampleListSpellings) {
  const std::string ok = validText();
  Measurement ref;
  std::string err;
  ASSERT_TRUE(parseMeasurement(ok, kName, ref, &err)) << err;
  const auto& want = ref.positions[0].accel_mps2;
  ASSERT_EQ(want.size(), 3u);
  const std::size_t key = ok.find("    accel_mps2:");
  ASSERT_NE(key, std::string::npos);
  const std::string head = ok.substr(0, key);
  std::string rows[3];  // "fx, fy, fz" as written
  for (int i = 0; i < 3; ++i) {
    const std::string l = lineText(ok, "      - [", i);
    rows[i] = l.substr(l.find('[') + 1, l.rfind(']') - l.find('[') - 1);
  }
  // the samples moved in front of the targets (with `lines` newlines), so the targets' lines check
  // that the placeholder keeps the file's line numbering
  const std::size_t tg = head.find("    targets:");
  ASSERT_NE(tg, std::string::npos);
  auto withSamples = [&](const std::string& block) { return head.substr(0, tg) + block + head.substr(tg); };
  const std::vector<std::string> spellings = {
      "    accel_mps2: [[" + rows[0] + "], [" + rows[1] + "], [" + rows[2] + "]]\n",
      "    accel_mps2: [  # the flow list across lines\n      [" + rows[0] + "],\n\n      [" + rows[1] +
          ",\n       ], # trailing comma\n      [" + rows[2] + "]\n    ]  # end\n",
      "    accel_mps2:   # block list, items at the key's column, comments and blank lines\n    - [" + rows[0] +
          "]\n\n    # a comment\n    - [" + rows[1] + "]   # c\n    - [" + rows[2] + "]\n",
      "    accel_mps2:\n      - [" + rows[0] + "]\n      - [" + rows[1].substr(0, rows[1].rfind(',') + 1) +
          "\n         " + rows[1].substr(rows[1].rfind(',') + 1) + "]\n      - [" + rows[2] + "]\n",
  };
  for (const std::string& sp : spellings) {
    const std::string text = withSamples(sp);
    Measurement m;
    ASSERT_TRUE(parseMeasurement(text, kName, m, &err)) << err << "\n" << sp;
    ASSERT_EQ(m.positions[0].accel_mps2.size(), 3u) << sp;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(m.positions[0].accel_mps2[i], want[i]) << sp;
    for (int i = 0; i < 5; ++i) EXPECT_EQ(m.positions[0].targets[i].line, lineOf(text, "centroid_px", i)) << sp;
    // Windows line ends
    std::string crlf;
    for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    ASSERT_TRUE(parseMeasurement(crlf, kName, m, &err)) << err << "\n" << sp;
    for (int i = 0; i < 3; ++i) EXPECT_EQ(m.positions[0].accel_mps2[i], want[i]) << sp;
  }
  // a position name that merely contains the key is a name
  {
    Measurement m;
    ASSERT_TRUE(parseMeasurement(replaced(ok, "name: \"position 1\"", "name: \"accel_mps2: [[1, 2, 3]]\""), kName, m, &err))
        << err;
    EXPECT_EQ(m.positions[0].name, "accel_mps2: [[1, 2, 3]]");
  }
  // errors, each on its line: a word and a NaN inside a multi-line flow list, an unclosed list, a
  // missing value, a quoted number, text after a row, four numbers, a number with a unit after it
  {
    const std::string t = withSamples("    accel_mps2: [\n      [" + rows[0] + "],\n      [" +
                                      rows[1].substr(0, rows[1].find(',')) + ",\n       nine, 1.0]]\n");
    const std::string e = errorOf(t);
    EXPECT_EQ(e, at(lineOf(t, "nine")) + "position 1: accel_mps2 sample 2: 'nine' is not a number");
    const std::string t2 = withSamples("    accel_mps2: [[" + rows[0] + "], [.nan, 1, 2]]\n");
    EXPECT_EQ(errorOf(t2), at(lineOf(t2, "accel_mps2")) + "position 1: accel_mps2 sample 2: not a finite number ('.nan')");
    const std::string t3 = withSamples("    accel_mps2: [[" + rows[0] + "],\n");
    EXPECT_EQ(errorOf(t3), at(lineOf(t3, "accel_mps2")) + "position 1: accel_mps2: the [ list is not closed");
    const std::string t4 = withSamples("    accel_mps2:\n");
    EXPECT_EQ(errorOf(t4), at(lineOf(t4, "accel_mps2")) + "position 1: accel_mps2: expected a list of [fx, fy, fz]");
    const std::string t5 = withSamples("    accel_mps2:\n      - [" + rows[0] + "]\n      - [\"9.8\", 0, 0]\n");
    EXPECT_EQ(errorOf(t5), at(lineOf(t5, "\"9.8\"")) + "position 1: accel_mps2 sample 2: a quoted value where a plain number belongs");
    const std::string t6 = withSamples("    accel_mps2:\n      - [" + rows[0] + "] x\n");
    EXPECT_EQ(errorOf(t6), at(lineOf(t6, "] x")) + "position 1: accel_mps2 sample 1: unexpected text after the list");
    const std::string t7 = withSamples("    accel_mps2:\n      - [" + rows[0] + "]\n      - [" + rows[1] + ", 1]\n");
    EXPECT_EQ(errorOf(t7), at(lineOf(t7, ", 1]")) + "position 1: accel_mps2 sample 2: expected a list of 3 numbers");
    const std::string t9 = withSamples("    accel_mps2: [[" + rows[0] + "]] tail\n");
    EXPECT_EQ(errorOf(t9), at(lineOf(t9, "tail")) + "position 1: accel_mps2: unexpected text after the list");
    const std::string t8 = withSamples("    accel_mps2:\n      - [0.1, -0.2, 9.8ms]\n");  // a number with a tail
    EXPECT_EQ(errorOf(t8), at(lineOf(t8, "9.8ms")) + "position 1: accel_mps2 sample 1: '9.8ms' is not a number");
  }
  // spellings the sample reader does not take are refused, not read another way: a quoted key, a
  // one-line { } position, the key inside a text value
  {
    const std::string e = errorOf(replaced(ok, "    accel_mps2:", "    \"accel_mps2\":"));
    EXPECT_EQ(e.rfind(at(lineOf(ok, "accel_mps2")), 0), 0u) << e;
    EXPECT_NE(e.find("write it as a plain key at the start of its line"), std::string::npos) << e;
    const std::string one = "positions:\n  - {name: a, prisms: [], targets: [], accel_mps2: [[" + rows[0] + "]]}\n";
    const std::string t = ok.substr(0, ok.find("positions:")) + one;
    EXPECT_NE(errorOf(t).find("write it as a plain key"), std::string::npos) << errorOf(t);
    const std::string t2 = replaced(ok, "name: \"position 1\"", "name: |\n      accel_mps2: [[1, 2, 3]]\n   ");
    EXPECT_EQ(errorOf(t2), at(lineOf(t2, "accel_mps2")) + "accel_mps2 here is not a position's key (inside a text value?)");
  }
}

}  // namespace

// The measurement file: round trip, both angle conventions, and every kind of bad file gives
// "name:line: reason" (line of the offending node), never a crash.
#include <boresight/ground/measurement.h>
#include <boresight/ground/simulate.h>

#include <gtest/gtest.h>

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
  const auto path = std::filesystem::temp_directory_path() / "boresight_ground_meas_test.yaml";
  EXPECT_TRUE(writeMeasurement(path.string(), m, nullptr));
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  std::filesystem::remove(path);
  return ss.str();
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
  const auto path = std::filesystem::temp_directory_path() / "boresight_ground_rt.yaml";
  ASSERT_TRUE(writeMeasurement(path.string(), m, nullptr));
  std::string err;
  ASSERT_TRUE(loadMeasurement(path.string(), back, &err)) << err;
  std::filesystem::remove(path);
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

}  // namespace

// Round trip through the command line: boresight simulate-ground -> boresight ground, the JSON keys of
// the issue exactly, the result against the truth written beside the measurement, clear errors.
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <gtest/gtest.h>
#include "test_files.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int status;
  std::string out, err;
};

CliRun run(const std::string& args, const fs::path& dir) {
  const std::string o = (dir / "stdout.txt").string(), e = (dir / "stderr.txt").string();
  const int rc = std::system((std::string(BORESIGHT_CLI) + " " + args + " >" + o + " 2>" + e).c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(o), slurp(e)};
}

class GroundCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testutil::makeTempDir(std::string("boresight_ground_cli_") +
                                 ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string p(const char* name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST_F(GroundCli, RoundTripSeparatingSetUp) {
  CliRun r = run("simulate-ground --seed 3 --setup tilted --bias-ug 100,-100,100 --out " + p("m.yaml"), dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(fs::exists(p("m.truth.yaml")));
  r = run("ground --input " + p("m.yaml") + " --json " + p("r.json") + " --report " + p("rep"), dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("rep/report.txt")));
  EXPECT_TRUE(fs::exists(p("rep/targets.csv")));
  const auto j = readJson(p("r.json"));
  // exactly the keys, in its order
  const std::vector<std::string> keys = {"q_s_t", "error_angles_arcsec", "sigma_arcsec", "covariance_arcsec2",
                                         "accel_bias_mps2", "accel_bias_sigma_mps2", "accel_bias_observable",
                                         "hidden_tilt_arcsec", "camera", "residual_rms_px", "seed", "positions"};
  std::vector<std::string> got;
  for (auto it = j.begin(); it != j.end(); ++it) got.push_back(it.key());
  std::sort(got.begin(), got.end());
  std::vector<std::string> want = keys;
  std::sort(want.begin(), want.end());
  EXPECT_EQ(got, want);
  ASSERT_EQ(j["covariance_arcsec2"].size(), 9u);
  ASSERT_EQ(j["positions"].size(), 3u);
  ASSERT_EQ(j["seed"]["error_angles_arcsec"].size(), 3u);
  // against the truth: within 4 sigma per axis; bias separated and within 4 sigma
  const YAML::Node truth = YAML::LoadFile(p("m.truth.yaml"));
  for (int i = 0; i < 3; ++i) {
    const double e = j["error_angles_arcsec"][i].get<double>() - truth["error_angles_arcsec"][i].as<double>();
    const double s = j["sigma_arcsec"][i].get<double>();
    EXPECT_GT(s, 1.0);
    EXPECT_LT(s, 10.0);
    EXPECT_LT(std::abs(e), 4 * s) << "axis " << i << " error " << e << " sigma " << s;
    EXPECT_NEAR(j["covariance_arcsec2"][4 * i].get<double>(), s * s, 1e-9 * s * s);
    EXPECT_TRUE(j["accel_bias_observable"][i].get<bool>());
    EXPECT_EQ(j["hidden_tilt_arcsec"][i].get<double>(), 0.0);
    const double eb = j["accel_bias_mps2"][i].get<double>() - truth["accel_bias_mps2"][i].as<double>();
    EXPECT_LT(std::abs(eb), 4 * j["accel_bias_sigma_mps2"][i].get<double>()) << "bias axis " << i;
  }
  // q_s_t is the design rotated by the error angles: its angle to the truth is a few arcsec
  double dot = 0;
  for (int i = 0; i < 4; ++i) dot += j["q_s_t"][i].get<double>() * truth["q_s_t"][i].as<double>();
  EXPECT_LT(2 * std::acos(std::min(1.0, std::abs(dot))) * 206264.806, 20.0);
  EXPECT_LT(j["residual_rms_px"].get<double>(), 0.08);
  EXPECT_GT(j["residual_rms_px"].get<double>(), 0.03);
}

TEST_F(GroundCli, RoundTripUnseparatedSetUpSaysSo) {
  CliRun r = run("simulate-ground --seed 4 --setup single --out " + p("m.yaml"), dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  r = run("ground --input " + p("m.yaml") + " --json " + p("r.json") + " --assumed-bias-ug 200", dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("NOT separated"), std::string::npos) << r.out;
  const auto j = readJson(p("r.json"));
  EXPECT_TRUE(j["accel_bias_observable"][0].get<bool>());
  EXPECT_FALSE(j["accel_bias_observable"][1].get<bool>());
  EXPECT_TRUE(j["accel_bias_observable"][2].get<bool>());
  double hidden2 = 0;
  for (int i = 0; i < 3; ++i) {
    const double h = j["hidden_tilt_arcsec"][i].get<double>();
    hidden2 += h * h;
    EXPECT_GE(j["sigma_arcsec"][i].get<double>(), 0.95 * h);
  }
  EXPECT_NEAR(std::sqrt(hidden2), 2 * 20.6, 0.5);  // 200 ug assumed: b/g = 41.2"
}

TEST_F(GroundCli, BadFileIsALocatedErrorNotACrash) {
  CliRun r = run("simulate-ground --seed 5 --targets 6 --accel-samples 5 --out " + p("m.yaml"), dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream in(p("m.yaml"));
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // the third target's centroid outside the detector
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) pos = text.find("centroid_px: [", pos + 1);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
  text.replace(pos, 14, "centroid_px: [2000.0, ");
  text.erase(text.find(", ", pos + 22), text.find(']', pos) - text.find(", ", pos + 22));
  std::ofstream(p("bad.yaml")) << text;
  r = run("ground --input " + p("bad.yaml") + " --json " + p("r.json"), dir_);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(p("bad.yaml") + ":" + std::to_string(line) + ": "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("outside the detector"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(p("r.json")));
  // usage errors: exit 2; --help: exit 0
  EXPECT_EQ(run("ground --input " + p("m.yaml"), dir_).status, 2);
  EXPECT_EQ(run("simulate-ground --out " + p("x.yaml"), dir_).status, 2);
  EXPECT_EQ(run("simulate-ground --seed 1 --setup sideways --out " + p("x.yaml"), dir_).status, 2);
  EXPECT_EQ(run("simulate-ground --seed -1 --out " + p("x.yaml"), dir_).status, 2);
  r = run("ground --help", dir_);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("hidden_tilt_arcsec"), std::string::npos);
  r = run("simulate-ground --help", dir_);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("two-faces"), std::string::npos);
}

}  // namespace

// The model audit of the real GRACE-FO sample (GRACE C, 2023-06-01: SCA1A 16 s, ACC1A 10 s, QSA1B of
// 2018-05-22, GNI1B; SCA1B and CLK1B as the outside reference), through audit::runAudit, the library
// path of `boresight audit`. The acceptance tests of issue 11 section 3: the audit finds by itself,
// with nothing told about this satellite,
//   - the heads' relative alignment changed since QSA1B      -> relative_misalignment named
//   - the head noise is not what the 6"/48" model assumes    -> cross_noise or anisotropic_noise named
//     against config/gracefo_ideal.yaml (the simulator's ideal preset); against config/gracefo.yaml,
//     whose noise section has the levels the audit measured on this sample (2"/25"), no noise test
//     passes: the configured levels now match the data
//   - the accelerometer's angular acceleration is biased    -> acc_bias named
//   - with SCA1B: the fused attitude differs from SCA1B by about 2' about pitch, and a tag latency and
//     a pitch alignment difference explain it equally at the nearly constant pitch rate
//                                                            -> an ambiguity group {time_offset, a
//                                                               misalignment about pitch} with what
//                                                               would separate them
// Skips with a message when ../shared/data/real is absent.
#include <boresight/audit/extension.h>
#include <boresight/audit/run.h>
#include <boresight/io/overlay_yaml.h>

#include "real_data.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using namespace boresight;
using boresight::test::realFile;

namespace {

std::vector<std::string> sampleFiles(bool with_reference) {
  const std::string l1a = realFile("gracefo/2023-06-01_L1A/"), l1b = realFile("gracefo/2023-06-01_L1B/");
  std::vector<std::string> f = {l1a + "SCA1A_2023-06-01_C_04.txt", l1a + "ACC1A_2023-06-01_C_04.txt",
                                realFile("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt"),
                                l1b + "GNI1B_2023-06-01_C_04.txt"};
  if (with_reference) {
    f.push_back(l1b + "SCA1B_2023-06-01_C_04.txt");
    f.push_back(l1b + "CLK1B_2023-06-01_C_04.txt");
  }
  return f;
}

audit::RunOutput runSample(bool with_reference, const char* config = BORESIGHT_SOURCE_DIR "/config/gracefo.yaml") {
  audit::RunRequest req;
  req.config = config;
  req.inputs = sampleFiles(with_reference);
  audit::RunOutput out;
  std::string err;
  EXPECT_TRUE(audit::runAudit(req, out, &err)) << err;
  return out;
}

void print(const char* what, const audit::RunOutput& out) {
  const audit::AuditResult& r = out.result;
  std::printf("\n== audit of the real GRACE-FO sample, %s ==\n", what);
  for (const auto& s : out.notes) std::printf("%s\n", s.c_str());
  std::printf("span %.1f s, %llu head epochs, %llu reference samples\n", out.span_s,
              static_cast<unsigned long long>(out.epochs), static_cast<unsigned long long>(out.reference_samples));
  for (const auto& f : r.findings) std::printf("finding: %s\n", f.c_str());
  for (const auto& e : r.named) {
    std::printf("named: %s[%s] (%s) statistic %.3g threshold %.3g p %.2g:", e.name.c_str(), e.sensor.c_str(),
                e.family.c_str(), e.statistic, e.threshold, e.p_value);
    for (const auto& p : e.params) std::printf(" %s=%.4g+-%.2g", p.key.c_str(), p.value, p.sigma);
    std::printf("\n");
  }
  for (const auto& a : r.ambiguous) {
    std::printf("ambiguous:");
    for (const auto& c : a.causes) std::printf(" %s", c.c_str());
    std::printf(" -- separate by: %s\n", a.separate_by.c_str());
  }
  for (const auto& n : r.not_explained) std::printf("not explained: %s: %s\n", n.family.c_str(), n.what.c_str());
  for (const auto& m : r.baseline.missing) std::printf("not formed: %s\n", m.c_str());
}

bool named(const audit::AuditResult& r, const std::string& name) {
  const auto n = r.namedCauseNames();
  return std::find(n.begin(), n.end(), name) != n.end();
}

/// `noise_named`: whether the configured noise levels differ from the data's (6"/48": yes; the
/// platform file's 2"/25": no).
void expectSection3Findings(const audit::AuditResult& r, bool noise_named) {
  EXPECT_TRUE(named(r, "relative_misalignment")) << "the heads' relative alignment changed since QSA1B";
  if (noise_named)
    EXPECT_TRUE(named(r, "cross_noise") || named(r, "anisotropic_noise")) << "the head noise is not the model's 6\"/48\"";
  else
    EXPECT_FALSE(named(r, "cross_noise") || named(r, "anisotropic_noise"))
        << "the platform file's noise is the sample's own: nothing to name";
  EXPECT_TRUE(named(r, "acc_bias")) << "the accelerometer's angular acceleration is biased";
  EXPECT_TRUE(r.baseline.head_epochs > 0);
}

}  // namespace

TEST(AuditReal, GraceFoSampleWithoutReference) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const audit::RunOutput out = runSample(false);
  print("SCA1A + ACC1A + QSA1B + GNI1B", out);
  EXPECT_EQ(out.reference_samples, 0u);
  EXPECT_TRUE(out.reference_time_base.empty());
  EXPECT_GT(out.orbit_samples, 0u);
  EXPECT_EQ(out.result.baseline.reference_samples, 0u);
  for (const auto& e : out.result.effects) EXPECT_NE(e.family, "reference") << e.name << ": tested without SCA1B";
  expectSection3Findings(out.result, false);
  // The levels the noise tests compared with are the platform file's, and it says so.
  EXPECT_NEAR(out.platform.pipeline.heads.head[0].sigma_cross_rad * kArcsecPerRad, 2.0, 1e-12);
  std::string model;
  for (const auto& l : out.model_in_use) model += l + "\n";
  EXPECT_NE(model.find("head 1: cross_x white 2\", cross_y white 2\", about_boresight white 25\", star_direction white 5\" (" BORESIGHT_SOURCE_DIR
                       "/config/gracefo.yaml noise.head_defaults)"),
            std::string::npos) << model;
}

TEST(AuditReal, GraceFoSampleAgainstTheIdealNoiseNamesTheNoise) {
  // The same sample against the simulator's 6"/48" (config/gracefo_ideal.yaml): the heads are quieter
  // than that, and the noise tests say so (issue 11's acceptance test, before the noise section).
  BORESIGHT_REQUIRE_REAL_DATA();
  const audit::RunOutput out = runSample(false, BORESIGHT_SOURCE_DIR "/config/gracefo_ideal.yaml");
  print("SCA1A + ACC1A + QSA1B + GNI1B against the ideal 6\"/48\"", out);
  expectSection3Findings(out.result, true);
}

TEST(AuditReal, GraceFoSampleWithSca1bLatencyAndPitchAlignmentAreNotSeparable) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const audit::RunOutput out = runSample(true);
  print("with SCA1B and CLK1B as the outside reference", out);
  EXPECT_GT(out.reference_samples, 10u);
  EXPECT_NE(out.reference_time_base.find("CLK1B"), std::string::npos) << out.reference_time_base;
  expectSection3Findings(out.result, false);
  const audit::AuditResult& r = out.result;
  // The reference family sees the fused attitude about 2' off SCA1B about pitch (body y): a
  // misalignment of the reference family whose largest component is about y.
  const audit::EffectTest* pitch = nullptr;
  for (const auto& e : r.effects) {
    if (e.family != "reference" || e.name.find("misalignment") == std::string::npos) continue;
    double x = 0, y = 0, z = 0;
    for (const auto& p : e.params) {
      if (p.key == "x_arcsec") x = std::abs(p.value);
      if (p.key == "y_arcsec") y = std::abs(p.value);
      if (p.key == "z_arcsec") z = std::abs(p.value);
    }
    if (y > 60.0 && y > x && y > z) pitch = &e;
  }
  ASSERT_NE(pitch, nullptr) << "no misalignment about pitch in the reference family";
  std::printf("pitch alignment candidate: %s[%s]\n", pitch->name.c_str(), pitch->sensor.c_str());
  // ... and a tag latency explains it equally: one ambiguity group holds both, with what would separate them.
  bool found = false;
  for (const auto& a : r.ambiguous) {
    bool latency = false, misalignment = false;
    for (const auto& c : a.causes) {
      latency |= c.rfind("time_offset", 0) == 0;
      misalignment |= c.rfind(pitch->name + "[" + pitch->sensor + "]", 0) == 0;
    }
    if (latency && misalignment) {
      found = true;
      EXPECT_FALSE(a.separate_by.empty());
    }
  }
  EXPECT_TRUE(found) << "no ambiguity group {time_offset, " << pitch->name << "[" << pitch->sensor << "]}";
}

TEST(AuditReal, GraceFoSampleWithSca1bWithoutClockSaysGpsTakenAsReceiverTime) {
  BORESIGHT_REQUIRE_REAL_DATA();
  audit::RunRequest req;
  req.config = BORESIGHT_SOURCE_DIR "/config/gracefo.yaml";
  req.inputs = sampleFiles(false);
  req.inputs.push_back(realFile("gracefo/2023-06-01_L1B/SCA1B_2023-06-01_C_04.txt"));
  audit::RunOutput out;
  std::string err;
  ASSERT_TRUE(audit::runAudit(req, out, &err)) << err;
  EXPECT_NE(out.reference_time_base.find("no CLK1B"), std::string::npos) << out.reference_time_base;
  EXPECT_GT(out.reference_samples, 10u);
}

// The extension applied on the real sample (`boresight audit --write-model`'s library path): the heads'
// misalignments and the accelerometer's bias named on the first pass are carried into an overlay;
// audited again with it, neither is named and the relative family's held-out residuals fall to what the
// first pass's fit left (measured: 51.9" -> 20.8", fit 20.9"). The accelerometer's bias on this 16 s
// sample is tested by the short-span rate route, which reads the accelerometer samples in the audit's
// collector: the overlay's correction has to reach them there too (it did not at first: acc_bias was
// named again). What is not carried (the clock drift of head 2, the finding against SCA1B) is listed.
TEST(AuditReal, TheExtensionAppliedRemovesWhatItCarries) {
  BORESIGHT_REQUIRE_REAL_DATA();
  const audit::RunOutput first = runSample(true);
  audit::ExtensionContext ctx;
  ctx.t0 = first.first_epoch;
  ctx.t1 = first.last_epoch;
  ctx.written_by = "audit_real_test";
  const audit::Extension x = audit::extensionOverlay(first.result, first.platform, first.overlay, ctx);
  std::string carried;
  for (const auto& c : x.carried) carried += c + "\n";
  for (const char* c : {"relative_misalignment[2]", "relative_misalignment[3]", "acc_bias[acc]"})
    EXPECT_NE(carried.find(c), std::string::npos) << c << " not carried:\n" << carried;
  const std::string path = ::testing::TempDir() + "audit_real_extension.yaml";
  std::string err;
  ASSERT_TRUE(io::writeOverlay(path, x.overlay, &err)) << err;
  audit::RunRequest req;
  req.config = BORESIGHT_SOURCE_DIR "/config/gracefo.yaml";
  req.inputs = sampleFiles(true);
  req.overlay = path;
  audit::RunOutput second;
  ASSERT_TRUE(audit::runAudit(req, second, &err)) << err;
  const audit::AppliedExtension a = audit::compareApplied(first.result, second.result);
  for (const auto& l : a.lines()) std::printf("%s\n", l.c_str());
  for (const auto& n : a.still_named) {
    EXPECT_EQ(n.find("relative_misalignment[2]"), std::string::npos) << n;
    EXPECT_EQ(n.find("relative_misalignment[3]"), std::string::npos) << n;
    EXPECT_EQ(n.find("acc_bias"), std::string::npos) << n;
  }
  bool seen = false;
  for (const auto& f : a.families)
    if (f.family == "relative") {
      seen = true;
      EXPECT_LT(f.heldout_rms_applied, 0.6 * f.heldout_rms_configured);
      EXPECT_NEAR(f.heldout_rms_applied / f.heldout_rms_fitted, 1.0, 0.05);
    }
  EXPECT_TRUE(seen);
  std::remove(path.c_str());
}

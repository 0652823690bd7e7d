// audit::extensionOverlay on hand-made audit results: what each named cause becomes in the model
// overlay, what is listed as not carried, and an overlay the audit ran with extended (not replaced).
#include <boresight/audit/extension.h>
#include <boresight/io/core_config.h>
#include <boresight/model/overlay.h>

#include <gtest/gtest.h>

#include <string>

namespace boresight::audit {
namespace {

EffectTest named(const std::string& name, const std::string& sensor, const std::string& family,
                 std::vector<std::pair<std::string, double>> params) {
  EffectTest e;
  e.name = name;
  e.sensor = sensor;
  e.family = family;
  e.named = true;
  for (const auto& [k, v] : params) e.params.push_back({k, "", v, 0.1 * std::abs(v), kNaN});
  return e;
}

io::PlatformConfig platform() {
  io::PlatformConfig pc;
  std::string err;
  EXPECT_TRUE(io::loadPlatformConfig(std::string(BORESIGHT_SOURCE_DIR) + "/config/gracefo.yaml", pc, &err)) << err;
  return pc;
}

TEST(Extension, EveryNamedCauseIsCarriedOrListedWithTheReason) {
  const io::PlatformConfig pc = platform();  // heads 1, 2, 3: white 2"/25"
  ASSERT_EQ(pc.pipeline.heads.n_heads, 3);
  AuditResult r;
  r.named.push_back(named("coloured_noise", "all", "relative",
                          {{"gm_arcsec", 0.8}, {"tau_s", 600}, {"head1_cross_arcsec", 0.8}, {"head1_about_arcsec", 0.4},
                           {"head2_cross_arcsec", 0}, {"head2_about_arcsec", 0}, {"head3_cross_arcsec", 0.3}, {"head3_about_arcsec", 0}}));
  r.named.push_back(named("cross_noise", "2", "noise", {{"cross_arcsec", 3.1}, {"configured_cross_arcsec", 2}}));
  r.named.push_back(named("time_offset", "acc", "angular_acceleration", {{"offset_ms", 15}}));
  r.named.push_back(named("step", "1", "relative", {{"x_arcsec", 2}, {"y_arcsec", 1}, {"z_arcsec", 0}, {"at_s", 3600}}));
  r.named.push_back(named("acc_bias", "acc", "angular_acceleration", {{"x", 1e-7}, {"y", 2e-7}, {"z", -1e-7}}));
  io::OverlayUse base;  // the audit ran with an overlay that had a bias already
  base.file = "before.yaml";
  base.overlay.written_by = "a test";
  model::AccelerometerTerms a;
  model::Uncertain3 b0;
  b0.value = Vec3(1e-6, 0, 0);
  a.bias_rad_s2 = b0;
  base.overlay.accelerometer = a;
  ExtensionContext ctx;
  ctx.t0 = 1000 * kUsPerSecond;
  ctx.t1 = 8200 * kUsPerSecond;
  ctx.written_by = "extension_test";
  const Extension x = extensionOverlay(r, pc, base, ctx);
  EXPECT_EQ(model::validate(x.overlay), "");
  EXPECT_EQ(x.carried.size(), 4u);
  ASSERT_EQ(x.not_carried.size(), 1u);
  EXPECT_EQ(x.not_carried[0].rfind("step[1] (relative): the overlay has no steps", 0), 0u) << x.not_carried[0];
  // noise: head 1 gets a Gauss-Markov term on every axis beside its white level; head 2 a new white
  // cross level and nothing about the boresight; head 3 a cross term only
  const auto& heads = x.overlay.noise.heads;
  ASSERT_EQ(heads.size(), 3u);
  auto entry = [&](int id) -> const model::HeadNoise& {
    for (const auto& h : heads)
      if (h.id == id) return h;
    ADD_FAILURE() << "no entry for head " << id;
    return heads[0];
  };
  const auto& h1 = entry(1);
  ASSERT_TRUE(h1.axis[0] && h1.axis[2]);
  EXPECT_EQ(h1.axis[0]->model, model::NoiseModel::white(2 * kRadPerArcsec).add(model::NoiseTerm::gaussMarkov(0.8 * kRadPerArcsec, 600)));
  EXPECT_EQ(h1.axis[2]->model, model::NoiseModel::white(25 * kRadPerArcsec).add(model::NoiseTerm::gaussMarkov(0.4 * kRadPerArcsec, 600)));
  EXPECT_FALSE(h1.axis[3]);  // the star direction keeps the platform file's model
  const auto& h2 = entry(2);
  ASSERT_TRUE(h2.axis[0] && h2.axis[1]);
  EXPECT_EQ(h2.axis[1]->model, model::NoiseModel::white(3.1 * kRadPerArcsec));
  EXPECT_FALSE(h2.axis[2]);
  const auto& h3 = entry(3);
  EXPECT_TRUE(h3.axis[0] && !h3.axis[2]);
  EXPECT_EQ(h1.valid.from, ctx.t0);
  // the accelerometer: the overlay's bias plus the new estimate (first order)
  ASSERT_TRUE(x.overlay.accelerometer && x.overlay.accelerometer->bias_rad_s2);
  EXPECT_NEAR(x.overlay.accelerometer->bias_rad_s2->value.x(), 1.1e-6, 1e-18);
  EXPECT_NEAR(x.overlay.accelerometer->bias_rad_s2->value.y(), 2e-7, 1e-18);
  // the time offset: catalogue sign (t_tag = t_true + offset, positive: late), seconds
  ASSERT_EQ(x.overlay.time_offsets.size(), 1u);
  EXPECT_EQ(x.overlay.time_offsets[0].sensor, "accelerometer");
  EXPECT_EQ(x.overlay.time_offsets[0].relative_to, "heads");
  EXPECT_DOUBLE_EQ(x.overlay.time_offsets[0].offset_s, 0.015);
  EXPECT_EQ(x.overlay.written_by, "extension_test");
  // nothing named: an overlay with nothing of its own (the base's content kept)
  const Extension none = extensionOverlay(AuditResult{}, pc, base, ctx);
  EXPECT_TRUE(none.carried.empty() && none.not_carried.empty());
  EXPECT_TRUE(none.overlay.mountings.empty() && none.overlay.noise.empty());
  EXPECT_EQ(none.overlay.accelerometer, base.overlay.accelerometer);
}

}  // namespace
}  // namespace boresight::audit

// The angular-acceleration family on synthetic rows with a known truth: star-derived angular
// acceleration = true + CRN-like star noise (little power at low frequencies), accelerometer = (1 + s)
// true + bias + low-frequency (Gauss-Markov, 2000 s) and white noise: on the A x axis a low-frequency
// level (4e-8 rad/s^2) as large as the true quiet-pointing angular acceleration.
//  - Quiet pointing over two days (true angular acceleration as small as the accelerometer's noise): the
//    accelerometer's own noise dilutes a regression on it (errors in variables) and its low-frequency
//    noise makes neighbouring bins alike; neither may be named as a scale error. The bias is named.
//  - Manoeuvres (true angular acceleration far above both noises): a 3 % scale error of one A axis is
//    named with its value; without it nothing but the bias is named.
#include <boresight/audit/audit.h>
#include <boresight/model/rotation.h>

#include <gtest/gtest.h>

#include "synthetic_heads.h"

#include <cmath>
#include <random>

namespace {

using namespace boresight;

using audittest::threeHeads;

const Vec3 kBiasB(1.3e-5, 1.2e-4, -7.8e-4);

struct Scenario {
  double span_s = 7200;
  bool manoeuvres = false;
  Vec3 scale_A = Vec3::Zero();  ///< scale error per accelerometer axis
  std::uint64_t seed = 1;
};

audit::AuditResult run(const Scenario& sc) {
  const auto cfg = threeHeads();
  audit::AuditOptions opt;
  audit::Collector c;
  std::string err;
  EXPECT_TRUE(c.configure(cfg, opt, &err)) << err;
  std::mt19937_64 rng(sc.seed);
  std::normal_distribution<double> n01;
  const TimeUs t0 = audittest::kT0;
  const Mat3 CBA = cfg.C_B_A, CAB = cfg.C_B_A.transpose();
  // per-row processes (1 Hz)
  Vec3 T_slow = Vec3::Zero(), gm_A = Vec3::Zero();
  const double phi_T = std::exp(-1.0 / 30), phi_gm = std::exp(-1.0 / 2000);
  const Vec3 gm_sigma_A(4e-8, 5e-9, 5e-9), white_A(1e-8, 1e-8, 1e-8);
  std::vector<Vec3> star_w(32, Vec3::Zero());  // white draws for the star noise's band-pass
  const int n_rows = static_cast<int>(sc.span_s);
  for (int k = 0; k < n_rows; ++k) {
    const double t = k;
    // two head epochs per row (2 Hz), aligned heads, small noise: they give the star data's span
    for (int half = 0; half < 2; ++half) {
      const double th = t + 0.5 * half;
      const Quat q_I_B = audittest::pitchTurn(th);
      core::HeadEpoch e;
      e.t = t0 + static_cast<TimeUs>(std::llround(th * 1e6));
      for (int h = 0; h < 3; ++h)
        audittest::addSample(e, cfg, h, q_I_B, cfg.heads.head[static_cast<std::size_t>(h)].q_Si_B, rng, n01);
      c.onHeads(e, core::Status::kOk);
    }
    // the true angular acceleration: a smooth quiet-pointing part, plus slews when manoeuvring
    for (int a = 0; a < 3; ++a) T_slow[a] = phi_T * T_slow[a] + std::sqrt(1 - phi_T * phi_T) * 4e-8 * n01(rng);
    Vec3 T = T_slow;
    if (sc.manoeuvres)
      for (int a = 0; a < 3; ++a) T[a] += 1e-5 * std::sin(2 * M_PI * t / (240 + 70 * a) + a);
    // star noise: white through a band-pass (8-sample mean minus 32-sample mean): no power at DC
    std::rotate(star_w.rbegin(), star_w.rbegin() + 1, star_w.rend());
    star_w[0] = Vec3(n01(rng), n01(rng), n01(rng)) * 3e-6;
    Vec3 m8 = Vec3::Zero(), m32 = Vec3::Zero();
    for (int j = 0; j < 32; ++j) (j < 8 ? m8 : m32) += star_w[static_cast<std::size_t>(j)];
    const Vec3 n_S = m8 / 8 - (m8 + m32) / 32;
    for (int a = 0; a < 3; ++a) gm_A[a] = phi_gm * gm_A[a] + std::sqrt(1 - phi_gm * phi_gm) * gm_sigma_A[a] * n01(rng);
    const Vec3 n_A = gm_A + Vec3(white_A[0] * n01(rng), white_A[1] * n01(rng), white_A[2] * n01(rng));
    const Vec3 T_A = CAB * T;
    core::PipelineRow row;
    row.t = t0 + static_cast<TimeUs>(k) * kUsPerSecond;
    row.has_rates = row.has_acc = true;
    row.a_sc_B = T + n_S;
    row.a_acc_B = CBA * (T_A + sc.scale_A.cwiseProduct(T_A) + n_A) + kBiasB;
    row.heads_used = 3;
    c.write(row);
  }
  c.onEnd();
  return audit::analyse(c, opt);
}

const audit::EffectTest* named(const audit::AuditResult& r, const std::string& name) {
  for (const auto& e : r.named)
    if (e.name == name && e.sensor == "acc") return &e;
  return nullptr;
}
std::string noteOf(const audit::EffectTest* e) { return e != nullptr ? std::string(e->note) : std::string("(none)"); }

const audit::EffectTest* tested(const audit::AuditResult& r, const std::string& name) {
  for (const auto& e : r.effects)
    if (e.name == name && e.sensor == "acc" && e.family == "angular_acceleration") return &e;
  return nullptr;
}

TEST(AuditAccFamily, QuietPointingForTwoDaysNamesTheBiasAndNoScaleError) {
  for (std::uint64_t seed : {1u, 2u}) {
    SCOPED_TRACE(seed);
    Scenario sc;
    sc.span_s = 2 * 86400;
    sc.seed = seed;
    const auto r = run(sc);
    ASSERT_NE(named(r, "acc_bias"), nullptr);
    const Vec3 bias_A = threeHeads().C_B_A.transpose() * kBiasB;  // the bias is reported per A axis
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(named(r, "acc_bias")->params[static_cast<std::size_t>(a)].value, bias_A[a], 1e-8);
    for (const char* n : {"acc_scale", "acc_misalignment", "time_offset", "clock_drift"})
      EXPECT_EQ(named(r, n), nullptr) << n << " named in quiet pointing: " << noteOf(named(r, n));
    // the scale's test says why it cannot be identified here
    EXPECT_NE(noteOf(tested(r, "acc_scale")).find("not identifiable on A axis"), std::string::npos)
        << noteOf(tested(r, "acc_scale"));
  }
}

TEST(AuditAccFamily, ManoeuvresNameAScaleErrorOfOneAxisAndNothingWithout) {
  Scenario sc;
  sc.span_s = 6 * 3600;
  sc.manoeuvres = true;
  sc.scale_A = Vec3(0.03, 0, 0);
  const auto r = run(sc);
  const auto* s = named(r, "acc_scale");
  ASSERT_NE(s, nullptr) << noteOf(tested(r, "acc_scale"));
  EXPECT_NEAR(s->params[0].value, 0.03, std::max(0.003, 3 * s->params[0].sigma));
  EXPECT_GT(s->params[0].value / s->params[0].sigma, 5);

  sc.scale_A = Vec3::Zero();
  sc.seed = 7;
  const auto clean = run(sc);
  ASSERT_NE(named(clean, "acc_bias"), nullptr);
  for (const char* n : {"acc_scale", "acc_misalignment", "time_offset", "clock_drift"})
    EXPECT_EQ(named(clean, n), nullptr) << n << " named without the effect";
}

}  // namespace

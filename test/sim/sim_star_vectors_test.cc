// The simulator's star vectors: catalogue stars through the true (mounted, thermally deformed,
// aberrated) head with the configured noise; and the whole chain simulate -> Pipeline (heads, then
// stars) -> joint attitude against the simulator's truth, for the three relative corrections.
#include <boresight/core/pipeline.h>
#include <boresight/io/scv.h>
#include <boresight/model/rotation.h>

#include "sim_test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>

namespace boresight {
namespace {

using simtest::gracefo;

sim::Scenario starScenario(const std::vector<std::string>& effects) {
  sim::Scenario sc = simtest::withEffects(gracefo(), effects);
  sc.output.star_vectors_interval_s = 1.0;
  return sc;
}

TEST(SimStarVectors, CatalogueStarsThroughTheTrueHeadWithTheConfiguredNoise) {
  // head 2 deformed (20/-15/25" about its axes, once per revolution); aberration on every head
  const auto sc = starScenario({"thermal_periodic:sensor=2,harmonic=1,x_arcsec=20,y_arcsec=-15,z_arcsec=25",
                                "aberration:sensor=1", "aberration:sensor=2", "aberration:sensor=3"});
  auto r = simtest::run(sc, 11, 5400);
  const auto& cap = r->cap;
  ASSERT_GT(cap.sv.size(), 3000u);
  const auto& cat = r->sim.stars();
  std::map<int, const sim::Star*> by_hip;
  for (const auto& s : cat.stars()) by_hip[s.hip] = &s;
  double ss[3] = {0, 0, 0};
  long n[3] = {0, 0, 0};
  double max_thermal[3] = {0, 0, 0}, max_aberr = 0;
  std::size_t k_head = 0;
  for (const auto& v : cap.sv) {
    const int slot = v.head - 1;
    const auto& hm = r->sim.heads()[static_cast<std::size_t>(slot)];
    ASSERT_GE(v.n, 1);
    ASSERT_LE(v.n, sc.output.star_vectors_per_head);
    // the head sample it belongs to was delivered (not blind), at the same tag
    const sim::HeadSampleOut* h = nullptr;
    for (; k_head < cap.heads.size(); ++k_head)
      if (cap.heads[k_head].tag == v.tag && cap.heads[k_head].head == v.head) {
        h = &cap.heads[k_head];
        break;
      }
    ASSERT_NE(h, nullptr) << "star vectors without a head sample at " << v.tag;
    ASSERT_FALSE(h->blind);
    // the geometric attitude is the true body attitude through the true mounting, deformed by at most
    // the injected amplitude (head 2) or not at all (heads 1 and 3)
    const Quat q_mount = h->q_I_B * hm.qSiBTrue().conjugate();
    max_thermal[slot] = std::max(max_thermal[slot], model::quatLog(q_mount.conjugate() * v.q_I_Si_geometric).norm());
    for (int j = 0; j < v.n; ++j) {
      const auto& st = v.star[static_cast<std::size_t>(j)];
      if (j > 0) {
        EXPECT_LE(v.star[static_cast<std::size_t>(j - 1)].mag, st.mag) << "brightest first";
      }
      ASSERT_TRUE(by_hip.count(st.hip));
      const Vec3 u_cat = by_hip[st.hip]->u_I;
      EXPECT_NEAR(st.r_I.norm(), 1.0, 1e-12);
      EXPECT_NEAR(st.s_Si.norm(), 1.0, 1e-12);
      // r differs from the catalogue by the aberration only (annual + orbital < 30")
      const double ab = std::acos(std::clamp(st.r_I.dot(u_cat), -1.0, 1.0));
      max_aberr = std::max(max_aberr, ab);
      // in the field of view
      EXPECT_LE(std::acos(std::clamp(st.s_Si_true.dot(hm.config().boresight_Si), -1.0, 1.0)),
                hm.config().fov_half_angle_rad + 1e-9);
      // the measured direction against the truth: inertial direction through the geometric attitude
      const Vec3 s_truth = v.q_I_Si_geometric.conjugate() * st.r_I;
      ss[slot] += (st.s_Si - s_truth).squaredNorm();
      ++n[slot];
    }
  }
  for (int k = 0; k < 3; ++k) {
    // mean squared angle of a 2-D error of sigma per axis: 2 sigma^2 (thousands of stars: 3 %)
    const double sigma = r->sim.heads()[static_cast<std::size_t>(k)].sigmaStar();
    ASSERT_GT(n[k], 1000);
    EXPECT_NEAR(std::sqrt(ss[k] / n[k] / 2.0) / sigma, 1.0, 0.05) << "head " << k + 1;
  }
  std::printf("star vectors: largest deformation from the mounting per head %.1f / %.1f / %.1f\", aberration %.1f\"\n",
              max_thermal[0] * kArcsecPerRad, max_thermal[1] * kArcsecPerRad, max_thermal[2] * kArcsecPerRad,
              max_aberr * kArcsecPerRad);
  EXPECT_LT(max_thermal[0], 1e-9);
  EXPECT_LT(max_thermal[2], 1e-9);
  EXPECT_GT(max_thermal[1], 0.8 * std::sqrt(20.0 * 20 + 15 * 15 + 25 * 25) * kRadPerArcsec);  // a full orbit sweeps it
  EXPECT_LT(max_thermal[1], 1.01 * std::sqrt(20.0 * 20 + 15 * 15 + 25 * 25) * kRadPerArcsec);
  EXPECT_GT(max_aberr, 5.0 * kRadPerArcsec);
  EXPECT_LT(max_aberr, 30.0 * kRadPerArcsec);
}

TEST(SimStarVectors, ZeroIntervalTurnsThemOffIntervalAndCapAreHonoured) {
  auto sc = gracefo();
  sc.output.star_vectors_interval_s = 0;
  auto off = simtest::run(sc, 3, 60);
  EXPECT_TRUE(off->cap.sv.empty());
  sc.output.star_vectors_interval_s = 10;
  sc.output.star_vectors_per_head = 3;
  auto on = simtest::run(sc, 3, 60);
  std::map<int, int> per_head;
  for (const auto& v : on->cap.sv) {
    EXPECT_LE(v.n, 3);
    ++per_head[v.head];
  }
  for (const auto& [id, count] : per_head) EXPECT_LE(count, 6) << "head " << id;  // 60 s / 10 s
  sc.output.star_vectors_per_head = sim::kMaxSimStarsPerHead + 1;
  sim::Simulator s;
  std::string err;
  EXPECT_FALSE(s.init(sc, 3, 60, &err));
  EXPECT_NE(err.find("star_vectors_per_head"), std::string::npos) << err;
}

TEST(SimStarVectors, Scv1aReaderRejectsBadLinesAndGroupsEpochs) {
  auto f = io::makeProduct<io::ScvRecord>(io::Product::SCV1A, 'C');
  io::ScvRecord r;
  r.t = 738849600LL * kUsPerSecond + 29992;
  r.star = 32349;
  r.mag = -1.09;
  for (int h = 1; h <= 3; ++h) {
    r.head = static_cast<std::uint8_t>(h);
    f.records.push_back(r);
    f.records.push_back(r);
  }
  r.t += 500000;
  f.records.push_back(r);
  std::string text = io::formatProduct(f);
  const auto good = io::parseProduct<io::ScvRecord>(text, "SCV1A_2023-06-01_C_04.txt");
  ASSERT_TRUE(good.ok) << good.error;
  ASSERT_EQ(good.records.size(), 7u);
  EXPECT_TRUE(good.records[0] == f.records[0]);
  core::StarEpoch e;
  std::size_t dropped = 0;
  std::size_t next = io::nextStarEpoch(good.records, 0, e, &dropped);
  EXPECT_EQ(next, 6u);
  EXPECT_EQ(e.n, 6);
  EXPECT_EQ(e.t, r.t - 500000);
  EXPECT_EQ(e.star[5].head_id, 3);
  next = io::nextStarEpoch(good.records, next, e, &dropped);
  EXPECT_EQ(next, 7u);
  EXPECT_EQ(e.n, 1);
  EXPECT_EQ(io::nextStarEpoch(good.records, next, e, &dropped), 7u);
  EXPECT_EQ(e.n, 0);
  EXPECT_EQ(dropped, 0u);
  // a direction that is not a unit vector, and a head id out of range: rejected with file:line
  const std::size_t last = text.rfind('\n', text.size() - 2) + 1;
  std::string bad = text.substr(0, last) + "738850100 529992 C 3 32349 0 0 1.1 0 0 1 -1.09\n" +
                    "738850100 529992 C 12 32349 0 0 1 0 0 1 -1.09\n";
  const auto b = io::parseProduct<io::ScvRecord>(bad, "SCV1A_2023-06-01_C_04.txt");
  ASSERT_TRUE(b.ok) << b.error;
  EXPECT_EQ(b.records.size(), 6u);
  ASSERT_EQ(b.rejected_count, 2u);
  EXPECT_NE(b.rejected[0].str().find("unit vector"), std::string::npos) << b.rejected[0].str();
  EXPECT_NE(b.rejected[1].str().find("sca_id"), std::string::npos) << b.rejected[1].str();
  EXPECT_NE(b.rejected[0].str().find("SCV1A_2023-06-01_C_04.txt:"), std::string::npos);
}

// ---- the chain against the simulator's truth ----

struct ModeStats {
  Vec3 ss = Vec3::Zero();
  double nees = 0;
  long n = 0;
  std::vector<double> blocks;
  double acc = 0;
  int acc_n = 0;
};

TEST(SimStarVectors, ChainSimulateToWahbaThreeAxisCorrectionBeatsNoneAndOneAxis) {
  // 1.5 orbits, head 2 deformed by an orbit-periodic three-axis rotation on top of the constant
  // mounting errors of the scenario (which the core does not know either), star vectors every second
  constexpr double kSpanS = 8100, kWarmupS = 900, kBlockS = 300;
  const auto sc = starScenario({"thermal_periodic:sensor=2,harmonic=1,x_arcsec=20,y_arcsec=-15,z_arcsec=25"});
  auto r = simtest::run(sc, 21, kSpanS);
  const auto& cap = r->cap;
  core::PipelineConfig pc;
  pc.heads.n_heads = 3;
  for (int k = 0; k < 3; ++k) pc.heads.head[static_cast<std::size_t>(k)] = sc.heads[static_cast<std::size_t>(k)].core();
  pc.use_accelerometer = false;
  const core::RelativeCorrection modes[3] = {core::RelativeCorrection::kNone, core::RelativeCorrection::kIbaOneAxis,
                                             core::RelativeCorrection::kFilteredThreeAxis};
  const char* names[3] = {"none", "one-axis (seed)", "three-axis filtered"};
  std::array<std::unique_ptr<core::Pipeline>, 3> p;
  for (int m = 0; m < 3; ++m) {
    pc.wahba_correction = modes[m];
    p[static_cast<std::size_t>(m)] = std::make_unique<core::Pipeline>();
    ASSERT_EQ(p[static_cast<std::size_t>(m)]->configure(pc), core::Status::kOk);
  }
  std::array<ModeStats, 3> st;
  // optional per-epoch table for a figure: BORESIGHT_CHAIN_CSV=path (see the report / README)
  std::FILE* csv = nullptr;
  if (const char* path = std::getenv("BORESIGHT_CHAIN_CSV")) {
    csv = std::fopen(path, "w");
    if (csv) std::fprintf(csv, "t_s,err_none_arcsec,err_one_axis_arcsec,err_three_axis_arcsec,sigma_three_axis_arcsec\n");
  }
  const model::HeadModel& h1 = r->sim.heads()[0];
  std::size_t ih = 0, is = 0;
  long star_epochs = 0, rejected = 0;
  while (ih < cap.heads.size()) {
    // one head epoch: every delivered sample with this tag
    const TimeUs t = cap.heads[ih].tag;
    core::HeadEpoch he;
    he.t = t;
    Quat q_I_B_true = cap.heads[ih].q_I_B;
    for (; ih < cap.heads.size() && cap.heads[ih].tag == t; ++ih) {
      const auto& h = cap.heads[ih];
      if (h.blind) continue;
      auto& s = he.sample[static_cast<std::size_t>(he.n++)];
      s.head_id = h.head;
      s.q_I_Si = h.q_I_Si;
    }
    if (he.n > 0) {
      for (auto& pp : p) ASSERT_EQ(pp->stepHeads(he), core::Status::kOk);
    }
    core::PipelineRow row;
    for (auto& pp : p)
      while (pp->popRow(row)) {
      }
    // the star vectors of the same tag
    core::StarEpoch se;
    se.t = t;
    for (; is < cap.sv.size() && cap.sv[is].tag <= t; ++is) {
      const auto& v = cap.sv[is];
      if (v.tag != t) continue;
      for (int j = 0; j < v.n && se.n < core::kMaxStarInputs; ++j) {
        auto& o = se.star[static_cast<std::size_t>(se.n++)];
        o.head_id = v.head;
        o.s_Sk = v.star[static_cast<std::size_t>(j)].s_Si;
        o.r_I = v.star[static_cast<std::size_t>(j)].r_I;
      }
    }
    if (se.n == 0) continue;
    ++star_epochs;
    const double t_rel = toSeconds(t - sc.start);
    // truth: head 1 has no time-varying effect: its geometric attitude is q_I_B through its true mounting
    const Quat q_I_S1 = q_I_B_true * h1.qSiBTrue().conjugate();
    double err_row[3] = {std::nan(""), std::nan(""), std::nan("")}, sig_row = std::nan("");
    for (int m = 0; m < 3; ++m) {
      auto& pp = *p[static_cast<std::size_t>(m)];
      if (pp.stepStars(se) != core::Status::kOk) {
        rejected += m == 2;
        continue;
      }
      if (t_rel < kWarmupS) continue;
      const core::WahbaSolution& sol = pp.wahba().output();
      const Vec3 e = core::quatLog(q_I_S1.conjugate() * sol.q_I_SR);
      err_row[m] = e.norm() * kArcsecPerRad;
      if (m == 2) sig_row = std::sqrt(sol.P_SR.trace()) * kArcsecPerRad;
      ModeStats& c = st[static_cast<std::size_t>(m)];
      c.ss += e.cwiseProduct(e);
      c.nees += e.dot(sol.P_SR.inverse() * e);
      ++c.n;
      c.acc += e.squaredNorm();
      if (++c.acc_n == static_cast<int>(kBlockS)) {
        c.blocks.push_back(c.acc / c.acc_n);
        c.acc = 0;
        c.acc_n = 0;
      }
    }
    if (csv && t_rel >= kWarmupS)
      std::fprintf(csv, "%.1f,%.4f,%.4f,%.4f,%.4f\n", t_rel, err_row[0], err_row[1], err_row[2], sig_row);
  }
  if (csv) std::fclose(csv);
  std::printf("simulated chain (%.0f s scored, %ld star epochs, %ld rejected):\n", kSpanS - kWarmupS, star_epochs, rejected);
  for (int m = 0; m < 3; ++m) {
    const ModeStats& c = st[static_cast<std::size_t>(m)];
    const Vec3 rms = (c.ss / static_cast<double>(c.n)).cwiseSqrt() * kArcsecPerRad;
    std::printf("  %-20s RMS x/y/z %.2f / %.2f / %.2f\", 3-D %.2f\", mean NEES %.2f\n", names[m], rms.x(), rms.y(),
                rms.z(), rms.norm(), c.nees / static_cast<double>(c.n));
  }
  ASSERT_GT(st[2].n, 5000);
  for (int m = 0; m < 2; ++m) {
    const std::size_t nb = std::min(st[static_cast<std::size_t>(m)].blocks.size(), st[2].blocks.size());
    double s = 0, s2 = 0;
    for (std::size_t i = 0; i < nb; ++i) {
      const double d = st[static_cast<std::size_t>(m)].blocks[i] - st[2].blocks[i];
      s += d;
      s2 += d * d;
    }
    const double mean = s / static_cast<double>(nb);
    const double se = std::sqrt((s2 / static_cast<double>(nb) - mean * mean) / static_cast<double>(nb - 1));
    EXPECT_GT(mean, 3 * se) << names[m] << " minus three-axis, mean square";
  }
  const double nees = st[2].nees / static_cast<double>(st[2].n);
  EXPECT_GT(nees, 2.0);
  EXPECT_LT(nees, 4.5);
}

}  // namespace
}  // namespace boresight

// The simulator's coloured effects end to end: coloured_noise, thermal_wander, fov_error,
// acc_coloured_noise and acc_bias_wander appear in the delivered data exactly as their recorded
// processes, with the spectra of their noise.h models (psd_check.h: Welch estimate against its exact
// expectation, tolerance from the number of averaged segments at a family-wise level of 1e-3), do not
// move any other sensor's data, compose (two specs add variances, the first keeps its draws), and
// leave the output of scenarios without them byte-identical to what the simulator wrote before they
// existed (checksums taken with the earlier program).
#include "../model/psd_check.h"
#include "sim_test_util.h"
#include "test_files.h"

#include <boresight/model/stochastic.h>
#include <boresight/sim/output.h>
#include <boresight/sim/stars.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace boresight {
namespace {

namespace fs = std::filesystem;
using simtest::gracefo;
using simtest::rotBetween;

constexpr double kFamilyAlpha = 1e-3;

/// Head `id`'s samples (blinded included: the coloured processes advance at every tag).
std::vector<const sim::HeadSampleOut*> samplesOf(const simtest::Capture& c, int id) {
  std::vector<const sim::HeadSampleOut*> v;
  for (const auto& h : c.heads)
    if (h.head == id) v.push_back(&h);
  return v;
}

void expectSpectrum(const std::vector<double>& x, const model::NoiseModel& m, double T, std::size_t L, int bands,
                    const std::string& what) {
  const testpsd::Welch W = testpsd::welch(x, T, L);
  const auto b = testpsd::bandCheck(W, [&](double lag) { return m.autocovariance(lag); }, 2, bands);
  ASSERT_GE(b.size(), 3u) << what;
  const double zc = testpsd::zCrit(kFamilyAlpha, static_cast<int>(b.size()));
  for (const auto& band : b) EXPECT_LT(std::abs(band.z), zc) << what << ": " << band.describe() << " (limit " << zc << ")";
}

sim::Scenario quiet() {
  auto sc = gracefo();
  sc.output.star_vectors_interval_s = 0;
  return sc;
}

TEST(SimNoiseEffects, ColouredNoiseIsItsRecordedProcessInTheDeliveredAttitudeOnly) {
  const auto base = quiet();
  const auto sc = simtest::withEffects(base, {"coloured_noise:sensor=2,cross_arcsec=3,about_arcsec=10,tau_s=60"});
  auto a = simtest::run(base, 31, 900), b = simtest::run(sc, 31, 900);
  ASSERT_EQ(a->cap.heads.size(), b->cap.heads.size());
  const model::HeadModel& hm = b->sim.heads()[1];
  std::size_t checked = 0;
  for (std::size_t k = 0; k < a->cap.heads.size(); ++k) {
    const auto &x = a->cap.heads[k], &y = b->cap.heads[k];
    ASSERT_EQ(x.tag, y.tag);
    if (x.head != 2) {
      EXPECT_TRUE(simtest::sameQuat(x.q_I_Si, y.q_I_Si)) << "head " << x.head << " moved";
      EXPECT_EQ(y.coloured_rad, Vec3::Zero());
      continue;
    }
    EXPECT_TRUE(simtest::sameQuat(x.q_I_Si_expected, y.q_I_Si_expected));  // a measurement error, not a rotation
    if (y.blind) continue;
    // q = expected Exp(n + c) against expected Exp(n): Log(Exp(-n) Exp(n + c)) = c + (n x c) / 2 + third
    // order (Baker-Campbell-Hausdorff), so the difference is c within |n| |c| / 2 (+1 % for the rest).
    const Vec3 d = hm.toHeadAxes(rotBetween(x.q_I_Si, y.q_I_Si));
    const double n = rotBetween(x.q_I_Si_expected, x.q_I_Si).norm();
    EXPECT_LT((d - y.coloured_rad).norm(), 0.505 * n * y.coloured_rad.norm() + 1e-13)
        << d.transpose() << " vs " << y.coloured_rad.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 1500u);
  for (std::size_t k = 0; k < a->cap.acc.size(); ++k) ASSERT_EQ(a->cap.acc[k].ang_A, b->cap.acc[k].ang_A);
}

TEST(SimNoiseEffects, ColouredNoiseHasItsSpectrumPerHeadAxisAndIgnoresGaps) {
  // Two specs on head 3 (a Gauss-Markov and a power law): per axis a two-term model. 6 h at 2 Hz.
  const std::vector<std::string> eff = {"coloured_noise:sensor=3,cross_arcsec=2,about_arcsec=8,tau_s=120",
                                        "coloured_noise:sensor=3,cross_arcsec=1,about_arcsec=3,alpha=1,f_lo_hz=1e-3,f_hi_hz=0.2"};
  const auto sc = simtest::withEffects(quiet(), eff);
  auto r = simtest::run(sc, 8, 6 * 3600.0);
  const auto s = samplesOf(r->cap, 3);
  const model::HeadEffects& e = r->sim.heads()[2].effects();
  ASSERT_EQ(e.coloured_cross.terms.size(), 2u);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    for (const auto* h : s) x.push_back(h->coloured_rad[axis]);
    expectSpectrum(x, axis < 2 ? e.coloured_cross : e.coloured_about, 0.5, 1024, 6, "coloured_noise axis " + std::to_string(axis));
  }
  // A gap on the head removes samples and nothing else: the delivered samples carry the same values.
  auto sc_gap = simtest::withEffects(sc, {"gaps:sensor=3,per_day=400,mean_s=30"});
  auto g = simtest::run(sc_gap, 8, 1800);
  auto full = simtest::run(sc, 8, 1800);
  const auto sg = samplesOf(g->cap, 3), sf = samplesOf(full->cap, 3);
  ASSERT_LT(sg.size(), sf.size());
  std::size_t j = 0;
  for (const auto* h : sg) {
    while (sf[j]->index != h->index) ++j;
    ASSERT_EQ(h->coloured_rad, sf[j]->coloured_rad);
    ASSERT_TRUE(simtest::sameQuat(h->q_I_Si, sf[j]->q_I_Si));
  }
}

TEST(SimNoiseEffects, TwoColouredNoiseSpecsAddVariancesAndTheFirstKeepsItsDraws) {
  const auto one = simtest::withEffects(quiet(), {"coloured_noise:sensor=1,cross_arcsec=2,tau_s=30"});
  const auto two = simtest::withEffects(one, {"coloured_noise:sensor=1,cross_arcsec=3,tau_s=10"});
  auto a = simtest::run(one, 5, 4 * 3600.0), b = simtest::run(two, 5, 4 * 3600.0);
  const auto sa = samplesOf(a->cap, 1), sb = samplesOf(b->cap, 1);
  ASSERT_EQ(sa.size(), sb.size());
  const model::NoiseModel& m2 = b->sim.heads()[0].effects().coloured_cross;
  ASSERT_EQ(m2.terms.size(), 2u);
  model::NoiseModel second;
  second.add(m2.terms[1]);
  // Sample variances against the model, with the standard deviation of a mean of squares of a stationary
  // normal series (2 sum_k R(kT)^2 / n); axis e1.
  auto check = [&](const std::vector<double>& x, const model::NoiseModel& m, const char* what) {
    double ss = 0;
    for (double v : x) ss += v * v;
    const double n = static_cast<double>(x.size());
    double acc = 0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      const double r = m.autocovariance(0.5 * static_cast<double>(k));
      if (r < 1e-9 * m.variance()) break;
      acc += (k ? 2.0 : 1.0) * r * r;
    }
    EXPECT_LT(std::abs(ss / n - m.variance()) / std::sqrt(2 * acc / n), testpsd::zCrit(kFamilyAlpha, 2))
        << what << ": " << std::sqrt(ss / n) * kArcsecPerRad << "\" against " << std::sqrt(m.variance()) * kArcsecPerRad << "\"";
  };
  std::vector<double> xb, diff;
  for (std::size_t k = 0; k < sa.size(); ++k) {
    xb.push_back(sb[k]->coloured_rad.x());
    diff.push_back(sb[k]->coloured_rad.x() - sa[k]->coloured_rad.x());  // the second spec's own process
  }
  check(xb, m2, "two specs: variances add");
  check(diff, second, "the difference is the second spec alone");
}

TEST(SimNoiseEffects, ThermalWanderRotatesTheMountingWithItsSpectrum) {
  const std::vector<std::string> eff = {"thermal_wander:sensor=1,cross_arcsec=3,about_arcsec=6,alpha=1.5,f_lo_hz=1e-4,f_hi_hz=1e-2"};
  const auto base = quiet();
  auto r = simtest::run(simtest::withEffects(base, eff), 12, 86400);
  auto clean = simtest::run(base, 12, 1200);
  auto with_sv = simtest::run(simtest::withEffects(gracefo(), eff), 12, 1200);  // star vectors on
  const model::HeadModel& hm = r->sim.heads()[0];
  const model::HeadEffects& e = hm.effects();
  // The wander is a rotation of the mounting: it is in the expected (noise-free) attitude and in the
  // star vectors' geometric attitude, and it moves the head's boresight against the other heads.
  const auto s = samplesOf(r->cap, 1), s0 = samplesOf(clean->cap, 1);
  std::size_t checked = 0;
  for (std::size_t k = 0; k < s0.size(); ++k) {
    const Vec3 d = hm.toHeadAxes(rotBetween(s0[k]->q_I_Si_expected, s[k]->q_I_Si_expected));
    // q_I_Si = q_I_B q_Si_B^-1 with q_Si_B = Exp(w) q_Si_B0: the head frame turns by -w.
    EXPECT_LT((d + s[k]->wander_rad).norm(), 1e-3 * s[k]->wander_rad.norm() + 1e-11) << k;
    ++checked;
  }
  EXPECT_GT(checked, 2000u);
  const auto sw = samplesOf(with_sv->cap, 1);
  std::size_t sv = 0;
  for (const auto& v : with_sv->cap.sv) {
    if (v.head != 1) continue;
    const auto* h = *std::find_if(sw.begin(), sw.end(), [&](const sim::HeadSampleOut* x) { return x->index == v.index; });
    EXPECT_EQ(h->wander_rad, s[h->index]->wander_rad);  // star vectors on or off: the same process
    const Quat q_geom_expected =
        (h->q_I_B * hm.qSiB(with_sv->sim.context(h->t_true_s), hm.fromHeadAxes(h->wander_rad)).conjugate()).normalized();
    EXPECT_LT(rotBetween(q_geom_expected, v.q_I_Si_geometric).norm(), 1e-12);
    ++sv;
  }
  EXPECT_GT(sv, 50u);
  // The stated spectrum, per head axis: the day decimated to 8 s (the model is sampled exactly).
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> x;
    for (std::size_t k = 0; k < s.size(); k += 16) x.push_back(s[k]->wander_rad[axis]);
    expectSpectrum(x, axis < 2 ? e.wander_cross : e.wander_about, 8.0, 512, 5, "thermal_wander axis " + std::to_string(axis));
  }
}

TEST(SimNoiseEffects, AccelerometerColouredNoiseAndBiasWanderHaveTheirSpectra) {
  const auto base = quiet();
  const auto sc = simtest::withEffects(
      base, {"acc_coloured_noise:x=2e-8,y=5e-9,z=1e-8,alpha=1,f_lo_hz=1e-3,f_hi_hz=1", "acc_bias_wander:x=3e-9,y=2e-9,z=4e-9,tau_s=2000"});
  auto r = simtest::run(sc, 17, 6 * 3600.0);
  auto clean = simtest::run(base, 17, 600);
  // In ang_A exactly (everything else identical), and only there.
  for (std::size_t k = 0; k < clean->cap.acc.size(); ++k) {
    const auto &a = clean->cap.acc[k], &b = r->cap.acc[k];
    EXPECT_LT((b.ang_A - a.ang_A - b.coloured_rad_s2 - b.bias_wander_rad_s2).norm(), 1e-18);
    EXPECT_EQ(a.lin_A, b.lin_A);
  }
  for (std::size_t k = 0; k < clean->cap.heads.size(); ++k) ASSERT_TRUE(simtest::sameQuat(clean->cap.heads[k].q_I_Si, r->cap.heads[k].q_I_Si));
  const auto& ae = r->sim.accel().effects();
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> c, w;
    for (const auto& a : r->cap.acc) {
      c.push_back(a.coloured_rad_s2[axis]);
      w.push_back(a.bias_wander_rad_s2[axis]);
    }
    expectSpectrum(c, ae.coloured[static_cast<std::size_t>(axis)], 0.1, 8192, 6, "acc_coloured_noise axis " + std::to_string(axis));
    // the bias wander: decimated to 10 s
    std::vector<double> wd;
    for (std::size_t k = 0; k < w.size(); k += 100) wd.push_back(w[k]);
    expectSpectrum(wd, ae.bias_wander[static_cast<std::size_t>(axis)], 10.0, 256, 4, "acc_bias_wander axis " + std::to_string(axis));
  }
}

// ---------------------------------------------------------------------------------------------
// Field-of-view error

TEST(SimNoiseEffects, FovErrorIsTheFieldAtItsOwnHeadsStarsAndRepeatsEachRevolution) {
  auto sc = simtest::withEffects(quiet(), {"fov_error:sensor=all,arcsec=4,order=3"});
  const double span = 4 * 5700.0;
  auto r = simtest::run(sc, 21, span);
  const auto& cat = r->sim.stars();
  // 1. The error of every (sampled) epoch is the field of ITS head evaluated at ITS stars: recomputed
  //    from the catalogue stars in the FOV through the expected attitude. The same field at another
  //    head's stars (another part of the sky on the same detector) is a different error.
  //    The comparison is on the variations: a constant part (the field's mean over any star set) does
  //    not tell where the stars are.
  double rms_own = 0, rms_other = 0, rms = 0;
  int n = 0;
  for (int id : {1, 2, 3}) {
    const model::HeadModel& hm = r->sim.heads()[static_cast<std::size_t>(id - 1)];
    const model::HeadModel& other = r->sim.heads()[static_cast<std::size_t>(id % 3)];
    const auto s = samplesOf(r->cap, id), so = samplesOf(r->cap, id % 3 + 1);
    std::vector<Vec3> rec, own_e, oth_e;
    for (std::size_t k = 0; k < s.size() && k < so.size(); k += 97) {
      if (s[k]->blind || so[k]->blind) continue;
      const auto& c = hm.config();
      const auto own = sim::starVectorsInHead(cat, s[k]->q_I_Si_expected, c.boresight_Si, c.fov_half_angle_rad, c.limiting_mag);
      EXPECT_EQ(static_cast<int>(own.size()), s[k]->nstars);
      const auto& oc = other.config();
      const auto theirs = sim::starVectorsInHead(cat, so[k]->q_I_Si_expected, oc.boresight_Si, oc.fov_half_angle_rad, oc.limiting_mag);
      rec.push_back(s[k]->fov_rad);
      own_e.push_back(hm.toHeadAxes(hm.fovAttitudeError(own.data(), own.size())));
      oth_e.push_back(hm.toHeadAxes(hm.fovAttitudeError(theirs.data(), theirs.size())));
    }
    Vec3 m_rec = Vec3::Zero(), m_oth = Vec3::Zero();
    for (std::size_t k = 0; k < rec.size(); ++k) m_rec += rec[k] / static_cast<double>(rec.size()), m_oth += oth_e[k] / static_cast<double>(rec.size());
    for (std::size_t k = 0; k < rec.size(); ++k) {
      rms_own += (own_e[k] - rec[k]).squaredNorm();
      rms_other += ((oth_e[k] - m_oth) - (rec[k] - m_rec)).squaredNorm();
      rms += (rec[k] - m_rec).squaredNorm();
      ++n;
    }
  }
  ASSERT_GT(n, 300);
  EXPECT_LT(std::sqrt(rms_own / n), 1e-9 * std::sqrt(rms / n));
  // uncorrelated variations of equal size would give sqrt(2); 0.5 means a correlation below 0.875
  EXPECT_GT(std::sqrt(rms_other / n), 0.5 * std::sqrt(rms / n));
  // The fields differ between heads.
  EXPECT_NE(r->sim.heads()[0].fovFields()[0].cx, r->sim.heads()[1].fovFields()[0].cx);

  // 2. The delivered attitude carries it: q = expected Exp(n + f) against a run without fov_error
  //    (the difference is f within |n| |f| / 2, as for coloured_noise).
  auto clean = simtest::run(quiet(), 21, 600);
  for (std::size_t k = 0; k < clean->cap.heads.size(); ++k) {
    const auto &x = clean->cap.heads[k], &y = r->cap.heads[k];
    if (y.blind) continue;
    const model::HeadModel& hm = r->sim.heads()[static_cast<std::size_t>(y.head - 1)];
    const double nn = rotBetween(x.q_I_Si_expected, x.q_I_Si).norm();
    EXPECT_LT((hm.toHeadAxes(rotBetween(x.q_I_Si, y.q_I_Si)) - y.fov_rad).norm(), 0.505 * nn * y.fov_rad.norm() + 1e-13);
  }

  // 3. Earth pointing: the same stars cross the same pixels every revolution. The autocorrelation of
  //    head 1's cross-boresight error over lags of 0.5-1.5 revolutions peaks at one revolution (the
  //    period of the argument of latitude, from the orbit), nearly at 1.
  const double T_orb = [&] {
    const double u0 = r->sim.context(0).arg_lat_rad, u1 = r->sim.context(100).arg_lat_rad;
    return 2 * kPi * 100 / std::remainder(u1 - u0, 2 * kPi);
  }();
  const auto s = samplesOf(r->cap, 1);
  std::vector<double> x;  // 10 s steps; blinded epochs carry no error: left out as gaps (NaN)
  for (std::size_t k = 0; k < s.size(); k += 20) x.push_back(s[k]->blind ? std::nan("") : s[k]->fov_rad.x());
  auto acf = [&](std::size_t lag) {
    double sxy = 0, sxx = 0, syy = 0, mx = 0, my = 0;
    int m = 0;
    for (std::size_t i = 0; i + lag < x.size(); ++i)
      if (std::isfinite(x[i]) && std::isfinite(x[i + lag])) mx += x[i], my += x[i + lag], ++m;
    mx /= m;
    my /= m;
    for (std::size_t i = 0; i + lag < x.size(); ++i)
      if (std::isfinite(x[i]) && std::isfinite(x[i + lag])) {
        sxy += (x[i] - mx) * (x[i + lag] - my);
        sxx += (x[i] - mx) * (x[i] - mx);
        syy += (x[i + lag] - my) * (x[i + lag] - my);
      }
    return sxy / std::sqrt(sxx * syy);
  };
  std::size_t best = 0;
  double best_r = -2;
  for (auto lag = static_cast<std::size_t>(0.5 * T_orb / 10); lag <= static_cast<std::size_t>(1.5 * T_orb / 10); ++lag) {
    const double c = acf(lag);
    if (c > best_r) best_r = c, best = lag;
  }
  std::printf("fov_error head 1: RMS of the variations %.3g\" (3 heads, all axes), other-head stars differ by %.3g\"; "
              "autocorrelation peak %.4f at %.0f s, revolution %.0f s\n",
              std::sqrt(rms / n) * kArcsecPerRad, std::sqrt(rms_other / n) * kArcsecPerRad, best_r, static_cast<double>(best) * 10.0, T_orb);
  EXPECT_NEAR(static_cast<double>(best) * 10.0, T_orb, 0.01 * T_orb) << "autocorrelation peak " << best_r;
  EXPECT_GT(best_r, 0.9);
}

TEST(SimNoiseEffects, FovErrorMovesTheStarVectorsAndDeliveredAttitudeConsistently) {
  // No other noise: the star vectors are the catalogue stars displaced by the field, and the delivered
  // attitude is expected Exp(f) with f the least-squares rotation of the displacements of all FOV stars.
  auto sc = simtest::withEffects(gracefo(), {"fov_error:sensor=2,arcsec=5", "cross_noise:sensor=all,cross_arcsec=0",
                                             "anisotropic_noise:sensor=all,about_arcsec=0"});
  for (auto& h : sc.heads) h.sigma_star_rad = 0;
  auto r = simtest::run(sc, 4, 600);
  const model::HeadModel& hm = r->sim.heads()[1];
  std::size_t n = 0;
  for (const auto& v : r->cap.sv) {
    if (v.head != 2) continue;
    for (int k = 0; k < v.n; ++k) {
      const auto& st = v.star[static_cast<std::size_t>(k)];
      EXPECT_LT((st.s_Si - hm.fovDisplacedStar(st.s_Si_true)).norm(), 1e-15);
      EXPECT_GT((st.s_Si - st.s_Si_true).norm(), 0.0);
    }
    ++n;
  }
  EXPECT_GT(n, 40u);
  for (const auto& h : r->cap.heads) {
    if (h.head != 2 || h.blind) continue;
    EXPECT_LT(rotBetween(h.q_I_Si_expected * model::quatExp(hm.fromHeadAxes(h.fov_rad)), h.q_I_Si).norm(), 1e-15);
  }
}

// ---------------------------------------------------------------------------------------------
// Existing output unchanged

std::uint64_t fnv1a(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : s.str()) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return h;
}

TEST(SimNoiseEffects, ScenariosWithoutTheNewEffectsWriteTheBytesTheyWroteBefore) {
  // FNV-1a 64 of every product of 600 s, seed 5, written by `boresight simulate` BEFORE the coloured
  // effects and the accelerometer noise's move onto the noise library (truth.yaml is left out: it
  // names the paths of its run; test/sim/bench/byte_identity.sh compares it too, across two programs).
  struct Case {
    std::string scenario;
    std::vector<std::string> effects;
    std::vector<std::pair<std::string, std::uint64_t>> files;
  };
  const std::string g = "GNV1B_2023-06-01_C_04.txt", q = "QSA1B_2023-06-01_C_04.txt", a = "ACC1A_2023-06-01_C_04.txt",
                    s = "SCA1A_2023-06-01_C_04.txt", v = "SCV1A_2023-06-01_C_04.txt", l = "sim.lcmlog";
  const std::vector<Case> cases = {
      {"sim_gracefo.yaml", {}, {{a, 0xf1cb8883077fb9eaULL}, {g, 0xbe2c428124004154ULL}, {q, 0x8100dab7a770a00cULL},
                                {s, 0xf26642852ea19afcULL}, {v, 0x0979b5f834ab6f27ULL}, {l, 0x1833828ea0cec1feULL}}},
      {"sim_audit.yaml", {}, {{a, 0xf9323530ef166468ULL}, {s, 0xcf9197464e5b7317ULL}, {l, 0xaf386d6474aa16d7ULL}}},
      {"sim_gracefo_node_demo.yaml", {}, {{a, 0xe2e6d124380ef89aULL}, {s, 0x8e34a59e3fece060ULL}, {v, 0x29038bf5cc6b8ba7ULL},
                                          {l, 0x66d35f8f972c5b4dULL}}},
      {"sim_gracefo.yaml",
       {"gaps:sensor=acc,per_day=3000,mean_s=5", "gaps:sensor=2,per_day=2000,mean_s=20", "outliers:sensor=1,rate=0.01",
        "sign_flips:sensor=3,rate=0.01", "clock_drift:sensor=acc,rate_ppm=3", "time_offset:sensor=all,offset_ms=20",
        "thermal_periodic:sensor=2,harmonic=1,x_arcsec=5", "aberration", "cross_noise:sensor=all,cross_arcsec=2",
        "acc_bias:x=1e-7"},
       {{a, 0x88ce3bdcace0ada7ULL}, {s, 0xc8f2e3c23cb8e502ULL}, {v, 0xad9959905a7af092ULL}, {l, 0xb70e9be6f2dc3642ULL}}},
  };
  for (const auto& c : cases) {
    sim::Scenario sc;
    std::string err;
    ASSERT_TRUE(sim::loadScenario(simtest::sourceDir() + "/config/" + c.scenario, sc, &err)) << err;
    ASSERT_TRUE(sim::addEffectArgs(sc, c.effects, &err)) << err;
    const fs::path dir = testutil::makeTempDir("boresight_sim_bytes");
    sim::Simulator sim;
    ASSERT_TRUE(sim.init(sc, 5, 600, &err)) << err;
    sim::Level1Sink l1;
    sim::LcmSink log;
    sim::TeeSink tee;
    ASSERT_TRUE(l1.open(dir.string(), sc, &err)) << err;
    ASSERT_TRUE(log.open((dir / "sim.lcmlog").string(), &err)) << err;
    ASSERT_TRUE(log.writeMountings(sim));  // as `boresight simulate` does
    tee.add(&l1);
    tee.add(&log);
    sim.run(tee);
    ASSERT_TRUE(l1.close(&err)) << err;
    ASSERT_TRUE(log.close(&err)) << err;
    ASSERT_TRUE(sim::writeQsa1b((dir / q).string(), sim, &err)) << err;
    for (const auto& [file, hash] : c.files) EXPECT_EQ(fnv1a((dir / file).string()), hash) << c.scenario << " " << file;
  }
}

}  // namespace
}  // namespace boresight

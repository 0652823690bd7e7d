// The orbit on the one data path: GNI1B files and ORBIT messages are stream samples; with the thermal
// terms of a model overlay the replay engine (Level-1 files or an LCM log) and the node step the core's
// thermal prediction with them, and predict the relative correction of a head pair while one head is
// blind. Without thermal terms the orbit is not read (files) or counted as rejected with its reason
// (messages): never "used" without a consumer.
//
// The world: three heads at 2 Hz whose relative alignment moves with the orbit (a constant, first and
// third harmonics of the argument of latitude, tens of arcseconds), white head noise, a circular orbit
// written as GNI1B records / ORBIT messages every 5 s; head 3 blind for two 20-minute windows, the
// second one running to the end of the data. The overlay holds the true terms, written to YAML and read
// back. Measured: the error of the relative matrix the star-vector solver would use for the pair
// (1,3) over the blind epochs, against the truth.
#include <boresight/core/rotation.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/node/node.h>
#include <boresight/sim/orbit.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>
#include <boresight/stream/sources.h>

#include <gtest/gtest.h>

#include "boresight_lcm/boresight_monitor_t.hpp"
#include "test_files.h"
#include "three_heads.h"

#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

using namespace boresight;

namespace {

constexpr double kT0 = 738849600.0;  // 2023-06-01 00:00 GPS
constexpr double kAs = kRadPerArcsec;
constexpr double kSpan = 7200.0;
constexpr double kOrbitStep = 5.0;
const double kBlind[2][2] = {{3000.0, 4200.0}, {6000.0, kSpan + 1.0}};

bool blindAt(double rel) {
  for (const auto& w : kBlind)
    if (rel >= w[0] && rel < w[1]) return true;
  return false;
}

core::HeadSetConfig heads() { return testutil::threeTiltedHeads(); }

/// The truth: deformation of head 3 relative to head 1, in S1, arcsec: constant, cos/sin of u and 3u.
struct Truth {
  double c[3] = {-15, 8, -25}, a1[3] = {6, 9, -20}, b1[3] = {-8, 4, 10}, a3[3] = {-4, 2, 5}, b3[3] = {2, -5, -6};
  Vec3 delta(double u) const {
    Vec3 d;
    for (int a = 0; a < 3; ++a)
      d(a) = (c[a] + a1[a] * std::cos(u) + b1[a] * std::sin(u) + a3[a] * std::cos(3 * u) + b3[a] * std::sin(3 * u)) * kAs;
    return d;
  }
  model::Overlay overlay() const {
    model::Overlay o;
    o.written_by = "orbit_thermal_test";
    model::ThermalTerms t;
    t.datum_head = 1;
    model::ThermalHeadEntry h;
    h.head = 3;
    h.constant_rad.value = Vec3(c[0], c[1], c[2]) * kAs;
    h.constant_rad.sigma = Vec3::Constant(0.5 * kAs);
    for (int n : {1, 3}) {
      model::ThermalHarmonicEntry e;
      e.harmonic = n;
      e.cos_rad.value = (n == 1 ? Vec3(a1[0], a1[1], a1[2]) : Vec3(a3[0], a3[1], a3[2])) * kAs;
      e.sin_rad.value = (n == 1 ? Vec3(b1[0], b1[1], b1[2]) : Vec3(b3[0], b3[1], b3[2])) * kAs;
      e.cos_rad.sigma = e.sin_rad.sigma = Vec3::Constant(0.3 * kAs);
      h.harmonics.push_back(e);
    }
    t.heads.push_back(h);
    o.thermal = t;
    return o;
  }
};

sim::CircularOrbit orbit() {
  sim::OrbitConfig c;
  c.raan_rad = 0.4;
  c.arg_lat0_rad = 0.3;
  return sim::CircularOrbit(c, kT0);
}

/// The data, as Level-1 files and as one LCM log with the same content.
struct Data {
  std::string dir, sca, gni, lcm, overlay;
  std::size_t n_orbit = 0, n_head_samples = 0;
};

const Data& data() {
  static const Data data_ = [] {
    Data d;
    d.dir = testutil::makeTempDir("boresight_orbit_thermal");
    const core::HeadSetConfig h = heads();
    const sim::CircularOrbit o = orbit();
    const Truth tr;
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n01(0.0, 1.0);
    auto sca = io::makeProduct<io::Sca1aRecord>(io::Product::SCA1A, 'C');
    auto gni = io::makeProduct<io::GnvRecord>(io::Product::GNI1B, 'C');
    io::LcmLogWriter log;
    std::string err;
    d.lcm = d.dir + "/data.lcmlog";
    EXPECT_TRUE(log.open(d.lcm, &err)) << err;
    std::int32_t seq_h[3] = {0, 0, 0}, seq_o = 0;
    for (int i = 0; i < static_cast<int>(2 * kSpan); ++i) {
      const double rel = 0.5 * i, t = kT0 + rel;
      const TimeUs tu = static_cast<TimeUs>(std::llround(t * 1e6));
      const sim::OrbitState s = o.state(t);
      const Quat q_I_B = core::quatExp(Vec3(0.3, -0.2, 1.1e-3 * rel));
      const Quat q_I_S0 = q_I_B * h.head[0].q_Si_B.conjugate();
      for (int k = 0; k < 3; ++k) {
        if (k == 2 && blindAt(rel)) continue;
        const auto u = static_cast<std::size_t>(k);
        const Quat q_C0 = h.head[0].q_Si_B * h.head[u].q_Si_B.conjugate();  // C_S1_Sk^0
        const Quat q_true = k == 0 ? q_I_S0 : q_I_S0 * core::quatExp(k == 2 ? tr.delta(s.arg_lat_rad) : Vec3::Zero()) * q_C0;
        const Vec3 b = h.head[u].boresight_Si, e1 = b.unitOrthogonal(), e2 = b.cross(e1);
        const Vec3 eps = h.head[u].sigma_cross_rad * (n01(rng) * e1 + n01(rng) * e2) + h.head[u].sigma_roll_rad * n01(rng) * b;
        Quat q = (q_true * core::quatExp(eps)).normalized();
        if (q.w() < 0) q.coeffs() *= -1;
        io::Sca1aRecord r;
        r.t = tu;
        r.head = static_cast<std::uint8_t>(k + 1);
        r.q[0] = q.w();
        r.q[1] = q.x();
        r.q[2] = q.y();
        r.q[3] = q.z();
        r.nstars = 5;
        sca.records.push_back(r);
        EXPECT_TRUE(log.write(io::headFromSca1a(r, seq_h[k]++)));
        ++d.n_head_samples;
      }
      if (i % static_cast<int>(2 * kOrbitStep) == 0) {
        io::GnvRecord g;
        g.t = tu;
        g.coord_ref = 'I';
        io::OrbitSample m;
        m.utime = tu;
        m.frame = 'I';
        m.seq = seq_o++;
        for (int a = 0; a < 3; ++a) {
          g.pos[a] = m.r_m[a] = s.r_I(a);
          g.vel[a] = m.v_m_s[a] = s.v_I(a);
        }
        gni.records.push_back(g);
        EXPECT_TRUE(log.write(m));
        ++d.n_orbit;
      }
    }
    EXPECT_TRUE(log.close(&err)) << err;
    d.sca = d.dir + "/SCA1A_2023-06-01_C_04.txt";
    d.gni = d.dir + "/GNI1B_2023-06-01_C_04.txt";
    EXPECT_TRUE(io::writeProduct(d.sca, sca, &err)) << err;
    EXPECT_TRUE(io::writeProduct(d.gni, gni, &err)) << err;
    d.overlay = d.dir + "/thermal.yaml";
    EXPECT_TRUE(io::writeOverlay(d.overlay, Truth{}.overlay(), &err)) << err;
    return d;
  }();
  return data_;
}

core::PipelineConfig pipelineConfig() {
  core::PipelineConfig pc;
  pc.heads = heads();
  pc.use_accelerometer = false;
  return pc;
}

/// The overlay as the programs read it: YAML -> model::Overlay -> the core's model.
core::ThermalHarmonicModel thermalModel() {
  model::Overlay ov;
  std::string err;
  EXPECT_TRUE(io::readOverlay(data().overlay, ov, &err)) << err;
  EXPECT_TRUE(ov.thermal.has_value());
  core::ThermalHarmonicModel m;
  EXPECT_TRUE(io::thermalModelFromOverlay(*ov.thermal, heads(), m, &err)) << err;
  return m;
}

/// The error of the pair (1,3)'s relative matrix against the truth over the blind epochs.
struct PairError {
  double sum2 = 0, max = 0, nees_sum = 0;
  int n = 0, predicted = 0;
  double rms() const { return n ? std::sqrt(sum2 / n) : 0.0; }
  void add(const core::Pipeline& p, TimeUs t) {
    const double rel = toSeconds(t) - kT0;
    if (!blindAt(rel)) return;
    Mat3 C, Q;
    p.monitor().relativeFor(0, 2, core::RelativeCorrection::kFilteredThreeAxis, t, C, Q);
    const Mat3 C_true = core::so3Exp(Truth{}.delta(orbit().state(toSeconds(t)).arg_lat_rad)) * core::groundRelative(heads(), 0, 2);
    const Vec3 e = core::so3Log(C * C_true.transpose());
    sum2 += e.squaredNorm() / (kAs * kAs);
    max = std::max(max, e.norm() / kAs);
    nees_sum += e.dot(Q.ldlt().solve(e));
    predicted += p.monitor().filtered(0, 2).predicted ? 1 : 0;
    ++n;
  }
};

/// Reads the core's monitor after each head epoch the engine steps.
struct MonitorProbe : stream::InputObserver {
  const stream::Engine* engine = nullptr;
  PairError err;
  void onHeads(const core::HeadEpoch& e, core::Status) override { err.add(engine->pipeline(), e.t); }
};

struct EngineRun {
  PairError err;
  stream::Counters counters;
  std::size_t sources = 0;
  std::uint64_t orbit_samples = 0;
  core::FilteredDeformation last{};
  core::Health health{};
};

/// The replay engine over the given inputs (as `boresight process` sets it up), with or without the
/// overlay's thermal model.
EngineRun runEngine(const std::vector<std::string>& files, bool with_model) {
  EngineRun r;
  std::string err;
  stream::ReplayInputs in;
  EXPECT_TRUE(stream::classifyInputs(files, in, &err)) << err;
  stream::Engine e;
  EXPECT_TRUE(e.configure(pipelineConfig(), &err)) << err;
  if (with_model) {
    EXPECT_TRUE(e.setThermalModel(thermalModel(), &err)) << err;
  }
  MonitorProbe probe;
  probe.engine = &e;
  e.addObserver(&probe);
  EXPECT_TRUE(stream::addSources(in, {}, false, e, &err)) << err;
  EXPECT_EQ(e.run(), stream::Engine::Result::kDone) << e.error();
  r.err = probe.err;
  r.counters = e.counters();
  r.sources = e.sourceCount();
  r.orbit_samples = e.orbitSamples();
  r.last = e.pipeline().monitor().filtered(0, 2);
  r.health = e.health();
  return r;
}

/// The pair (1,3) as the node publishes it (BORESIGHT_MONITOR) over the blind epochs, against the truth.
struct MonitorCapture : node::Output {
  double sum2 = 0;
  int n = 0;
  std::map<int, int> sources;  ///< pair_source of the pair (1,3) over the blind epochs
  std::vector<std::pair<double, int>> trail;  ///< (seconds since the start, pair_source) of every blind epoch
  std::vector<double> sigma_x;                 ///< the published 1-sigma about x of S1, arcsec, alongside
  double rms() const { return n ? std::sqrt(sum2 / n) : 0.0; }
  void publish(const std::string& ch, TimeUs, const void* data, int size) override {
    if (ch != "BORESIGHT_MONITOR") return;
    boresight_lcm::boresight_monitor_t m;
    EXPECT_EQ(m.decode(data, 0, size), size);
    const double rel = toSeconds(m.pair_utime) - kT0;
    if (!blindAt(rel)) return;
    const int p = core::pairIndex(0, 2);
    ++sources[m.pair_source[p]];
    trail.emplace_back(rel, m.pair_source[p]);
    sigma_x.push_back(m.pair_sigma_rad[p][0] / kAs);
    const Vec3 delta(m.pair_delta_rad[p][0], m.pair_delta_rad[p][1], m.pair_delta_rad[p][2]);
    const Vec3 e = core::so3Log(core::so3Exp(delta) * core::so3Exp(Truth{}.delta(orbit().state(toSeconds(m.pair_utime)).arg_lat_rad)).transpose());
    sum2 += e.squaredNorm() / (kAs * kAs);
    ++n;
  }
};

struct NodeRun {
  node::Counters c;
  core::FilteredDeformation last{};
  MonitorCapture published;
};

NodeRun runNode(bool with_model, const std::string& log = data().lcm) {
  node::NodeConfig cfg;
  std::string err;
  EXPECT_TRUE(node::loadNodeConfig(std::string(BORESIGHT_SOURCE_DIR) + "/config/boresightd.yaml", cfg, &err)) << err;
  cfg.pipeline = pipelineConfig();
  cfg.mountings_from_log = false;
  cfg.calibration.enabled = false;
  if (with_model) cfg.thermal_model = thermalModel();
  node::Node n;
  NodeRun r;
  EXPECT_TRUE(n.configure(cfg, node::Node::Mode::kReplay, &r.published, &err)) << err;
  EXPECT_TRUE(node::replayLog(n, log, &err)) << err;
  r.c = n.counters();
  r.last = n.pipeline().monitor().filtered(0, 2);
  return r;
}

}  // namespace

TEST(OrbitThermal, TheOverlaysTermsBecomeTheCoresModel) {
  const core::ThermalHarmonicModel m = thermalModel();
  ASSERT_EQ(m.n_harmonics, 2);
  EXPECT_EQ(m.order[0], 1);
  EXPECT_EQ(m.order[1], 3);
  EXPECT_EQ(m.datum_slot, 0);
  EXPECT_FALSE(m.head[1].valid);
  ASSERT_TRUE(m.head[2].valid);
  EXPECT_NEAR(m.head[2].cos_rad[1](2) / kAs, 5.0, 1e-9);
  EXPECT_NEAR(m.head[2].sin_rad[0](0) / kAs, -8.0, 1e-9);
  // diagonal: 0.5^2 + 0.5 (2 harmonics x (0.3^2 + 0.3^2)) arcsec^2
  EXPECT_NEAR(m.head[2].cov_rad2(1, 1) / (kAs * kAs), 0.25 + 0.18, 1e-9);
  // A head the platform does not have, the datum with terms, and too many harmonics are refused.
  model::ThermalTerms t = *Truth{}.overlay().thermal;
  std::string err;
  core::ThermalHarmonicModel x;
  t.heads[0].head = 7;
  EXPECT_FALSE(io::thermalModelFromOverlay(t, heads(), x, &err));
  EXPECT_NE(err.find("head 7"), std::string::npos) << err;
  t.heads[0].head = 1;
  EXPECT_FALSE(io::thermalModelFromOverlay(t, heads(), x, &err));
  EXPECT_NE(err.find("datum"), std::string::npos) << err;
  t.heads[0].head = 3;
  for (int n = 4; n <= 8; ++n) {
    model::ThermalHarmonicEntry e;
    e.harmonic = n;
    t.heads[0].harmonics.push_back(e);
  }
  EXPECT_FALSE(io::thermalModelFromOverlay(t, heads(), x, &err));
  EXPECT_NE(err.find("at most"), std::string::npos) << err;
}

TEST(OrbitThermal, Level1OrbitFilesStepThePredictionOnlyWithAThermalModel) {
  const Data& d = data();
  const EngineRun with = runEngine({d.sca, d.gni}, true);
  const EngineRun without = runEngine({d.sca, d.gni}, false);
  // With the model the GNI1B file is a source and every record is used; without it, it is not opened.
  EXPECT_EQ(with.sources, 2u);
  EXPECT_EQ(with.counters.used_orbit, d.n_orbit);
  EXPECT_EQ(with.orbit_samples, d.n_orbit);
  EXPECT_EQ(with.counters.read, d.n_orbit + d.n_head_samples);
  EXPECT_EQ(with.counters.read, with.counters.used() + with.counters.rejectedTotal());
  EXPECT_EQ(without.sources, 1u);
  EXPECT_EQ(without.counters.used_orbit, 0u);
  EXPECT_EQ(without.counters.read, d.n_head_samples);
  // Head 3 blind for 2 x 20 minutes: the prediction from the orbit follows the deformation; holding
  // the last correction does not.
  ASSERT_EQ(with.err.n, without.err.n);
  ASSERT_GT(with.err.n, 4000);
  std::printf("pair (1,3) over %d blind epochs: predicted from the orbit RMS %.2f\" (max %.2f\", NEES/3 %.2f), "
              "held RMS %.2f\" (max %.2f\")\n",
              with.err.n, with.err.rms(), with.err.max, with.err.nees_sum / (3.0 * with.err.n), without.err.rms(),
              without.err.max);
  EXPECT_EQ(with.err.predicted, with.err.n);  // every blind epoch used the prediction
  EXPECT_EQ(without.err.predicted, 0);
  EXPECT_GT(without.err.rms(), 10.0);  // the deformation moves tens of arcseconds while head 3 is blind
  EXPECT_LT(with.err.rms(), 0.2 * without.err.rms());
  EXPECT_LT(with.err.nees_sum / (3.0 * with.err.n), 3.0);  // the published covariance is not overconfident
  EXPECT_TRUE(with.last.predicted);                         // the data end inside a blind window
}

TEST(OrbitThermal, AnLcmLogAndTheNodeGiveWhatTheLevel1ReplayGives) {
  const Data& d = data();
  const EngineRun files = runEngine({d.sca, d.gni}, true);
  const EngineRun log = runEngine({d.lcm}, true);
  const EngineRun log_without = runEngine({d.lcm}, false);
  // The log's ORBIT messages are samples: used with a model, rejected with their reason without one.
  EXPECT_EQ(log.counters.used_orbit, d.n_orbit);
  EXPECT_EQ(log.counters.rejectedTotal(), 0u);
  EXPECT_EQ(log_without.counters.used_orbit, 0u);
  EXPECT_EQ(log_without.counters.rejected[static_cast<std::size_t>(stream::Reject::kNoConsumer)], d.n_orbit);
  EXPECT_EQ(log_without.counters.read, log_without.counters.used() + log_without.counters.rejectedTotal());
  // Same samples, same order: the same predictions (the text files round the quaternions, so not
  // bit for bit).
  ASSERT_EQ(log.err.n, files.err.n);
  EXPECT_NEAR(log.err.rms(), files.err.rms(), 0.02);
  EXPECT_NEAR(log.last.delta_Si.norm() / kAs, files.last.delta_Si.norm() / kAs, 0.02);

  // The node on the same log: the orbit is consumed (stepped), not merely counted.
  const NodeRun node = runNode(true);
  const NodeRun node_without = runNode(false);
  EXPECT_EQ(node.c.orbit_steps, d.n_orbit);
  EXPECT_EQ(node.c.rejected[static_cast<std::size_t>(io::Reject::kNoConsumer)], 0u);
  EXPECT_EQ(node.c.received, node.c.used + [&] {
    std::uint64_t s = 0;
    for (auto v : node.c.rejected) s += v;
    return s;
  }());
  EXPECT_EQ(node.c.used, d.n_orbit + d.n_head_samples);
  EXPECT_EQ(node_without.c.orbit_steps, 0u);
  EXPECT_EQ(node_without.c.rejected[static_cast<std::size_t>(io::Reject::kNoConsumer)], d.n_orbit);
  EXPECT_EQ(node_without.c.used, d.n_head_samples);
  // Its core ends in the state of the engine's on the same log: predicted, the same deformation.
  ASSERT_TRUE(node.last.predicted);
  EXPECT_LT((node.last.delta_Si - log.last.delta_Si).norm() / kAs, 1e-9);
  EXPECT_EQ(node.last.t, log.last.t);
  EXPECT_FALSE(node_without.last.predicted);
  // What the node publishes (BORESIGHT_MONITOR: the pair corrections at the latest head epoch): the
  // prediction while head 3 is blind, held without the thermal terms.
  std::printf("node, published pair (1,3) over %d blind-epoch messages: predicted RMS %.2f\", held RMS %.2f\"\n",
              node.published.n, node.published.rms(), node_without.published.rms());
  ASSERT_GT(node.published.n, 1000);
  EXPECT_EQ(node.published.sources.size(), 1u);
  EXPECT_EQ(node.published.sources.at(2), node.published.n);  // 2: predicted
  EXPECT_EQ(node_without.published.sources.count(3) ? node_without.published.sources.at(3) : 0, node_without.published.n);  // 3: held
  EXPECT_LT(node.published.rms(), 0.2 * node_without.published.rms());
  EXPECT_NEAR(node.published.rms(), files.err.rms(), 0.5);  // the engine's figure over every blind epoch
}

// Seams: the orbit stops for 400 s inside the second blindness (a dropout of the orbit link). The
// prediction extrapolates the argument of latitude for at most max_orbit_age_s (60 s), then the pair is
// held, and it is predicted again as soon as the orbit comes back; the data still end inside the blind
// window. A GNI1B record inside the Earth is refused by the reader, not handed to the core.
TEST(OrbitThermal, AnOrbitDropoutHoldsThePairUntilTheOrbitComesBack) {
  const Data& d = data();
  const std::string cut = d.dir + "/orbit_dropout.lcmlog";
  {
    io::LcmLogReader r;
    io::LcmLogWriter w;
    std::string err;
    ASSERT_TRUE(r.open(d.lcm, &err)) << err;
    ASSERT_TRUE(w.open(cut, &err)) << err;
    io::LcmLogReader::RawEvent ev;
    while (r.nextRaw(ev)) {
      if (*ev.channel == io::kOrbitChannel) {
        io::OrbitSample o;
        ASSERT_TRUE(io::decodeOrbit(ev.data, ev.size, o));
        const double rel = toSeconds(o.utime) - kT0;
        if (rel >= 6300.0 && rel < 6700.0) continue;
      }
      ASSERT_TRUE(w.writeRaw(*ev.channel, 0, ev.data, ev.size));
    }
    ASSERT_TRUE(w.close(&err)) << err;
  }
  const NodeRun node = runNode(true, cut);
  EXPECT_EQ(node.c.orbit_steps, d.n_orbit - 80);  // 400 s at one per 5 s
  int held_in_gap = 0, n_in_gap = 0, predicted_out = 0, n_out = 0;
  double sigma_gap_first = 0, sigma_gap_last = 0;
  for (std::size_t i = 0; i < node.published.trail.size(); ++i) {
    const auto& [rel, src] = node.published.trail[i];
    // the last orbit sample before the dropout is at 6295 s
    if (rel >= 6295.0 + 60.0 + 1.0 && rel < 6700.0) {  // beyond the extrapolation limit, before the orbit is back
      if (n_in_gap == 0) sigma_gap_first = node.published.sigma_x[i];
      sigma_gap_last = node.published.sigma_x[i];
      ++n_in_gap;
      held_in_gap += src == 3 ? 1 : 0;
    } else if (rel < 6295.0 + 59.0 || rel >= 6700.0 + 1.0) {
      ++n_out;
      predicted_out += src == 2 ? 1 : 0;
    }
  }
  ASSERT_GT(n_in_gap, 150);
  EXPECT_EQ(held_in_gap, n_in_gap);
  // the held prediction's sigma grows with its age (0.023"/s by default over the ~340 s held)
  EXPECT_GT(sigma_gap_last, sigma_gap_first + 5.0);
  ASSERT_GT(n_out, 1500);
  EXPECT_EQ(predicted_out, n_out);
  // The reader's gate on a Level-1 orbit record: refused (implausible), counted, never a sample.
  auto gni = io::makeProduct<io::GnvRecord>(io::Product::GNI1B, 'C');
  io::GnvRecord g;
  g.t = static_cast<TimeUs>(kT0 * 1e6);
  g.coord_ref = 'I';
  g.pos[0] = 1.0e6;
  g.vel[1] = 7.6e3;
  gni.records.push_back(g);
  g.t += kUsPerSecond;
  g.pos[0] = 6.8e6;
  gni.records.push_back(g);
  std::string err;
  const std::string path = d.dir + "/GNI1B_bad.txt";
  ASSERT_TRUE(io::writeProduct(path, gni, &err)) << err;
  stream::OrbitFileSource src;
  ASSERT_TRUE(src.open(path, {}, &err)) << err;
  stream::Sample x;
  stream::Reject why = stream::Reject::kMalformed;
  EXPECT_EQ(src.next(x, why), stream::Source::Next::kRejected);
  EXPECT_EQ(why, stream::Reject::kImplausible);
  ASSERT_EQ(src.next(x, why), stream::Source::Next::kSample);
  EXPECT_EQ(x.kind, stream::Sample::Kind::kOrbit);
  EXPECT_EQ(x.r_orbit.x(), 6.8e6);
  EXPECT_EQ(src.next(x, why), stream::Source::Next::kEnd);
}

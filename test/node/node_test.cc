// The node (boresight::node) driven by simulated LCM logs, hardware-in-the-loop style: message types
// round trip, sequence gaps counted as lost, bad traffic accounted message by message, replays
// deterministic, outputs compared with a committed golden file by matching digits.
//
// Golden file: test/node/golden/replay_short.txt. Regenerate (after a change made on purpose) with
//   BORESIGHT_UPDATE_GOLDEN=1 ./build/test/node/node_test --gtest_filter='*Golden*'
#include <boresight/calib/problem.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/io/level1.h>
#include <boresight/model/rotation.h>
#include <boresight/node/node.h>
#include <boresight/stream/sources.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include "boresight_lcm/accel_sample_t.hpp"
#include "boresight_lcm/calibration_t.hpp"
#include "boresight_lcm/fused_attitude_t.hpp"
#include "boresight_lcm/node_command_t.hpp"
#include "boresight_lcm/node_health_t.hpp"
#include "boresight_lcm/nominal_mountings_t.hpp"
#include "boresight_lcm/orbit_sample_t.hpp"
#include "boresight_lcm/star_head_sample_t.hpp"
#include "boresight_lcm/star_vectors_t.hpp"

#include "test_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace boresight {
namespace {
using testutil::makeTempDir;

std::string src(const std::string& rel) { return std::string(BORESIGHT_SOURCE_DIR) + "/" + rel; }

struct Captured : node::Output {
  struct Msg {
    std::string ch;
    TimeUs t;
    std::vector<std::uint8_t> bytes;
  };
  std::vector<Msg> msgs;
  void publish(const std::string& ch, TimeUs t, const void* data, int size) override {
    const auto* p = static_cast<const std::uint8_t*>(data);
    msgs.push_back({ch, t, std::vector<std::uint8_t>(p, p + size)});
  }
  template <typename M>
  std::vector<M> all(const std::string& ch) const {
    std::vector<M> v;
    for (const auto& m : msgs)
      if (m.ch == ch) {
        M x;
        EXPECT_EQ(x.decode(m.bytes.data(), 0, static_cast<int>(m.bytes.size())), static_cast<int>(m.bytes.size()));
        v.push_back(x);
      }
    return v;
  }
};

/// A simulated log (GRACE-FO scenario) with the given effects.
std::string simulate(const std::string& name, double duration_s, const std::vector<std::string>& effects,
                     sim::SimStats* stats = nullptr, const std::string& scenario = "config/sim_gracefo.yaml",
                     std::array<Quat, 4>* q_true = nullptr, std::array<Quat, 4>* q_nominal = nullptr) {
  const std::string dir = makeTempDir("node_" + name);
  sim::Scenario sc;
  std::string err;
  EXPECT_TRUE(sim::loadScenario(src(scenario), sc, &err)) << err;
  EXPECT_TRUE(sim::addEffectArgs(sc, effects, &err)) << err;
  sim::Simulator s;
  EXPECT_TRUE(s.init(sc, 7, duration_s, &err)) << err;
  sim::LcmSink log;
  const std::string path = dir + "/sim.lcmlog";
  EXPECT_TRUE(log.open(path, &err)) << err;
  EXPECT_TRUE(log.writeMountings(s));
  s.run(log);
  EXPECT_TRUE(log.close(&err)) << err;
  if (stats) *stats = s.stats();
  for (std::size_t i = 0; i < s.heads().size() && i < 4; ++i) {
    const auto& h = s.heads()[i];
    // The constant truth: mounting error and the relative misalignment effect, both in the head frame.
    if (q_true) (*q_true)[i] = (model::quatExp(h.effects().misalignment_rad) * h.qSiBTrue()).normalized();
    if (q_nominal) (*q_nominal)[i] = h.config().q_Si_B;
  }
  return path;
}

node::NodeConfig nodeConfig(double cadence_s = 21600, double min_span_s = 10800) {
  node::NodeConfig cfg;
  std::string err;
  EXPECT_TRUE(node::loadNodeConfig(src("config/boresightd.yaml"), cfg, &err)) << err;
  cfg.calibration.cadence_s = cadence_s;
  cfg.calibration.min_span_s = min_span_s;
  return cfg;
}

/// Events of the log on one channel.
std::uint64_t eventsOn(const std::string& log, const std::string& channel) {
  io::LcmLogReader rd;
  std::string err;
  EXPECT_TRUE(rd.open(log, &err)) << err;
  io::LcmLogReader::RawEvent ev;
  std::uint64_t n = 0;
  while (rd.nextRaw(ev)) n += *ev.channel == channel ? 1 : 0;
  return n;
}

std::uint64_t noConsumer(const node::Counters& c) { return c.rejected[static_cast<std::size_t>(io::Reject::kNoConsumer)]; }

struct Replay {
  Captured out;
  node::Counters c;
  std::uint64_t events = 0;
};

std::unique_ptr<Replay> replay(const std::string& log, const node::NodeConfig& cfg) {
  auto r = std::make_unique<Replay>();
  node::Node n;
  std::string err;
  EXPECT_TRUE(n.configure(cfg, node::Node::Mode::kReplay, &r->out, &err)) << err;
  EXPECT_TRUE(node::replayLog(n, log, &err)) << err;
  r->c = n.counters();
  EXPECT_EQ(r->c.outputs_failed, 0u) << "every output message encoded";
  io::LcmLogReader rd;
  EXPECT_TRUE(rd.open(log, &err));
  io::LcmLogReader::RawEvent ev;
  while (rd.nextRaw(ev)) ++r->events;
  return r;
}

std::uint64_t rejected(const node::Counters& c, io::Reject r) { return c.rejected[static_cast<std::size_t>(r)]; }

// ---- 1. message types -------------------------------------------------------------------------

TEST(NodeLcmTypes, MountingsAndOrbitRoundTripThroughALog) {
  const std::string path = makeTempDir("node_types") + "/t.lcm";
  io::LcmLogWriter w;
  std::string err;
  ASSERT_TRUE(w.open(path, &err)) << err;
  io::NominalMountings m;
  m.utime = 123456789;
  m.n_heads = 3;
  for (int i = 0; i < 3; ++i) {
    m.head_id[i] = i + 1;
    const Quat q = Quat(Eigen::AngleAxisd(0.3 * (i + 1), Vec3(1, 2, 3).normalized()));
    m.q_Si_B[i][0] = q.w(), m.q_Si_B[i][1] = q.x(), m.q_Si_B[i][2] = q.y(), m.q_Si_B[i][3] = q.z();
  }
  m.C_B_A[0][1] = 1, m.C_B_A[1][0] = -1, m.C_B_A[2][2] = 1;
  m.source = 1;
  io::OrbitSample o;
  o.utime = 987654321;
  o.frame = 'E';
  o.r_m[0] = 6.8e6, o.v_m_s[2] = 7.6e3;
  o.seq = 41;
  io::NominalMountings bad = m;
  bad.n_heads = 5;
  EXPECT_FALSE(w.write(bad));  // refused, not truncated
  ASSERT_TRUE(w.write(m));
  ASSERT_TRUE(w.write(o));
  w.close();
  io::LcmLogReader r;
  ASSERT_TRUE(r.open(path, &err)) << err;
  io::LcmLogReader::RawEvent ev;
  ASSERT_TRUE(r.nextRaw(ev));
  EXPECT_EQ(*ev.channel, io::kMountingsChannel);
  io::NominalMountings m2;
  ASSERT_TRUE(io::decodeNominalMountings(ev.data, ev.size, m2));
  EXPECT_EQ(m2.utime, m.utime);
  EXPECT_EQ(m2.n_heads, 3);
  EXPECT_EQ(m2.source, 1);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(m2.head_id[i], i + 1);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(m2.q_Si_B[i][k], m.q_Si_B[i][k]);
  }
  EXPECT_EQ(m2.C_B_A[1][0], -1);
  EXPECT_FALSE(io::decodeOrbit(ev.data, ev.size, o));  // another type's bytes: refused
  ASSERT_TRUE(r.nextRaw(ev));
  EXPECT_EQ(*ev.channel, io::kOrbitChannel);
  io::OrbitSample o2;
  ASSERT_TRUE(io::decodeOrbit(ev.data, ev.size, o2));
  EXPECT_EQ(o2.utime, o.utime);
  EXPECT_EQ(o2.frame, 'E');
  EXPECT_EQ(o2.r_m[0], 6.8e6);
  EXPECT_EQ(o2.v_m_s[2], 7.6e3);
  EXPECT_EQ(o2.seq, 41);
  EXPECT_FALSE(r.nextRaw(ev));
}

// Sequence numbers count what the sender sent: samples lost to the `gaps` effect consume numbers
// (the node's lost counter sees each), a blinded head sends nothing and consumes none (not lost).
TEST(NodeReplay, SimulatedGapsAreLostBlindingIsNot) {
  sim::SimStats st;
  const std::string log = simulate("gaps", 1800, {"gaps:sensor=2,at_s=300,duration_s=30", "gaps:sensor=acc,at_s=900,duration_s=7"}, &st);
  std::uint64_t missing = st.acc_missing, blinded = 0;
  for (auto v : st.head_missing) missing += v;
  for (std::size_t i = 0; i < st.head_blinded_sun.size(); ++i)
    blinded += st.head_blinded_sun[i] + st.head_blinded_earth[i] + st.head_blinded_moon[i];
  ASSERT_EQ(st.head_missing[1], 60u);  // 30 s at 2 Hz
  ASSERT_EQ(st.acc_missing, 70u);      // 7 s at 10 Hz
  auto r = replay(log, nodeConfig());
  EXPECT_EQ(r->c.lost, missing) << "blinded samples in this run: " << blinded;
  EXPECT_EQ(r->c.received, r->events);
  EXPECT_EQ(r->c.received, r->c.used + r->c.rejectedTotal());
  // Nothing rejected but the orbit, which nothing here reads (no thermal terms): used means consumed.
  EXPECT_GT(eventsOn(log, "ORBIT"), 0u);
  EXPECT_EQ(noConsumer(r->c), eventsOn(log, "ORBIT"));
  EXPECT_EQ(r->c.rejectedTotal(), noConsumer(r->c));
  // The NOMINAL_MOUNTINGS message configured the core: every epoch was stepped and published.
  EXPECT_GT(r->c.head_epochs, 3500u);
  EXPECT_EQ(r->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE").size(), r->c.rows);
  EXPECT_GT(r->c.rows, 1700u);
}

#ifdef BORESIGHT_CLI
// `boresight convert` puts the QSA1B mountings and the GNV1B orbit into the log: the node replays the
// converted log with nothing but its configuration (mountings: log).
TEST(NodeReplay, ConvertedLevel1LogCarriesMountingsAndOrbit) {
  const std::string dir = makeTempDir("node_convert");
  auto sim = testutil::runProgram(BORESIGHT_CLI, "simulate --scenario " + src("config/sim_gracefo.yaml") +
                                                     " --seed 3 --duration 600 --quiet --no-lcm --out " + dir);
  ASSERT_EQ(sim.status, 0) << sim.out;
  const std::string l1 = dir + "/SCA1A_2023-06-01_C_04.txt " + dir + "/ACC1A_2023-06-01_C_04.txt " + dir +
                         "/QSA1B_2023-06-01_C_04.txt " + dir + "/GNV1B_2023-06-01_C_04.txt";
  auto conv = testutil::runProgram(BORESIGHT_CLI, "convert " + l1 + " --out " + dir + "/conv.lcm");
  ASSERT_EQ(conv.status, 0) << conv.out;
  EXPECT_NE(conv.out.find("NOMINAL_MOUNTINGS of 3 heads from QSA1B"), std::string::npos) << conv.out;
  const auto qsa = io::readProduct<io::QsaRecord>(dir + "/QSA1B_2023-06-01_C_04.txt");
  const auto gnv = io::readProduct<io::GnvRecord>(dir + "/GNV1B_2023-06-01_C_04.txt");
  ASSERT_TRUE(qsa.ok && gnv.ok);
  io::LcmLogReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir + "/conv.lcm", &err)) << err;
  io::LcmLogReader::RawEvent ev;
  ASSERT_TRUE(r.nextRaw(ev));
  ASSERT_EQ(*ev.channel, io::kMountingsChannel);  // first, before any sample
  io::NominalMountings m;
  ASSERT_TRUE(io::decodeNominalMountings(ev.data, ev.size, m));
  ASSERT_EQ(m.n_heads, 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(m.head_id[i], qsa.records[static_cast<std::size_t>(i)].sensor);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(m.q_Si_B[i][k], qsa.records[static_cast<std::size_t>(i)].q[k]);
  }
  std::size_t orbit = 0;
  TimeUs last_t = 0;
  while (r.nextRaw(ev)) {
    if (*ev.channel != io::kOrbitChannel) continue;
    io::OrbitSample o;
    ASSERT_TRUE(io::decodeOrbit(ev.data, ev.size, o));
    EXPECT_EQ(o.utime, gnv.records[orbit].t);
    EXPECT_EQ(o.r_m[0], gnv.records[orbit].pos[0]);
    EXPECT_EQ(o.seq, static_cast<std::int32_t>(orbit));
    EXPECT_GE(o.utime, last_t);
    last_t = o.utime;
    ++orbit;
  }
  EXPECT_EQ(orbit, gnv.records.size());
  const auto rep = replay(dir + "/conv.lcm", nodeConfig());
  EXPECT_EQ(rep->c.received, rep->events);
  // Every message used but the orbit (no thermal terms in this configuration: nothing reads it).
  EXPECT_EQ(noConsumer(rep->c), orbit);
  EXPECT_EQ(rep->c.used + orbit, rep->c.received);
  EXPECT_EQ(rep->c.lost, 0u);
  EXPECT_GT(rep->c.rows, 550u);
}
#endif

// ---- bad traffic ------------------------------------------------------------------------------

/// Copies a log event by event with bad traffic injected; counts what was injected.
struct Injected {
  int garbage = 0, wrong_type = 0, nan = 0, duplicate = 0, late = 0, future = 0, flood = 0, unknown_head = 0,
      other = 0, swapped = 0, vanished = 0;
};

std::string badLog(const std::string& clean, Injected& inj) {
  const std::string path = makeTempDir("node_bad") + "/bad.lcm";
  io::LcmLogReader r;
  io::LcmLogWriter w;
  std::string err;
  EXPECT_TRUE(r.open(clean, &err)) << err;
  EXPECT_TRUE(w.open(path, &err)) << err;
  io::LcmLogReader::RawEvent ev;
  int n_head = 0, n_acc = 0;
  std::vector<std::uint8_t> held;  // an accelerometer message held back (out of order within the look-ahead)
  TimeUs held_t = 0;
  std::vector<std::uint8_t> buf(4096);
  auto writeMsg = [&](const std::string& ch, TimeUs t, const auto& m) {
    const int n = m.getEncodedSize();
    m.encode(buf.data(), 0, n);
    w.writeRaw(ch, t, buf.data(), n);
  };
  TimeUs vanish_from = 0;
  while (r.nextRaw(ev)) {
    const std::string ch = *ev.channel;
    if (ch == "STAR_HEAD") {
      boresight_lcm::star_head_sample_t m;
      m.decode(ev.data, 0, ev.size);
      ++n_head;
      if (vanish_from == 0 && n_head == 3000) vanish_from = m.utime;
      if (vanish_from != 0 && m.head_id == 3) {  // head 3 vanishes for good
        ++inj.vanished;
        continue;
      }
      w.writeRaw(ch, m.utime, ev.data, ev.size);
      if (n_head % 500 == 10) {  // the same message twice
        w.writeRaw(ch, m.utime, ev.data, ev.size);
        ++inj.duplicate;
      }
      if (n_head % 500 == 20) {  // NaN quaternion
        auto b = m;
        b.utime += 1000;
        b.q[2] = std::nan("");
        writeMsg(ch, b.utime, b);
        ++inj.nan;
      }
      if (n_head % 500 == 30) {  // a tag years ahead (one corrupt time tag)
        auto b = m;
        b.utime += 5LL * 365 * 86400 * kUsPerSecond;
        b.seq += 0;  // same counter: a repeat for the sequence check
        writeMsg(ch, m.utime, b);
        ++inj.future;
      }
      if (n_head % 500 == 40) {  // undecodable bytes and a wrong type (an accel message) on STAR_HEAD
        const char junk[7] = {1, 2, 3, 4, 5, 6, 7};
        w.writeRaw(ch, m.utime, junk, 7);
        ++inj.garbage;
        boresight_lcm::accel_sample_t a{};
        a.utime = m.utime;
        writeMsg(ch, m.utime, a);
        ++inj.wrong_type;
      }
      if (n_head % 500 == 50) {  // a head the configuration does not know
        auto b = m;
        b.head_id = 9;
        writeMsg(ch, m.utime, b);
        ++inj.unknown_head;
      }
      if (n_head % 500 == 60) {  // a message 20 s old: beyond the look-ahead
        auto b = m;
        b.utime -= 20 * kUsPerSecond;
        writeMsg(ch, m.utime, b);
        ++inj.late;
      }
      continue;
    }
    if (ch == "ACCEL") {
      boresight_lcm::accel_sample_t m;
      m.decode(ev.data, 0, ev.size);
      ++n_acc;
      if (n_acc % 1000 == 5) {  // hold one back: it arrives after the next (sorted back in: used)
        held.assign(static_cast<const std::uint8_t*>(ev.data), static_cast<const std::uint8_t*>(ev.data) + ev.size);
        held_t = m.utime;
        ++inj.swapped;
        continue;
      }
      w.writeRaw(ch, m.utime, ev.data, ev.size);
      if (!held.empty()) {
        w.writeRaw(ch, held_t, held.data(), static_cast<int>(held.size()));
        held.clear();
      }
      if (n_acc == 7000) {  // a flooding accelerometer: 100 more messages inside one data second
        for (int k = 1; k <= 100; ++k) {
          auto b = m;
          b.utime += k * 500;  // 0.5 ms apart
          b.seq = m.seq;       // no new sequence numbers (a babbling sender)
          writeMsg(ch, b.utime, b);
        }
        inj.flood += 100;
      }
      continue;
    }
    w.writeRaw(ch, 0, ev.data, ev.size);
  }
  for (int k = 0; k < 25; ++k) {  // traffic on a channel the node does not read
    const char x[3] = {9, 9, 9};
    w.writeRaw("SOMEONE_ELSE", 0, x, 3);
    ++inj.other;
  }
  w.close();
  return path;
}

/// Content faults of every input type, one per kind of fault, injected after every 200th message of a
/// clean log at tags of their own; `faults[reason]` counts them by the node reason they must get.
std::string contentFaultLog(const std::string& clean, std::map<io::Reject, std::uint64_t>& faults,
                            std::uint64_t& good_stars) {
  const std::string path = makeTempDir("node_content") + "/content.lcm";
  io::LcmLogReader r;
  io::LcmLogWriter w;
  std::string err;
  EXPECT_TRUE(r.open(clean, &err)) << err;
  EXPECT_TRUE(w.open(path, &err)) << err;
  std::vector<std::uint8_t> buf(8192);
  auto put = [&](const std::string& ch, TimeUs t, const auto& m) {
    const int n = m.getEncodedSize();
    m.encode(buf.data(), 0, n);
    w.writeRaw(ch, t, buf.data(), n);
  };
  auto stars = [](TimeUs t) {
    boresight_lcm::star_vectors_t v{};
    v.utime = t;
    v.head_id = 1;
    v.n_stars = 3;
    v.flags = 1;
    for (int i = 0; i < 3; ++i) {
      v.s_head[i][0] = 0.01 * i;
      v.s_head[i][2] = std::sqrt(1 - 1e-4 * i * i);
      v.r_inertial[i][1] = 1;
      v.sigma_rad[i] = 0;
    }
    return v;
  };
  io::LcmLogReader::RawEvent ev;
  std::uint64_t n = 0;
  TimeUs last = 0;
  while (r.nextRaw(ev)) {
    w.writeRaw(*ev.channel, 0, ev.data, ev.size);
    if (*ev.channel == "STAR_HEAD") {
      boresight_lcm::star_head_sample_t m;
      m.decode(ev.data, 0, ev.size);
      last = m.utime;
    }
    if (++n % 200 != 0 || last == 0) continue;
    const TimeUs t = last + 1000;  // 1 ms after the last head epoch: a tag of its own
    boresight_lcm::star_head_sample_t h{};
    h.utime = t;
    h.head_id = 1;
    h.q[0] = 1;
    h.flags = 1;
    auto head = [&](auto edit, io::Reject why) {
      auto b = h;
      edit(b);
      put("STAR_HEAD", t, b);
      ++faults[why];
    };
    head([](auto& b) { b.flags = 0; }, io::Reject::kInvalidFlag);
    head([](auto& b) { b.q[0] = 0; }, io::Reject::kNonUnit);  // zeros: no rotation
    head([](auto& b) { b.q[0] = 1.01; }, io::Reject::kNonUnit);
    head([](auto& b) { b.q[3] = INFINITY; }, io::Reject::kNonFinite);
    boresight_lcm::accel_sample_t a{};
    a.utime = t;
    a.flags = 3;
    auto acc = [&](auto edit, io::Reject why) {
      auto b = a;
      edit(b);
      put("ACCEL", t, b);
      ++faults[why];
    };
    acc([](auto& b) { b.flags = 2; }, io::Reject::kInvalidFlag);  // linear only
    acc([](auto& b) { b.ang_accel[1] = NAN; }, io::Reject::kNonFinite);
    acc([](auto& b) { b.ang_accel[2] = 0.5; }, io::Reject::kImplausible);
    auto star = [&](auto edit, io::Reject why) {
      auto b = stars(t);
      edit(b);
      put("STAR_VECTORS", t, b);
      ++faults[why];
    };
    star([](auto& b) { b.flags = 0; }, io::Reject::kInvalidFlag);
    star([](auto& b) { b.n_stars = 0; }, io::Reject::kInvalidFlag);
    star([](auto& b) { b.sigma_rad[2] = -1e-5f; }, io::Reject::kImplausible);  // one star of three
    star([](auto& b) { b.s_head[1][0] = 0.1; }, io::Reject::kNonUnit);
    star([](auto& b) { b.r_inertial[0][2] = NAN; }, io::Reject::kNonFinite);
    boresight_lcm::orbit_sample_t o{};
    o.utime = t;
    o.frame = 'I';
    o.r_m[0] = 1.0e6;  // inside the Earth
    o.v_m_s[1] = 7.6e3;
    put("ORBIT", t, o);
    ++faults[io::Reject::kImplausible];
    o.r_m[0] = 6.8e6;
    o.v_m_s[1] = NAN;
    put("ORBIT", t, o);
    ++faults[io::Reject::kNonFinite];
    put("STAR_VECTORS", t + 1, stars(t + 1));  // and one good star message
    ++good_stars;
  }
  w.close();
  return path;
}

// One decoder and one rule (io::decodeInput, io::checkInput) for the node and the replay: every
// message with a content fault gets the same verdict from both, under the same reason (io::Reject). Before, the node took a star-vector message with a negative sigma, and the
// replay dropped only the bad star of a message the node refused whole.
TEST(NodeBadInput, TheNodeAndTheReplayJudgeEveryInputMessageByOneRule) {
  const std::string clean = simulate("content", 600, {});
  std::map<io::Reject, std::uint64_t> faults;
  std::uint64_t good_stars = 0;
  const std::string log = contentFaultLog(clean, faults, good_stars);
  ASSERT_GT(good_stars, 20u);
  const auto ref = replay(clean, nodeConfig());
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  std::uint64_t n_faults = 0;
  for (const auto& [why, n] : faults) {
    EXPECT_EQ(rejected(c, why), rejected(ref->c, why) + n) << io::rejectKey(why);
    n_faults += n;
  }
  EXPECT_EQ(c.used, ref->c.used + good_stars);  // the good star messages, nothing else
  EXPECT_EQ(c.rejectedTotal(), ref->c.rejectedTotal() + n_faults);
  // The replay's source reads the same log: the same messages refused, in its reasons.
  auto readAll = [](const std::string& path) {
    stream::LcmLogSource src;
    std::string err;
    EXPECT_TRUE(src.open(path, &err)) << err;
    stream::Counters sc;
    stream::Sample x;
    stream::Reject why = stream::Reject::kMalformed;
    for (;;) {
      const auto nx = src.next(x, why);
      if (nx == stream::Source::Next::kEnd || nx == stream::Source::Next::kError) break;
      if (nx == stream::Source::Next::kRejected) ++sc.rejected[static_cast<std::size_t>(why)];
      if (nx == stream::Source::Next::kSample && x.kind == stream::Sample::Kind::kStar) ++sc.used_stars;
    }
    return sc;
  };
  const stream::Counters sc_ref = readAll(clean), sc = readAll(log);
  EXPECT_EQ(sc.used_stars, sc_ref.used_stars + 3 * good_stars);  // a message with one bad star gives none of its stars
  auto rej = [&](stream::Reject k) {
    return sc.rejected[static_cast<std::size_t>(k)] - sc_ref.rejected[static_cast<std::size_t>(k)];
  };
  // The same reasons (io::Reject, one list): per reason the injected count, nothing else refused.
  std::uint64_t n_replay = 0;
  for (int k = 0; k < io::kRejectCount; ++k) {
    const auto why = static_cast<io::Reject>(k);
    const auto it = faults.find(why);
    EXPECT_EQ(rej(why), it == faults.end() ? 0u : it->second) << io::rejectKey(why);
    n_replay += rej(why);
  }
  EXPECT_EQ(n_replay, n_faults);
  EXPECT_GE(faults.size(), 4u);  // invalid_flag, non_finite, non_unit, implausible
}

TEST(NodeReplay, BadTrafficIsAccountedMessageByMessage) {
  const std::string clean = simulate("clean", 2400, {});
  Injected inj;
  const std::string bad = badLog(clean, inj);
  const auto ref = replay(clean, nodeConfig());
  const auto r = replay(bad, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.received, r->events);
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_EQ(rejected(c, io::Reject::kMalformed), static_cast<std::uint64_t>(inj.garbage + inj.wrong_type));
  EXPECT_EQ(rejected(c, io::Reject::kNonFinite), static_cast<std::uint64_t>(inj.nan));
  EXPECT_EQ(rejected(c, io::Reject::kDuplicate), static_cast<std::uint64_t>(inj.duplicate));
  EXPECT_EQ(rejected(c, io::Reject::kTimeJump), static_cast<std::uint64_t>(inj.future));
  EXPECT_EQ(rejected(c, io::Reject::kLate), static_cast<std::uint64_t>(inj.late));
  EXPECT_EQ(rejected(c, io::Reject::kUnknownHead), static_cast<std::uint64_t>(inj.unknown_head));
  EXPECT_EQ(rejected(c, io::Reject::kOtherChannel), static_cast<std::uint64_t>(inj.other));
  EXPECT_EQ(rejected(c, io::Reject::kAssembler), 0u);
  // The flood: at most max_rate_hz.accel messages of that data second pass, the rest are refused.
  EXPECT_GE(rejected(c, io::Reject::kFlood), static_cast<std::uint64_t>(inj.flood) - 40u);
  EXPECT_LE(rejected(c, io::Reject::kFlood), static_cast<std::uint64_t>(inj.flood) + 10u);  // + that second's own
  EXPECT_EQ(c.time_resyncs, 0u);
  ASSERT_GT(inj.future, 5);
  ASSERT_GT(inj.swapped, 5);
  ASSERT_GT(inj.vanished, 500);
  // Every head epoch of the clean run is still stepped (the swapped and corrupt messages cost none):
  // the corrupt tags did not turn the rest of the log into late messages.
  EXPECT_GE(c.head_epochs, ref->c.head_epochs * 99 / 100);
  EXPECT_GE(c.rows, ref->c.rows * 99 / 100);
  // A vanished head is no loss (nothing was sent) and the fusion goes on with two heads.
  EXPECT_EQ(c.lost, 0u);
  const auto att = r->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  ASSERT_FALSE(att.empty());
  EXPECT_LE(att.back().heads_used, 2);
  EXPECT_GE(att.back().heads_used, 1);
  // The final health message carries the same counters.
  const auto health = r->out.all<boresight_lcm::node_health_t>("BORESIGHT_HEALTH");
  ASSERT_FALSE(health.empty());
  EXPECT_EQ(health.back().received, static_cast<int64_t>(c.received));
  EXPECT_EQ(health.back().used, static_cast<int64_t>(c.used));
  EXPECT_EQ(health.back().rejected[static_cast<int>(io::Reject::kTimeJump)], inj.future);
}

// ---- determinism and golden output --------------------------------------------------------------

TEST(NodeReplay, TwoReplaysPublishIdenticalPayloadsWithTheWorkerInLockstep) {
  std::array<Quat, 4> q_true{}, q_nom{};
  const std::string log = simulate("det", 15000, {"relative_misalignment:sensor=2,x_arcsec=20,y_arcsec=-10"}, nullptr,
                                   "config/sim_gracefo_calibration.yaml", &q_true, &q_nom);
  auto cfg = nodeConfig(3600, 7200);
  cfg.ring_capacity = 1u << 16;  // a ring that never fills: lockstep alone must make the runs agree
  cfg.calibration.apply_lag_epochs = 20;
  const auto a = replay(log, cfg);
  const auto b = replay(log, cfg);
  ASSERT_EQ(a->out.msgs.size(), b->out.msgs.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a->out.msgs.size(); ++i)
    differ += a->out.msgs[i].ch != b->out.msgs[i].ch || a->out.msgs[i].t != b->out.msgs[i].t ||
              a->out.msgs[i].bytes != b->out.msgs[i].bytes;
  EXPECT_EQ(differ, 0u);
  for (std::size_t i = 0, shown = 0; i < a->out.msgs.size() && shown < 3; ++i)
    if (a->out.msgs[i].bytes != b->out.msgs[i].bytes) {
      ADD_FAILURE() << "message " << i << " on " << a->out.msgs[i].ch << " differs";
      ++shown;
    }
  const auto cal = a->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cal.size(), 3u);  // started after 2 h, 3 h and 4 h of data (the last applied at the end)
  EXPECT_EQ(a->c.calibrations_published, 3u);
  // The worker's cost is counted per solve: the largest span is the last one's epochs.
  EXPECT_EQ(a->c.solves, 3u);
  EXPECT_GT(a->c.solve_cpu_s_max, 0.0);
  EXPECT_GE(a->c.solve_cpu_s_sum, a->c.solve_cpu_s_max);
  EXPECT_GE(a->c.solve_observations_max, static_cast<std::uint64_t>(cal.back().epochs));
  EXPECT_EQ(a->c.solve_observation_bytes_max, a->c.solve_observations_max * sizeof(calib::Observation));
  EXPECT_LT(cal[0].span_end_utime, cal[1].span_end_utime);
  // The last calibration (manoeuvres about all three axes) against the truth: the relative attitude of
  // heads 1 and 2 (what is handed back to the core) within its uncertainty.
  const auto& k = cal.back();
  ASSERT_EQ(k.status, 0);
  EXPECT_EQ(k.applied, 1);
  auto est = [&](int h) {
    return (model::quatExp(Vec3(k.error_angles_arcsec[h][0], k.error_angles_arcsec[h][1], k.error_angles_arcsec[h][2]) *
                           kRadPerArcsec) * q_nom[static_cast<std::size_t>(h)]).normalized();
  };
  const Quat rel_est = est(1) * est(0).conjugate(), rel_true = q_true[1] * q_true[0].conjugate();
  const double err_arcsec = model::quatLog(rel_est.conjugate() * rel_true).norm() * kArcsecPerRad;
  const double rel_nominal_arcsec = model::quatLog((q_nom[1] * q_nom[0].conjugate()).conjugate() * rel_true).norm() * kArcsecPerRad;
  double sig = 0;
  for (int h = 0; h < 2; ++h)
    for (int ax = 0; ax < 3; ++ax) sig += k.sigma_arcsec[h][ax] * k.sigma_arcsec[h][ax];
  std::printf("relative attitude heads 1-2: error %.2f arcsec (nominal was %.2f off), sigma scale %.2f arcsec\n", err_arcsec,
              rel_nominal_arcsec, std::sqrt(sig));
  EXPECT_GT(rel_nominal_arcsec, 50.0);
  // The pair means are good to ~1"; the scenario's thermal_periodic effect on head 2 (4, -3, 10" once
  // per orbit) does not average out over 4 h, so the constant truth is known only to its amplitude, 11".
  EXPECT_LT(err_arcsec, 12.0);
  // Handing the mountings back keeps the datum: the published attitude does not jump where the
  // mounting version changes. The second difference of consecutive rows is the manoeuvre's angular
  // acceleration (up to 14" per s^2) plus the fused attitude's noise (~10"); a common rotation
  // handed back with the relative part would be hundreds of arc seconds (the calibration's common
  // part is undetermined at that level here).
  const auto att = a->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  auto quat = [](const boresight_lcm::fused_attitude_t& x) { return Quat(x.q_I_B[0], x.q_I_B[1], x.q_I_B[2], x.q_I_B[3]); };
  int changes = 0;
  for (std::size_t i = 2; i < att.size(); ++i) {
    if (att[i].mounting_version == att[i - 1].mounting_version) continue;
    ++changes;
    const Vec3 d1 = model::quatLog(quat(att[i - 2]).conjugate() * quat(att[i - 1]));
    const Vec3 d2 = model::quatLog(quat(att[i - 1]).conjugate() * quat(att[i]));
    EXPECT_LT((d2 - d1).norm() * kArcsecPerRad, 60.0) << "attitude jump at " << att[i].utime;
  }
  EXPECT_EQ(changes, 3);  // solves at 2 h, 3 h and 4 h, each applied 20 epochs (10 s) later
  for (const auto& c : cal)
    std::printf("calibration at %lld: status %d applied %d epochs %d head 2 x %.2f +- %.2f arcsec, y %.2f +- %.2f\n",
                static_cast<long long>(c.utime), c.status, c.applied, c.epochs, c.error_angles_arcsec[1][0],
                c.sigma_arcsec[1][0], c.error_angles_arcsec[1][1], c.sigma_arcsec[1][1]);
}

// ---- the frame change (calibration.apply_common_rotation) -----------------------------------------

/// The simulator's true body attitude per head-sample tag (head 1), for comparing published attitudes.
struct TruthSink : sim::SimSink {
  std::map<TimeUs, Quat> q_I_B;
  void head(const sim::HeadSampleOut& s) override {
    if (s.head == 1) q_I_B[s.tag] = s.q_I_B;
  }
};

struct FrameRun {
  std::unique_ptr<Replay> r;
  std::string err_out;
  std::uint64_t frame_changes = 0;
};

TEST(NodeReplay, CommonRotationIsAppliedOnlyWhenConfiguredAsOneLoggedFrameChange) {
  // 20 min with 5 deg manoeuvres about each axis: one calibration (started at 840 s of data, applied
  // 20 head epochs later) determines the common rotation to tens of arc seconds.
  const std::string dir = makeTempDir("node_frame");
  sim::Scenario sc;
  std::string err;
  ASSERT_TRUE(sim::loadScenario(src("config/sim_gracefo_node_demo.yaml"), sc, &err)) << err;
  sim::Simulator s;
  ASSERT_TRUE(s.init(sc, 11, 1200, &err)) << err;
  sim::LcmSink log;
  TruthSink truth;
  sim::TeeSink tee;
  tee.add(&log);
  tee.add(&truth);
  const std::string path = dir + "/sim.lcmlog";
  ASSERT_TRUE(log.open(path, &err)) << err;
  ASSERT_TRUE(log.writeMountings(s));
  s.run(tee);
  ASSERT_TRUE(log.close(&err)) << err;
  // The accelerometer datum B': the frame the configured C_B_A puts A into; the simulator's
  // acc_misalignment (~0.2 deg) rotates the true A, so C_B_B' = C_A_B_true^T C_A_B_nominal.
  const Mat3 C_B_Bp = s.accel().C_A_B_true().transpose() * s.accel().config().C_A_B;
  const Quat q_B_Bp(C_B_Bp);
  std::printf("accelerometer datum vs true body: %.1f arcsec\n", model::quatLog(q_B_Bp).norm() * kArcsecPerRad);

  auto run = [&](bool apply_common) {
    FrameRun f;
    auto cfg = nodeConfig(3600, 840);
    cfg.calibration.apply_lag_epochs = 20;
    cfg.calibration.apply_common_rotation = apply_common;
    testing::internal::CaptureStderr();
    f.r = replay(path, cfg);
    f.err_out = testing::internal::GetCapturedStderr();
    f.frame_changes = f.r->c.frame_changes;
    return f;
  };
  const FrameRun off = run(false), on = run(true);

  // Mean small-angle difference (in B') of the published attitude from the truth in B', before and
  // after the calibration is applied (the last 200 s before it; everything after it).
  struct Means {
    Vec3 before = Vec3::Zero(), after = Vec3::Zero();
    int n_before = 0, n_after = 0;
  };
  auto means = [&](const FrameRun& f) {
    Means m;
    const auto att = f.r->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
    TimeUs change = 0;
    for (std::size_t i = 1; i < att.size() && change == 0; ++i)
      if (att[i].mounting_version != att[i - 1].mounting_version) change = att[i].utime;
    EXPECT_NE(change, 0) << "no calibration applied";
    for (const auto& a : att) {
      const auto it = truth.q_I_B.find(a.utime);
      if (it == truth.q_I_B.end() || a.heads_used < 2) continue;
      const Quat q_true = (it->second * q_B_Bp).normalized();
      const Vec3 d = model::quatLog(q_true.conjugate() * Quat(a.q_I_B[0], a.q_I_B[1], a.q_I_B[2], a.q_I_B[3])) * kArcsecPerRad;
      if (a.utime < change && a.utime >= change - 200 * kUsPerSecond) {
        m.before += d;
        ++m.n_before;
      } else if (a.utime >= change) {
        m.after += d;
        ++m.n_after;
      }
    }
    EXPECT_GE(m.n_before, 100);
    EXPECT_GE(m.n_after, 100);
    m.before /= std::max(1, m.n_before);
    m.after /= std::max(1, m.n_after);
    return m;
  };
  const Means mo = means(off), mn = means(on);
  const auto cal = on.r->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cal.size(), 1u);
  ASSERT_EQ(cal[0].status, 0);
  ASSERT_EQ(cal[0].applied, 1);
  // The calibration's uncertainty of the common rotation: the largest per-axis sigma of any head
  // (the common part is a weighted mean of the heads' errors, so no worse than the worst head).
  double sig = 0;
  for (int h = 0; h < cal[0].n_heads; ++h)
    for (int ax = 0; ax < 3; ++ax) sig = std::max(sig, cal[0].sigma_arcsec[h][ax]);
  const Vec3 common(cal[0].common_rotation_B_arcsec[0], cal[0].common_rotation_B_arcsec[1], cal[0].common_rotation_B_arcsec[2]);
  std::printf("off: before (%.1f %.1f %.1f) after (%.1f %.1f %.1f) arcsec\n", mo.before[0], mo.before[1], mo.before[2],
              mo.after[0], mo.after[1], mo.after[2]);
  std::printf("on:  before (%.1f %.1f %.1f) after (%.1f %.1f %.1f) arcsec; common (%.1f %.1f %.1f), max sigma %.1f\n",
              mn.before[0], mn.before[1], mn.before[2], mn.after[0], mn.after[1], mn.after[2], common[0], common[1],
              common[2], sig);
  // Before the calibration both runs publish the same frame, far (the common rotation) from B'.
  EXPECT_LT((mo.before - mn.before).norm(), 1e-6);
  EXPECT_GT(mo.before.norm(), 300.0);
  // Off: the published attitude keeps its frame across the hand-over (the datum keeps the relative
  // part only); its offset from B' stays, and the frame rotation stays the identity.
  EXPECT_LT((mo.after - mo.before).norm(), 3 * sig + 10.0);
  EXPECT_GT(mo.after.norm(), 300.0);
  EXPECT_EQ(off.frame_changes, 0u);
  EXPECT_EQ(off.err_out.find("frame change"), std::string::npos);
  // On: the published attitude after the change is the off run's rotated by exactly the published
  // common rotation (to second order in the 0.2 deg: well under 2")...
  EXPECT_LT((mo.after - mn.after - common).norm(), 2.0);
  // ... and it is the truth in B' within the calibration's uncertainty: every axis within 3 sigma of
  // the worst-determined head axis (the common rotation is a weighted mean of the heads' errors, which
  // the shared accelerometer datum makes strongly correlated), where it was ~770" off before.
  for (int ax = 0; ax < 3; ++ax) EXPECT_LT(std::abs(mn.after[ax]), 3 * sig) << "axis " << ax;
  // Reported once: one counted change, one stderr line.
  EXPECT_EQ(on.frame_changes, 1u);
  EXPECT_NE(on.err_out.find("boresightd: frame change 1:"), std::string::npos) << on.err_out;
  EXPECT_EQ(on.err_out.find("frame change 2"), std::string::npos) << on.err_out;
  // The published calibration itself does not depend on the switch (only the published attitude does).
  const auto cal_off = off.r->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cal_off.size(), 1u);
  EXPECT_EQ(cal_off[0].error_angles_arcsec[0][0], cal[0].error_angles_arcsec[0][0]);
}

#ifdef BORESIGHTD
// The command line the demo uses: replay, record, summary JSON with the last calibration, CSV.
TEST(NodeReplay, AFrameChangeNeedsEveryCommonAxisDeterminedAndIsRateLimited) {
  // The demo's manoeuvres: about x from 60 s, y from 300 s, z from 540 s (5 deg, 40 s period).
  const std::string path = simulate("frame_gate", 1200, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  auto run = [&](double cadence_s, double min_span_s, double min_interval_s) {
    auto cfg = nodeConfig(cadence_s, min_span_s);
    cfg.calibration.apply_lag_epochs = 20;
    cfg.calibration.apply_common_rotation = true;
    cfg.calibration.frame_change_min_interval_s = min_interval_s;
    testing::internal::CaptureStderr();
    FrameRun f;
    f.r = replay(path, cfg);
    f.err_out = testing::internal::GetCapturedStderr();
    return f;
  };
  // Solves every 120 s from 840 s: each applied; one frame change, the others too soon after it.
  const FrameRun limited = run(120, 840, 3600);
  const node::Counters& c = limited.r->c;
  EXPECT_GE(c.calibrations_applied, 3u);
  EXPECT_EQ(c.frame_changes, 1u);
  EXPECT_EQ(c.frame_changes_refused, c.calibrations_applied - 1);
  EXPECT_NE(limited.err_out.find("frame change refused"), std::string::npos) << limited.err_out;
  EXPECT_NE(limited.err_out.find("frame_change_min_interval_s"), std::string::npos) << limited.err_out;
  // Without the limit every applied calibration changes the frame.
  const FrameRun free = run(120, 840, 0);
  EXPECT_EQ(free.r->c.frame_changes, free.r->c.calibrations_applied);
  EXPECT_EQ(free.r->c.frame_changes_refused, 0u);
  // A span of the x manoeuvre alone (solved at 280 s): the rotation about x is not determined, so the
  // frame stays (the relative part may still be applied).
  const FrameRun x_only = run(3600, 280, 0);
  EXPECT_EQ(x_only.r->c.frame_changes, 0u) << x_only.err_out;
  EXPECT_GE(x_only.r->c.calibrations_published, 1u);
  std::printf("x manoeuvre alone: %llu applied, %llu refused, frame changes refused %llu\n",
              static_cast<unsigned long long>(x_only.r->c.calibrations_applied),
              static_cast<unsigned long long>(x_only.r->c.calibrations_refused),
              static_cast<unsigned long long>(x_only.r->c.frame_changes_refused));
  ASSERT_GE(x_only.r->c.calibrations_applied, 1u) << "the relative part was determined (seed 7: 1 applied)";
  EXPECT_EQ(x_only.r->c.frame_changes_refused, x_only.r->c.calibrations_applied);
  EXPECT_NE(x_only.err_out.find("not determined about every axis"), std::string::npos) << x_only.err_out;
}

TEST(Boresightd, ReplayWritesSummaryWithTheLastCalibrationAndACsvPerAttitude) {
  const std::string log = simulate("cli", 1200, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  const std::string dir = makeTempDir("node_cli");
  {
    std::ifstream in(src("config/boresightd.yaml"));
    std::ofstream o(dir + "/node.yaml");
    std::string line;
    while (std::getline(in, line)) {
      // the ideal noise preset: the log is simulated from config/sim_gracefo_node_demo.yaml (white 6"/48")
      if (line.rfind("platform:", 0) == 0) line = "platform: " + src("config/gracefo_ideal.yaml");
      if (line.find("apply_common_rotation:") != std::string::npos) line = "  apply_common_rotation: true";
      if (line.find("cadence_s:") != std::string::npos) line = "  cadence_s: 3600";
      if (line.find("min_span_s:") != std::string::npos) line = "  min_span_s: 840";
      if (line.find("apply_lag_epochs:") != std::string::npos) line = "  apply_lag_epochs: 20";
      o << line << "\n";
    }
  }
  const std::string args = "--config " + dir + "/node.yaml --replay " + log + " --summary-json " + dir + "/s.json --csv " +
                           dir + "/n.csv --record " + dir + "/out.lcm";
  const auto r = testutil::runProgram(BORESIGHTD, args);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("boresightd: frame change 1:"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("frame change 2"), std::string::npos) << r.out;
  std::ifstream js(dir + "/s.json");
  std::stringstream ss;
  ss << js.rdbuf();
  const std::string j = ss.str();
  for (const char* key : {"\"frame_changes\": 1", "\"last_calibration\"", "\"status\": \"ok\"", "\"applied\": true",
                          "\"sigma_arcsec\"", "\"crlb_arcsec\"", "\"common_rotation_B_arcsec\"", "\"id\": 3"})
    EXPECT_NE(j.find(key), std::string::npos) << key << " not in\n" << j;
  // One CSV row per published attitude (the core's rows, 1 Hz) over 1200 s; the mounting version
  // steps 0 -> 1 once.
  std::ifstream csv(dir + "/n.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line.rfind("time_s,mounting_version,heads_used,iba_12_dev_arcsec", 0), 0u) << line;
  int rows = 0, steps = 0, last_version = 0, three_heads = 0;
  double iba23 = 0;
  double corr_after = 0;
  while (std::getline(csv, line)) {
    ++rows;
    std::stringstream ls(line);
    std::string cell;
    std::vector<double> v;
    while (std::getline(ls, cell, ',')) v.push_back(std::stod(cell));
    ASSERT_EQ(v.size(), 9u) << line;
    if (static_cast<int>(v[1]) != last_version) ++steps;
    last_version = static_cast<int>(v[1]);
    corr_after = v[6] + v[7] + v[8];
    if (v[2] == 3) ++three_heads, iba23 += std::abs(v[5]);
  }
  EXPECT_GT(rows, 1150);
  EXPECT_LE(rows, 1201);
  EXPECT_EQ(steps, 1);
  EXPECT_GT(corr_after, 10.0);  // the relative corrections in use after the hand-over (arcsec)
  // Every pair column is a real pair (the 2-3 deviation is not an unused slot's zero).
  ASSERT_GT(three_heads, 100);
  EXPECT_GT(iba23 / three_heads, 0.1);
  // An unwritable CSV is a clear error before anything runs.
  const auto bad = testutil::runProgram(BORESIGHTD, "--config " + dir + "/node.yaml --replay " + log + " --csv " + dir +
                                                        "/no/such/dir/n.csv");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("n.csv: cannot create"), std::string::npos) << bad.out;
}
#endif

/// Digits two numbers share (15 when equal).
double matchingDigits(double a, double b) {
  if (a == b || (std::isnan(a) && std::isnan(b))) return 15;
  const double scale = std::max(std::abs(a), std::abs(b));
  return std::min(15.0, -std::log10(std::abs(a - b) / scale));
}

TEST(NodeReplay, GoldenOutputsByMatchingDigits) {
  const std::string log = simulate("golden", 1200, {"relative_misalignment:sensor=2,x_arcsec=20"});
  const auto r = replay(log, nodeConfig());
  std::ostringstream s;
  s.precision(17);
  const auto att = r->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  for (std::size_t i = 0; i < att.size(); i += 50) {
    const auto& a = att[i];
    s << "att " << a.utime << " " << a.q_I_B[0] << " " << a.q_I_B[1] << " " << a.q_I_B[2] << " " << a.q_I_B[3] << " "
      << a.P_B[0][0] << " " << (a.has_rates ? a.w_B[0] : 0.0) << " " << (a.has_rates ? a.w_B[1] : 0.0) << " "
      << (a.has_rates ? a.w_B[2] : 0.0) << " " << (a.has_acc ? a.alpha_acc_B[1] : 0.0) << "\n";
  }
  const auto& c = r->c;
  s << "counters " << c.received << " " << c.used << " " << c.rejectedTotal() << " " << c.lost << " " << c.head_epochs
    << " " << c.rows << "\n";
  const std::string golden_path = src("test/node/golden/replay_short.txt");
  if (std::getenv("BORESIGHT_UPDATE_GOLDEN")) {
    std::ofstream f(golden_path);
    f << s.str();
    GTEST_SKIP() << "golden file rewritten: " << golden_path;
  }
  std::ifstream f(golden_path);
  ASSERT_TRUE(f) << golden_path << " missing (regenerate: see the top of this file)";
  std::istringstream now(s.str());
  std::string gl, nl;
  int lines = 0;
  double worst = 15;
  while (std::getline(f, gl)) {
    ASSERT_TRUE(std::getline(now, nl)) << "fewer lines than the golden file";
    std::istringstream g(gl), n(nl);
    std::string gt, nt;
    g >> gt;
    n >> nt;
    ASSERT_EQ(gt, nt) << "line " << lines + 1;
    double gv, nv;
    while (g >> gv) {
      ASSERT_TRUE(n >> nv) << "line " << lines + 1;
      worst = std::min(worst, matchingDigits(gv, nv));
    }
    ++lines;
  }
  EXPECT_FALSE(std::getline(now, nl)) << "more lines than the golden file";
  EXPECT_GT(lines, 20);
  // 10 digits: the same code on another compiler or CPU may round differently in the last digits.
  EXPECT_GE(worst, 10.0);
}

// ---- configuration errors -----------------------------------------------------------------------

// A configuration the calibration worker cannot run, handed to the library directly (not through
// boresightd.yaml, whose reader refuses it too): refused by configure() with the worker's reason even
// while the mountings are still to come from the log (the core starts only then) - before, the worker's
// span builder refused it on the worker thread, nothing calibrated and a replay waited for the worker.
TEST(NodeConfig, AConfigurationTheWorkerCannotRunIsRefusedAtStart) {
  node::NodeConfig cfg = nodeConfig();
  ASSERT_TRUE(cfg.mountings_from_log);
  cfg.calibration.decimation_s = 0.2;  // below the 2 Hz heads' interval
  node::Node n;
  Captured out;
  std::string err;
  EXPECT_FALSE(n.configure(cfg, node::Node::Mode::kReplay, &out, &err));
  EXPECT_NE(err.find("boresightd.yaml: the calibration worker cannot run this configuration: span builder: "
                     "decimation_s must be at least the head sampling interval"),
            std::string::npos)
      << err;
  // The same configuration without the worker runs.
  cfg.calibration.enabled = false;
  node::Node n2;
  EXPECT_TRUE(n2.configure(cfg, node::Node::Mode::kReplay, &out, &err)) << err;
}

TEST(NodeConfig, ClearErrors) {
  const std::string dir = makeTempDir("node_cfg");
  auto write = [&](const std::string& text) {
    const std::string p = dir + "/n.yaml";
    std::ofstream(p) << "platform: " << src("config/gracefo.yaml") << "\n" << text;
    return p;
  };
  node::NodeConfig cfg;
  std::string err;
  EXPECT_FALSE(node::loadNodeConfig(write("lookahed_s: 2\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:2: key 'lookahed_s': unknown key; did you mean 'lookahead_s'?"), std::string::npos)
      << err;
  EXPECT_FALSE(node::loadNodeConfig(write("ring_capacity: 1000\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:2: key 'ring_capacity': must be a power of two"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("mountings: config\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:2: key 'mountings'"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("channels: {accel: STAR_HEAD}\n"), cfg, &err));
  EXPECT_NE(err.find("own name"), std::string::npos) << err;
  EXPECT_TRUE(node::loadNodeConfig(write("health_period_s: 5\n"), cfg, &err)) << err;
  EXPECT_EQ(cfg.health_period_s, 5);
  EXPECT_FALSE(node::loadNodeConfig(write("calibration:\n  method: raw\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'calibration.method': expected 'crn'"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("calibration:\n  raw_passes: 2.5\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'calibration.raw_passes': expected a whole number"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("calibration:\n  frame_change_max_chi2_per_dof: 0\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'calibration.frame_change_max_chi2_per_dof': must be within"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("calibration:\n  time_offset: often\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'calibration.time_offset'"), std::string::npos) << err;
  EXPECT_TRUE(node::loadNodeConfig(write("calibration:\n  method: attitude\n  acc_scale: false\n  time_offset: false\n"), cfg, &err)) << err;
  ASSERT_TRUE(cfg.raw_config.has_value());
  EXPECT_FALSE(cfg.raw_config->options.scale);
  EXPECT_FALSE(cfg.raw_config->options.time_offset);
  EXPECT_TRUE(node::loadNodeConfig(write("calibration:\n  method: attitude\n"), cfg, &err)) << err;
  EXPECT_EQ(cfg.calibration.method, node::CalibrationConfig::Method::kAttitude);
  ASSERT_TRUE(cfg.raw_config.has_value());
  EXPECT_TRUE(cfg.raw_config->options.time_offset) << "the attitude domain takes the time offset by default";
  EXPECT_TRUE(cfg.raw_config->options.scale) << "and the scale factors";
  EXPECT_EQ(cfg.raw_config->heads.size(), 3u);
  // Every error names the file, the line and the key; NaN, duplicated keys and a directory too.
  EXPECT_FALSE(node::loadNodeConfig(write("lookahead_s: 2\nhealth_period_s: .nan\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'health_period_s': must be within"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("lookahead_s: 2\nlookahead_s: 3\n"), cfg, &err));
  EXPECT_NE(err.find(dir + "/n.yaml:3: key 'lookahead_s': given twice in this mapping (first at line 2)"), std::string::npos) << err;
  {
    const std::string p = dir + "/d.yaml";
    std::ofstream(p) << "platform: " << dir << "\n";
    EXPECT_FALSE(node::loadNodeConfig(p, cfg, &err));
    EXPECT_NE(err.find("is a directory, not a platform configuration file"), std::string::npos) << err;
  }
  EXPECT_FALSE(node::loadNodeConfig(dir, cfg, &err));
  EXPECT_NE(err.find("is a directory, not a node configuration file"), std::string::npos) << err;
  EXPECT_FALSE(node::loadNodeConfig(write("calibration: {decimation_s: 0.2}\n"), cfg, &err));
  EXPECT_NE(err.find("key 'calibration.decimation_s'"), std::string::npos) << err;
}

// ---- bad input (issue 18): the node's cases ------------------------------------------------------

/// A copy of `clean` with every event passed through `edit(index, channel, bytes)`: it returns the
/// events to write (none drops it) as (channel, event time, bytes).
struct Event {
  std::string ch;
  TimeUs t;
  std::vector<std::uint8_t> bytes;
};
template <typename Edit>
std::string editLog(const std::string& clean, const std::string& name, Edit edit) {
  const std::string path = makeTempDir("node_edit") + "/" + name;
  io::LcmLogReader r;
  io::LcmLogWriter w;
  std::string err;
  EXPECT_TRUE(r.open(clean, &err)) << err;
  EXPECT_TRUE(w.open(path, &err)) << err;
  io::LcmLogReader::RawEvent ev;
  std::size_t k = 0;
  while (r.nextRaw(ev)) {
    if (ev.size < 0) continue;
    const auto* p = static_cast<const std::uint8_t*>(ev.data);
    Event in{*ev.channel, ev.timestamp, std::vector<std::uint8_t>(p, p + ev.size)};
    for (const Event& o : edit(k++, in)) w.writeRaw(o.ch, o.t, o.bytes.data(), static_cast<int>(o.bytes.size()));
  }
  EXPECT_TRUE(w.close(&err)) << err;
  return path;
}

template <typename M>
M decodeAs(const Event& e) {
  M m;
  EXPECT_EQ(m.decode(e.bytes.data(), 0, static_cast<int>(e.bytes.size())), static_cast<int>(e.bytes.size()));
  return m;
}
template <typename M>
Event encodeAs(const std::string& ch, TimeUs t, const M& m) {
  Event e{ch, t, std::vector<std::uint8_t>(static_cast<std::size_t>(m.getEncodedSize()))};
  m.encode(e.bytes.data(), 0, static_cast<int>(e.bytes.size()));
  return e;
}

#ifdef BORESIGHT_CLI
/// The numbers of every `"key": [a, b, c]` of a JSON text, in order (the tests' minimal reader).
std::vector<std::array<double, 3>> jsonTriples(const std::string& j, const std::string& key) {
  std::vector<std::array<double, 3>> out;
  for (std::size_t at = j.find("\"" + key + "\""); at != std::string::npos; at = j.find("\"" + key + "\"", at + 1)) {
    std::size_t p = j.find_first_not_of(" \n", j.find(':', at) + 1);
    if (p == std::string::npos || j[p] != '[') continue;  // the key in a text (the conventions)
    std::array<double, 3> v{};
    for (int i = 0; i < 3 && p != std::string::npos; ++i) {
      p = j.find_first_of("-0123456789n", p + 1);
      if (p == std::string::npos) break;
      v[static_cast<std::size_t>(i)] = j.compare(p, 4, "null") == 0 ? std::nan("") : std::strtod(j.c_str() + p, nullptr);
      p = j.find_first_of(",]", p);
    }
    out.push_back(v);
  }
  return out;
}

// One orchestration of method A (calib::runCalibration): the node's worker and `boresight calibrate`
// give the same calibration of the same data. The node solves once, at the first head epoch 1300 s
// into a manoeuvring span; calibrate runs on the log cut where the worker's span ends (the heads up to
// that epoch, the accelerometer before it: the worker has the epoch's heads, its accelerometer sample
// comes after the request). The same samples, the same code: the angles agree to 1e-6 arcsec.
TEST(NodeReplay, TheWorkerCalibratesAsCalibrateDoesOnTheSameData) {
  const std::string log = simulate("same_cal", 1500, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  node::NodeConfig cfg = nodeConfig(1e6, 1300);
  cfg.calibration.apply_lag_epochs = 20;
  const auto r = replay(log, cfg);
  const auto cals = r->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cals.size(), 1u);
  const auto& k = cals[0];
  ASSERT_EQ(k.status, 0);
  const TimeUs T = k.utime;
  const std::string cut = editLog(log, "cut.lcm", [&](std::size_t, const Event& e) {
    std::vector<Event> keep;  // (event times are Unix time, message times GPS: cut by the messages')
    if (e.ch == "STAR_HEAD") {
      if (decodeAs<boresight_lcm::star_head_sample_t>(e).utime <= T) keep.push_back(e);
    } else if (e.ch == "ACCEL") {
      if (decodeAs<boresight_lcm::accel_sample_t>(e).utime < T) keep.push_back(e);
    } else if (e.ch == "NOMINAL_MOUNTINGS") {
      keep.push_back(e);
    }  // star vectors and the orbit: not method A's inputs
    return keep;
  });
  const std::string dir = makeTempDir("node_same_cal");
  const auto cal = testutil::runProgram(BORESIGHT_CLI, "calibrate --config " + src("config/gracefo_ideal.yaml") +
                                                           " --json " + dir + "/c.json " + cut);
  ASSERT_EQ(cal.status, 0) << cal.out;
  const std::string j = testutil::slurp(dir + "/c.json");
  const auto angles = jsonTriples(j, "error_angles_arcsec"), sigmas = jsonTriples(j, "sigma_arcsec");
  ASSERT_GE(angles.size(), static_cast<std::size_t>(k.n_heads));
  ASSERT_GE(sigmas.size(), static_cast<std::size_t>(k.n_heads));
  for (int h = 0; h < k.n_heads; ++h)
    for (int a = 0; a < 3; ++a) {
      const auto uh = static_cast<std::size_t>(h), ua = static_cast<std::size_t>(a);
      EXPECT_NEAR(k.error_angles_arcsec[h][a], angles[uh][ua], 1e-6) << "head " << h << " axis " << a;
      EXPECT_NEAR(k.sigma_arcsec[h][a], sigmas[uh][ua], 1e-6) << "head " << h << " axis " << a;
      EXPECT_GT(std::abs(k.error_angles_arcsec[h][a]), 1.0);  // a real calibration, not zeros on both sides
    }
}

// calibration.method: attitude - the worker publishes and applies the attitude-domain estimate from the
// raw samples (calib::estimateRaw after the CRN solve), and it is `boresight calibrate --raw`'s on the
// same data: the same orchestration, the same conversion of the estimate into mountings and sigmas
// (calib::rawMountings). Without the worker's raw path the node publishes the CRN solver's angles, which
// differ from these by arcseconds.
TEST(NodeReplay, TheWorkerInTheAttitudeDomainIsCalibrateRawOnTheSameData) {
  const std::string log = simulate("same_raw", 1500, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  // The committed configuration with method: attitude (read through the node's own reader).
  std::string y = testutil::slurp(src("config/boresightd.yaml"));
  const auto at = y.find("method: crn");
  ASSERT_NE(at, std::string::npos);
  y.replace(at, 11, "method: attitude");
  const auto pl = y.find("platform: gracefo_ideal.yaml");
  ASSERT_NE(pl, std::string::npos);
  y.replace(pl, 28, "platform: " + src("config/gracefo_ideal.yaml"));
  const std::string dir = makeTempDir("node_same_raw");
  {
    std::ofstream f(dir + "/node.yaml");
    f << y;
  }
  node::NodeConfig cfg;
  std::string err;
  ASSERT_TRUE(node::loadNodeConfig(dir + "/node.yaml", cfg, &err)) << err;
  ASSERT_EQ(cfg.calibration.method, node::CalibrationConfig::Method::kAttitude);
  ASSERT_TRUE(cfg.raw_config.has_value());
  cfg.calibration.cadence_s = 1e6;
  cfg.calibration.min_span_s = 1300;
  cfg.calibration.apply_lag_epochs = 20;
  const auto r = replay(log, cfg);
  EXPECT_EQ(noConsumer(r->c), 0u);  // the worker takes the ORBIT messages
  EXPECT_GT(r->c.orbit_steps, 1000u);
  const auto cals = r->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cals.size(), 1u);
  const auto& k = cals[0];
  ASSERT_EQ(k.status, 0);
  EXPECT_EQ(k.applied, 1);
  const TimeUs T = k.utime;
  const std::string cut = editLog(log, "cut.lcm", [&](std::size_t, const Event& e) {
    std::vector<Event> keep;
    if (e.ch == "STAR_HEAD") {
      if (decodeAs<boresight_lcm::star_head_sample_t>(e).utime <= T) keep.push_back(e);
    } else if (e.ch == "ACCEL") {
      if (decodeAs<boresight_lcm::accel_sample_t>(e).utime < T) keep.push_back(e);
    } else if (e.ch == "ORBIT") {  // the orbit before the request: both remove the stars' aberration with it
      if (decodeAs<boresight_lcm::orbit_sample_t>(e).utime < T) keep.push_back(e);
    } else if (e.ch == "NOMINAL_MOUNTINGS") {
      keep.push_back(e);
    }
    return keep;
  });
  const auto cal = testutil::runProgram(BORESIGHT_CLI, "calibrate --raw --config " + src("config/gracefo_ideal.yaml") +
                                                           " --json " + dir + "/c.json " + cut);
  ASSERT_EQ(cal.status, 0) << cal.out;
  EXPECT_NE(cal.out.find("aberration removed from"), std::string::npos) << cal.out;
  const std::string j = testutil::slurp(dir + "/c.json");
  const auto ad = j.find("\"attitude_domain\"");
  ASSERT_NE(ad, std::string::npos);
  const auto angles = jsonTriples(j.substr(ad), "error_angles_arcsec"), sigmas = jsonTriples(j.substr(ad), "sigma_arcsec");
  const auto crn = jsonTriples(j.substr(0, ad), "error_angles_arcsec");  // the CRN solver's heads come first
  ASSERT_GE(crn.size(), static_cast<std::size_t>(k.n_heads));
  ASSERT_GE(angles.size(), static_cast<std::size_t>(k.n_heads));
  ASSERT_GE(sigmas.size(), static_cast<std::size_t>(k.n_heads));
  double max_from_crn = 0;
  for (int h = 0; h < k.n_heads; ++h)
    for (int a = 0; a < 3; ++a) {
      const auto uh = static_cast<std::size_t>(h), ua = static_cast<std::size_t>(a);
      EXPECT_NEAR(k.error_angles_arcsec[h][a], angles[uh][ua], 1e-6) << "head " << h << " axis " << a;
      if (std::isnan(sigmas[uh][ua])) EXPECT_TRUE(std::isnan(k.sigma_arcsec[h][a])) << "head " << h << " axis " << a;
      else EXPECT_NEAR(k.sigma_arcsec[h][a], sigmas[uh][ua], 1e-6) << "head " << h << " axis " << a;
      EXPECT_GT(std::abs(k.error_angles_arcsec[h][a]), 1.0);
      max_from_crn = std::max(max_from_crn, std::abs(crn[uh][ua] - angles[uh][ua]));
    }
  EXPECT_GT(max_from_crn, 1.0);  // the attitude-domain angles are not the CRN solver's

  // The frame change's chi-square gate (calibration.frame_change_max_chi2_per_dof): the fit's noise
  // models describe these data (chi-square per degree of freedom about 1), so a change is made under the
  // default bound of 2 and refused under a bound of 0.5 - the relative part is applied either way.
  cfg.calibration.apply_common_rotation = true;
  const auto ok = replay(log, cfg);
  EXPECT_EQ(ok->c.frame_changes, 1u);
  EXPECT_EQ(ok->c.frame_changes_refused, 0u);
  cfg.calibration.frame_change_max_chi2_per_dof = 0.5;
  const auto tight = replay(log, cfg);
  std::printf("frame changes: bound 2: %llu made, %llu refused; bound 0.5: %llu made, %llu refused\n",
              static_cast<unsigned long long>(ok->c.frame_changes), static_cast<unsigned long long>(ok->c.frame_changes_refused),
              static_cast<unsigned long long>(tight->c.frame_changes), static_cast<unsigned long long>(tight->c.frame_changes_refused));
  EXPECT_EQ(tight->c.frame_changes, 0u);
  EXPECT_EQ(tight->c.frame_changes_refused, 1u);
  EXPECT_EQ(tight->c.calibrations_applied, 1u);

  // One CRN row per 1000 s leaves the CRN solver too few epochs: it refuses, and the attitude-domain
  // estimate, which uses no CRN row, is published and applied as before, the same to the bit.
  cfg.calibration.frame_change_max_chi2_per_dof = 2;
  cfg.calibration.apply_common_rotation = false;
  cfg.calibration.decimation_s = 1000;
  const auto nocrn = replay(log, cfg);
  const auto cals2 = nocrn->out.all<boresight_lcm::calibration_t>("BORESIGHT_CALIBRATION");
  ASSERT_EQ(cals2.size(), 1u);
  EXPECT_EQ(cals2[0].status, 0);
  EXPECT_EQ(cals2[0].applied, 1);
  EXPECT_EQ(nocrn->c.calibrations_refused, 0u);
  for (int h = 0; h < k.n_heads; ++h)
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(cals2[0].error_angles_arcsec[h][a], k.error_angles_arcsec[h][a]) << "head " << h << " axis " << a;
      EXPECT_EQ(cals2[0].sigma_arcsec[h][a], k.sigma_arcsec[h][a]) << "head " << h << " axis " << a;
    }
}
#endif

/// Moves the sensor time of a STAR_HEAD, ACCEL, STAR_VECTORS or ORBIT message by dt (a sender clock).
Event shifted(const Event& e, TimeUs dt) {
  if (e.ch == "STAR_HEAD") {
    auto m = decodeAs<boresight_lcm::star_head_sample_t>(e);
    m.utime += dt;
    return encodeAs(e.ch, m.utime, m);
  }
  if (e.ch == "ACCEL") {
    auto m = decodeAs<boresight_lcm::accel_sample_t>(e);
    m.utime += dt;
    return encodeAs(e.ch, m.utime, m);
  }
  if (e.ch == "STAR_VECTORS") {
    auto m = decodeAs<boresight_lcm::star_vectors_t>(e);
    m.utime += dt;
    return encodeAs(e.ch, m.utime, m);
  }
  if (e.ch == "ORBIT") {
    auto m = decodeAs<boresight_lcm::orbit_sample_t>(e);
    m.utime += dt;
    return encodeAs(e.ch, m.utime, m);
  }
  return e;
}

/// Runs fn on a thread; a run that has not finished after `seconds` is a hang: the test program ends
/// with a failure (a dead-locked thread cannot be joined).
template <typename Fn>
void withinSeconds(double seconds, const char* what, Fn fn) {
  std::atomic<bool> done{false};
  std::thread t([&] {
    fn();
    done = true;
  });
  const auto t0 = std::chrono::steady_clock::now();
  while (!done && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < seconds)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  if (!done) {
    std::fprintf(stderr, "FAILED: %s did not finish in %.0f s (a hang)\n", what, seconds);
    std::fflush(stderr);
    std::_Exit(1);
  }
  t.join();
}

TEST(NodeBadInput, AOneDayJumpWithCalibrationOnFinishesInsteadOfHanging) {
  // Tags one day ahead from the middle of the log on: the cadences the jump skips used to queue one
  // solve per epoch, and the real-time thread, the worker and the solver waited on each other.
  const std::string clean = simulate("jump", 7200, {}, nullptr, "config/sim_gracefo_calibration.yaml");
  std::size_t n = 0;
  {
    io::LcmLogReader r;
    std::string err;
    EXPECT_TRUE(r.open(clean, &err));
    io::LcmLogReader::RawEvent ev;
    while (r.nextRaw(ev)) ++n;
  }
  const std::string log = editLog(clean, "jump.lcm", [&](std::size_t k, const Event& e) {
    return std::vector<Event>{k > n / 2 ? shifted(e, 86400 * kUsPerSecond) : e};
  });
  auto cfg = nodeConfig(1800, 1800);
  cfg.calibration.apply_lag_epochs = 2400;  // the demo's lag: the ring fills long before a result is due
  std::unique_ptr<Replay> r;
  withinSeconds(240, "the replay with a one-day jump", [&] { r = replay(log, cfg); });
  const node::Counters& c = r->c;
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_GE(c.time_resyncs, 1u);
  EXPECT_LE(rejected(c, io::Reject::kTimeJump), 12u);  // the votes that confirmed the jump
  EXPECT_GE(c.calibrations_published, 2u);
  EXPECT_LE(c.calibrations_published, 4u);  // one for the whole skipped day, not one per skipped cadence
}

TEST(NodeBadInput, AStopRequestEndsTheReplayWithItsSummary) {
  const std::string log = simulate("stop", 1200, {});
  struct StopAfter : node::Output {
    std::atomic<bool>* flag;
    int n = 0;
    void publish(const std::string& ch, TimeUs, const void*, int) override {
      if (ch == "BORESIGHT_ATTITUDE" && ++n == 300) flag->store(true);
    }
  } out;
  std::atomic<bool> stop{false};
  out.flag = &stop;
  node::Node nd;
  std::string err;
  ASSERT_TRUE(nd.configure(nodeConfig(), node::Node::Mode::kReplay, &out, &err)) << err;
  ASSERT_TRUE(node::replayLog(nd, log, &err, &stop)) << err;
  const node::Counters& c = nd.counters();
  std::uint64_t events = 0;
  {
    io::LcmLogReader rd;
    ASSERT_TRUE(rd.open(log, &err));
    io::LcmLogReader::RawEvent ev;
    while (rd.nextRaw(ev)) ++events;
  }
  EXPECT_TRUE(stop.load());
  EXPECT_GT(c.received, 1000u);
  EXPECT_LT(c.received, events / 2) << "the replay did not stop: " << events << " events";  // 300 of 1200 s
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
}

TEST(NodeBadInput, OneCorruptSequenceNumberIsOneBadMessageNotAMillionLost) {
  const std::string clean = simulate("seq", 1200, {});
  int acc = 0;
  const std::string corrupt = editLog(clean, "seq.lcm", [&](std::size_t, const Event& e) {
    if (e.ch != "ACCEL" || ++acc != 1000) return std::vector<Event>{e};
    auto m = decodeAs<boresight_lcm::accel_sample_t>(e);
    m.seq += 1000000;
    return std::vector<Event>{encodeAs(e.ch, e.t, m)};
  });
  const auto r = replay(corrupt, nodeConfig());
  EXPECT_EQ(r->c.lost, 0u);
  EXPECT_EQ(r->c.received, r->c.used + r->c.rejectedTotal());
  // A real loss of 100 messages beyond the reorder window is still counted (confirmed by the next one).
  acc = 0;
  const std::string lossy = editLog(clean, "loss.lcm", [&](std::size_t, const Event& e) {
    if (e.ch == "ACCEL" && ++acc > 2000 && acc <= 2100) return std::vector<Event>{};
    return std::vector<Event>{e};
  });
  EXPECT_EQ(replay(lossy, nodeConfig())->c.lost, 100u);
}

TEST(NodeBadInput, AClockStepped700sBackIsResynchronisedNotHalfTheMessagesLost) {
  const std::string clean = simulate("back", 2400, {});
  std::size_t n = 0;
  {
    io::LcmLogReader r;
    std::string err;
    EXPECT_TRUE(r.open(clean, &err));
    io::LcmLogReader::RawEvent ev;
    while (r.nextRaw(ev)) ++n;
  }
  const std::string log = editLog(clean, "back.lcm", [&](std::size_t k, const Event& e) {
    return std::vector<Event>{k > n / 2 ? shifted(e, -700 * kUsPerSecond) : e};
  });
  const auto ref = replay(clean, nodeConfig());
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_GE(c.time_resyncs, 1u);
  EXPECT_LE(rejected(c, io::Reject::kTimeJump), 12u) << "before: about half the messages";
  EXPECT_LE(c.rejectedTotal() - noConsumer(c), 20u);  // the orbit: nothing reads it here
  EXPECT_GE(c.head_epochs, ref->c.head_epochs * 98 / 100);
  EXPECT_GE(c.rows, ref->c.rows * 9 / 10);  // the filters restart at the step (about 70 s of rows)
}

TEST(NodeBadInput, AWrongFirstTagIsOutVotedWithoutAssemblerRejects) {
  const std::string clean = simulate("first", 1200, {});
  bool first = true;
  const std::string log = editLog(clean, "first.lcm", [&](std::size_t, const Event& e) {
    if ((e.ch != "STAR_HEAD" && e.ch != "ACCEL") || !first) return std::vector<Event>{e};
    first = false;
    return std::vector<Event>{shifted(e, 86400 * kUsPerSecond)};
  });
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(rejected(c, io::Reject::kAssembler), 0u) << "before: 840";
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_LE(c.rejectedTotal() - noConsumer(c), 12u);  // the orbit: nothing reads it here
}

// ---- link faults (issue 17): each injected into a simulated log ----------------------------------

TEST(NodeFaults, ASenderRestartIsOneRestartAndTheLossesAfterItAreCounted) {
  // The accelerometer's counter starts again at 0 a third of the way in; 20 messages are lost after
  // that. Before, every number below the old one was taken for a late arrival: no loss was seen until
  // the counter passed its old value.
  const std::string clean = simulate("restart", 1200, {});
  const auto ref = replay(clean, nodeConfig());
  int acc = 0;
  std::int32_t base = 0;
  const std::string log = editLog(clean, "restart.lcm", [&](std::size_t, const Event& e) {
    if (e.ch != "ACCEL") return std::vector<Event>{e};
    ++acc;
    auto m = decodeAs<boresight_lcm::accel_sample_t>(e);
    if (acc == 4000) base = m.seq;
    if (acc < 4000) return std::vector<Event>{e};
    if (acc >= 5000 && acc < 5020) return std::vector<Event>{};
    m.seq -= base;
    return std::vector<Event>{encodeAs(e.ch, e.t, m)};
  });
  ASSERT_GT(base, 1000);
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.seq_restarts, 1u);
  EXPECT_EQ(c.lost, ref->c.lost + 20u);
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_EQ(c.rejectedTotal(), ref->c.rejectedTotal());
  EXPECT_EQ(ref->c.seq_restarts, 0u);
}

namespace {
/// Events whose log time lies in [from_s, to_s) of the log's first time are passed through `edit`.
template <typename Edit>
std::string editSpan(const std::string& clean, const std::string& name, double from_s, double to_s, Edit edit) {
  TimeUs t0 = -1;
  return editLog(clean, name, [&](std::size_t, const Event& e) {
    if (t0 < 0) t0 = e.t;
    const double s = static_cast<double>(e.t - t0) * 1e-6;
    return s >= from_s && s < to_s ? edit(e) : std::vector<Event>{e};
  });
}
}  // namespace

TEST(NodeFaults, AForwardJumpOfOneTagIsHeldAndRefutedNotTaken) {
  // One accelerometer tag 300 s ahead. Before, any jump under max_time_jump_s (600 s) was taken without
  // confirmation: the data time moved 300 s ahead.
  const std::string clean = simulate("fwd", 1200, {});
  const auto ref = replay(clean, nodeConfig());
  bool done = false;
  const std::string log = editSpan(clean, "fwd.lcm", 500, 1200, [&](const Event& e) {
    if (e.ch != "ACCEL" || done) return std::vector<Event>{e};
    done = true;
    return std::vector<Event>{shifted(e, 300 * kUsPerSecond)};
  });
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(rejected(c, io::Reject::kTimeJump), 1u);
  EXPECT_EQ(c.rejectedTotal(), ref->c.rejectedTotal() + 1u);
  EXPECT_EQ(c.time_resyncs, 0u);
  EXPECT_EQ(c.held, 1u);
  EXPECT_EQ(c.head_epochs, ref->c.head_epochs);
  EXPECT_EQ(c.rows, ref->c.rows);
  EXPECT_EQ(c.accel_steps + 1, ref->c.accel_steps);
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
}

TEST(NodeFaults, AWholeLinkOutageIsAConfirmedJumpAndNothingAfterItIsLost) {
  // Every message of 30 s dropped: the first ones after the outage are a jump beyond the look-ahead,
  // held until three (from two channels) agree, then used - none rejected.
  const std::string clean = simulate("outage", 1200, {});
  const auto ref = replay(clean, nodeConfig());
  const std::string log = editSpan(clean, "outage.lcm", 600, 630, [](const Event&) { return std::vector<Event>{}; });
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.rejectedTotal() - noConsumer(c), ref->c.rejectedTotal() - noConsumer(ref->c));  // orbit: none reads it
  EXPECT_EQ(c.time_resyncs, 1u);
  EXPECT_GE(c.held, 2u);  // the votes before the confirming one
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_LT(c.head_epochs, ref->c.head_epochs);
  EXPECT_GE(c.head_epochs + 61, ref->c.head_epochs);  // 30 s at 2 Hz
}

TEST(NodeFaults, OneSenderClockAheadIsRefutedByTheOthersNotFollowed) {
  // From 600 s on the accelerometer's tags are 10 s ahead of the heads'. Before, they were taken (under
  // max_time_jump_s) and sorted 10 s late into the heads' epochs; a vote counted on the channel alone
  // confirms the jump between two head epochs, and the heads then confirm the way back.
  const std::string clean = simulate("ahead", 1200, {});
  const auto ref = replay(clean, nodeConfig());
  std::size_t shifted_n = 0;
  const std::string log = editSpan(clean, "ahead.lcm", 600, 1e9, [&](const Event& e) {
    if (e.ch != "ACCEL") return std::vector<Event>{e};
    ++shifted_n;
    return std::vector<Event>{shifted(e, 10 * kUsPerSecond)};
  });
  ASSERT_GT(shifted_n, 5000u);
  const auto r = replay(log, nodeConfig());
  const node::Counters& c = r->c;
  EXPECT_EQ(c.time_resyncs, 0u);
  // every shifted sample is refused (the last few at most by the end of the data)
  EXPECT_GE(rejected(c, io::Reject::kTimeJump) + rejected(c, io::Reject::kLate), shifted_n);
  EXPECT_EQ(c.head_epochs, ref->c.head_epochs);
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  // The star cameras (every head and the star vectors) 5 s behind from 600 s on: the three heads of an
  // epoch are three channels but one sensor; the accelerometer refutes them.
  const std::string behind = editSpan(clean, "behind.lcm", 600, 1e9, [&](const Event& e) {
    return std::vector<Event>{e.ch == "ACCEL" ? e : shifted(e, -5 * kUsPerSecond)};
  });
  const auto rb = replay(behind, nodeConfig());
  EXPECT_EQ(rb->c.time_resyncs, 0u);
  EXPECT_EQ(rb->c.accel_steps, ref->c.accel_steps);
  EXPECT_EQ(rb->c.received, rb->c.used + rb->c.rejectedTotal());
}

TEST(NodeFaults, ANewMountingsMessageIsValidatedAndAppliedAtAnEpochBoundary) {
  // A second NOMINAL_MOUNTINGS message at 600 s of log time. Before, any later one was counted as used
  // and ignored.
  const std::string clean = simulate("newmount", 1200, {});
  const auto ref = replay(clean, nodeConfig());
  auto withMountings = [&](const std::string& name, const std::function<void(boresight_lcm::nominal_mountings_t&)>& change) {
    TimeUs t0 = -1;
    bool inserted = false;
    Event first;
    return editLog(clean, name, [&](std::size_t, const Event& e) {
      if (t0 < 0) t0 = e.t;
      if (e.ch == "NOMINAL_MOUNTINGS" && first.ch.empty()) first = e;
      if (inserted || e.t - t0 < 600 * kUsPerSecond || e.ch != "ACCEL") return std::vector<Event>{e};
      inserted = true;
      auto m = decodeAs<boresight_lcm::nominal_mountings_t>(first);
      m.utime = decodeAs<boresight_lcm::accel_sample_t>(e).utime;  // the data time there
      change(m);
      return std::vector<Event>{encodeAs("NOMINAL_MOUNTINGS", e.t, m), e};
    });
  };
  auto attitudes = [](const Replay& r) { return r.out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE"); };
  const auto ref_att = attitudes(*ref);
  ASSERT_GT(ref_att.size(), 1000u);

  // The same mountings again: used, nothing changes.
  const auto same = replay(withMountings("same.lcm", [](boresight_lcm::nominal_mountings_t&) {}), nodeConfig());
  EXPECT_EQ(same->c.mountings_applied, 0u);
  EXPECT_EQ(same->c.used, ref->c.used + 1);
  EXPECT_EQ(same->c.rows, ref->c.rows);

  // Not a unit quaternion: rejected, nothing changes.
  const auto bad = replay(withMountings("bad.lcm", [](boresight_lcm::nominal_mountings_t& m) {
                            for (int j = 0; j < 4; ++j) m.q_Si_B[1][j] *= 1.1;
                          }),
                          nodeConfig());
  EXPECT_EQ(bad->c.mountings_applied, 0u);
  EXPECT_EQ(rejected(bad->c, io::Reject::kNonUnit), rejected(ref->c, io::Reject::kNonUnit) + 1);
  EXPECT_EQ(bad->c.rows, ref->c.rows);

  // Head 2's mounting 100" about its x axis: applied at the next head epoch, the rows before it as they
  // were (mountings identifier 0), the rows after it with identifier 1 and moved.
  TimeUs t_msg = 0;
  const auto moved = replay(withMountings("moved.lcm",
                                          [&](boresight_lcm::nominal_mountings_t& m) {
                                            const Quat q(m.q_Si_B[1][0], m.q_Si_B[1][1], m.q_Si_B[1][2], m.q_Si_B[1][3]);
                                            const Quat q2 = (model::quatExp(Vec3(100 * kRadPerArcsec, 0, 0)) * q).normalized();
                                            m.q_Si_B[1][0] = q2.w();
                                            m.q_Si_B[1][1] = q2.x();
                                            m.q_Si_B[1][2] = q2.y();
                                            m.q_Si_B[1][3] = q2.z();
                                            t_msg = m.utime;
                                          }),
                            nodeConfig());
  const node::Counters& c = moved->c;
  EXPECT_EQ(c.mountings_applied, 1u);
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  const auto att = attitudes(*moved);
  std::map<TimeUs, boresight_lcm::fused_attitude_t> by_t;
  for (const auto& a : ref_att) by_t[a.utime] = a;
  std::size_t before_same = 0, before = 0;
  std::vector<double> after_d;
  for (const auto& a : att) {
    const auto it = by_t.find(a.utime);
    if (it == by_t.end()) continue;
    const Quat q(a.q_I_B[0], a.q_I_B[1], a.q_I_B[2], a.q_I_B[3]);
    const Quat p(it->second.q_I_B[0], it->second.q_I_B[1], it->second.q_I_B[2], it->second.q_I_B[3]);
    if (a.utime < t_msg - 2 * kUsPerSecond) {
      ++before;
      if (q.angularDistance(p) == 0.0 && a.mounting_version == 0) ++before_same;
    } else if (a.utime > t_msg + 5 * kUsPerSecond && a.heads_used >= 2) {
      EXPECT_EQ(a.mounting_version, 1);
      after_d.push_back(q.angularDistance(p) / kRadPerArcsec);
    }
  }
  EXPECT_GT(before, 500u);
  EXPECT_EQ(before_same, before);
  ASSERT_GT(after_d.size(), 300u);
  std::nth_element(after_d.begin(), after_d.begin() + static_cast<std::ptrdiff_t>(after_d.size() / 2), after_d.end());
  std::printf("new mountings (head 2 moved 100 arcsec): the fused attitude after them moves by %.1f arcsec (median)\n",
              after_d[after_d.size() / 2]);
  EXPECT_GT(after_d[after_d.size() / 2], 10.0);
}

TEST(NodeReplay, GroundCommandsAcceptAHeldCalibrationAndRevertIt) {
  // hold_for_command: the demo span's calibration (ready at 850 s) waits; an accept at 900 s applies
  // it (frame change included), a revert at 1000 s goes back to the nominal mountings and frame. An
  // accept with nothing held and a revert naming a calibration not in use are refused (reason command).
  const std::string full = simulate("command", 1200, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  struct Cmd {
    double at_s;
    int command;
    int id;
  };
  const std::vector<Cmd> cmds = {{300, 1, 0}, {900, 1, 0}, {950, 2, 7}, {1000, 2, 1}};
  std::vector<TimeUs> cmd_t(cmds.size(), 0);
  TimeUs t0 = -1;
  std::size_t next = 0;
  const std::string log = editLog(full, "command.lcm", [&](std::size_t, const Event& e) {
    if (t0 < 0) t0 = e.t;
    if (next == cmds.size() || e.ch != "ACCEL" || static_cast<double>(e.t - t0) * 1e-6 < cmds[next].at_s) return std::vector<Event>{e};
    boresight_lcm::node_command_t m{};
    m.utime = decodeAs<boresight_lcm::accel_sample_t>(e).utime;
    m.seq = static_cast<std::int32_t>(next);
    m.command = static_cast<std::int8_t>(cmds[next].command);
    m.calibration_id = cmds[next].id;
    cmd_t[next++] = m.utime;
    return std::vector<Event>{encodeAs("BORESIGHT_COMMAND", e.t, m), e};
  });
  ASSERT_EQ(next, cmds.size());
  auto cfgWith = [](bool hold) {
    auto cfg = nodeConfig(3600, 840);
    cfg.calibration.apply_lag_epochs = 20;
    cfg.calibration.apply_common_rotation = true;
    cfg.calibration.frame_change_min_interval_s = 0;
    cfg.calibration.hold_for_command = hold;
    return cfg;
  };
  testing::internal::CaptureStderr();
  const auto r = replay(log, cfgWith(true));
  const std::string err_out = testing::internal::GetCapturedStderr();
  const auto automatic = replay(full, cfgWith(false));
  const node::Counters& c = r->c;
  EXPECT_EQ(c.received, c.used + c.rejectedTotal());
  EXPECT_EQ(c.calibrations_held, 1u);
  EXPECT_EQ(c.commands_accepted, 1u);
  EXPECT_EQ(c.commands_reverted, 1u);
  EXPECT_EQ(c.calibrations_applied, 1u);
  EXPECT_EQ(c.frame_changes, 1u);
  EXPECT_EQ(rejected(c, io::Reject::kCommand), 2u);
  EXPECT_NE(err_out.find("command accept"), std::string::npos) << err_out;
  EXPECT_NE(err_out.find("command revert"), std::string::npos) << err_out;
  EXPECT_EQ(automatic->c.calibrations_applied, 1u);

  // Rows by time: identifier 0 before the accept, 1 until the revert, 0 after; between them as the run
  // that applied the calibration by itself, after the revert as in the same data without it. (A command
  // takes effect at the head epoch stepped next, up to the look-ahead, 2 s, before its arrival time.)
  const auto plain = replay(full, [&] {
    auto cfg = cfgWith(false);
    cfg.calibration.enabled = false;
    return cfg;
  }());
  auto table = [](const Replay& x) {
    std::map<TimeUs, boresight_lcm::fused_attitude_t> m;
    for (const auto& a : x.out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE")) m[a.utime] = a;
    return m;
  };
  const auto auto_t = table(*automatic), plain_t = table(*plain);
  auto angle = [](const boresight_lcm::fused_attitude_t& a, const boresight_lcm::fused_attitude_t& b) {
    return Quat(a.q_I_B[0], a.q_I_B[1], a.q_I_B[2], a.q_I_B[3]).angularDistance(Quat(b.q_I_B[0], b.q_I_B[1], b.q_I_B[2], b.q_I_B[3])) /
           kRadPerArcsec;
  };
  std::vector<double> mid, after;
  int wrong_id = 0;
  for (const auto& a : r->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE")) {
    if (a.utime < cmd_t[1] - 3 * kUsPerSecond) {
      wrong_id += a.mounting_version != 0;
    } else if (a.utime > cmd_t[1] + 2 * kUsPerSecond && a.utime < cmd_t[3] - 3 * kUsPerSecond) {
      wrong_id += a.mounting_version != 1;
      if (auto it = auto_t.find(a.utime); it != auto_t.end() && a.heads_used >= 2) mid.push_back(angle(a, it->second));
    } else if (a.utime > cmd_t[3] + 2 * kUsPerSecond) {
      wrong_id += a.mounting_version != 0;
      if (auto it = plain_t.find(a.utime); it != plain_t.end() && a.heads_used >= 2) {
        after.push_back(angle(a, it->second));
      }
    }
  }
  EXPECT_EQ(wrong_id, 0);
  ASSERT_GT(mid.size(), 50u);
  ASSERT_GT(after.size(), 100u);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  std::printf("accepted: %.2f arcsec from the run that applied it itself; reverted: %.2f from the run without calibration\n",
              median(mid), median(after));
  EXPECT_LT(median(mid), 1.0);
  EXPECT_LT(median(after), 1.0);
}

TEST(NodeReplay, AStateFileKeepsTheCalibrationAndTheFrameAcrossARestart) {
  // The demo span with a frame change (840 s + 20 epochs), cut at 1000 s of log time: the node is
  // restarted there. With the state file the second run publishes what the uninterrupted run does
  // (the same calibration identifier, the same frame: the filters restart, so arc seconds apart at
  // most); without it the attitude jumps back to the heads' datum by the whole common rotation.
  const std::string full = simulate("state", 1200, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  const std::string dir = makeTempDir("node_state");
  auto part = [&](const std::string& name, bool second) {
    TimeUs t0 = -1;
    return editLog(full, name, [&](std::size_t, const Event& e) {
      if (t0 < 0) t0 = e.t;
      if (e.ch == "NOMINAL_MOUNTINGS") return std::vector<Event>{e};
      const bool late = static_cast<double>(e.t - t0) * 1e-6 >= 1000;
      return late == second ? std::vector<Event>{e} : std::vector<Event>{};
    });
  };
  const std::string first = part("first.lcm", false), second = part("second.lcm", true);
  auto cfgWith = [&](const std::string& state) {
    auto cfg = nodeConfig(3600, 840);
    cfg.calibration.apply_lag_epochs = 20;
    cfg.calibration.apply_common_rotation = true;
    cfg.calibration.frame_change_min_interval_s = 0;
    cfg.state_file = state;
    return cfg;
  };
  const std::string state = dir + "/state.yaml";
  const auto whole = replay(full, cfgWith(""));
  ASSERT_EQ(whole->c.frame_changes, 1u);
  testing::internal::CaptureStderr();
  const auto r1 = replay(first, cfgWith(state));
  testing::internal::GetCapturedStderr();
  ASSERT_EQ(r1->c.calibrations_applied, 1u);
  model::Overlay st;
  std::string err;
  ASSERT_TRUE(io::readOverlay(state, st, &err)) << err;
  ASSERT_TRUE(st.published_frame.has_value());
  EXPECT_EQ(st.published_frame->calibration, 1);
  EXPECT_EQ(st.mountings.size(), 3u);
  testing::internal::CaptureStderr();
  const auto r2 = replay(second, cfgWith(state));
  const std::string log2 = testing::internal::GetCapturedStderr();
  EXPECT_NE(log2.find("state from"), std::string::npos) << log2;
  const auto r2_bare = replay(second, cfgWith(""));

  auto ref = whole->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  std::map<TimeUs, boresight_lcm::fused_attitude_t> by_t;
  for (const auto& a : ref) by_t[a.utime] = a;
  // Median angle from the uninterrupted run over the second run's rows (two heads or more in use).
  auto median = [&](const Replay& r, std::int32_t* version) {
    std::vector<double> d;
    for (const auto& a : r.out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE")) {
      // the uninterrupted run's rows fall on other epochs (every second one): interpolated to a.utime
      const auto hi = by_t.lower_bound(a.utime);
      if (hi == by_t.end() || hi == by_t.begin() || a.heads_used < 2) continue;
      const auto lo = std::prev(hi);
      if (hi->first - lo->first > 2 * kUsPerSecond) continue;
      auto quat = [](const boresight_lcm::fused_attitude_t& x) { return Quat(x.q_I_B[0], x.q_I_B[1], x.q_I_B[2], x.q_I_B[3]); };
      const double w = hi->first == lo->first ? 0.0 : static_cast<double>(a.utime - lo->first) / static_cast<double>(hi->first - lo->first);
      const Quat q = quat(a), p = quat(lo->second).slerp(w, quat(hi->second));
      d.push_back(q.angularDistance(p) / kRadPerArcsec);
      *version = a.mounting_version;
    }
    EXPECT_GT(d.size(), 100u);
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2];
  };
  std::int32_t v_state = -1, v_bare = -1;
  const double with_state = median(*r2, &v_state), without = median(*r2_bare, &v_bare);
  std::printf("restart at 1000 s: median %.2f arcsec from the uninterrupted run with the state file, %.1f without\n",
              with_state, without);
  EXPECT_LT(with_state, 5.0);
  EXPECT_GT(without, 100.0);
  EXPECT_EQ(v_state, 1);
  EXPECT_EQ(v_bare, 0);
  // A state file that is not one is refused at start with its name.
  ASSERT_TRUE(testutil::writeFile(dir + "/bad.yaml", "boresight_overlay: 1\nwritten_by: x\nnote: y\n"));
  node::Node n;
  EXPECT_FALSE(n.configure(cfgWith(dir + "/bad.yaml"), node::Node::Mode::kReplay, nullptr, &err));
  EXPECT_NE(err.find("bad.yaml"), std::string::npos) << err;
}

#ifdef BORESIGHTD
namespace {
std::string nodeYaml(const std::string& dir, const std::vector<std::pair<std::string, std::string>>& set) {
  std::ifstream in(src("config/boresightd.yaml"));
  std::ostringstream o;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("platform:", 0) == 0) line = "platform: " + src("config/gracefo.yaml");
    for (const auto& [k, v] : set)
      if (line.find(k + ":") != std::string::npos) line = v;
    o << line << "\n";
  }
  const std::string p = dir + "/node.yaml";
  EXPECT_TRUE(testutil::writeFile(p, o.str()));
  return p;
}
}  // namespace

TEST(Boresightd, OutputsNeverDestroyTheLogAndEmptyLogsSaySo) {
  const std::string log = simulate("cli_bad", 300, {});
  const std::string dir = makeTempDir("node_cli_bad");
  const std::string cfg = nodeYaml(dir, {});
  const std::string before = testutil::slurp(log);
  // --record over --replay truncated the log and exited 0.
  auto r = testutil::runProgram(BORESIGHTD, "--config " + cfg + " --replay " + log + " --record " + log);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("is also an input"), std::string::npos) << r.out;
  EXPECT_EQ(testutil::slurp(log), before);
  // An empty log exited 0 without a word; a log without head messages too.
  ASSERT_TRUE(testutil::writeFile(dir + "/empty.lcm", ""));
  r = testutil::runProgram(BORESIGHTD, "--config " + cfg + " --replay " + dir + "/empty.lcm --summary-json " + dir +
                                           "/s.json");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("an empty LCM log"), std::string::npos) << r.out;
  EXPECT_NE(::access((dir + "/s.json").c_str(), F_OK), 0);
  const std::string other = editLog(log, "other.lcm", [](std::size_t, const Event& e) {
    return std::vector<Event>{Event{"SOMEONE_ELSE", e.t, e.bytes}};
  });
  r = testutil::runProgram(BORESIGHTD, "--config " + cfg + " --replay " + other);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("no STAR_HEAD message the node could use"), std::string::npos) << r.out;
  // A directory as the platform file: an error, not an uncaught std::ios_base::failure.
  const std::string bad = dir + "/bad.yaml";
  ASSERT_TRUE(testutil::writeFile(bad, "platform: " + dir + "\n"));
  r = testutil::runProgram(BORESIGHTD, "--config " + bad + " --replay " + log);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("is a directory"), std::string::npos) << r.out;
  // The platform's head rate against the data's: both rates, before anything runs.
  std::string plat = testutil::slurp(src("config/gracefo.yaml"));
  plat.replace(plat.find("fs_hz: 2.0"), 10, "fs_hz: 10.0");
  ASSERT_TRUE(testutil::writeFile(dir + "/gracefo10.yaml", plat));
  const std::string cfg10 = nodeYaml(dir, {{"platform", "platform: " + dir + "/gracefo10.yaml"}});
  r = testutil::runProgram(BORESIGHTD, "--config " + cfg10 + " --replay " + log);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("crn_attitude.fs_hz is 10 Hz"), std::string::npos) << r.out;
}

TEST(Boresightd, ARefusedCalibrationSaysWhyAndDecimationHalfASecondWorks) {
  const std::string log = simulate("cli_cal", 1500, {}, nullptr, "config/sim_gracefo_node_demo.yaml");
  const std::string quiet = simulate("cli_cal_quiet", 1500, {});
  const std::string dir = makeTempDir("node_cli_cal");
  // A span too quiet to calibrate: "refused" with no reason before.
  const std::string cfg = nodeYaml(dir, {{"cadence_s", "  cadence_s: 600"},
                                         {"min_span_s", "  min_span_s: 600"},
                                         {"apply_lag_epochs", "  apply_lag_epochs: 20"}});
  auto r = testutil::runProgram(BORESIGHTD, "--config " + cfg + " --replay " + quiet + " --summary-json " + dir + "/s.json");
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string j = testutil::slurp(dir + "/s.json");
  EXPECT_NE(r.out.find("calibration at data time"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("refused:"), std::string::npos) << r.out;
  EXPECT_NE(j.find("\"reason\": \"too"), std::string::npos) << j;
  // The reason is calibrate's (calib::runCalibration): what the span would need comes with it.
  EXPECT_NE(j.find("Needed: the Cramer-Rao bound needs about"), std::string::npos) << j;
  EXPECT_NE(j.find("at this span's weakest-axis excitation"), std::string::npos) << j;
  // decimation_s 0.5 (the head interval): a calibration as at 10 s, not a refusal.
  const std::string cfg05 = nodeYaml(dir, {{"cadence_s", "  cadence_s: 1200"},
                                           {"min_span_s", "  min_span_s: 1200"},
                                           {"apply_lag_epochs", "  apply_lag_epochs: 20"},
                                           {"decimation_s", "  decimation_s: 0.5"}});
  r = testutil::runProgram(BORESIGHTD, "--config " + cfg05 + " --replay " + log + " --summary-json " + dir + "/s05.json");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(testutil::slurp(dir + "/s05.json").find("\"status\": \"ok\""), std::string::npos)
      << testutil::slurp(dir + "/s05.json") << r.out;
}

TEST(Boresightd, SigtermStopsAReplayWithCompleteOutputsAndTheSummary) {
  // The CSV goes to a FIFO the test does not read at first: the replay blocks on it, so the signal
  // surely arrives while it runs; then the test reads, the replay notices the signal at the next event.
  const std::string log = simulate("cli_term", 3600, {});
  const std::string dir = makeTempDir("node_cli_term");
  const std::string cfg = nodeYaml(dir, {});
  const std::string fifo = dir + "/rows.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int devnull = ::open("/dev/null", O_WRONLY);
    ::dup2(devnull, 1);
    ::dup2(devnull, 2);
    const std::string sj = dir + "/s.json";
    ::execl(BORESIGHTD, BORESIGHTD, "--config", cfg.c_str(), "--replay", log.c_str(), "--csv", fifo.c_str(),
            "--summary-json", sj.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  const int fd = ::open(fifo.c_str(), O_RDONLY);  // returns once boresightd opened it for writing
  ASSERT_GE(fd, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the pipe is full: the replay waits
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  std::string csv;
  char buf[65536];
  ssize_t got;
  while ((got = ::read(fd, buf, sizeof buf)) > 0) csv.append(buf, static_cast<std::size_t>(got));
  ::close(fd);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WEXITSTATUS(status), 1);  // interrupted: not a complete run
  const std::string j = testutil::slurp(dir + "/s.json");
  EXPECT_NE(j.find("\"interrupted\": true"), std::string::npos) << j;
  EXPECT_NE(j.find("\"accounted\": true"), std::string::npos) << j;
  ASSERT_FALSE(csv.empty());
  EXPECT_EQ(csv.back(), '\n') << "the CSV was cut mid-line";
  std::istringstream in(csv);
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), 8) << line;
    ++rows;
  }
  EXPECT_GT(rows, 100);
  EXPECT_LT(rows, 3600) << "the replay ran to the end: the signal was ignored";
}
#endif

TEST(NodeConfig, OverlayKeyLaysItsNoiseAndMountingsOverThePlatform) {
  const std::string dir = makeTempDir("node_overlay");
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string p = dir + "/" + name;
    std::ofstream(p) << text;
    return p;
  };
  const std::string node_yaml = "platform: " + src("config/gracefo_ideal.yaml") + "\noverlay: ov.yaml\n";
  node::NodeConfig cfg;
  std::string err;
  // refused with the overlay's file and line: an unknown version, an unknown key
  write("ov.yaml", "boresight_overlay: 7\nwritten_by: test\n");
  EXPECT_FALSE(node::loadNodeConfig(write("n.yaml", node_yaml), cfg, &err));
  EXPECT_NE(err.find("n.yaml:2: key 'overlay': " + dir + "/ov.yaml:1: key 'boresight_overlay': unsupported version 7"), std::string::npos) << err;
  write("ov.yaml", "boresight_overlay: 1\nwritten_by: test\nnoise:\n  head_defaults:\n    cross_z: []\n");
  EXPECT_FALSE(node::loadNodeConfig(dir + "/n.yaml", cfg, &err));
  EXPECT_NE(err.find(dir + "/ov.yaml:5: key 'noise.head_defaults.cross_z': unknown key"), std::string::npos) << err;
  // the overlay's noise reaches the core's sigmas and the worker's accelerometer weight; its
  // mountings of every head replace the NOMINAL_MOUNTINGS message
  write("ov.yaml",
        "boresight_overlay: 1\nwritten_by: test\n"
        "noise:\n  heads:\n    - {id: 2, about_boresight: [{kind: white, sigma_arcsec: 90}]}\n"
        "  accelerometer:\n    y: [{kind: white, sigma_rad_s2: 7.0e-8}]\n"
        "mountings:\n"
        "  - {head: 1, q_Si_B: [1, 0, 0, 0], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\n"
        "  - {head: 2, q_Si_B: [0, 1, 0, 0], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\n"
        "  - {head: 3, q_Si_B: [0, 0, 1, 0], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\n"
        "time_offsets:\n  - {sensor: accelerometer, relative_to: heads, offset_s: 0.015, offset_sigma_s: 0.001}\n");
  ASSERT_TRUE(node::loadNodeConfig(dir + "/n.yaml", cfg, &err)) << err;
  EXPECT_NEAR(cfg.pipeline.heads.head[1].sigma_roll_rad * kArcsecPerRad, 90.0, 1e-12);
  EXPECT_NEAR(cfg.pipeline.heads.head[0].sigma_roll_rad * kArcsecPerRad, 48.0, 1e-12);
  EXPECT_EQ(cfg.acc_white_noise_radps2, Vec3(1.5e-7, 7.0e-8, 5.0e-8));
  EXPECT_EQ(cfg.overlay_mounting_mask, 7u);
  EXPECT_FALSE(cfg.mountings_from_log);  // nothing to wait for
  EXPECT_TRUE(cfg.pipeline.heads.head[1].q_Si_B.coeffs() == Quat(0, 1, 0, 0).coeffs());
  std::string lines;
  for (const auto& l : cfg.model_in_use) lines += l + "\n";
  for (const char* what : {"about_boresight white 90\" (overlay " , "noise.heads[id 2])", "not applied: time_offsets: boresightd",
                           "head 3: overlay "})
    EXPECT_NE(lines.find(what), std::string::npos) << what << " not in\n" << lines;
  // mountings of some heads only: the message still sets the others
  write("ov.yaml", "boresight_overlay: 1\nwritten_by: test\nmountings:\n"
                   "  - {head: 2, q_Si_B: [0, 1, 0, 0], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\n");
  ASSERT_TRUE(node::loadNodeConfig(dir + "/n.yaml", cfg, &err)) << err;
  EXPECT_EQ(cfg.overlay_mounting_mask, 2u);
  EXPECT_TRUE(cfg.mountings_from_log);
}

TEST(NodeReplay, OverlayMountingsSurviveTheMountingsMessage) {
  // The log's NOMINAL_MOUNTINGS message sets heads 1 and 3; head 2 keeps the overlay's mounting (here
  // the truth with its mounting error: the fused attitude moves, the message's value would not).
  std::array<Quat, 4> q_true{}, q_nominal{};
  const std::string log = simulate("overlay_mount", 300, {}, nullptr, "config/sim_gracefo.yaml", &q_true, &q_nominal);
  node::NodeConfig plain = nodeConfig();
  plain.calibration.enabled = false;
  const std::string dir = makeTempDir("node_overlay_replay");
  const Quat q2 = q_true[1];
  std::ofstream(dir + "/ov.yaml") << "boresight_overlay: 1\nwritten_by: test\nmountings:\n  - {head: 2, q_Si_B: [" << std::setprecision(17)
                                  << q2.w() << ", " << q2.x() << ", " << q2.y() << ", " << q2.z()
                                  << "], datum: ground, epoch: \"2023-06-01\", sigma_arcsec: [1, 1, 1]}\n";
  std::ofstream(dir + "/n.yaml") << "platform: " << src("config/gracefo_ideal.yaml") << "\noverlay: ov.yaml\n";
  node::NodeConfig with;
  std::string err;
  ASSERT_TRUE(node::loadNodeConfig(dir + "/n.yaml", with, &err)) << err;
  with.calibration.enabled = false;
  const auto a = replay(log, plain), b = replay(log, with);
  const auto qa = a->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  const auto qb = b->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  ASSERT_EQ(qa.size(), qb.size());
  ASSERT_GT(qa.size(), 100u);
  // the pipeline's head 2 mounting after the message: the overlay's, not the message's (nominal)
  EXPECT_TRUE(with.overlay_mounting_mask == 2u);
  double max_diff = 0;
  for (std::size_t i = 0; i < qa.size(); ++i) {
    const Quat x(qa[i].q_I_B[0], qa[i].q_I_B[1], qa[i].q_I_B[2], qa[i].q_I_B[3]);
    const Quat y(qb[i].q_I_B[0], qb[i].q_I_B[1], qb[i].q_I_B[2], qb[i].q_I_B[3]);
    max_diff = std::max(max_diff, 2 * std::asin(std::min(1.0, (x.conjugate() * y).vec().norm())) * kArcsecPerRad);
  }
  EXPECT_GT(max_diff, 1.0) << "head 2's mounting from the overlay did not reach the fusion";
  EXPECT_EQ(a->c.used, b->c.used);  // the message is used (it sets heads 1 and 3) in both runs
}

TEST(NodeReplay, OverlayAccelerometerTermsCorrectThePublishedAngularAcceleration) {
  // An overlay's accelerometer terms correct every sample before the core, as in process and the audit:
  // a_A <- M (a_A - b). The CRN is linear with unit gain at zero frequency, so every published row
  // with the terms is C_B_A M (C_B_A^T row_without - b) of the same replay without them.
  const std::string log = simulate("overlay_acc", 300, {});
  const std::string dir = makeTempDir("node_overlay_acc");
  std::ofstream(dir + "/ov.yaml") << "boresight_overlay: 1\nwritten_by: test\naccelerometer:\n"
                                  << "  bias_rad_s2: [2.0e-6, -1.0e-6, 5.0e-7]\n  bias_sigma_rad_s2: [1.0e-8, 1.0e-8, 1.0e-8]\n"
                                  << "  scale: [0.02, -0.01, 0.03]\n  scale_sigma: [1.0e-4, 1.0e-4, 1.0e-4]\n"
                                  << "  misalignment_arcsec: [200, -100, 50]\n  misalignment_sigma_arcsec: [5, 5, 5]\n";
  std::ofstream(dir + "/n.yaml") << "platform: " << src("config/gracefo_ideal.yaml") << "\noverlay: ov.yaml\n";
  std::ofstream(dir + "/plain.yaml") << "platform: " << src("config/gracefo_ideal.yaml") << "\n";
  node::NodeConfig plain, with;
  std::string err;
  ASSERT_TRUE(node::loadNodeConfig(dir + "/plain.yaml", plain, &err)) << err;
  ASSERT_TRUE(node::loadNodeConfig(dir + "/n.yaml", with, &err)) << err;
  plain.calibration.enabled = with.calibration.enabled = false;
  ASSERT_TRUE(with.pipeline.acc_correction.on);
  EXPECT_FALSE(plain.pipeline.acc_correction.on);
  std::string lines;
  for (const auto& l : with.model_in_use) lines += l + "\n";
  EXPECT_NE(lines.find("accelerometer: bias, scale, misalignment (every accelerometer sample corrected"), std::string::npos) << lines;
  EXPECT_EQ(lines.find("does not apply accelerometer terms"), std::string::npos) << lines;

  const auto a = replay(log, plain), b = replay(log, with);
  const auto ra = a->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  const auto rb = b->out.all<boresight_lcm::fused_attitude_t>("BORESIGHT_ATTITUDE");
  ASSERT_EQ(ra.size(), rb.size());
  const Mat3 C = with.pipeline.C_B_A, M = with.pipeline.acc_correction.M;
  const Vec3 bias = with.pipeline.acc_correction.bias_A;
  int compared = 0;
  double worst = 0, moved = 0;
  for (std::size_t i = 0; i < ra.size(); ++i) {
    ASSERT_EQ(ra[i].utime, rb[i].utime);
    ASSERT_EQ(ra[i].has_acc, rb[i].has_acc);
    if (!ra[i].has_acc) continue;
    const Vec3 x(ra[i].alpha_acc_B[0], ra[i].alpha_acc_B[1], ra[i].alpha_acc_B[2]);
    const Vec3 y(rb[i].alpha_acc_B[0], rb[i].alpha_acc_B[1], rb[i].alpha_acc_B[2]);
    worst = std::max(worst, (y - C * M * (C.transpose() * x - bias)).norm());
    moved = std::max(moved, (y - x).norm());
    ++compared;
  }
  ASSERT_GT(compared, 200);
  EXPECT_GT(moved, 1e-6) << "the terms did not reach the published angular acceleration";
  EXPECT_LT(worst, 1e-12) << "rad/s^2: not the corrected samples through the same filter";
  EXPECT_EQ(a->c.used, b->c.used);
}

}  // namespace
}  // namespace boresight

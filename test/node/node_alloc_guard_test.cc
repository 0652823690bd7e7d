// Guard: the node's real-time path makes no heap allocation per message once started. The path is
// what boresightd runs on its real-time thread for every message: the log reader (replay) or LCM's
// dispatch (live) -> Node::onMessage (decode, validate, count) -> the epoch assembler -> the core's
// steps -> encoding the outputs -> Output::publish (the recorder: io::LcmLogWriter::writeRaw), and at
// epoch boundaries the calibration hand-over and the frame change.
//
// Detector: every operator new and (outside sanitizer builds) malloc/calloc/realloc/aligned
// allocations are replaced and counted, but only on the thread that armed the count: the worker and
// its Ceres solver allocate freely on their own threads and are not counted. LCM's own live transport
// (lcm::LCM::publish and handle on udpm) is measured and printed, not asserted (see DESIGN.md).
#include <boresight/io/lcm_log.h>
#include <boresight/node/node.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include "boresight_lcm/star_head_sample_t.hpp"
#include "test_files.h"

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "alloc_interpose.h"

namespace boresight {
namespace {

/// Counts allocations made by this thread while alive.
class Count {
 public:
  Count() { allocguard::arm(/*this_thread_only=*/true); }
  ~Count() { stop(); }
  long stop() { return allocguard::disarm(); }
};

std::string src(const std::string& rel) { return std::string(BORESIGHT_SOURCE_DIR) + "/" + rel; }

/// Publishes into nothing: counts and sums the bytes (the node's encode is what is measured).
struct SumOutput : node::Output {
  std::uint64_t n = 0, bytes = 0;
  io::LcmLogWriter* rec = nullptr;
  void publish(const std::string& ch, TimeUs t, const void* data, int size) override {
    ++n;
    bytes += static_cast<std::uint64_t>(size);
    if (rec) rec->writeRaw(ch, t, data, size);
  }
};

/// The demo span (5 deg manoeuvres, hidden mounting and accelerometer errors), simulated once.
const std::string& simLog() {
  static const std::string path = [] {
    const std::string dir = testutil::makeTempDir("node_alloc");
    sim::Scenario sc;
    std::string err;
    EXPECT_TRUE(sim::loadScenario(src("config/sim_gracefo_node_demo.yaml"), sc, &err)) << err;
    sim::Simulator s;
    EXPECT_TRUE(s.init(sc, 3, 1500, &err)) << err;
    sim::LcmSink log;
    const std::string p = dir + "/sim.lcmlog";
    EXPECT_TRUE(log.open(p, &err)) << err;
    EXPECT_TRUE(log.writeMountings(s));
    s.run(log);
    EXPECT_TRUE(log.close(&err)) << err;
    return p;
  }();
  return path;
}

TEST(NodeAllocGuard, DetectorCountsOnlyTheArmedThread) {
  {
    Count c;
    auto* p = new int(3);
    const long n = c.stop();
    delete p;
    EXPECT_GE(n, 1);  // the guard can fail
  }
  {
    std::thread t;
    long n = 0;
    {
      Count c;
      t = std::thread([] {
        for (int i = 0; i < 100; ++i) delete new int(i);
      });
      t.join();
      n = c.stop();
    }
    EXPECT_LT(n, 100);  // the other thread's 100 allocations are not counted (the thread's state may be)
  }
}

void replaySteadyState(bool record) {
  node::NodeConfig cfg;
  std::string err;
  ASSERT_TRUE(node::loadNodeConfig(src("config/boresightd.yaml"), cfg, &err)) << err;
  cfg.calibration.min_span_s = 600;   // calibrations at 600, 900, 1200 s of data ...
  cfg.calibration.cadence_s = 300;
  cfg.calibration.apply_lag_epochs = 20;
  cfg.calibration.apply_common_rotation = true;  // ... each applied, with a frame change
  cfg.calibration.frame_change_min_interval_s = 0;  // every determined one (the rate limit is tested in node_test)
  const std::string dir = testutil::makeTempDir("node_alloc_rec");
  io::LcmLogWriter rec;
  ASSERT_TRUE(rec.open(dir + "/out.lcmlog", &err)) << err;
  SumOutput out;
  out.rec = record ? &rec : nullptr;
  node::Node n;
  ASSERT_TRUE(n.configure(cfg, node::Node::Mode::kReplay, &out, &err)) << err;
  io::LcmLogReader r;
  ASSERT_TRUE(r.open(simLog(), &err)) << err;
  io::LcmLogReader::RawEvent ev;
  // Start-up: the mountings message starts the core and the worker thread, the reader's and the
  // recorder's buffers reach their size, the first outputs are encoded: the first 120 s of data.
  std::uint64_t events = 0;
  while (r.nextRaw(ev)) {
    n.onMessage(*ev.channel, ev.data, ev.size);
    ++events;
    if (n.dataTime() > 0 && events > 1000 && n.counters().head_epochs > 240) break;
  }
  const node::Counters c0 = n.counters();
  std::map<std::string, long> by_channel;  // which inputs allocated (for the message when it fails)
  long total = 0;
  std::uint64_t steady = 0;
  for (;;) {
    Count c;
    const bool more = r.nextRaw(ev);
    if (more) n.onMessage(*ev.channel, ev.data, ev.size);
    const long a = c.stop();
    if (!more) break;
    ++steady;
    if (a) by_channel[*ev.channel] += a;
    total += a;
  }
  const node::Counters c1 = n.counters();
  n.finish();
  rec.close();
  std::printf("%s steady state: %llu messages, %llu head epochs, %llu rows, %llu calibrations applied, %llu frame changes, "
              "%llu outputs: %ld allocations on the real-time thread\n", record ? "recording," : "no recorder,",
              static_cast<unsigned long long>(steady), static_cast<unsigned long long>(c1.head_epochs - c0.head_epochs),
              static_cast<unsigned long long>(c1.rows - c0.rows),
              static_cast<unsigned long long>(c1.calibrations_applied - c0.calibrations_applied),
              static_cast<unsigned long long>(c1.frame_changes), static_cast<unsigned long long>(out.n),
              total);
  // The steady phase covers what it claims: epochs, rows, calibrations handed over and published.
  EXPECT_GT(steady, 10000u);
  EXPECT_GT(c1.rows - c0.rows, 1000u);
  EXPECT_GE(c1.calibrations_applied - c0.calibrations_applied, 2u);
  EXPECT_GE(c1.frame_changes, 2u);
  EXPECT_EQ(total, 0);
  for (const auto& [ch, k] : by_channel) ADD_FAILURE() << ch << ": " << k << " allocations";
}

TEST(NodeAllocGuard, ReplayAndCalibrationHandOverAllocateNothingPerMessage) { replaySteadyState(false); }
TEST(NodeAllocGuard, RecordingTheOutputsAllocatesNothingPerMessage) { replaySteadyState(true); }

/// Live: LCM's udpm transport delivers into the node's handler. The node's part (the handler) is
/// guarded; what LCM itself allocates per publish and per handle() is measured and printed.
TEST(NodeAllocGuard, LiveHandlerAllocatesNothingAndLcmTransportIsMeasured) {
  lcm::LCM lcm("udpm://239.255.76.67:7671?ttl=0");
  if (!lcm.good()) GTEST_SKIP() << "no udpm multicast on this machine";
  node::NodeConfig cfg;
  std::string err;
  ASSERT_TRUE(node::loadNodeConfig(src("config/boresightd.yaml"), cfg, &err)) << err;
  cfg.calibration.enabled = false;
  SumOutput out;
  node::Node n;
  ASSERT_TRUE(n.configure(cfg, node::Node::Mode::kLive, &out, &err)) << err;
  struct Handler {
    node::Node* n;
    long handler_allocs = 0;
    std::uint64_t calls = 0;
    void onMessage(const lcm::ReceiveBuffer* rb, const std::string& ch) {
      const long before = allocguard::count();
      n->onMessage(ch, rb->data, static_cast<int>(rb->data_size));
      handler_allocs += allocguard::count() - before;
      ++calls;
    }
  } h{&n};
  for (const std::string ch : {"STAR_HEAD", "ACCEL", "STAR_VECTORS", "NOMINAL_MOUNTINGS", "ORBIT"})
    lcm.subscribe(ch, &Handler::onMessage, &h);
  io::LcmLogReader r;
  ASSERT_TRUE(r.open(simLog(), &err)) << err;
  io::LcmLogReader::RawEvent ev;
  long pub_allocs = 0, handle_allocs = 0;
  std::uint64_t published = 0, warm = 0;
  const long max_messages = 6000;
  while (published < static_cast<std::uint64_t>(max_messages) && r.nextRaw(ev)) {
    const bool arm = warm++ > 500;
    {
      Count c;
      if (!arm) c.stop();
      lcm.publish(*ev.channel, ev.data, static_cast<unsigned>(ev.size));
      if (arm) pub_allocs += c.stop();
    }
    {
      const long h0 = h.handler_allocs;
      Count c;
      if (!arm) c.stop();
      while (lcm.handleTimeout(0) > 0) {
      }
      if (arm) handle_allocs += c.stop() - (h.handler_allocs - h0);
      if (!arm) h.handler_allocs = h0;
    }
    if (arm) ++published;
  }
  std::printf("live udpm, %llu messages after warm-up: lcm::LCM::publish %ld allocations, lcm handle() dispatch "
              "(without the node's handler) %ld, the node's handler %ld (%llu messages handled)\n",
              static_cast<unsigned long long>(published), pub_allocs, handle_allocs, h.handler_allocs,
              static_cast<unsigned long long>(h.calls));
  if (h.calls < 1000 || n.counters().rows == 0) GTEST_SKIP() << "multicast loopback delivered only " << h.calls << " messages";
  EXPECT_EQ(h.handler_allocs, 0);
}

}  // namespace
}  // namespace boresight

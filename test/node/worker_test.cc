// The node's calibration worker alone (src/node/worker.h): the mailbox's states across the real-time
// thread and the solver thread, results in request order, the idle hook, the stop; the real-time
// side's calls do not allocate.
#include "worker.h"

#include <boresight/node/node.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "alloc_interpose.h"

namespace {
using namespace boresight;
using node::CalibrationWorker;
using node::MailState;
using node::WorkItem;

core::PipelineConfig nodePipeline() {
  node::NodeConfig cfg;
  std::string err;
  EXPECT_TRUE(node::loadNodeConfig(std::string(BORESIGHT_SOURCE_DIR) + "/config/boresightd.yaml", cfg, &err)) << err;
  return cfg.pipeline;
}

/// Waits (bounded) for the mailbox.
bool waitReady(const CalibrationWorker& w) {
  for (int i = 0; i < 20000 && !w.ready(); ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  return w.ready();
}

TEST(CalibrationWorker, AnsweringEachSolveRequestInTheMailboxInOrder) {
  const core::PipelineConfig pc = nodePipeline();
  ASSERT_GE(pc.heads.n_heads, 2);
  CalibrationWorker w;
  w.init(64);
  std::atomic<int> idles{0};
  calib::SpanOptions so;
  w.start(pc, so, [&] { ++idles; });
  EXPECT_TRUE(w.running());
  EXPECT_FALSE(w.ready());

  // Two requests on a span without data: each is answered (refused, with the solver's reason), the
  // second only after the first was taken (one slot).
  for (std::uint64_t id = 1; id <= 2; ++id) {
    WorkItem s;
    s.kind = WorkItem::kSolve;
    s.t = static_cast<TimeUs>(id) * 1000000;
    s.solve_id = id;
    EXPECT_TRUE(w.push(s));
  }
  ASSERT_TRUE(waitReady(w));
  node::Mailbox& m = w.mailbox();
  EXPECT_EQ(m.state.load(), MailState::kReady);
  EXPECT_EQ(m.solve_id, 1u);
  EXPECT_FALSE(m.ok);
  // A refusal says why, as `boresight calibrate` says it (calib::runCalibration): no CRN output in an
  // empty span, and what the span would need.
  const std::string why(m.reason.data());
  EXPECT_EQ(why.rfind("the span is too short (0.0 s of head data", 0), 0u) << why;
  EXPECT_NE(why.find("\nNeeded: the CRN gives an angular acceleration only with Tf = "), std::string::npos) << why;
  EXPECT_EQ(m.msg.status, 1);
  EXPECT_EQ(m.msg.utime, 1000000);
  EXPECT_EQ(m.msg.n_heads, pc.heads.n_heads);
  EXPECT_EQ(m.msg.head_id[1], pc.heads.head[1].id);
  EXPECT_FALSE(m.common_determined);
  for (int k = 0; k < pc.heads.n_heads; ++k)  // refused: the nominal mountings stand
    EXPECT_LT(m.q_Si_B[static_cast<std::size_t>(k)].angularDistance(pc.heads.head[static_cast<std::size_t>(k)].q_Si_B), 1e-15);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(m.solve_id, 1u) << "the second result waits until the first is taken";
  w.release();
  ASSERT_TRUE(waitReady(w));
  EXPECT_EQ(w.mailbox().solve_id, 2u);
  EXPECT_EQ(w.mailbox().msg.utime, 2000000);

  // New nominal mountings start the span again under a new generation; a result carries it.
  WorkItem mnt;
  mnt.kind = WorkItem::kMountings;
  mnt.solve_id = 7;
  for (int k = 0; k < core::kMaxHeads; ++k) mnt.q_Si_B[static_cast<std::size_t>(k)] = pc.heads.head[static_cast<std::size_t>(k)].q_Si_B;
  w.release();
  EXPECT_TRUE(w.push(mnt));
  WorkItem s3;
  s3.kind = WorkItem::kSolve;
  s3.solve_id = 3;
  EXPECT_TRUE(w.push(s3));
  ASSERT_TRUE(waitReady(w));
  EXPECT_EQ(w.mailbox().nominal_gen, 7u);
  w.release();

  // Stop: the worker and its solver end.
  WorkItem stop;
  stop.kind = WorkItem::kStop;
  EXPECT_TRUE(w.push(stop));
  for (int i = 0; i < 20000 && !w.done(); ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
  EXPECT_TRUE(w.done());
  w.join();
  EXPECT_FALSE(w.running());
  EXPECT_GT(idles.load(), 0) << "the idle hook runs on the worker thread while the ring is empty";
}

// A configuration the worker cannot run is refused by start() with the reason, and no thread starts
// (before, the worker thread found it, never calibrated, and a replay waited for it).
TEST(CalibrationWorker, StartRefusesAConfigurationItCannotRun) {
  const core::PipelineConfig pc = nodePipeline();
  CalibrationWorker w;
  w.init(64);
  calib::SpanOptions so;
  so.decimation_s = 0.1;  // below the head interval
  std::string err;
  EXPECT_FALSE(CalibrationWorker::check(pc, so, &err));
  EXPECT_NE(err.find("decimation_s must be at least the head sampling interval"), std::string::npos) << err;
  err.clear();
  EXPECT_FALSE(w.start(pc, so, nullptr, &err));
  EXPECT_FALSE(w.running());
  EXPECT_NE(err.find("the calibration worker cannot run this configuration"), std::string::npos) << err;
  so.decimation_s = 10.0;
  EXPECT_TRUE(CalibrationWorker::check(pc, so, &err)) << err;
}

TEST(CalibrationWorker, TheRealTimeSideNeitherAllocatesNorWaits) {
  const core::PipelineConfig pc = nodePipeline();
  CalibrationWorker w;
  w.init(16);
  w.start(pc, calib::SpanOptions{}, nullptr);
  WorkItem h;
  h.kind = WorkItem::kAcc;
  h.a_A = Vec3(1e-7, 0, 0);
  int pushed = 0, full = 0;
  allocguard::arm(/*this_thread_only=*/true);
  for (int i = 0; i < 100000; ++i) {
    h.t = static_cast<TimeUs>(i) * 100000;
    if (w.push(h)) ++pushed;
    else ++full;  // a full ring refuses at once (the node counts it); it never waits here
    (void)w.ready();
    (void)w.fill();
  }
  const long n = allocguard::disarm();
  EXPECT_EQ(n, 0);
  EXPECT_EQ(pushed + full, 100000);
  EXPECT_GT(pushed, 0);
  WorkItem stop;
  stop.kind = WorkItem::kStop;
  while (!w.push(stop)) std::this_thread::yield();
  w.join();
  EXPECT_TRUE(w.done());
}

}  // namespace

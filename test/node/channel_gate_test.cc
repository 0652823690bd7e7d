// The sequence bookkeeping of one channel alone (node/channel_gate.h): loss, reordering, corrupt
// numbers, jumps and sender restarts.
#include <boresight/node/channel_gate.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace {
using boresight::node::SequenceCounts;
using boresight::node::SequenceGate;

SequenceCounts feed(const std::vector<std::int32_t>& seqs) {
  SequenceGate g;
  SequenceCounts c;
  for (auto s : seqs) g.check(s, c);
  return c;
}

std::vector<std::int32_t> run(std::int32_t from, std::int32_t to) {
  std::vector<std::int32_t> v;
  for (std::int32_t s = from; s <= to; ++s) v.push_back(s);
  return v;
}

std::vector<std::int32_t> cat(std::vector<std::int32_t> a, const std::vector<std::int32_t>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(SequenceGate, GapsAreLostAndLateArrivalsTakeTheirLossBack) {
  EXPECT_EQ(feed(run(0, 100)).lost, 0u);
  EXPECT_EQ(feed(cat(run(0, 10), run(14, 30))).lost, 3u);  // 11, 12, 13
  // 12 arrives late (after 14): its loss is taken back; a repeat of 14 changes nothing
  EXPECT_EQ(feed(cat(cat(run(0, 10), {14, 12, 14}), run(15, 30))).lost, 2u);
  // a jump of exactly the window, confirmed by the next number: 63 lost
  EXPECT_EQ(feed(cat(run(0, 10), run(74, 80))).lost, 63u);
}

TEST(SequenceGate, OneCorruptNumberEitherWayIsNoLossAndNoRestart) {
  for (std::int32_t bad : {1000000, -5000, 2000000000, 5}) {
    std::vector<std::int32_t> v = run(1000, 1100);
    v.push_back(bad);  // stands for 1101
    const auto rest = run(1102, 1200);
    v.insert(v.end(), rest.begin(), rest.end());
    const SequenceCounts c = feed(v);
    EXPECT_EQ(c.lost, 0u) << bad;
    EXPECT_EQ(c.restarts, 0u) << bad;
  }
}

TEST(SequenceGate, ASenderRestartIsCountedAsOneRestartAndLossesAfterItCountAgain) {
  // counter at 5000 restarts at 0: before, every message until it passed 5000 was taken for a late
  // arrival, and the losses among them were not seen
  std::vector<std::int32_t> v = cat(run(4000, 5000), run(0, 100));
  SequenceCounts c = feed(v);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(c.lost, 0u);
  // losses after the restart are counted
  v = cat(cat(run(4000, 5000), run(0, 100)), run(110, 200));  // 101..109 lost
  c = feed(v);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(c.lost, 9u);
  // a restart whose second message is already missing: that one is lost too
  v = cat(cat(run(4000, 5000), {0}), run(2, 50));
  c = feed(v);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(c.lost, 1u);
  // a new counter far ahead (2^24 or more) is a restart, not millions lost
  v = cat(run(0, 100), run(50000000, 50000100));
  c = feed(v);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(c.lost, 0u);
  // numbers repeated within the window are repeats, not a restart; beyond it, a second restart
  v = cat(cat(run(4000, 5000), run(0, 100)), run(50, 90));
  c = feed(v);
  EXPECT_EQ(c.restarts, 1u) << "50 is within the window of 100: repeats, not a restart";
  EXPECT_EQ(c.lost, 0u);
  v = cat(cat(run(4000, 5000), run(0, 1000)), run(0, 40));
  EXPECT_EQ(feed(v).restarts, 2u);
}

TEST(SequenceGate, TheCounterWrapsWithoutLoss) {
  std::vector<std::int32_t> v;
  for (std::int64_t s = 2147483600LL; s < 2147483700LL; ++s)
    v.push_back(static_cast<std::int32_t>(static_cast<std::uint32_t>(s)));
  const SequenceCounts c = feed(v);
  EXPECT_EQ(c.lost, 0u);
  EXPECT_EQ(c.restarts, 0u);
}

}  // namespace

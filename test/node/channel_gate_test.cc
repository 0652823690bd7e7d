// The node's input gates alone (node/channel_gate.h): the sequence bookkeeping of one channel (loss,
// reordering, corrupt numbers, jumps and sender restarts), a channel's duplicate and flood checks, and
// the time gate's confirmation of jumps.
#include <boresight/node/channel_gate.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
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

using boresight::TimeUs;
using boresight::node::ChannelGate;
using boresight::node::TimeGate;
constexpr TimeUs kS = 1000000;

/// What the gate hands on: every passed message (channel, tag), the refusals by kind, the restarts.
/// Everything passed counts as handed out at once (the node's assembler hands out behind a look-ahead;
/// the gate only asks for the latest tag).
struct Recorder final : TimeGate::Sink {
  std::vector<std::pair<const ChannelGate*, TimeUs>> passed;
  int late = 0, jump = 0, restarts = 0;
  TimeUs handed = std::numeric_limits<TimeUs>::min();
  TimeGate* gate = nullptr;
  void pass(ChannelGate& ch, const boresight::stream::Sample*, int n, TimeUs t) override {
    EXPECT_EQ(n, 1);
    passed.emplace_back(&ch, t);
    ch.passed(t);
    gate->advance(t);
    handed = std::max(handed, t);
  }
  void refuse(bool is_late) override { ++(is_late ? late : jump); }
  TimeUs handedOut() const override { return handed; }
  void restart() override {
    ++restarts;
    handed = std::numeric_limits<TimeUs>::min();
  }
};

/// Two star-camera channels (heads), the accelerometer and the orbit; look-ahead 2 s, 3 to confirm.
struct GateWorld {
  ChannelGate h1, h2, acc, orbit;
  TimeGate gate;
  Recorder rec;
  explicit GateWorld(int confirm = 3, bool orbit_active = false) {
    acc.sensor = ChannelGate::kAccelerometer;
    orbit.sensor = ChannelGate::kOrbit;
    ChannelGate* active[] = {&h1, &h2, &acc, &orbit};
    gate.configure(2 * kS, confirm, active, orbit_active ? 4 : 3);
    rec.gate = &gate;
  }
  void msg(ChannelGate& ch, TimeUs t) {
    boresight::stream::Sample x;
    x.t = t;
    gate.admit(ch, &x, 1, t, rec);
  }
  /// Ten seconds of both sensors from t0: heads at 1 Hz, the accelerometer at 2 Hz.
  void steady(TimeUs t0) {
    for (TimeUs t = t0; t < t0 + 10 * kS; t += kS / 2) {
      if ((t - t0) % kS == 0) {
        msg(h1, t);
        msg(h2, t);
      }
      msg(acc, t);
    }
  }
};

TEST(ChannelGate, DuplicatesAreTheLastEightTagsAndFloodIsCountedPerDataSecond) {
  ChannelGate g;
  for (TimeUs t = 0; t < 10; ++t) g.passed(t * kS);
  EXPECT_TRUE(g.duplicate(9 * kS));
  EXPECT_TRUE(g.duplicate(2 * kS));
  EXPECT_FALSE(g.duplicate(1 * kS)) << "only the last eight tags are kept";
  EXPECT_FALSE(g.duplicate(10 * kS));
  EXPECT_EQ(g.last_pass_t, 9 * kS);
  int flooded = 0;
  for (int i = 0; i < 5; ++i) flooded += g.flooded(20 * kS + i, 2.5) ? 1 : 0;  // 3 allowed in this second
  EXPECT_EQ(flooded, 2);
  EXPECT_FALSE(g.flooded(21 * kS, 2.5)) << "a new data second starts its own count";
  EXPECT_FALSE(g.flooded(-kS / 2, 1.0));  // negative tags: second -1
  EXPECT_TRUE(g.flooded(-1, 1.0));
  EXPECT_FALSE(g.flooded(0, 1.0));
}

TEST(TimeGate, TagsWithinTheLookAheadPassAndMoveTheDataTime) {
  GateWorld w;
  w.steady(100 * kS);
  EXPECT_EQ(w.rec.passed.size(), 40u);
  EXPECT_EQ(w.gate.now(), 100 * kS + 19 * kS / 2);
  EXPECT_EQ(w.gate.heldCount(), 0u);
  EXPECT_EQ(w.gate.resyncs(), 0u);
}

TEST(TimeGate, OneCorruptTagIsHeldThenRefusedAndNeverMovesTheDataTime) {
  GateWorld w;
  w.steady(100 * kS);
  const TimeUs now = w.gate.now();
  w.msg(w.h1, now + 1000 * kS);  // far ahead: held
  EXPECT_EQ(w.gate.heldCount(), 1u);
  EXPECT_EQ(w.rec.passed.size(), 40u);
  w.msg(w.acc, now + kS / 2);  // the stream goes on: the held one is refused as a jump
  EXPECT_EQ(w.rec.jump, 1);
  EXPECT_EQ(w.rec.late, 0);
  w.msg(w.h2, now - 1000 * kS);  // far back, behind what was handed out: late when refuted
  w.msg(w.acc, now + kS);
  EXPECT_EQ(w.rec.late, 1);
  EXPECT_EQ(w.gate.now(), now + kS);
  EXPECT_EQ(w.gate.resyncs(), 0u);
  EXPECT_EQ(w.rec.restarts, 0);
}

TEST(TimeGate, AJumpNeedsTheVotesOfEverySensorActiveLately) {
  GateWorld w;
  w.steady(100 * kS);
  const TimeUs j = w.gate.now() + 500 * kS;
  // the star cameras alone (both heads, three messages) cannot confirm while the accelerometer is active
  w.msg(w.h1, j);
  w.msg(w.h2, j);
  w.msg(w.h1, j + kS);
  EXPECT_EQ(w.gate.resyncs(), 0u);
  EXPECT_EQ(w.rec.passed.size(), 40u);
  w.msg(w.acc, j + kS / 2);  // the accelerometer agrees: confirmed
  EXPECT_EQ(w.gate.resyncs(), 1u);
  ASSERT_EQ(w.rec.passed.size(), 44u);
  // the held messages pass in their arrival order, then the confirming one; the data time moves to
  // the earliest of them and onward
  EXPECT_EQ(w.rec.passed[40].second, j);
  EXPECT_EQ(w.rec.passed[42].second, j + kS);
  EXPECT_EQ(w.rec.passed[43].second, j + kS / 2);
  EXPECT_EQ(w.gate.now(), j + kS);
  EXPECT_EQ(w.rec.restarts, 0) << "a jump forward does not restart the consumer";
  EXPECT_EQ(w.rec.jump + w.rec.late, 0);
}

TEST(TimeGate, OneSensorWithAClockOffIsRefutedByTheOther) {
  GateWorld w;
  w.steady(100 * kS);
  TimeUs t = w.gate.now();
  // the accelerometer runs 20 s ahead while the heads go on: never confirmed, every message refused
  for (int i = 0; i < 20; ++i) {
    t += kS / 2;
    w.msg(w.acc, t + 20 * kS);
    if (i % 2 == 0) w.msg(w.h1, t);
  }
  EXPECT_EQ(w.rec.jump, 19) << "the last is still held";
  w.msg(w.h1, t + kS / 2);
  EXPECT_EQ(w.gate.resyncs(), 0u);
  EXPECT_EQ(w.rec.jump, 20);
}

TEST(TimeGate, AClockSetBackIsConfirmedByBothSensorsAndRestartsTheConsumer) {
  GateWorld w;
  w.steady(100 * kS);
  const TimeUs b = 20 * kS;  // 80 s back
  w.msg(w.h1, b);
  w.msg(w.acc, b);
  EXPECT_EQ(w.rec.restarts, 0);
  w.msg(w.h2, b);
  EXPECT_EQ(w.gate.resyncs(), 1u);
  EXPECT_EQ(w.rec.restarts, 1);
  EXPECT_EQ(w.gate.now(), b);
  EXPECT_EQ(w.rec.passed.size(), 43u);
  w.steady(b + kS / 2);  // and the stream goes on from there
  EXPECT_EQ(w.rec.jump + w.rec.late, 0);
}

TEST(TimeGate, TheOrbitVotesButIsNeverRequired) {
  GateWorld w(3, /*orbit_active=*/true);
  w.steady(100 * kS);
  w.msg(w.orbit, w.gate.now());  // the orbit channel is active
  const TimeUs j = w.gate.now() + 500 * kS;
  w.msg(w.h1, j);
  w.msg(w.acc, j);
  w.msg(w.h2, j + kS);
  EXPECT_EQ(w.gate.resyncs(), 1u) << "confirmed by heads and accelerometer without an orbit vote";
}

TEST(TimeGate, HeldMessagesAreBoundedAndTheEndRefusesAnUnconfirmedJump) {
  GateWorld w(16);
  w.steady(100 * kS);
  const TimeUs j = w.gate.now() + 500 * kS;
  for (int i = 0; i < 40; ++i) w.msg(w.h1, j + i);  // one sensor: never confirmed
  EXPECT_EQ(w.gate.heldCount(), static_cast<std::uint64_t>(TimeGate::kMaxHeld));
  EXPECT_EQ(w.rec.jump, 40 - TimeGate::kMaxHeld);
  w.gate.dropHeld(w.rec);
  EXPECT_EQ(w.rec.jump, 40);
  EXPECT_EQ(w.rec.passed.size(), 40u);
}

}  // namespace

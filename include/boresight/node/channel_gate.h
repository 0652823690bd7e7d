// boresight::node - the gates an input message passes before its samples reach the assembler, apart
// from the node so each can be tested alone (test/node/channel_gate_test.cc): SequenceGate (what a
// sender's sequence numbers say about the link), ChannelGate (one channel's duplicate and flood
// checks) and TimeGate (a tag far from the data time waits for confirmation). All are allocation-free
// and never throw: they run on the node's real-time thread.
//
// SequenceGate - the bookkeeping of one channel's `seq` field.
// A sender numbers what it sends (int32, wrapping). Between two arrivals on a channel:
//   - forward by d < window: d - 1 numbers have not arrived (yet): counted lost; one that arrives later
//     (out of order, within the window) takes its loss back; a repeat changes nothing;
//   - beyond the window, forward or back: wait for the next number. When it continues from the jump
//     (0 < next - jump < window) the jump was real: forward by less than 2^24, the numbers between were
//     lost; back, or forward by 2^24 or more, the sender's counter started again (a restart: counted
//     as one, not as loss, and losses after it are counted from the new numbers). When it does not,
//     that one message carried a corrupt number: no loss, nothing moved, and it stands for the next
//     number missing before the current one.
// A restart that lands within the window of the old numbers (a sender restarted within 64 messages of
// its start) cannot be told from reordering; it is taken as reordering.
// Allocation-free, no exceptions: it runs on the node's real-time thread.
#pragma once

#include <boresight/core/ring.h>
#include <boresight/stream/source.h>

#include <array>
#include <cstdint>
#include <limits>

namespace boresight::node {

struct SequenceCounts {
  std::uint64_t lost = 0;      ///< numbers sent and not (yet) arrived
  std::uint64_t restarts = 0;  ///< confirmed restarts of the sender's counter
};

class SequenceGate {
 public:
  static constexpr std::int32_t kWindow = 64;  ///< reorder window, numbers

  /// The number of the message that just arrived; updates *c.
  void check(std::int32_t seq, SequenceCounts& c);
  /// A jump beyond the window waits for the next number (nothing counted for it yet).
  bool pending() const { return have_cand_; }
  std::int32_t last() const { return last_; }

 private:
  bool have_ = false;
  std::int32_t last_ = 0;
  std::uint64_t seen_ = 0;  ///< bit i: number last_ - i arrived
  bool have_cand_ = false;
  std::int32_t cand_ = 0;
};

/// One input channel (a head, the accelerometer, the star vectors of a head, the orbit): its sequence
/// gate, the tags it passed lately (a tag again is a duplicate) and its flood count per data second.
struct ChannelGate {
  /// Which sensor the channel belongs to, for TimeGate's confirmation rule.
  enum Sensor : unsigned { kStarCamera = 1u, kAccelerometer = 2u, kOrbit = 4u };
  unsigned sensor = kStarCamera;
  SequenceGate seq;
  core::Ring<TimeUs, 8> recent{};  ///< tags passed lately
  TimeUs bucket = std::numeric_limits<TimeUs>::min();  ///< data second of the flood count
  int in_bucket = 0;
  TimeUs last_pass_t = std::numeric_limits<TimeUs>::min();  ///< the last tag that passed

  bool duplicate(TimeUs t) const;
  /// Counts a message at t in its data second; true when that makes more than ceil(max_hz).
  bool flooded(TimeUs t, double max_hz);
  /// A message at t passed.
  void passed(TimeUs t);
};

/// Time: every message goes through admit(). A tag within the look-ahead of the data time (the latest
/// tag passed) passes on. A tag beyond it, either way, is a jump: the message is held until `confirm`
/// messages in a row (sensors as below) agree on the new time - then the data time moves (a step back
/// restarts the consumer) and the held messages pass in their order - or until a message within the
/// look-ahead arrives: then a held one still that far from the data time is refused (late when the
/// consumer has handed out later tags, else a time jump), and one the data time has come to meanwhile
/// passes. Votes are counted over all channels, and where both sensors (the star cameras - heads and
/// star vectors - and the accelerometer) passed messages in the last kActiveUs of data time the votes
/// must come from both: a whole link that stops and resumes, or a spacecraft clock set back, moves every
/// channel, while one sensor whose clock is off is refuted by the other's messages (without that rule a
/// 10 Hz accelerometer 10 s ahead confirmed its jump between two head epochs, and the heads then
/// confirmed the way back: a re-synchronisation every half second; counted per channel instead of per
/// sensor, the three heads' messages of one epoch confirmed a step back of the star cameras alone).
/// Orbit messages vote with their own bit and are never required (a slow channel would hold the fast
/// ones past kMaxHeld). One corrupt tag therefore never moves the data time; the first message sets it
/// and a wrong one is out-voted the same way.
class TimeGate {
 public:
  static constexpr int kMaxHeld = 32;     ///< messages held at one jump (confirm is at most 16)
  static constexpr int kMaxSamples = 16;  ///< samples of one message (a star-vector message)
  static constexpr TimeUs kActiveUs = 10 * kUsPerSecond;  ///< a channel is active: it passed this recently

  /// Where admitted messages go.
  class Sink {
   public:
    virtual ~Sink() = default;
    /// A message within the look-ahead of the data time (its duplicate, late and flood checks follow).
    virtual void pass(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t) = 0;
    /// A message refused: late (before what was handed out) or a time jump nothing confirmed.
    virtual void refuse(bool late) = 0;
    /// The latest tag handed on (numeric_limits::min() when nothing since the start or a restart).
    virtual TimeUs handedOut() const = 0;
    /// A confirmed step back: what is buffered goes out, then the consumer starts again.
    virtual void restart() = 0;
  };

  /// jump_us: the look-ahead; confirm: messages in a row that confirm a jump (1..16); active: the
  /// channels whose recent messages make their sensor's vote necessary (they must outlive the gate).
  void configure(TimeUs jump_us, int confirm, ChannelGate* const* active, int n_active);
  void admit(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t, Sink& sink);
  /// A jump the end of the data left unconfirmed: every held message refused as a time jump.
  void dropHeld(Sink& sink);
  /// The data time moves forward to t (a message passed).
  void advance(TimeUs t) {
    if (t > now_) now_ = t;
  }
  TimeUs now() const { return now_; }
  std::uint64_t heldCount() const { return held_count_; }  ///< messages held at a jump
  std::uint64_t resyncs() const { return resyncs_; }       ///< confirmed jumps (forward or back)

 private:
  struct Held {
    ChannelGate* ch = nullptr;
    TimeUs t = 0;
    int n = 0;
    std::array<stream::Sample, kMaxSamples> xs{};
  };
  bool near(TimeUs t) const { return t <= now_ + jump_us_ && t >= now_ - jump_us_; }
  void hold(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t, Sink& sink);
  void settle(Sink& sink);

  TimeUs jump_us_ = 0;
  int confirm_ = 3;
  std::array<ChannelGate*, 16> active_{};
  int n_active_ = 0;
  bool have_time_ = false;
  TimeUs now_ = 0;
  int votes_ = 0;
  unsigned sensors_ = 0, need_sensors_ = 0;
  TimeUs vote_last_ = 0;
  std::array<Held, kMaxHeld> held_{};
  int n_held_ = 0;
  std::uint64_t held_count_ = 0, resyncs_ = 0;
};

}  // namespace boresight::node

// boresight::node - what a sender's sequence numbers say about the link: the bookkeeping of one
// channel's `seq` field, apart from the node so it can be tested alone (test/node/channel_gate_test.cc).
//
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

#include <cstdint>

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

}  // namespace boresight::node

// The sequence-number bookkeeping of one channel (channel_gate.h).
#include <boresight/node/channel_gate.h>

namespace boresight::node {
namespace {
/// b - a on the wrapping int32 counter.
std::int32_t diff(std::int32_t b, std::int32_t a) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(b) - static_cast<std::uint32_t>(a));
}
constexpr std::int32_t kHuge = 1 << 24;  ///< a forward jump this large is a new counter, not a loss
}  // namespace

void SequenceGate::check(std::int32_t seq, SequenceCounts& c) {
  if (!have_) {
    have_ = true;
    last_ = seq;
    seen_ = 1;
    return;
  }
  bool credit = false;  // an unconfirmed jump: that message stood for the next missing number
  if (have_cand_) {
    have_cand_ = false;
    credit = true;
    const std::int32_t dc = diff(seq, cand_);
    if (dc > 0 && dc < kWindow) {  // confirmed: the jump was real
      const std::int32_t jump = diff(cand_, last_);
      if (jump > 0 && jump < kHuge) {
        c.lost += static_cast<std::uint64_t>(jump - 1);  // the numbers between were lost
      } else {
        ++c.restarts;  // the counter started again: the old numbers tell nothing about the new ones
      }
      c.lost += static_cast<std::uint64_t>(dc - 1);
      last_ = seq;
      seen_ = 1u | (std::uint64_t{1} << static_cast<unsigned>(dc));
      return;
    }
  }
  const std::int32_t d = diff(seq, last_);
  if (d >= kWindow || d <= -kWindow) {  // far away either way: the next number confirms it or not
    have_cand_ = true;
    cand_ = seq;
    return;
  }
  if (d > 0) {  // forward: d - 1 numbers have not arrived (yet)
    c.lost += static_cast<std::uint64_t>(d - 1);
    seen_ = (seen_ << d) | 1u;
    last_ = seq;
    if (credit && d >= 2 && c.lost > 0) {  // the corrupt-numbered message was the one before this
      --c.lost;
      seen_ |= 2u;
    }
  } else if (d < 0) {  // back: a late arrival of a number counted lost, or a repeat
    const std::uint64_t bit = std::uint64_t{1} << static_cast<unsigned>(-d);
    if (!(seen_ & bit)) {
      seen_ |= bit;
      if (c.lost > 0) --c.lost;
    }
  }
}

}  // namespace boresight::node

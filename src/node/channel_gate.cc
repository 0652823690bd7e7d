// The input gates of one channel and of the data time (channel_gate.h).
#include <boresight/node/channel_gate.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

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

namespace boresight::node {

bool ChannelGate::duplicate(TimeUs t) const {
  for (std::size_t i = 0; i < recent.size(); ++i)
    if (recent[i] == t) return true;
  return false;
}

bool ChannelGate::flooded(TimeUs t, double max_hz) {
  const TimeUs sec = t >= 0 ? t / kUsPerSecond : (t - kUsPerSecond + 1) / kUsPerSecond;
  if (sec != bucket) {
    bucket = sec;
    in_bucket = 0;
  }
  return ++in_bucket > static_cast<int>(std::ceil(max_hz));
}

void ChannelGate::passed(TimeUs t) {
  recent.pushOverwrite(t);
  last_pass_t = t;
}

void TimeGate::configure(TimeUs jump_us, int confirm, ChannelGate* const* active, int n_active) {
  have_time_ = false;
  now_ = 0;
  votes_ = 0;
  sensors_ = need_sensors_ = 0;
  n_held_ = 0;
  held_count_ = resyncs_ = 0;
  jump_us_ = jump_us;
  confirm_ = confirm;
  n_active_ = std::min(n_active, static_cast<int>(active_.size()));
  for (int i = 0; i < n_active_; ++i) active_[static_cast<std::size_t>(i)] = active[i];
}

void TimeGate::admit(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t, Sink& sink) {
  if (!have_time_) {
    have_time_ = true;
    now_ = t;
  }
  if (near(t)) {
    votes_ = 0;
    if (n_held_ > 0) settle(sink);
    sink.pass(ch, xs, n, t);
    return;
  }
  if (votes_ > 0 && std::abs(t - vote_last_) <= jump_us_) {
    ++votes_;
    sensors_ |= ch.sensor;
  } else {
    dropHeld(sink);  // an earlier jump that nothing confirmed
    votes_ = 1;
    sensors_ = ch.sensor;
    need_sensors_ = 0;  // the sensors active lately: each must vote
    for (int i = 0; i < n_active_; ++i) {
      const ChannelGate* a = active_[static_cast<std::size_t>(i)];
      if (a->last_pass_t != std::numeric_limits<TimeUs>::min() && a->last_pass_t >= now_ - kActiveUs)
        need_sensors_ |= a->sensor & ~static_cast<unsigned>(ChannelGate::kOrbit);
    }
  }
  vote_last_ = t;
  if (votes_ < confirm_ || (sensors_ & need_sensors_) != need_sensors_) {
    hold(ch, xs, n, t, sink);
    return;
  }
  // Confirmed: the data time moves to the first message of the jump.
  ++resyncs_;
  votes_ = 0;
  TimeUs t0 = t;
  for (int i = 0; i < n_held_; ++i) t0 = std::min(t0, held_[static_cast<std::size_t>(i)].t);
  now_ = t0;
  if (t0 <= sink.handedOut()) sink.restart();  // a step back (a sender clock set back)
  const int nh = n_held_;
  n_held_ = 0;
  for (int i = 0; i < nh; ++i) {
    Held& h = held_[static_cast<std::size_t>(i)];
    sink.pass(*h.ch, h.xs.data(), h.n, h.t);
  }
  sink.pass(ch, xs, n, t);
}

void TimeGate::hold(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t, Sink& sink) {
  if (n_held_ >= kMaxHeld || n > kMaxSamples) return sink.refuse(false);
  Held& h = held_[static_cast<std::size_t>(n_held_++)];
  h.ch = &ch;
  h.t = t;
  h.n = n;
  for (int i = 0; i < n; ++i) h.xs[static_cast<std::size_t>(i)] = xs[i];
  ++held_count_;
}

void TimeGate::settle(Sink& sink) {
  const int nh = n_held_;
  n_held_ = 0;
  for (int i = 0; i < nh; ++i) {
    Held& h = held_[static_cast<std::size_t>(i)];
    if (near(h.t)) sink.pass(*h.ch, h.xs.data(), h.n, h.t);
    else sink.refuse(h.t < sink.handedOut());
  }
}

void TimeGate::dropHeld(Sink& sink) {
  const int nh = n_held_;
  n_held_ = 0;
  for (int i = 0; i < nh; ++i) sink.refuse(false);
}

}  // namespace boresight::node

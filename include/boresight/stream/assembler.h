// Epoch assembler: merges the samples of several sources by time with a bounded look-ahead and
// groups the head samples of one time tag into a core::HeadEpoch.
//
// Order handed out: by time tag; at equal tags heads, then the accelerometer, then star vectors (grouped
// into a core::StarEpoch like the heads), then by source (in the
// order they were added), then in the order each source gave them. That is the order of a stable
// sort of all inputs concatenated, so within the look-ahead a stream gives what sorting all the data
// would. A sample is handed out only when every unfinished source has read past its tag plus the
// look-ahead (or the buffer is full), so samples up to `lookahead_us` out of order are sorted back
// in. A sample older than what was already handed out (a head sample at or before it) is rejected as
// Reject::kLate and counted; nothing is dropped silently. Memory: at most `max_buffered` samples.
//
// Robust time base: a sample more than W = max(look-ahead, 1 s, 3 typical steps of its source) ahead
// of its source's time (the latest tag it confirmed) is held until the source's next sample: when that
// one lies at least as close to it as to the source's time, the jump is real (a gap in the data) and
// both go on; otherwise the held sample was one corrupt tag and is rejected as Reject::kTimeJump. So
// a tag 1e8 s ahead costs that sample, not the look-ahead of every later one (it would have become the
// source's time: every later sample handed out alone, heads of one tag split and late). A source's
// first sample waits for the second (near it: confirmed; far: a third decides, in line with both
// confirms both, else the nearer one is kept). An unconfirmed jump at a source's end is an outlier
// too (one sample). A sample more than max(look-ahead, 1 s) behind its own source's time is late
// (Reject::kLate) even before anything after it was handed out. The same head twice at one tag (a
// file given twice, a repeated record) is rejected as Reject::kDuplicate.
#pragma once

#include <boresight/core/heads.h>
#include <boresight/stream/source.h>

#include <cstdint>
#include <limits>
#include <vector>

namespace boresight::stream {

struct AssemblerConfig {
  TimeUs lookahead_us = 2 * kUsPerSecond;  ///< how far out of order a sample may arrive and be sorted in
  std::size_t max_buffered = 1u << 16;     ///< buffered samples at most (hand-out is forced beyond)
};

class EpochAssembler {
 public:
  enum class Out : std::uint8_t { kHeads, kAccel, kEnd, kPending, kError, kStars, kOrbit };

  explicit EpochAssembler(const AssemblerConfig& cfg = {});
  /// Sources are read in the order added (ties at equal tags too). Not owned.
  void addSource(Source* s);
  /// The next epoch (kHeads: `epoch`), accelerometer sample (kAccel: `t`, `a_A`) or star epoch
  /// (kStars: `*stars`, all star vectors of one tag, at most core::kMaxStarInputs: the rest are
  /// rejected as kTooManyStars). Without `stars`, star vectors are rejected as kNoStarConsumer
  /// (counted, never handed out). kOrbit: `*orbit` holds an orbit sample; without `orbit`, orbit
  /// samples are rejected as kNoOrbitConsumer. kPending: a source has nothing now (call again later);
  /// kError: a source failed (errorSource()).
  Out next(core::HeadEpoch& epoch, TimeUs& t, Vec3& a_A, core::StarEpoch* stars = nullptr, Sample* orbit = nullptr);
  /// The same merge one sample at a time, with every field the source gave (kHeads: a head sample,
  /// kAccel: an accelerometer sample), for consumers that write messages rather than feed the core
  /// (`boresight convert`). Same order, look-ahead, late rule and counters as next(), except that
  /// samples are not grouped into epochs, so no kTooManyHeads; orbit samples come as kOrbit. Use one of
  /// next() and nextSample().
  Out nextSample(Sample& s);

  /// A re-synchronisation (the node after a confirmed clock step back): what is buffered is handed out
  /// by the next calls as if every source had finished, then the assembler forgets its time (held
  /// samples become time outliers) and starts again with the next sample. No allocation.
  void restart() { restart_ = true; }
  /// The tag and kind of the last sample handed out since the start or the last restart (false: none):
  /// what the late rule compares a new sample with, for a driver that checks before it pushes.
  bool lastHandedOut(TimeUs& t, Sample::Kind& kind) const {
    t = last_t_;
    kind = last_kind_;
    return emitted_;
  }
  /// The late rule: a sample at `t` of `kind` would be rejected as Reject::kLate now (older than the
  /// last hand-out; at its tag, a head - its epoch is gone - or a star vector after a star epoch).
  bool late(TimeUs t, Sample::Kind kind) const {
    return emitted_ && (t < last_t_ || (t == last_t_ && (kind == Sample::Kind::kHead ||
                                                         (kind == Sample::Kind::kStar && last_kind_ == Sample::Kind::kStar))));
  }

  /// Counters of all sources together, and of each (index = order added).
  const Counters& counters() const { return total_; }
  const Counters& counters(std::size_t source) const { return src_[source].c; }
  std::size_t sourceCount() const { return src_.size(); }
  int errorSource() const { return error_source_; }
  std::size_t buffered() const { return heap_.size(); }
  std::size_t maxBuffered() const { return max_seen_; }

 private:
  struct Item {
    TimeUs t;
    std::uint8_t kind;
    std::uint32_t src;
    std::uint64_t seq;
    Sample s;
  };
  struct SourceState {
    Source* s = nullptr;
    bool done = false;
    bool have_frontier = false;  ///< a confirmed tag exists
    TimeUs frontier = std::numeric_limits<TimeUs>::min();
    Counters c;
    TimeUs step = 0;  ///< the source's typical step between distinct tags (0: not known yet)
    Sample held[2];  ///< samples waiting for confirmation (oldest first)
    int n_held = 0;
  };
  /// A sample read from source i: held, confirmed or queued (see the robust time base above).
  void admit(std::size_t i, const Sample& s);
  /// Into the buffer (or rejected as late); moves the source's frontier.
  void enqueue(std::size_t i, const Sample& s);
  /// End of source i: held samples go (a lone first sample) or are outliers.
  void settle(std::size_t i);
  static bool later(const Item& a, const Item& b);
  /// Reads one sample from source i into the buffer. False: pending or error (out says which).
  bool pull(std::size_t i, Out& out);
  /// Reads until the earliest buffered sample may go (false: pending or error, out says which).
  bool fill(Out& out);
  void reject(std::size_t i, Reject why);
  void pop(Item& it);

  AssemblerConfig cfg_;
  std::vector<SourceState> src_;
  std::vector<Item> heap_;
  Counters total_;
  std::uint64_t seq_ = 0;
  bool emitted_ = false;
  TimeUs last_t_ = 0;
  Sample::Kind last_kind_ = Sample::Kind::kHead;
  int error_source_ = -1;
  std::size_t max_seen_ = 0;
  bool restart_ = false;
};

}  // namespace boresight::stream

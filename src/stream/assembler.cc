// EpochAssembler: k-way merge by time with a bounded look-ahead buffer (a binary heap).
#include <boresight/stream/assembler.h>

#include <algorithm>

namespace boresight::stream {

EpochAssembler::EpochAssembler(const AssemblerConfig& cfg) : cfg_(cfg) {
  if (cfg_.lookahead_us < 1) cfg_.lookahead_us = 1;  // a source must be past a tag before its epoch goes
  if (cfg_.max_buffered < 1) cfg_.max_buffered = 1;
  heap_.reserve(std::min<std::size_t>(cfg_.max_buffered, 4096));
}

void EpochAssembler::addSource(Source* s) {
  SourceState st;
  st.s = s;
  src_.push_back(st);
}

// std heap is a max-heap: "later" puts the earliest item on top.
bool EpochAssembler::later(const Item& a, const Item& b) {
  if (a.t != b.t) return a.t > b.t;
  if (a.kind != b.kind) return a.kind > b.kind;
  if (a.src != b.src) return a.src > b.src;
  return a.seq > b.seq;
}

void EpochAssembler::reject(std::size_t i, Reject why) {
  ++src_[i].c.rejected[static_cast<std::size_t>(why)];
  ++total_.rejected[static_cast<std::size_t>(why)];
}

void EpochAssembler::enqueue(std::size_t i, const Sample& s) {
  SourceState& ss = src_[i];
  if (!ss.have_frontier) {
    ss.frontier = s.t;
  } else if (s.t > ss.frontier) {
    // The source's typical step (a sampling interval, not a gap): what a jump is measured against.
    const TimeUs d = s.t - ss.frontier;
    if (ss.step == 0) ss.step = d;
    else if (d <= 4 * ss.step) ss.step = (3 * ss.step + d) / 4;
    ss.frontier = s.t;
  }
  ss.have_frontier = true;
  // Late: something after it was handed out already. A head sample at the tag of the last
  // hand-out is late too (its epoch, or an accelerometer sample that sorts after it, is gone), and
  // so is a star vector at the tag of a star epoch already handed out.
  if (late(s.t, s.kind)) {
    reject(i, Reject::kLate);
    return;
  }
  heap_.push_back(Item{s.t, static_cast<std::uint8_t>(s.kind), static_cast<std::uint32_t>(i), seq_++, s});
  std::push_heap(heap_.begin(), heap_.end(), later);
  max_seen_ = std::max(max_seen_, heap_.size());
}

namespace {
TimeUs dist(TimeUs a, TimeUs b) { return a > b ? a - b : b - a; }
}  // namespace

void EpochAssembler::admit(std::size_t i, const Sample& s) {
  SourceState& ss = src_[i];
  // Jumps are judged at the look-ahead, but never finer than a second (a look-ahead of microseconds
  // must not make every sampling interval a jump) nor than three of the source's own steps (a sparse
  // source is no sequence of jumps).
  const TimeUs J = std::max<TimeUs>(cfg_.lookahead_us, kUsPerSecond);
  const TimeUs W = std::max<TimeUs>(J, 3 * ss.step);
  if (ss.n_held > 0) {
    if (ss.have_frontier) {
      // One held jump: real when this sample is at least as close to it as to the source's time.
      const Sample h = ss.held[0];
      ss.n_held = 0;
      if (dist(s.t, h.t) <= dist(s.t, ss.frontier)) enqueue(i, h);
      else reject(i, Reject::kTimeJump);
    } else if (ss.n_held == 1) {
      // The source's first sample: confirmed by a second one near it; otherwise both wait for a third.
      if (dist(s.t, ss.held[0].t) > W) {
        ss.held[ss.n_held++] = s;
        return;
      }
      const Sample h = ss.held[0];
      ss.n_held = 0;
      enqueue(i, h);
    } else {
      // Two first samples far apart: a third in line with both (steps within a factor of 4) confirms
      // both (a sparse source); otherwise the one nearer to it is confirmed and the other is an outlier.
      const Sample a = ss.held[0], b = ss.held[1];
      ss.n_held = 0;
      const bool in_line = a.t < b.t && b.t < s.t && b.t - a.t <= 4 * (s.t - b.t) + J && s.t - b.t <= 4 * (b.t - a.t) + J;
      if (in_line) {
        enqueue(i, a);
        enqueue(i, b);
      } else if (dist(s.t, b.t) <= dist(s.t, a.t)) {
        reject(i, Reject::kTimeJump);
        enqueue(i, b);
      } else {
        enqueue(i, a);
        reject(i, Reject::kTimeJump);
      }
    }
  }
  if (!ss.have_frontier) {  // the first sample: wait for the next one
    ss.held[ss.n_held++] = s;
    return;
  }
  const TimeUs W2 = std::max<TimeUs>(J, 3 * ss.step);
  if (s.t > ss.frontier + W2) {  // a jump ahead of the source's time: wait for the next sample
    ss.held[0] = s;
    ss.n_held = 1;
    return;
  }
  // Behind the source's time by more than the look-ahead: late, whatever was handed out.
  if (s.t < ss.frontier - J) {
    reject(i, Reject::kLate);
    return;
  }
  enqueue(i, s);
}

void EpochAssembler::settle(std::size_t i) {
  SourceState& ss = src_[i];
  if (!ss.have_frontier) {
    for (int k = 0; k < ss.n_held; ++k) enqueue(i, ss.held[k]);  // nothing contradicts them
  } else {
    for (int k = 0; k < ss.n_held; ++k) reject(i, Reject::kTimeJump);  // a jump nothing confirmed
  }
  ss.n_held = 0;
}

bool EpochAssembler::pull(std::size_t i, Out& out) {
  SourceState& ss = src_[i];
  Sample s;
  Reject why = Reject::kMalformed;
  switch (ss.s->next(s, why)) {
    case Source::Next::kSample:
      ++ss.c.read;
      ++total_.read;
      admit(i, s);
      return true;
    case Source::Next::kRejected:
      ++ss.c.read;
      ++total_.read;
      reject(i, why);
      return true;
    case Source::Next::kEnd:
      settle(i);
      ss.done = true;
      return true;
    case Source::Next::kPending:
      out = Out::kPending;
      return false;
    case Source::Next::kError:
      ss.done = true;
      error_source_ = static_cast<int>(i);
      out = Out::kError;
      return false;
  }
  return true;
}

void EpochAssembler::pop(Item& it) {
  std::pop_heap(heap_.begin(), heap_.end(), later);
  it = heap_.back();
  heap_.pop_back();
}

bool EpochAssembler::fill(Out& out) {
  if (restart_) {
    if (!heap_.empty()) return true;  // hand out what is buffered first
    restart_ = false;
    emitted_ = false;
    for (std::size_t i = 0; i < src_.size(); ++i) {
      SourceState& ss = src_[i];
      for (int k = 0; k < ss.n_held; ++k) reject(i, Reject::kTimeJump);
      ss.n_held = 0;
      ss.have_frontier = false;
      ss.step = 0;
      ss.frontier = std::numeric_limits<TimeUs>::min();
    }
  }
  // Read from the source that is furthest behind until every unfinished source is past the
  // earliest buffered tag plus the look-ahead (or the buffer is full).
  for (;;) {
    std::size_t lag = src_.size();
    for (std::size_t i = 0; i < src_.size(); ++i)
      if (!src_[i].done && (lag == src_.size() || src_[i].frontier < src_[lag].frontier)) lag = i;
    if (lag == src_.size()) return true;  // every source finished
    if (!heap_.empty() && src_[lag].frontier >= heap_.front().t + cfg_.lookahead_us) return true;
    if (heap_.size() >= cfg_.max_buffered) return true;
    if (!pull(lag, out)) return false;
  }
}

EpochAssembler::Out EpochAssembler::nextSample(Sample& s) {
  Out o = Out::kEnd;
  if (!fill(o)) return o;
  if (heap_.empty()) return Out::kEnd;
  Item it;
  pop(it);
  emitted_ = true;
  last_t_ = it.t;
  last_kind_ = it.s.kind;
  s = it.s;
  if (it.s.kind == Sample::Kind::kAccel) {
    ++src_[it.src].c.used_accel;
    ++total_.used_accel;
    return Out::kAccel;
  }
  if (it.s.kind == Sample::Kind::kStar) {
    ++src_[it.src].c.used_stars;
    ++total_.used_stars;
    return Out::kStars;
  }
  if (it.s.kind == Sample::Kind::kOrbit) {
    ++src_[it.src].c.used_orbit;
    ++total_.used_orbit;
    return Out::kOrbit;
  }
  ++src_[it.src].c.used_heads;
  ++total_.used_heads;
  return Out::kHeads;
}

EpochAssembler::Out EpochAssembler::next(core::HeadEpoch& epoch, TimeUs& t, Vec3& a_A, core::StarEpoch* stars,
                                         Sample* orbit) {
  Out o = Out::kEnd;
  if (!fill(o)) return o;
  if (heap_.empty()) return Out::kEnd;
  Item it;
  pop(it);
  // Inputs nobody here takes: counted, never handed out.
  while ((it.s.kind == Sample::Kind::kStar && stars == nullptr) || (it.s.kind == Sample::Kind::kOrbit && orbit == nullptr)) {
    reject(it.src, it.s.kind == Sample::Kind::kStar ? Reject::kNoConsumer : Reject::kNoConsumer);
    if (!fill(o)) return o;
    if (heap_.empty()) return Out::kEnd;
    pop(it);
  }
  emitted_ = true;
  last_t_ = it.t;
  last_kind_ = it.s.kind;
  if (it.s.kind == Sample::Kind::kOrbit) {
    ++src_[it.src].c.used_orbit;
    ++total_.used_orbit;
    *orbit = it.s;
    t = it.t;
    return Out::kOrbit;
  }
  if (it.s.kind == Sample::Kind::kStar) {
    stars->t = it.t;
    stars->n = 0;
    for (;;) {
      if (stars->n < core::kMaxStarInputs) {
        stars->star[static_cast<std::size_t>(stars->n++)] = it.s.star;
        ++src_[it.src].c.used_stars;
        ++total_.used_stars;
      } else {
        reject(it.src, Reject::kTooManyStars);
      }
      if (heap_.empty() || heap_.front().t != stars->t || heap_.front().s.kind != Sample::Kind::kStar) break;
      pop(it);
    }
    return Out::kStars;
  }
  if (it.s.kind == Sample::Kind::kAccel) {
    ++src_[it.src].c.used_accel;
    ++total_.used_accel;
    t = it.t;
    a_A = it.s.a_A;
    return Out::kAccel;
  }
  epoch.t = it.t;
  epoch.n = 0;
  for (;;) {
    bool dup = false;
    for (int k = 0; k < epoch.n && !dup; ++k) dup = epoch.sample[static_cast<std::size_t>(k)].head_id == it.s.head_id;
    if (dup) {
      reject(it.src, Reject::kDuplicate);
    } else if (epoch.n < core::kMaxHeads) {
      auto& h = epoch.sample[static_cast<std::size_t>(epoch.n++)];
      h = core::HeadSample{};
      h.head_id = it.s.head_id;
      h.q_I_Si = it.s.q_I_S;
      ++src_[it.src].c.used_heads;
      ++total_.used_heads;
    } else {
      reject(it.src, Reject::kTooManyHeads);
    }
    if (heap_.empty() || heap_.front().t != epoch.t || heap_.front().kind != 0) break;
    pop(it);
  }
  return Out::kHeads;
}

}  // namespace boresight::stream

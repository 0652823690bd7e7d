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

bool EpochAssembler::pull(std::size_t i, Out& out) {
  SourceState& ss = src_[i];
  Sample s;
  Reject why = Reject::kMalformed;
  switch (ss.s->next(s, why)) {
    case Source::Next::kSample: {
      ++ss.c.read;
      ++total_.read;
      ss.frontier = std::max(ss.frontier, s.t);
      // Late: something after it was handed out already. A head sample at the tag of the last
      // hand-out is late too (its epoch, or an accelerometer sample that sorts after it, is gone), and
      // so is a star vector at the tag of a star epoch already handed out.
      if (emitted_ && (s.t < last_t_ || (s.t == last_t_ && (s.kind == Sample::Kind::kHead ||
                                                             (s.kind == Sample::Kind::kStar &&
                                                              last_kind_ == Sample::Kind::kStar))))) {
        reject(i, Reject::kLate);
        return true;
      }
      heap_.push_back(Item{s.t, static_cast<std::uint8_t>(s.kind), static_cast<std::uint32_t>(i), seq_++, s});
      std::push_heap(heap_.begin(), heap_.end(), later);
      max_seen_ = std::max(max_seen_, heap_.size());
      return true;
    }
    case Source::Next::kRejected:
      ++ss.c.read;
      ++total_.read;
      reject(i, why);
      return true;
    case Source::Next::kEnd:
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
  ++src_[it.src].c.used_heads;
  ++total_.used_heads;
  return Out::kHeads;
}

EpochAssembler::Out EpochAssembler::next(core::HeadEpoch& epoch, TimeUs& t, Vec3& a_A, core::StarEpoch* stars) {
  Out o = Out::kEnd;
  if (!fill(o)) return o;
  if (heap_.empty()) return Out::kEnd;
  Item it;
  pop(it);
  while (it.s.kind == Sample::Kind::kStar && stars == nullptr) {  // counted, never handed out
    reject(it.src, Reject::kNoStarConsumer);
    if (!fill(o)) return o;
    if (heap_.empty()) return Out::kEnd;
    pop(it);
  }
  emitted_ = true;
  last_t_ = it.t;
  last_kind_ = it.s.kind;
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
    if (epoch.n < core::kMaxHeads) {
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

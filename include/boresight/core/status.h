// Status codes and health counters of the real-time core.
// Bad data is data: every rejected or degraded input yields a Status and increments one counter.
// The counters are plain data (an array of integers) that the node can publish as they are.
#pragma once

#include <array>
#include <cstdint>

namespace boresight::core {

enum class Status : std::uint8_t {
  kOk = 0,
  kNotConfigured,      ///< step() before a successful configure()
  kInvalidConfig,      ///< configure() rejected the configuration
  kNonFinite,          ///< NaN or Inf in an input value
  kNonUnitQuaternion,  ///< | |q| - 1 | above the configured tolerance
  kTimeBackwards,      ///< time tag older than the previous one
  kDuplicateTime,      ///< time tag equal to the previous one
  kIrregularTime,      ///< time step shorter than the stream's sampling interval allows
  kGapRestarted,       ///< a gap restarted the filter (accepted sample, history dropped)
  kGapBridged,         ///< a gap was bridged by interpolation (accepted sample)
  kUnknownHead,        ///< head id not in the configuration
  kDuplicateHead,      ///< the same head twice in one epoch
  kTooFewStars,        ///< not enough (or only collinear) star vectors for an attitude
  kNumericalFailure,   ///< a singular system; no output
  kNoValidInput,       ///< nothing usable in the epoch (all parts rejected)
  kNotReady,           ///< evaluateAt(): the filter has not seen enough samples after the tag yet
  kUnavailable,        ///< evaluateAt(): the tag is not covered by the filter's history
  kCapacityExceeded,   ///< more inputs than the compile-time capacity; the excess is dropped
  kImplausible,        ///< a finite value outside its physical plausibility gate (core/plausibility.h)
  kCount_
};
constexpr int kStatusCount = static_cast<int>(Status::kCount_);

/// Short stable name (for logs and reports, outside the real-time loop).
const char* statusName(Status s);

/// True for statuses where the input was used (possibly with a gap).
constexpr bool accepted(Status s) {
  return s == Status::kOk || s == Status::kGapRestarted || s == Status::kGapBridged;
}

/// Counters by reason. `by_status[int(Status::kOk)]` counts fully accepted inputs.
struct Health {
  std::array<std::uint64_t, kStatusCount> by_status{};

  void record(Status s) { ++by_status[static_cast<std::size_t>(s)]; }
  std::uint64_t count(Status s) const { return by_status[static_cast<std::size_t>(s)]; }
  /// Sum of every counter except kOk, gaps (accepted) and kNotReady.
  std::uint64_t rejected() const;
  void add(const Health& other);
  void clear() { by_status.fill(0); }
};

/// The entry check of every component's step(): kNotConfigured before a successful configure(), then
/// kDuplicateTime / kTimeBackwards unless t is later than the last accepted tag. A refusal is counted
/// in h; kOk means the caller goes on (and records t as its last tag when it accepts the input).
inline Status admitStep(bool configured, bool have_last, std::int64_t last_t, std::int64_t t, Health& h) {
  Status r = Status::kOk;
  if (!configured) r = Status::kNotConfigured;
  else if (have_last && t <= last_t) r = t == last_t ? Status::kDuplicateTime : Status::kTimeBackwards;
  if (r != Status::kOk) h.record(r);
  return r;
}

}  // namespace boresight::core

// boresight::io - why an input was not used: one list for every program. The replay engine's sources
// and assembler (`boresight process`, `calibrate`, `convert`, `audit`, `noise`) and the node
// (`boresightd`) count every record or message they read either as used or under one of these reasons,
// so the same damaged message has the same name everywhere (io::checkInput gives the content verdict
// to both). Some reasons can only arise in one of them (the node's flood and command checks, the
// engine's per-epoch capacities); they are in the one list all the same.
#pragma once

#include <cstdint>

namespace boresight::io {

// The order is the node's health message's (node_health_t.rejected, 16 entries: index = reason); the
// two reasons after kOtherVersion arise only in the replay engine's assembler (the node counts what its
// assembler refuses as kAssembler).
enum class Reject : std::uint8_t {
  kMalformed = 0,  ///< a Level-1 line the reader refused; an LCM message that does not decode as its
                   ///< channel's type (length, fingerprint, a count out of range, an orbit frame
                   ///< other than I or E)
  kInvalidFlag,    ///< the input says it is not valid (flags bit 0 clear; no stars; an accelerometer
                   ///< sample without all three angular accelerations)
  kNonFinite,      ///< NaN or Inf in a value that is used
  kNonUnit,        ///< a quaternion or direction that is no rotation / no direction (norm)
  kUnknownHead,    ///< a head id not in the configuration (the node; a replay leaves it to the core,
                   ///< which counts it as core::Status::kUnknownHead)
  kDuplicate,      ///< the same head / sample at the same tag again (a file given twice, a repeat)
  kLate,           ///< older than what was already handed to the core (beyond the look-ahead)
  kTimeJump,       ///< a tag far from the data time (beyond the look-ahead), not confirmed by what
                   ///< follows: one corrupt tag, one sender's clock off
  kFlood,          ///< more messages per second of data time than the channel's limit (the node)
  kNoMountings,    ///< input before the nominal mountings are known (the node, mountings: log)
  kOtherChannel,   ///< an LCM channel nothing here reads (a replay: e.g. earlier outputs)
  kAssembler,      ///< the node's assembler refused what its handlers passed (should stay 0)
  kImplausible,    ///< a finite value outside its physical gate (core/plausibility.h); the Level-1
                   ///< readers' implausible lines
  kCommand,        ///< a ground command that does not apply (the node): unknown, or naming a
                   ///< calibration not held / not in use
  kNoConsumer,     ///< an input nothing in this run uses: star vectors where no star epoch is taken,
                   ///< an orbit without a thermal model or fit
  kOtherVersion,   ///< an LCM message of another layout of its type (io::isOtherVersion,
                   ///< src/lcmtypes/versions.txt): written with other message types
  kTooManyHeads,   ///< more head samples in one epoch than core::kMaxHeads (replay engine)
  kTooManyStars,   ///< more star vectors in one epoch than core::kMaxStarInputs (replay engine)
  kCount
};
constexpr int kRejectCount = static_cast<int>(Reject::kCount);

/// The reason's key in JSON summaries ("malformed", "invalid_flag", "time_jump", ...).
const char* rejectKey(Reject r);
/// The reason in words for printed summaries ("implausible value", "duplicate (same head, same tag)").
const char* rejectText(Reject r);

}  // namespace boresight::io

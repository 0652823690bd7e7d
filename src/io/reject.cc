// The one list of reasons an input is not used (include/boresight/io/reject.h).
#include "boresight/io/reject.h"

namespace boresight::io {

const char* rejectKey(Reject r) {
  switch (r) {
    case Reject::kMalformed: return "malformed";
    case Reject::kInvalidFlag: return "invalid_flag";
    case Reject::kNonFinite: return "non_finite";
    case Reject::kNonUnit: return "non_unit";
    case Reject::kUnknownHead: return "unknown_head";
    case Reject::kDuplicate: return "duplicate";
    case Reject::kLate: return "late";
    case Reject::kTimeJump: return "time_jump";
    case Reject::kFlood: return "flood";
    case Reject::kNoMountings: return "no_mountings";
    case Reject::kOtherChannel: return "other_channel";
    case Reject::kAssembler: return "assembler";
    case Reject::kImplausible: return "implausible";
    case Reject::kCommand: return "command";
    case Reject::kNoConsumer: return "no_consumer";
    case Reject::kOtherVersion: return "other_version";
    case Reject::kTooManyHeads: return "too_many_heads";
    case Reject::kTooManyStars: return "too_many_stars";
    case Reject::kCount: break;
  }
  return "?";
}

const char* rejectText(Reject r) {
  switch (r) {
    case Reject::kMalformed: return "malformed (reader, decoder)";
    case Reject::kInvalidFlag: return "flagged invalid (or no angular acceleration, no stars)";
    case Reject::kNonFinite: return "non-finite value";
    case Reject::kNonUnit: return "quaternion or direction not unit";
    case Reject::kUnknownHead: return "unknown head id";
    case Reject::kDuplicate: return "duplicate (same head, same tag)";
    case Reject::kLate: return "late (beyond look-ahead)";
    case Reject::kTimeJump: return "time tag far from the data time (not confirmed)";
    case Reject::kFlood: return "flood (above the channel's rate)";
    case Reject::kNoMountings: return "before the nominal mountings";
    case Reject::kOtherChannel: return "other LCM channel";
    case Reject::kAssembler: return "refused by the assembler";
    case Reject::kImplausible: return "implausible value";
    case Reject::kCommand: return "command that does not apply";
    case Reject::kNoConsumer: return "not used here (star vectors, or an orbit without thermal model or fit)";
    case Reject::kOtherVersion: return "other layout of the message type (versions.txt)";
    case Reject::kTooManyHeads: return "more heads than kMaxHeads";
    case Reject::kTooManyStars: return "more star vectors than kMaxStarInputs";
    case Reject::kCount: break;
  }
  return "?";
}

}  // namespace boresight::io

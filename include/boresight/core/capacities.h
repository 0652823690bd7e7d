// Compile-time capacities of the real-time core: the ONE place where fixed sizes are set.
// Every buffer of the core is sized from these constants; nothing in the core grows at run time.
#pragma once

namespace boresight::core {

/// Star-sensor heads handled by one core instance (GRACE-FO flies 3).
constexpr int kMaxHeads = 4;
/// Unordered head pairs (i < j).
constexpr int kMaxPairs = kMaxHeads * (kMaxHeads - 1) / 2;
/// Ordered head triples (i < j < k) for the closure check B_ij B_jk = B_ik.
constexpr int kMaxTriples = kMaxHeads * (kMaxHeads - 1) * (kMaxHeads - 2) / 6;

/// Star observations one head may deliver per epoch.
constexpr int kMaxStarsPerHead = 16;
/// Star observations of all heads in one epoch (input capacity of the multi-head Wahba solver).
constexpr int kMaxStarInputs = kMaxHeads * kMaxStarsPerHead;
/// Stars actually used by the Wahba solution (a well-distributed subset of the inputs).
constexpr int kMaxStars = 24;

/// Longest CRN FIR (odd number of taps): fs * Tf rounded to odd; 707 for GRACE (10 Hz, 70.7 s).
constexpr int kMaxCrnTaps = 1023;
/// Length of a stored CRN kernel: kMaxCrnTaps rounded up to a multiple of 8, the taps beyond the
/// design's zero (the dot products run over whole blocks of 8 taps, no scalar tail).
constexpr int kCrnKernelStride = (kMaxCrnTaps + 7) & ~7;
/// Ring length of a CRN stream (power of two, > kMaxCrnTaps).
constexpr int kCrnRing = 1024;
/// Most missing samples a CRN stream bridges by interpolation (longer gaps restart the filter).
constexpr int kMaxBridgeSamples = 64;
/// Most outputs one CRN step can produce (a bridged gap may complete several output epochs).
constexpr int kMaxCrnOutputsPerStep = kMaxBridgeSamples + 1;

/// Harmonics of the argument of latitude in the thermal model handed to the core (thermal_harmonics.h).
constexpr int kMaxThermalHarmonics = 6;

/// Output epochs the pipeline holds while the CRN filters (centre-stamped, ~35 s late) catch up.
constexpr int kMaxPendingRows = 256;

static_assert(kMaxHeads >= 4, "the issue asks for at least four heads");
static_assert((kCrnRing & (kCrnRing - 1)) == 0 && kCrnRing > kMaxCrnTaps, "ring must be 2^k > taps");
static_assert(kMaxCrnTaps % 2 == 1, "CRN filters have an odd number of taps");

}  // namespace boresight::core

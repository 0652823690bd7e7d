// LCM log files of the node's input messages (star head samples, accelerometer samples).
//
// Channels: "STAR_HEAD" carries boresight_lcm::star_head_sample_t, "ACCEL" boresight_lcm::accel_sample_t.
// The event timestamp of each log entry is set to the message's sensor time tag (utime), so a log
// written here plays back in sensor-time order; readers still use the message's own utime.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/heads.h>
#include <boresight/io/level1.h>
#include <boresight/io/reject.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace boresight::io {

constexpr const char* kStarHeadChannel = "STAR_HEAD";
constexpr const char* kAccelChannel = "ACCEL";
/// boresight_lcm::star_vectors_t: one head's star vectors of one epoch (Wahba input).
constexpr const char* kStarVectorsChannel = "STAR_VECTORS";
/// boresight_lcm::nominal_mountings_t: the heads' nominal mountings (QSA1B, simulator, configuration).
constexpr const char* kMountingsChannel = "NOMINAL_MOUNTINGS";
/// boresight_lcm::orbit_sample_t: GNI1B / GNV1B orbit samples.
constexpr const char* kOrbitChannel = "ORBIT";

/// Plain mirrors of the LCM types (so users of this header need no generated code).
struct HeadSample {
  TimeUs utime = 0;
  int head_id = 1;
  double q[4] = {1, 0, 0, 0};  ///< q_I_S, scalar first
  int star_count = 0;
  std::int32_t flags = 1;  ///< bit 0 valid, bit 1 degraded, bit 2 blinded
  std::int32_t seq = 0;
};
struct AccelSample {
  TimeUs utime = 0;
  double ang_accel[3] = {0, 0, 0};  ///< rad/s^2, accelerometer frame A
  double lin_accel[3] = {0, 0, 0};  ///< m/s^2, accelerometer frame A
  std::int32_t flags = 3;  ///< bit 0 angular valid, bit 1 linear valid
  std::int32_t seq = 0;
};

/// Mirror of star_vectors_t (units in src/lcmtypes/star_vectors_t.lcm).
struct StarVectors {
  static constexpr int kCapacity = 16;
  TimeUs utime = 0;
  int head_id = 1;
  std::int32_t seq = 0;
  int n_stars = 0;                 ///< 0..kCapacity
  std::int32_t star_id[kCapacity] = {};
  double s_head[kCapacity][3] = {};      ///< unit, head frame
  double r_inertial[kCapacity][3] = {};  ///< unit, inertial frame
  float sigma_rad[kCapacity] = {};       ///< rad, 0: configured
  float magnitude[kCapacity] = {};       ///< Hp
  std::int32_t flags = 1;                ///< bit 0 valid
};

/// Mirror of nominal_mountings_t (units in src/lcmtypes/nominal_mountings_t.lcm).
struct NominalMountings {
  static constexpr int kCapacity = 4;
  TimeUs utime = 0;
  int n_heads = 0;                     ///< 1..kCapacity
  int head_id[kCapacity] = {};
  double q_Si_B[kCapacity][4] = {};    ///< scalar first, R = C_Si_B
  double C_B_A[3][3] = {};             ///< row-major; all zero: not given
  int source = 0;                      ///< 0 configuration, 1 QSA1B, 2 simulator
};
/// Mirror of orbit_sample_t.
struct OrbitSample {
  TimeUs utime = 0;
  char frame = 'I';         ///< 'I' inertial (GNI1B), 'E' Earth-fixed (GNV1B)
  double r_m[3] = {0, 0, 0};
  double v_m_s[3] = {0, 0, 0};
  std::int32_t seq = 0;
};
/// Decoders of one message's bytes (false: not decodable, or counts outside their range).
bool decodeNominalMountings(const void* data, int size, NominalMountings& out);
/// The message's mounting for every configured head whose bit is not set in `keep_mask` (slot k: bit
/// k), into `heads`: the node's rule, and the replay programs' when a log carries the mountings. False
/// with the reason, `heads` unchanged: a configured head the message does not name (kUnknownHead), a
/// non-finite (kNonFinite) or non-unit (kNonUnit, 1e-6) quaternion.
bool applyNominalMountings(const NominalMountings& m, core::HeadSetConfig& heads, std::uint32_t keep_mask, Reject& why);
/// The first NOMINAL_MOUNTINGS message of an LCM log (its first 100 000 events): false when there is none
/// that decodes.
bool firstNominalMountings(const std::string& path, NominalMountings& out);
bool decodeOrbit(const void* data, int size, OrbitSample& out);

// ---- The input messages, decoded and judged once for every reader ------------------------------
// The node's handlers, the replay's LCM log source (process, calibrate, audit, noise) and the log reader
// below decode the four input types with decodeInput() and judge them with checkInput(): one decoder,
// one rule. What only a reader with a configuration can judge (an unknown head, mountings not known
// yet, the time and sequence checks) stays with that reader.

// ---- Versions of the message types -------------------------------------------------------------
// Every layout a boresight LCM type has had (src/lcmtypes/versions.txt): a message whose fingerprint is
// an earlier (or later) layout of the type a channel carries was written by a build with other types -
// named as such, not taken for damaged bytes.

/// One recorded layout.
struct LcmTypeVersion {
  const char* type = nullptr;     ///< e.g. "fused_attitude_t"
  int version = 0;                ///< the type's VERSION constant for this layout
  std::uint64_t fingerprint = 0;  ///< the first 8 bytes of every encoded message, big-endian
  bool current = false;           ///< the layout this build reads and writes
};
/// The table, n entries (static storage; no allocation).
const LcmTypeVersion* lcmTypeVersions(int& n);
/// The recorded layout whose fingerprint opens `data` (nullptr: fewer than 8 bytes, or none).
const LcmTypeVersion* lcmTypeVersionOf(const void* data, int size);
/// The bytes open with the fingerprint of a layout of `type` other than the current one.
bool isOtherVersion(const char* type, const void* data, int size);

/// The input message types (channels STAR_HEAD, ACCEL, STAR_VECTORS, ORBIT by default).
enum class InputKind : std::uint8_t { kHead, kAccel, kStars, kOrbit };

/// One decoded input message: the member of its kind is set.
struct InputMessage {
  InputKind kind = InputKind::kHead;
  HeadSample head;
  AccelSample accel;
  StarVectors stars;
  OrbitSample orbit;
  TimeUs utime() const;
  std::int32_t seq() const;
};

/// Decodes one message of `kind`. False: the bytes are not that type (length, fingerprint) or a count
/// is outside its range (star vectors above StarVectors::kCapacity, an orbit frame other than I or E).
bool decodeInput(InputKind kind, const void* data, int size, InputMessage& out);
/// The LCM type name of an input kind ("star_head_sample_t", "accel_sample_t", ...).
const char* inputTypeName(InputKind kind);

/// Why a decoded input message cannot be used, from its content alone. A star-vector message is judged
/// whole: one impossible star makes the message untrustworthy.
enum class InputFault : std::uint8_t {
  kNone,
  kInvalidFlag,  ///< the message says it is not valid (head, star vectors: flags bit 0; no stars;
                 ///< accelerometer: no valid angular acceleration)
  kNonFinite,    ///< NaN or Inf in a value the core uses
  kNonUnit,      ///< a quaternion (zero, a component above 1, norm off by more than quat_tol) or a star
                 ///< direction (norm off by more than 1e-6) that is no rotation / no direction
  kImplausible,  ///< a finite value outside its physical gate (core/plausibility.h: angular
                 ///< acceleration, orbit radius and speed, a negative star sigma)
};
const char* inputFaultName(InputFault f);
/// The rule; `quat_tol` is the platform's heads.unit_norm_tolerance.
InputFault checkInput(const InputMessage& m, double quat_tol);

class LcmLogWriter {
 public:
  LcmLogWriter();
  ~LcmLogWriter();
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;
  /// Opens the log: written under a temporary name next to `path` until close() renames it over `path`
  /// (a writer destroyed without close() removes it: a failed run leaves the previous log or none). A
  /// device or a pipe is written in place. False with *error on failure.
  bool open(const std::string& path, std::string* error);
  bool write(const HeadSample& s);
  bool write(const AccelSample& s);
  bool write(const StarVectors& s);  ///< false also when n_stars is outside 0..kCapacity
  bool write(const NominalMountings& m);  ///< false also when n_heads is outside 1..kCapacity
  bool write(const OrbitSample& o);
  /// Any encoded message on any channel, with the event time taken from `utime` (the node's outputs).
  bool writeRaw(const std::string& channel, TimeUs utime, const void* data, int size);
  /// Completes the log at its path. False with *error when it cannot be renamed there.
  bool close(std::string* error = nullptr);
  /// Removes the log being written (the previous file at the path stays).
  void abandon();
  std::uint64_t written() const { return written_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint64_t written_ = 0;
};

/// Reads a log event by event. Unknown channels and undecodable messages are counted, not fatal.
class LcmLogReader {
 public:
  enum class Kind { Head, Accel, Skipped, End, Stars, Orbit };
  LcmLogReader();
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;
  bool open(const std::string& path, std::string* error);
  /// Next event: fills head or accel. Skipped: unknown channel or decode failure (see counters).
  Kind next(HeadSample& head, AccelSample& accel);
  /// After next() returned Kind::Stars: the star-vector message (STAR_VECTORS channel).
  const StarVectors& stars() const { return msg_.stars; }
  /// After next() returned Kind::Orbit: the orbit message (ORBIT channel).
  const OrbitSample& orbit() const { return msg_.orbit; }
  /// After next() returned Head, Accel, Stars or Orbit: the message as decodeInput() gives it.
  const InputMessage& message() const { return msg_; }
  /// One event of the log as it is: channel and encoded bytes (valid until the next call). size -1:
  /// bytes that are not an event (skipped up to the next sync word). False at the end. Use either
  /// next() or nextRaw() on one reader (the node decodes the bytes itself, like live traffic).
  struct RawEvent {
    const std::string* channel = nullptr;
    const void* data = nullptr;
    int size = 0;
    std::int64_t timestamp = 0;  ///< the log's event time, Unix us (not the measurement time)
  };
  bool nextRaw(RawEvent& ev);
  std::uint64_t unknownChannel() const { return unknown_channel_; }
  std::uint64_t decodeFailures() const { return decode_failures_; }
  /// Input messages of another layout of their type (isOtherVersion; not in decodeFailures).
  std::uint64_t otherVersions() const { return other_versions_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::uint64_t unknown_channel_ = 0, decode_failures_ = 0, other_versions_ = 0;
  InputMessage msg_{};
};

/// The input type of a channel of the default names (kStarHeadChannel, ...); false for any other.
bool inputKindOf(const std::string& channel, InputKind& kind);

/// Decodes one STAR_VECTORS message (false: not decodable or n_stars outside 0..kCapacity).
bool decodeStarVectors(const void* data, int size, StarVectors& out);

// ---- Level-1 <-> message conversions (used by `boresight convert` and `boresight process`) ----

/// An SCA1A record as a head message (valid; nstars as star count).
HeadSample headFromSca1a(const Sca1aRecord& r, std::int32_t seq);
/// An ACC1A record as an accelerometer message; the validity bits say which triples were present.
AccelSample accelFromAcc1a(const FlaggedRecord& r, std::int32_t seq);

/// A head message as an SCA1A record (the fields the message does not carry are 0).
Sca1aRecord sca1aFromHead(const HeadSample& h, char satellite);
/// An accelerometer message as an ACC1A record: the valid triples become prod_flag bits.
FlaggedRecord acc1aFromAccel(const AccelSample& a, char satellite);

/// The contents of a log as Level-1 records. The fields the messages do not carry (SCA1A nlocks,
/// sca_confid, sca_mode, qualflg; ACC1A ICU block number) are 0; absent triples are absent bits.
struct LcmAsLevel1 {
  std::vector<Sca1aRecord> sca;
  std::vector<FlaggedRecord> acc;
  std::uint64_t invalid_heads = 0;   ///< head messages without the valid bit (dropped if asked)
  std::uint64_t invalid_accel = 0;   ///< accelerometer messages without valid angular acceleration
  std::uint64_t unknown_channel = 0, decode_failures = 0;
};
bool readLcmAsLevel1(const std::string& path, char satellite, bool drop_invalid, LcmAsLevel1& out,
                     std::string* error);

}  // namespace boresight::io

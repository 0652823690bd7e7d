// The inputs of the streaming replay engine: samples, the reasons an input is not used, and the
// interface every source implements (Level-1 files, an LCM log, later a live LCM subscription).
//
// Contract: every record or message a source reads is reported exactly once, either as a sample
// (Next::kSample) or as rejected with a reason (Next::kRejected); the engine counts both, so
// read == used + rejected holds for every run (EngineCounters).
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/core/wahba.h>
#include <boresight/io/reject.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace boresight::stream {

/// One input of the core: a star-head sample, an accelerometer angular acceleration, or one star
/// vector of one head (star samples of one tag form a core::StarEpoch for the multi-head Wahba).
struct Sample {
  /// Order at equal tags: heads first (the monitor's corrections are then those of the star epoch's
  /// own head epoch), then the accelerometer, then star vectors.
  /// Orbit samples (GNI1B / GNV1B records, ORBIT messages) come last: the thermal prediction of a head
  /// epoch uses the orbit input before it.
  enum class Kind : std::uint8_t { kHead = 0, kAccel = 1, kStar = 2, kOrbit = 3 };
  Kind kind = Kind::kHead;
  TimeUs t = 0;                 ///< sensor time tag, us past GPS J2000
  int head_id = 0;              ///< kHead: telemetry id
  Quat q_I_S = Quat::Identity();  ///< kHead: head attitude, R = C_I_S
  Vec3 a_A = Vec3::Zero();      ///< kAccel: angular acceleration, rad/s^2, accelerometer frame
  // Message fields the core does not use, kept so that a sample can be written as an LCM message
  // again (`boresight convert`): as in io::HeadSample / io::AccelSample.
  int star_count = 0;            ///< kHead: stars tracked (SCA1A nstars)
  std::int32_t flags = 1;        ///< head: bit 0 valid; accelerometer: bit 0 angular, bit 1 linear valid
  Vec3 lin_A = Vec3::Zero();     ///< kAccel: linear acceleration, m/s^2, accelerometer frame (flags bit 1)
  core::StarObservation star{};  ///< kStar: head id, measured direction in the head frame, catalogue
                                 ///< direction in I, sigma (0: the head's configured sigma_star)
  Vec3 r_orbit = Vec3::Zero();   ///< kOrbit: position, m, in the frame `orbit_frame`
  Vec3 v_orbit = Vec3::Zero();   ///< kOrbit: velocity, m/s, in the frame `orbit_frame`
  char orbit_frame = 'I';        ///< kOrbit: 'I' inertial (GNI1B, ORBIT messages), 'E' Earth-fixed (GNV1B)
};

/// Why an input record or message was not handed to the core: the one list every program counts in
/// (io/reject.h).
using io::Reject;
using io::kRejectCount;

/// Counts of one source or of the whole run.
struct Counters {
  std::uint64_t read = 0;        ///< records / messages read
  std::uint64_t used_heads = 0;  ///< head samples handed to the core
  std::uint64_t used_accel = 0;  ///< accelerometer samples handed to the core
  std::uint64_t used_stars = 0;  ///< star vectors handed to the core (each star counts once)
  std::uint64_t used_orbit = 0;  ///< orbit samples handed to their consumer (the core's thermal
                                 ///< prediction, a thermal fit)
  std::array<std::uint64_t, kRejectCount> rejected{};
  std::uint64_t used() const { return used_heads + used_accel + used_stars + used_orbit; }
  std::uint64_t rejectedTotal() const {
    std::uint64_t n = 0;
    for (auto v : rejected) n += v;
    return n;
  }
};

class Source {
 public:
  enum class Next : std::uint8_t {
    kSample,    ///< `out` holds the next sample
    kRejected,  ///< one record/message was read and is not usable: `why` says why
    kEnd,       ///< no more data, ever
    kPending,   ///< nothing available now (a live source); ask again later
    kError,     ///< the source cannot go on (read error, OnError::Stop): see error()
  };
  virtual ~Source() = default;
  virtual Next next(Sample& out, Reject& why) = 0;
  /// Name used in reports (the file name).
  virtual const std::string& name() const = 0;
  virtual std::string error() const { return {}; }
  /// The first few rejected records with their place ("file:line: reason"), for reports.
  virtual std::vector<std::string> issues() const { return {}; }
};

}  // namespace boresight::stream

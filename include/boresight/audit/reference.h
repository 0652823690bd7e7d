// The outside reference of the model audit and of `boresight process --compare-sca1b`: the official
// attitude product SCA1B (GPS time tags) and the receiver clock map CLK1B (Level-1A tags such as
// SCA1A's are receiver time).
//
//   process: the fused attitude (receiver tags mapped to GPS time through CLK1B) against SCA1B at
//            SCA1B's tags, per body axis mean and scatter, and the time shift of the fused attitude
//            that makes the mean smallest (compareAttitudes, scanTimeShift).
//   audit:   SCA1B streamed into Collector::addReference in the receiver time base of SCA1A
//            (ReferenceFeed: t_rcv = t_gps - eps(t_rcv) through CLK1B; without CLK1B the GPS tags
//            are taken as receiver time, which the caller must say).
//
// Time: TimeUs / seconds past the GPS J2000 epoch (core/conventions.h). Rotation SCA1B -> fused in
// body axes: Log(q_fused^-1 q_SCA1B), arcsec.
#pragma once

#include <boresight/audit/audit.h>
#include <boresight/core/conventions.h>
#include <boresight/io/level1.h>
#include <boresight/stream/sinks.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace boresight::audit {

/// Receiver time -> GPS time from CLK1B: t_gps = t_rcv + eps_time(t_rcv), linear between records,
/// held constant outside them. Empty: no clock correction (eps = 0).
struct ClockMap {
  std::vector<io::ClkRecord> records;  ///< good records (qualflg 0), receiver time order
  bool empty() const { return records.empty(); }
  /// eps_time at receiver time t, s.
  double epsAt(TimeUs t_rcv) const;
  /// The receiver time whose GPS time is t_gps (the inverse of t_rcv + eps(t_rcv), by fixed-point
  /// iteration: eps changes by far less than a second per second, so three steps are exact to 1 us).
  TimeUs toReceiver(TimeUs t_gps) const;
};

/// Opens PATH's header and checks it is the product `want` (e.g. io::Product::SCA1B): false with
/// *error "PATH:0: cannot open ..." or "PATH:1: GNV1B is not an SCA1B product".
bool checkProduct(const std::string& path, io::Product want, std::string* error);
inline bool checkSca1b(const std::string& path, std::string* error) {
  return checkProduct(path, io::Product::SCA1B, error);
}
inline bool checkClk1b(const std::string& path, std::string* error) {
  return checkProduct(path, io::Product::CLK1B, error);
}

/// Reads every CLK1B file (good records, qualflg 0) into one map, sorted by receiver time.
bool loadClk1b(const std::vector<std::string>& paths, ClockMap& out, std::string* error);

/// Reads the SCA1B records (text streamed, GRACE binary read whole).
bool readSca1b(const std::string& path, std::vector<io::Sca1bRecord>& out, std::string* error);

/// An attitude at a time in seconds (GPS or receiver: the caller keeps one time base).
struct TimedAttitude {
  double t_s;
  Quat q_I_B;
};

/// Rotation reference -> fused in body axes over the common epochs: count, mean and scatter (arcsec).
struct AttitudeDifference {
  int n = 0;
  Vec3 mean = Vec3::Zero(), sd = Vec3::Zero();
};

/// The fused attitude (time order) taken at each reference tag + shift_s (slerp between the two
/// fused samples around it; none across a gap over 1.5 s) against the reference.
AttitudeDifference compareAttitudes(const std::vector<TimedAttitude>& fused, const std::vector<TimedAttitude>& ref,
                                    double shift_s);

/// The shift of the fused attitude, on a +-1 s grid of 10 ms, that makes the mean difference smallest
/// (among shifts keeping at least half the epochs). For small shifts the mean difference is close to
/// linear in the shift (the rate about each axis times the shift), so its norm is convex along the
/// grid: a 100 ms scan finds the neighbourhood and a 10 ms scan within +-100 ms of the best coarse
/// point the grid minimum.
struct ShiftScan {
  AttitudeDifference at_zero;  ///< shift 0
  AttitudeDifference best;     ///< at best_shift_s (== at_zero when no shift is better)
  double best_shift_s = 0;
};
ShiftScan scanTimeShift(const std::vector<TimedAttitude>& fused, const std::vector<TimedAttitude>& ref);

/// The SCA1B records of one file as reference samples in GPS seconds (quaternions normalised).
std::vector<TimedAttitude> referenceSamples(const std::vector<io::Sca1bRecord>& recs);

/// Feeds SCA1B files to a Collector in time order, in the receiver time base (through `clock`; empty:
/// GPS tags taken as receiver time). As an InputObserver registered on the engine BEFORE the
/// collector it interleaves the reference with the head epochs (every reference sample up to a head
/// epoch's tag before that epoch; the rest at the end), so the collector sees one time-ordered
/// stream; feedAll() does it without an engine. Text SCA1B is streamed (constant memory).
class ReferenceFeed final : public stream::InputObserver {
 public:
  using Sink = std::function<void(TimeUs t_rcv, const Quat& q_I_B)>;
  ReferenceFeed(Collector& c, ClockMap clock);
  /// Feeds `sink` instead of a collector.
  ReferenceFeed(Sink sink, ClockMap clock);
  ~ReferenceFeed() override;
  /// Opens the files (each in time order; files given in time order). False with *error.
  bool open(const std::vector<std::string>& sca1b, std::string* error);
  void onHeads(const core::HeadEpoch& e, core::Status core_status) override;
  void onEnd() override;
  /// Every remaining sample (false with *error on a read error).
  bool feedAll(std::string* error);
  /// Feeds the samples with receiver time <= t; false on a read error.
  bool feedUntil(TimeUs t_rcv);
  std::uint64_t fed() const { return fed_; }
  /// Samples not fed: bad quality or quaternion, or out of time order.
  std::uint64_t dropped() const { return dropped_; }
  bool clockApplied() const { return !clock_.empty(); }
  /// "receiver time through CLK1B" or "GPS time taken as receiver time (no CLK1B)".
  std::string timeBase() const;
  const std::string& error() const { return error_; }

 private:
  struct Reader;
  bool next(TimeUs& t_rcv, Quat& q);
  Sink sink_;
  ClockMap clock_;
  std::vector<std::string> files_;
  std::size_t file_ = 0;
  std::unique_ptr<Reader> reader_;
  bool have_pending_ = false;
  TimeUs pending_t_ = 0, last_t_ = 0;
  Quat pending_q_ = Quat::Identity();
  std::uint64_t fed_ = 0, dropped_ = 0;
  std::string error_;
};

}  // namespace boresight::audit

// Sinks of the replay engine: where the core's output rows go. An LCM message sink (the node's
// output) implements the same interface later.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/core/ring.h>
#include <boresight/io/files.h>
#include <boresight/io/chunked_writer.h>
#include <boresight/io/level1.h>
#include <boresight/model/orbit_context.h>

#include <array>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace boresight::stream {

/// The joint attitude of one star epoch (multi-head Wahba, METHODS 2.4) with the fused attitude of the
/// head epoch at the same tag, when there is one.
struct StarSolution {
  core::WahbaSolution wahba;       ///< q_I_B through the reference head's mounting, P_SR, stars used
  bool has_fused = false;          ///< a head epoch with the same tag was fused
  Quat q_I_B_fused = Quat::Identity();
};

class RowSink {
 public:
  virtual ~RowSink() = default;
  /// Before the first row, with the configuration the core runs (head ids for column names).
  virtual bool begin(const core::PipelineConfig& /*cfg*/) { return true; }
  virtual bool write(const core::PipelineRow& row) = 0;
  /// A solved star epoch (only when star vectors are among the inputs); sinks that do not want them
  /// ignore them.
  virtual bool writeStars(const StarSolution& /*s*/) { return true; }
  /// After the last row (flush, close).
  virtual bool end() { return true; }
  /// Empty unless a call returned false.
  virtual std::string error() const { return {}; }
};

/// Sees the core's inputs as the engine hands them to the pipeline, in the same order, with the
/// status the core returned for each (a batch consumer such as calib::SpanBuilder). Head epochs are
/// passed as the core's input validator leaves them: samples it rejects (unknown head, NaN or Inf,
/// non-unit quaternion, a head twice) are removed, quaternions normalised, samples in slot order; an
/// epoch the validator rejects as a whole (no valid head, time not increasing) is not passed (the
/// core's health counts it). Called on the engine's thread, after the core's step.
class InputObserver {
 public:
  virtual ~InputObserver() = default;
  virtual void onHeads(const core::HeadEpoch& /*e*/, core::Status /*core_status*/) {}
  virtual void onAcc(TimeUs /*t*/, const Vec3& /*a_A*/, core::Status /*core_status*/) {}
  /// True when this observer takes the orbit (then the engine reads orbit inputs and calls onOrbit).
  virtual bool wantsOrbit() const { return false; }
  /// An orbit sample with its angles (model/orbit_context.h), in time order with the other inputs.
  virtual void onOrbit(const model::OrbitSample& /*o*/) {}
  /// After the last input (before the sinks end); a consumer completes what it holds.
  virtual void onEnd() {}
};

/// The `boresight process` table: one CSV row per output epoch (columns in cmd_process --help).
/// Numbers are formatted as printf's %.17g (quaternion), %.9e (rates, accelerations), %.9f (angles,
/// deg) and %.3f (deviations, arcsec); a value that is not available is an empty field.
class CsvRowSink final : public RowSink {
 public:
  explicit CsvRowSink(std::string path) : path_(std::move(path)) {}
  ~CsvRowSink() override;
  /// The file is written under a temporary name (io::AtomicFile) and appears at its path whole: at
  /// end(), or, after deferCommit(), only at commit() (a run that fails after the replay leaves the
  /// previous file or nothing).
  void deferCommit() { defer_ = true; }
  bool begin(const core::PipelineConfig& cfg) override;
  bool write(const core::PipelineRow& row) override;
  bool end() override;
  bool commit(std::string* error);
  std::string error() const override { return error_; }
  std::size_t rows() const { return rows_; }
  std::size_t withRates() const { return with_rates_; }
  std::size_t withAcc() const { return with_acc_; }

 private:
  bool flushBuffer();
  std::string path_, error_;
  io::AtomicFile file_;
  std::FILE* f_ = nullptr;
  bool defer_ = false;
  std::string buf_;
  int n_heads_ = 0;
  std::size_t rows_ = 0, with_rates_ = 0, with_acc_ = 0;
};

/// The `boresight process --stars-out` table: one CSV row per solved star epoch.
///   time_s, q0..q3 (q_I_B from the stars, scalar first), sigma_x..z_arcsec (1-sigma of that attitude
///   about the body axes, from the Wahba covariance including the relative matrices' uncertainty),
///   stars_in, stars_used, residual_rms_arcsec, d_fused_x..z_arcsec (rotation from the fused attitude
///   of the same tag to the star attitude, body axes; empty when no head epoch has that tag)
class CsvStarSink final : public RowSink {
 public:
  explicit CsvStarSink(std::string path) : path_(std::move(path)) {}
  ~CsvStarSink() override;
  /// As CsvRowSink: whole at end(), or at commit() after deferCommit().
  void deferCommit() { defer_ = true; }
  bool begin(const core::PipelineConfig& cfg) override;
  bool write(const core::PipelineRow&) override { return true; }
  bool writeStars(const StarSolution& s) override;
  bool end() override;
  bool commit(std::string* error);
  std::string error() const override { return error_; }
  std::size_t rows() const { return rows_; }

 private:
  std::string path_, error_;
  io::AtomicFile file_;
  std::FILE* f_ = nullptr;
  bool defer_ = false;
  std::size_t rows_ = 0;
};

/// The fused attitude as a GRACE-FO SCA1B product (`boresight process --sca1b`): q_I_B (inertial to
/// the body frame, scalar first and non-negative: quatangle = cos(theta/2), theta in [0, 180 deg]) at
/// every whole GPS second between two rows with heads at most max_gap_s apart, by slerp; rows further
/// apart leave a hole (no record, counted), never an interpolated value, so qualflg bit 0
/// ("interpolated") is never set. Per record:
///   sca_id    the heads fused in the rows around it, as SCA1B counts them: bit id-1 for head id 1..3
///             (7: SCAs 1, 2 and 3); the IMU bits stay 0 (the fusion uses no IMU)
///   qual_rss  the RSS of the formal errors of the four quaternion components: 0.5 sqrt(trace P_B) of
///             the fused covariance (a body-frame error e moves q by q (0, e/2), an isometry of e/2), the
///             larger of the two rows'
///   qualflg   bit 3 when either row fused one head only
/// Row tags are the inputs' time (receiver time for Level-1A); `gps_minus_tag_s` (e.g. CLK1B's
/// eps_time) turns them into GPS time, otherwise they are written as they are. Records are written as
/// they come (io::ChunkedProductWriter: one chunk of 16384 in memory, whatever the span) under a
/// temporary name that commit() renames; the header states the record count and the records' time span
/// (time_coverage_start/stop, start/stop_time_epoch_secs, as the official product has them).
class Sca1bSink final : public RowSink {
 public:
  Sca1bSink(std::string path, char satellite, double max_gap_s, std::function<double(TimeUs)> gps_minus_tag_s = {});
  /// False with error() when a head id is outside 1..3 (SCA1B's sca_id has bits for three cameras).
  bool begin(const core::PipelineConfig& cfg) override;
  bool write(const core::PipelineRow& row) override;
  /// Finishes the product (a synthesised SCA1B header with the record count and the time coverage of
  /// the records), whole or not at all: it is written as the rows come (io::ChunkedProductWriter, one
  /// chunk of records in memory), under a temporary name until then.
  bool commit(std::string* error);
  std::string error() const override { return error_; }
  std::size_t records() const { return static_cast<std::size_t>(writer_.written()); }
  std::uint64_t holeSeconds() const { return holes_; }  ///< whole seconds inside gaps, not written
  std::uint64_t rowsOutOfOrder() const { return out_of_order_; }  ///< rows at or before the previous one (not used)

 private:
  void emit(TimeUs t_gps, const Quat& q, std::uint32_t mask, double qual_rss, bool one_head);
  std::string path_, error_;
  double max_gap_s_;
  std::function<double(TimeUs)> eps_;
  std::array<std::int32_t, core::kMaxHeads> bit_{};
  char satellite_ = 'C';
  io::ChunkedProductWriter<io::Sca1bRecord> writer_;
  bool have_prev_ = false;
  TimeUs prev_t_ = 0, next_s_ = 0;  ///< GPS us of the previous row; the next whole second to write
  Quat prev_q_ = Quat::Identity();
  std::uint32_t prev_mask_ = 0;
  double prev_rss_ = 0;
  bool prev_one_ = false;
  std::uint64_t holes_ = 0, out_of_order_ = 0;
};

/// The last `capacity` rows in a ring (for a batch solver that works on a sliding span). Fixed
/// memory after construction; rows beyond the capacity push the oldest out (counted).
class BatchBufferSink final : public RowSink {
 public:
  explicit BatchBufferSink(std::size_t capacity);
  bool write(const core::PipelineRow& row) override;
  std::size_t size() const { return ring_.size(); }
  std::size_t capacity() const { return ring_.capacity(); }
  /// Row i of the buffer, 0 = oldest kept.
  const core::PipelineRow& at(std::size_t i) const { return ring_[i]; }
  std::uint64_t written() const { return written_; }
  std::uint64_t overwritten() const { return written_ - ring_.size(); }
  void clear() { ring_.clear(); }

 private:
  core::Ring<core::PipelineRow> ring_;
  std::uint64_t written_ = 0;
};

}  // namespace boresight::stream

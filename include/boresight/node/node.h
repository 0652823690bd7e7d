// boresight::node - the LCM node `boresightd`: message handlers (decode, validate, count) in front of
// the replay engine every program runs (stream::Engine: epoch assembler, real-time core, sinks),
// outputs published as LCM messages, and a worker thread that runs the method A solver at a
// configured cadence and hands the mountings back.
//
//   live:    lcm::LCM subscriptions ---------\                  stream::Engine     /--> publish (lcm::LCM)
//   replay:  io::LcmLogReader::nextRaw() -----+-> Node::onMessage() -> PushSource -> core +--> record (LCM log)
//                                             (same handlers)      (hook, sink)    \--> SPSC ring -> worker
//
// Threads: the caller's thread (the real-time one) runs the handlers and the engine (its assembler and
// core; the node's work at each head-epoch boundary is the engine's StepHook, the published messages
// its RowSink, the worker's ring its InputObserver); after configure() it does not allocate
// (fixed-size messages decoded on the stack, a fixed ring, a fixed latency histogram). The worker
// thread owns a calib::CalibrationFeed fed from a bounded lock-free single-producer/single-consumer
// ring (head epochs as the core's validator leaves them and the accelerometer samples the core
// accepted: what `boresight calibrate`'s feed takes from the same engine);
// at every `cadence_s` of data time the real-time thread puts a solve request into the ring, and the
// worker solves a copy of the span (single-threaded Ceres) and leaves the result in a one-slot mailbox.
// The real-time thread takes it at a head-epoch boundary and hands the mountings to the core
// (Pipeline::handMountings keeps the datum: only the relative, head-to-head part changes the fusion,
// so the published attitude does not jump; the common rotation to the accelerometer frame is
// published in the calibration message, and applied to the published attitude only when
// calibration.apply_common_rotation says so: a frame change, counted (frame_changes) and logged on
// stderr by the worker thread, never by the real-time one).
//   Live: ring full -> the item is dropped and counted (ring_dropped); a result is applied at the first
//   epoch after it is ready; the real-time thread never waits.
//   Replay (lockstep): a full ring makes the reader wait (it is not real time), and a calibration
//   started at head epoch k is applied at head epoch k + apply_lag_epochs (waiting for the worker if
//   needed): every run publishes identical payloads.
//
// Accounting: every message received on a node channel is either used or rejected with one reason,
// so received == used + sum(rejected). `lost` counts what the senders' sequence numbers say was sent
// and never arrived (per head, accelerometer, star-vector and orbit channel); a jump of a sequence
// number beyond the reorder window (64) counts as loss only when the next number continues from it, so
// one corrupt number is one bad message, not a million lost; a jump back beyond it, confirmed the same
// way, is a sender's restart (seq_restarts), and losses after it count from the new numbers
// (channel_gate.h). Time: a message whose tag is more than lookahead_s away from the node's data time
// is held, and passes once time_jump_confirm messages in a row (from both sensors where both are
// active) agree on the new time (a real jump: resync), else it is rejected (time_jump): one corrupt
// tag never moves the assembler's frontier nor turns every later message into "late"; a confirmed
// step back re-synchronises the assembler and the core (their filters restart, the counts go on). The
// first message sets the data time (a wrong one is out-voted the same way, and the assembler drops it
// as a time outlier).
#pragma once

#include <boresight/calib/raw_bound.h>
#include <boresight/core/pipeline.h>
#include <boresight/io/reject.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace boresight::node {

/// Reasons a message is rejected: the one list of every program (io/reject.h; index into
/// Counters::rejected, and node_health_t.rejected uses the same for the first 16, all the node counts).
using io::Reject;
using io::kRejectCount;

struct Channels {
  std::string star_head = "STAR_HEAD", accel = "ACCEL", star_vectors = "STAR_VECTORS";
  std::string mountings = "NOMINAL_MOUNTINGS", orbit = "ORBIT", command = "BORESIGHT_COMMAND";
  std::string attitude = "BORESIGHT_ATTITUDE", monitor = "BORESIGHT_MONITOR";
  std::string calibration = "BORESIGHT_CALIBRATION", health = "BORESIGHT_HEALTH";
};

struct CalibrationConfig {
  bool enabled = true;
  double cadence_s = 6 * 3600.0;    ///< data time between solves, s
  double min_span_s = 3 * 3600.0;   ///< first solve only after this much data, s
  int apply_lag_epochs = 20;        ///< replay: a result started at head epoch k is applied at k + this
  double decimation_s = 10.0;       ///< calib::SpanOptions::decimation_s, s
  std::size_t max_observations = 0; ///< 0: the whole run (memory: ~0.5 kB per observation)
  bool apply = true;                ///< hand the relative part back to the core
  /// Hold every result until a ground command accepts it (BORESIGHT_COMMAND, node_command_t); off: each
  /// result is applied when it is ready (a revert command works either way).
  bool hold_for_command = false;
  /// Frame change: the published attitude (and its covariance, rate, accelerations) is rotated into
  /// the accelerometer-datum frame with the common rotation of each applied calibration (from the
  /// head epoch at which it is applied on). Off: the published attitude keeps its frame (the heads'
  /// datum) and the common rotation is only published in calibration_t.
  bool apply_common_rotation = false;
  /// A frame change also needs the common rotation determined about all three axes (the solver's
  /// unobservable common directions: none) and at least this much data time since the last change, s;
  /// else it is refused (frame_changes_refused, logged) and only the relative part is applied.
  double frame_change_min_interval_s = 3 * 3600.0;
  /// A frame change also needs the fit's chi-square per degree of freedom (the attitude-domain estimate's
  /// largest over the heads and their groups) at most this: a fit whose noise model does not describe
  /// the data does not move the published frame. The CRN solver has none: not applied to it.
  double frame_change_max_chi2_per_dof = 2.0;
  /// crn (default): method A's CRN-domain solver, as `boresight calibrate`. attitude: after a successful
  /// CRN solve, the attitude-domain estimate from the raw head and accelerometer samples of the same
  /// window of data time (calib::estimateRaw, as `calibrate --raw`, noise fitted to the data), whose
  /// mountings and sigmas are the ones published and applied; it keeps every raw sample of the window
  /// (about 150 MB per day of GRACE-FO data: 112 bytes per sample, 16 samples a second) and costs
  /// seconds to minutes per solve.
  enum class Method : std::uint8_t { kCrn, kAttitude } method = Method::kCrn;
  int raw_passes = 3;  ///< attitude: the estimator's passes (3: the noise models fitted after the second)
  /// attitude: the estimate also takes the accelerometer's time offset against the heads (one column;
  /// the raw samples determine it to a fraction of a millisecond in manoeuvres) and its scale factors.
  /// Either one left out is read as mounting error: the committed calibration day's 15 ms and
  /// 0.05-0.2 % put the published angles 5 sigma off (13" RMS against a 3.5-4.2" bound).
  bool raw_time_offset = true;
  bool raw_acc_scale = true;
  /// attitude: heads 2..n's alignment as a constant plus this many harmonics of the argument of latitude
  /// (from the ORBIT messages; none when the window holds less than one revolution of orbit), as
  /// `calibrate --raw-harmonics`.
  int raw_harmonics = 2;
};

struct NodeConfig {
  std::string file;                 ///< the configuration file (for messages)
  std::string platform_file;        ///< the platform file it names (an input: outputs never go over it)
  core::PipelineConfig pipeline;    ///< platform (heads, CRNs, C_B_A), the head sigmas from its noise section
  bool mountings_from_log = false;  ///< wait for a NOMINAL_MOUNTINGS message before stepping
  /// `overlay: FILE` (io/overlay_apply.h): its noise replaces the platform file's, its mountings the
  /// platform file's or the NOMINAL_MOUNTINGS message's (slots in this mask keep the overlay's; when it
  /// gives every head the node does not wait for the message).
  std::string overlay;
  std::uint32_t overlay_mounting_mask = 0;
  /// The overlay's thermal terms as the core's model (io::thermalModelFromOverlay): with it, ORBIT
  /// messages step the core's thermal prediction of the pairs a head epoch does not see; without it
  /// they are rejected as no_consumer.
  std::optional<core::ThermalHarmonicModel> thermal_model;
  /// The accelerometer's white noise per A axis for the worker's method A (the platform's noise
  /// section, or the overlay's), rad/s^2 per sample.
  Vec3 acc_white_noise_radps2 = Vec3(1.5e-7, 3.0e-8, 5.0e-8);
  /// calibration.method attitude: the estimator's configuration (the platform's heads and the noise in
  /// use, the bias estimated, the noise fitted to the data) and the sigma above which an axis is not
  /// determined (the platform file's heads.mounting_uncertainty_arcsec when smaller than 3600", rad).
  std::optional<calib::RawBoundConfig> raw_config;
  double raw_not_determined_rad = 3600.0 * kRadPerArcsec;
  /// The noise and mountings in use with their sources, and the overlay's applied / not applied parts
  /// (io::modelInUseLines): printed at start and written into the summary.
  std::vector<std::string> model_in_use;
  /// `state_file: FILE` (relative to the node's file; empty: none): a model overlay with the last applied
  /// calibration's mountings and the published frame, written atomically by the worker thread after
  /// each applied calibration and at the end, and read at start (a restart goes on with the same
  /// mountings, frame and calibration identifier instead of jumping back to the nominal ones).
  std::string state_file;
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  Channels channels;
  double lookahead_s = 2.0;         ///< assembler look-ahead, s
  double health_period_s = 10.0;    ///< data time between health messages, s
  /// A tag further than lookahead_s from the data time is a jump: held until this many messages in a
  /// row (from the star cameras and the accelerometer, where both are active) agree on the new time (1-16).
  int time_jump_confirm = 3;
  double max_head_rate_hz = 20.0;   ///< per head: more messages per data second are a flood
  double max_accel_rate_hz = 50.0;
  double max_star_rate_hz = 20.0;   ///< per head
  std::size_t ring_capacity = 4096; ///< worker ring items (power of two)
  CalibrationConfig calibration;
};

/// Parses and validates the node's YAML configuration (it names the platform file). False with
/// *error as "FILE: KEY: reason".
bool loadNodeConfig(const std::string& path, NodeConfig& out, std::string* error);

/// Where the node's outputs go (an LCM instance, a log, a test's list).
class Output {
 public:
  virtual ~Output() = default;
  virtual void publish(const std::string& channel, TimeUs utime, const void* data, int size) = 0;
};

struct LatencySummary {
  double p50_us = 0, p99_us = 0, p999_us = 0, max_us = 0;
  std::uint64_t n = 0;
};

struct Counters {
  std::uint64_t received = 0, used = 0, lost = 0;
  std::array<std::uint64_t, kRejectCount> rejected{};
  std::uint64_t head_epochs = 0, accel_steps = 0, star_epochs = 0, rows = 0;
  std::uint64_t orbit_steps = 0;  ///< orbit samples the core's thermal prediction stepped with
  std::uint64_t calibrations_published = 0, calibrations_applied = 0, calibrations_refused = 0;
  std::uint64_t ring_high_water = 0, ring_dropped = 0, ring_waits = 0;
  std::uint64_t outputs_failed = 0;  ///< output messages that did not encode into the encoder's buffer (not published; stays 0)
  std::uint64_t stars_dropped = 0;  ///< star vectors (not messages) the assembler refused
  std::uint64_t time_resyncs = 0;  ///< confirmed jumps of the data time (forward or back)
  std::uint64_t held = 0;          ///< messages held at a jump until it was confirmed or refuted
  std::uint64_t seq_restarts = 0;  ///< senders' counters that started again (not counted as loss)
  std::uint64_t frame_changes = 0;  ///< common rotations applied to the published attitude
  std::uint64_t frame_changes_refused = 0;  ///< not determined about every axis, or too soon after the last
  std::uint64_t mountings_applied = 0;      ///< later NOMINAL_MOUNTINGS messages with new mountings, applied
  std::uint64_t mountings_refused = 0;      ///< new mountings the core refused (kept the old ones)
  std::uint64_t calibrations_superseded = 0;  ///< results solved against nominal mountings replaced since
  std::uint64_t calibrations_held = 0;        ///< results held for a ground command (hold_for_command)
  std::uint64_t commands_accepted = 0, commands_reverted = 0;  ///< ground commands applied
  /// The worker's solves (published or refused): CPU seconds of the solver thread (sum, largest), the
  /// largest wall time, the largest span solved (decimated epochs, their bytes). Summary only (wall
  /// clock: never published in replay).
  std::uint64_t solves = 0;
  double solve_cpu_s_sum = 0, solve_cpu_s_max = 0, solve_wall_s_max = 0;
  std::uint64_t solve_observations_max = 0, solve_observation_bytes_max = 0;
  std::uint64_t rejectedTotal() const {
    std::uint64_t n = 0;
    for (auto v : rejected) n += v;
    return n;
  }
};

class Node {
 public:
  enum class Mode : std::uint8_t { kLive, kReplay };
  Node();
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  /// Sizes everything and starts the worker. False with *error.
  bool configure(const NodeConfig& cfg, Mode mode, Output* out, std::string* error);
  /// One message as received (channel name, encoded bytes). Never throws; counts everything.
  void onMessage(const std::string& channel, const void* data, int size);
  /// Bytes that are not even an LCM event (replay: damage in the log): counted as undecodable.
  void onGarbage();
  /// End of data: flushes the assembler and the core, stops the worker, publishes the final health.
  void finish();

  const Counters& counters() const;
  /// Wall time of each core step (head epochs, accelerometer samples, star epochs), and of the head
  /// epochs alone (the expensive ones: fusion, monitor, rates).
  LatencySummary stepLatency() const;
  LatencySummary headStepLatency() const;
  core::Health coreHealth() const;
  const core::Pipeline& pipeline() const;
  TimeUs dataTime() const;
  std::uint64_t mountingVersion() const;
  /// The rotation applied to the published attitude (q_B_Bpub: identity until a frame change).
  Quat frameRotation() const;
  /// Why the last refused calibration was refused (the solver's message; empty when none was).
  std::string lastCalibrationReason() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Replay: every event of the log into the node's handlers, as fast as possible (io::LcmLogReader,
/// not LCM's file provider), then finish(). False with *error when the log cannot be read. `stop`
/// (a signal handler's flag) ends the replay early, still with finish() (the summary counts what was
/// read).
bool replayLog(Node& node, const std::string& path, std::string* error, const std::atomic<bool>* stop = nullptr);

}  // namespace boresight::node

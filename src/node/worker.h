// boresight::node - the node's calibration worker (private to the node library): it keeps method A's
// feed (calib::CalibrationFeed) fed from a lock-free ring the real-time thread pushes to, hands a copy
// of it to its solver thread at each solve request, which runs calib::runCalibration as `boresight
// calibrate` does, and leaves the result in a one-slot mailbox the real-time
// thread takes at a head-epoch boundary. The ring's push and the mailbox's check are the only calls
// on the real-time thread: neither allocates, blocks or throws. Everything else runs on the worker's
// two threads, which may allocate and block on each other.
#pragma once

#include <boresight/calib/calibration.h>
#include <boresight/core/pipeline.h>
#include <boresight/core/ring.h>

#include "boresight_lcm/calibration_t.hpp"

#include <array>
#include <atomic>
#include <condition_variable>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace boresight::node {

/// What the real-time thread hands the worker.
struct WorkItem {
  enum Kind : std::uint8_t { kHeads, kAcc, kSolve, kStop, kMountings, kOrbit } kind = kHeads;
  TimeUs t = 0;
  core::HeadEpoch heads{};
  Vec3 a_A = Vec3::Zero();
  std::uint64_t solve_id = 0;  ///< kSolve: the request; kMountings: the nominal generation from here on
  std::array<Quat, core::kMaxHeads> q_Si_B = core::filled<Quat, core::kMaxHeads>(Quat::Identity());  ///< kMountings: the new nominal mountings by slot
  model::OrbitSample orbit{};  ///< kOrbit: for the attitude-domain estimate (the stars' aberration)
};

/// The mailbox's state: empty -> being written (solver thread) -> ready -> taken back to empty
/// (real-time thread).
enum class MailState : std::uint8_t { kEmpty, kWriting, kReady };

/// One solve's result as the real-time thread takes it.
struct Mailbox {
  std::atomic<MailState> state{MailState::kEmpty};
  std::uint64_t solve_id = 0;
  bool ok = false;
  std::array<Quat, core::kMaxHeads> q_Si_B{};  ///< the calibrated mountings (the nominal ones when refused)
  boresight_lcm::calibration_t msg{};   ///< the message to publish (seq and applied set by the node)
  /// Why a calibration was refused, NUL-terminated: calib::CalibrationRun::refusal_text (the reason and,
  /// for a span too short or too quiet, what would be needed), cut at the array's size.
  std::array<char, 1024> reason{};
  /// The common rotation is determined about every B axis (the solver's unobservable directions of a
  /// common rotation: none).
  bool common_determined = false;
  std::uint64_t nominal_gen = 0;  ///< the nominal mountings the span was built with (0: the first)
  /// The solve's cost: CPU time of the solver thread in calib::runCalibration, its wall time, and the
  /// span it solved (decimated epochs kept, their bytes: what the solve's copy of the feed holds).
  double cpu_s = 0.0, wall_s = 0.0;
  bool method_attitude = false;  ///< the attitude-domain estimate's mountings (else the CRN solver's)
  /// The attitude-domain estimate's largest chi-square per degree of freedom over the heads and their
  /// groups (cross-boresight, boresight) in its last pass; NaN for the CRN solver (it has none).
  double chi2_per_dof_max = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t observations = 0, observation_bytes = 0;
};

class CalibrationWorker {
 public:
  CalibrationWorker() = default;
  CalibrationWorker(const CalibrationWorker&) = delete;
  CalibrationWorker& operator=(const CalibrationWorker&) = delete;
  ~CalibrationWorker() { join(); }

  /// The ring's storage (before start).
  void init(std::size_t ring_capacity) { ring_.init(ring_capacity); }
  /// The attitude-domain estimate after each successful CRN solve (before start): its configuration
  /// (the heads' nominal mountings are replaced by the ones in use at each solve), passes and the sigma
  /// above which an axis is not determined; its mountings and sigmas are published. Without it: the CRN
  /// solver's.
  /// The worker takes the orbit (WorkItem::kOrbit): the attitude-domain estimate removes the stars'
  /// aberration with the orbit's velocity.
  bool wantsOrbit() const { return raw_.has_value(); }
  void setAttitudeDomain(const calib::RawBoundConfig& raw, int passes, double not_determined_rad, int harmonics = 0) {
    raw_ = raw;
    raw_passes_ = passes;
    raw_harmonics_ = harmonics;
    raw_not_determined_rad_ = not_determined_rad;
  }
  /// Whether the worker can run this configuration (the feed's configure): false with *error. The node
  /// asks at start-up, so a configuration the worker cannot run is refused there, never found later.
  static bool check(const core::PipelineConfig& pcfg, const calib::SpanOptions& so, std::string* error);
  /// Starts the threads. pcfg: the core configuration (its heads and nominal mountings; the worker
  /// keeps a copy); idle: called on the worker thread whenever the ring is empty (logging, the state
  /// file). False with *error when the configuration cannot be run (check()); no thread is started.
  bool start(const core::PipelineConfig& pcfg, const calib::SpanOptions& so, std::function<void()> idle,
             std::string* error = nullptr);
  bool running() const { return thread_.joinable(); }

  /// Real-time thread: false when the ring is full.
  bool push(const WorkItem& it) { return ring_.push(it); }
  std::size_t fill() const { return ring_.size(); }
  /// Real-time thread: a result waits in the mailbox.
  bool ready() const { return mail_.state.load(std::memory_order_acquire) == MailState::kReady; }
  /// The result (while ready()); release() empties the slot for the next one.
  Mailbox& mailbox() { return mail_; }
  void release() { mail_.state.store(MailState::kEmpty, std::memory_order_release); }
  /// Both threads finished their last item (after a kStop was pushed).
  bool done() const { return done_.load(std::memory_order_acquire); }
  void join() {
    if (thread_.joinable()) thread_.join();
  }

 private:
  struct SolveJob {
    std::unique_ptr<calib::CalibrationFeed> feed;
    WorkItem req;
    std::array<Quat, core::kMaxHeads> nominal = core::filled<Quat, core::kMaxHeads>(Quat::Identity());  ///< the mountings the span was built with
    std::uint64_t nominal_gen = 0;
  };
  void workerLoop();
  void solverLoop();
  void fillResult(const calib::CalibrationSpan& sp, const calib::CalibrationRun& run, const SolveJob& j);

  core::SpscRing<WorkItem> ring_;
  Mailbox mail_;
  core::PipelineConfig cfg_;  ///< the worker's copy (the real-time thread may change its own)
  calib::SpanOptions so_;
  std::function<void()> idle_;
  std::thread thread_;
  std::atomic<bool> done_{false};
  std::mutex job_m_;
  std::condition_variable job_cv_;
  std::unique_ptr<SolveJob> job_;
  bool job_stop_ = false;
  std::optional<calib::RawBoundConfig> raw_;
  int raw_passes_ = 3;
  int raw_harmonics_ = 0;  ///< the relative alignment's orbit harmonics (calib::RunOptions::raw_harmonics)
  double raw_not_determined_rad_ = 0;
};

}  // namespace boresight::node

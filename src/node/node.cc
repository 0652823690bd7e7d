// boresight::node::Node - handlers, assembler, core, worker (see include/boresight/node/node.h).
#include <boresight/node/node.h>
#include <boresight/node/channel_gate.h>

#include "encode.h"
#include "worker.h"

#include <boresight/calib/solver.h>
#include <boresight/calib/span_builder.h>
#include <boresight/core/plausibility.h>
#include <boresight/core/ring.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/stream/assembler.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/sources.h>

#include "boresight_lcm/calibration_t.hpp"
#include "boresight_lcm/node_command_t.hpp"

#include <algorithm>
#include <fstream>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>
#include <vector>

namespace boresight::node {
using core::kMaxHeads;
using core::kMaxPairs;
using core::quatExp;
using core::quatLog;


namespace {

// node_health_t.rejected has 16 entries: every reason the node counts is among the first 16 (what its
// assembler refuses, too many heads or stars included, it counts as kAssembler or drops as stars).
static_assert(static_cast<int>(Reject::kOtherVersion) < 16 && static_cast<int>(Reject::kTooManyHeads) >= 16,
              "node_health_t.rejected has 16 entries, in io::Reject's order");
static_assert(core::kStatusCount <= 20, "node_health_t.core_status has 20 entries");
static_assert(core::kMaxHeads == 4 && core::kMaxPairs == 6, "the output types are sized for 4 heads");

/// Step latency histogram: 64 bins per doubling from 10 ns (about 1 % resolution), fixed size.
class LatencyHistogram {
 public:
  static constexpr int kPerOctave = 64, kOctaves = 32, kBins = kPerOctave * kOctaves;
  void add(double ns) {
    ++n_;
    max_ns_ = std::max(max_ns_, ns);
    int i = 0;
    if (ns > 10.0) i = static_cast<int>(std::log2(ns / 10.0) * kPerOctave);
    ++bins_[static_cast<std::size_t>(std::clamp(i, 0, kBins - 1))];
  }
  double quantileUs(double q) const {
    if (n_ == 0) return 0;
    const auto want = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(n_)));
    std::uint64_t c = 0;
    for (int i = 0; i < kBins; ++i) {
      c += bins_[static_cast<std::size_t>(i)];
      if (c >= want && c > 0) return std::min(10.0 * std::exp2((i + 1.0) / kPerOctave), max_ns_) * 1e-3;
    }
    return max_ns_ * 1e-3;
  }
  LatencySummary summary() const {
    return LatencySummary{quantileUs(0.5), quantileUs(0.99), quantileUs(0.999), max_ns_ * 1e-3, n_};
  }

 private:
  std::array<std::uint64_t, kBins> bins_{};
  std::uint64_t n_ = 0;
  double max_ns_ = 0;
};

}  // namespace

struct Node::Impl {
  NodeConfig cfg;
  Mode mode = Mode::kLive;
  Output* out = nullptr;
  bool configured = false, core_ready = false, finished = false;
  core::PipelineConfig pcfg;
  /// The one data path of every program (stream::Engine): the handlers push what they admit into
  /// `src`, the engine's assembler merges it, steps the core and hands the rows to `rows` (the
  /// published messages); `feed` (the worker's ring) observes the inputs as calibrate's feed does, and
  /// `hook` does the node's work at each head-epoch boundary and after each step.
  std::unique_ptr<stream::Engine> eng = std::make_unique<stream::Engine>();
  stream::PushSource* src = nullptr;  ///< owned by eng
  core::Pipeline& pipe() { return eng->pipeline(); }
  Counters c;
  LatencyHistogram lat, lat_heads;  ///< every core step; head epochs only
  std::uint64_t mounting_version = 0;
  std::uint64_t mounting_prev = 0;  ///< the identifier before the last change (rows the core held at it)
  /// Rows from this time on were computed with mounting_version (rows still pending in the core at a
  /// hand-over were computed with the one before).
  TimeUs mounting_from_t = std::numeric_limits<TimeUs>::min();

  // time state
  TimeGate gate;           ///< data time, jumps (channel_gate.h)
  TimeUs lookahead_us = 0;

  std::array<ChannelGate, kMaxHeads> ch_head{}, ch_stars{};
  ChannelGate ch_acc{}, ch_stars_seq{}, ch_orbit{};

  // outputs (encode buffers sized once)
  Encoder enc;
  std::int32_t seq_att = 0, seq_mon = 0, seq_cal = 0, seq_health = 0;
  TimeUs next_health = std::numeric_limits<TimeUs>::min();
  TimeUs last_epoch_t = 0;

  // worker
  CalibrationWorker worker;
  std::uint64_t next_solve_id = 1;
  TimeUs first_head_t = 0, next_cal_t = 0;
  bool have_first_head = false;
  std::uint64_t head_epoch_index = 0;
  // replay lockstep: solve id -> epoch index at which it is applied (FIFO, at most a few)
  core::Ring<std::pair<std::uint64_t, std::uint64_t>, 64> due{};
  std::atomic<std::uint64_t> worker_published{0};
  std::array<char, 1024> last_reason{};  ///< the last refused calibration's reason (real-time thread's copy)

  // frame change (calibration.apply_common_rotation): rows with t >= frame_from_t are published
  // rotated by q_frame (q_B_Bpub), older ones by q_frame_old. The real-time thread only fills a slot of
  // flog; the worker thread (or finish(), after it) writes the stderr line.
  Quat q_frame = Quat::Identity(), q_frame_old = Quat::Identity();
  TimeUs frame_from_t = std::numeric_limits<TimeUs>::min();
  enum class FrameVerdict : std::uint8_t { kOk, kNotDetermined, kTooSoon, kChi2 };
  /// What the worker writes on stderr for the real-time thread (frame changes, commands).
  enum class LogKind : std::uint8_t { kFrameChange, kFrameNotDetermined, kFrameTooSoon, kFrameChi2, kAccepted, kReverted };
  struct FrameLog {
    TimeUs from_t = 0, cal_t = 0;
    Vec3 common_arcsec = Vec3::Zero();
    LogKind kind = LogKind::kFrameChange;
    std::uint64_t id = 0;
  };
  void logEvent(LogKind kind, TimeUs from_t, TimeUs cal_t, const Vec3& common_arcsec, std::uint64_t id) {
    const std::uint64_t n = flog_n.load(std::memory_order_relaxed);
    FrameLog& e = flog[n % flog.size()];
    e.from_t = from_t;
    e.cal_t = cal_t;
    e.common_arcsec = common_arcsec;
    e.kind = kind;
    e.id = id;
    flog_n.store(n + 1, std::memory_order_release);
  }
  std::uint64_t frames_done = 0;  ///< frame changes printed (the numbering of the stderr lines)
  std::array<FrameLog, 16> flog{};
  std::atomic<std::uint64_t> flog_n{0};
  std::uint64_t flog_printed = 0;  ///< the worker's, then finish()'s (after the join)

  void printFrameChanges() {
    const std::uint64_t n = flog_n.load(std::memory_order_acquire);
    for (; flog_printed < n; ++flog_printed) {
      const FrameLog& e = flog[flog_printed % flog.size()];
      switch (e.kind) {
        case LogKind::kFrameNotDetermined:
        case LogKind::kFrameTooSoon:
        case LogKind::kFrameChi2:
          std::fprintf(stderr,
                       "boresightd: frame change refused (calibration of %lld us; common rotation %.2f %.2f %.2f "
                       "arcsec): %s; the relative part is applied, the published frame stays\n",
                       static_cast<long long>(e.cal_t), e.common_arcsec[0], e.common_arcsec[1], e.common_arcsec[2],
                       e.kind == LogKind::kFrameNotDetermined ? "the common rotation is not determined about every axis"
                       : e.kind == LogKind::kFrameChi2
                           ? "the fit's chi-square per degree of freedom is above calibration.frame_change_max_chi2_per_dof"
                           : "less than calibration.frame_change_min_interval_s since the last frame change");
          break;
        case LogKind::kFrameChange:
          ++frames_done;
          std::fprintf(stderr,
                       "boresightd: frame change %llu: from data time %lld us the published attitude is in the "
                       "accelerometer-datum frame (calibration of %lld us; common rotation %.2f %.2f %.2f arcsec, "
                       "%.1f arcsec)\n",
                       static_cast<unsigned long long>(frames_done), static_cast<long long>(e.from_t),
                       static_cast<long long>(e.cal_t), e.common_arcsec[0], e.common_arcsec[1], e.common_arcsec[2],
                       e.common_arcsec.norm());
          break;
        case LogKind::kAccepted:
          std::fprintf(stderr, "boresightd: command accept: the calibration of %lld us is in use from data time %lld us (identifier %llu)\n",
                       static_cast<long long>(e.cal_t), static_cast<long long>(e.from_t), static_cast<unsigned long long>(e.id));
          break;
        case LogKind::kReverted:
          std::fprintf(stderr, "boresightd: command revert: calibration %llu reverted from data time %lld us; the one before it is in use\n",
                       static_cast<unsigned long long>(e.id), static_cast<long long>(e.from_t));
          break;
      }
    }
  }

  // ---------------------------------------------------------------------------------------------
  void reject(Reject r) { ++c.rejected[static_cast<std::size_t>(r)]; }

  SequenceCounts seqc;  ///< lost and restarts over every channel (channel_gate.h)
  void seqCheck(ChannelGate& s, std::int32_t seq) {
    s.seq.check(seq, seqc);
    c.lost = seqc.lost;
    c.seq_restarts = seqc.restarts;
  }

  /// Time: every input goes through the time gate (TimeGate, channel_gate.h); what it lets through
  /// comes back to pass().
  struct GateSink final : TimeGate::Sink {
    Impl* m = nullptr;
    void pass(ChannelGate& ch, const stream::Sample* xs, int n, TimeUs t) override { m->pass(ch, xs, n, t); }
    void refuse(bool late) override { m->reject(late ? Reject::kLate : Reject::kTimeJump); }
    TimeUs handedOut() const override {
      TimeUs t = 0;
      return m->eng->lastHandedOut(t) ? t : std::numeric_limits<TimeUs>::min();
    }
    void restart() override { m->resyncBack(); }
  } gate_sink;
  void admit(ChannelGate& s, const stream::Sample* xs, int n, TimeUs t) {
    gate.admit(s, xs, n, t, gate_sink);
    c.held = gate.heldCount();
    c.time_resyncs = gate.resyncs();
  }
  void dropHeld() { gate.dropHeld(gate_sink); }

  /// The checks after the time gate (duplicate, late, flood), then the samples to the assembler.
  void pass(ChannelGate& s, const stream::Sample* xs, int n, TimeUs t) {
    if (s.duplicate(t)) return reject(Reject::kDuplicate);
    const stream::Sample::Kind kind = xs[0].kind;
    // The assembler's late rule, asked before the push: a late message is one rejection, whatever
    // number of samples it carries.
    if (eng->late(t, kind)) return reject(Reject::kLate);
    const double max_hz = kind == stream::Sample::Kind::kHead || kind == stream::Sample::Kind::kOrbit ? cfg.max_head_rate_hz
                          : kind == stream::Sample::Kind::kAccel                                        ? cfg.max_accel_rate_hz
                                                                                                        : cfg.max_star_rate_hz;
    if (s.flooded(t, max_hz)) return reject(Reject::kFlood);
    for (int i = 0; i < n; ++i) {
      if (!src->push(xs[i])) {
        if (kind != stream::Sample::Kind::kStar) return reject(Reject::kAssembler);
        ++stars_dropped_push;
        continue;
      }
      drain();
    }
    s.passed(t);
    gate.advance(t);
    ++c.used;
  }
  void resyncBack() {
    // What the assembler holds goes to the core, in order, and the rows out; then the assembler forgets
    // its time and the core starts again, its counts kept in core_base.
    eng->restart([this] { core_base.add(pipe().health()); });
    account();
    if (core_handed) pipe().handMountings(handed_q);  // the calibration in use stays in use
  }
  core::Health core_base{};  ///< core counts before the last re-synchronisation (reset() clears them)
  bool core_handed = false;  ///< mountings handed to the core (else its running means align the heads)
  /// The mountings in use: the nominal ones until a calibration is handed to the core.
  std::array<Quat, kMaxHeads> handed_q = core::filled<Quat, kMaxHeads>(Quat::Identity());

  int slotOf(int head_id) const {
    for (int k = 0; k < pcfg.heads.n_heads; ++k)
      if (pcfg.heads.head[static_cast<std::size_t>(k)].id == head_id) return k;
    return -1;
  }

  // ---------------------------------------------------------------------------------------------
  /// The decoded message's content against the rule every reader applies (io::checkInput).
  bool checked(const io::InputMessage& m) {
    switch (io::checkInput(m, pcfg.heads.unit_norm_tolerance)) {
      case io::InputFault::kNone: return true;
      case io::InputFault::kInvalidFlag: reject(Reject::kInvalidFlag); return false;
      case io::InputFault::kNonFinite: reject(Reject::kNonFinite); return false;
      case io::InputFault::kNonUnit: reject(Reject::kNonUnit); return false;
      case io::InputFault::kImplausible: reject(Reject::kImplausible); return false;
    }
    return false;
  }
  /// Bytes the channel's decoder refused: another layout of its type, or damaged / another type.
  static Reject undecodable(const char* type, const void* data, int size) {
    return io::isOtherVersion(type, data, size) ? Reject::kOtherVersion : Reject::kMalformed;
  }
  io::InputMessage msg{};  ///< the message being handled (decodeInput writes it; no allocation)

  void onHead(const void* data, int size) {
    if (!io::decodeInput(io::InputKind::kHead, data, size, msg)) return reject(undecodable(io::inputTypeName(io::InputKind::kHead), data, size));
    const io::HeadSample& m = msg.head;
    const int slot = slotOf(m.head_id);
    if (slot < 0) return reject(Reject::kUnknownHead);
    ChannelGate& s = ch_head[static_cast<std::size_t>(slot)];
    seqCheck(s, m.seq);
    if (!core_ready) return reject(Reject::kNoMountings);
    if (!checked(msg)) return;
    stream::Sample x;
    x.kind = stream::Sample::Kind::kHead;
    x.t = m.utime;
    x.head_id = m.head_id;
    x.q_I_S = quatFromScalarFirst(m.q);
    admit(s, &x, 1, m.utime);
  }

  void onAccel(const void* data, int size) {
    if (!io::decodeInput(io::InputKind::kAccel, data, size, msg)) return reject(undecodable(io::inputTypeName(io::InputKind::kAccel), data, size));
    const io::AccelSample& m = msg.accel;
    seqCheck(ch_acc, m.seq);
    if (!core_ready) return reject(Reject::kNoMountings);
    if (!checked(msg)) return;
    stream::Sample x;
    x.kind = stream::Sample::Kind::kAccel;
    x.t = m.utime;
    x.a_A = Vec3(m.ang_accel[0], m.ang_accel[1], m.ang_accel[2]);
    admit(ch_acc, &x, 1, m.utime);
  }

  void onStars(const void* data, int size) {
    if (!io::decodeInput(io::InputKind::kStars, data, size, msg)) return reject(undecodable(io::inputTypeName(io::InputKind::kStars), data, size));
    const io::StarVectors& m = msg.stars;
    seqCheck(ch_stars_seq, m.seq);
    const int slot = slotOf(m.head_id);
    if (slot < 0) return reject(Reject::kUnknownHead);
    if (!core_ready) return reject(Reject::kNoMountings);
    if (!checked(msg)) return;
    std::array<stream::Sample, io::StarVectors::kCapacity> xs;
    for (int i = 0; i < m.n_stars; ++i) {
      stream::Sample& x = xs[static_cast<std::size_t>(i)];
      x.kind = stream::Sample::Kind::kStar;
      x.t = m.utime;
      x.star.head_id = m.head_id;
      x.star.s_Sk = Vec3(m.s_head[i][0], m.s_head[i][1], m.s_head[i][2]);
      x.star.r_I = Vec3(m.r_inertial[i][0], m.r_inertial[i][1], m.r_inertial[i][2]);
      x.star.sigma_rad = m.sigma_rad[i];
    }
    admit(ch_stars[static_cast<std::size_t>(slot)], xs.data(), m.n_stars, m.utime);
  }

  void onMountings(const void* data, int size) {
    io::NominalMountings m;
    if (!io::decodeNominalMountings(data, size, m)) return reject(undecodable("nominal_mountings_t", data, size));
    core::PipelineConfig p = pcfg;
    Reject why = Reject::kMalformed;
    // The overlay's mountings stay (overlay_mounting_mask); the rule is the replay programs' too.
    if (!io::applyNominalMountings(m, p.heads, cfg.overlay_mounting_mask, why)) return reject(why);
    if (core_ready) {
      // A later message: the same mountings again are used and change nothing; new ones are applied at
      // the next head-epoch boundary (applyNominal).
      bool same = true;
      for (int k = 0; k < p.heads.n_heads; ++k) {
        const auto u = static_cast<std::size_t>(k);
        if (p.heads.head[u].q_Si_B.angularDistance(pcfg.heads.head[u].q_Si_B) > 1e-12) same = false;
      }
      if (!same) {
        for (int k = 0; k < kMaxHeads; ++k) pending_nominal[static_cast<std::size_t>(k)] = p.heads.head[static_cast<std::size_t>(k)].q_Si_B;
        have_pending_nominal = true;
      }
      ++c.used;
      return;
    }
    pcfg = p;
    if (!startCore()) return reject(Reject::kInvalidFlag);
    ++c.used;
  }

  /// New nominal mountings (a later NOMINAL_MOUNTINGS message) at a head-epoch boundary: the core's rows
  /// so far go out, the core starts again with them (its filters restart, its counts go on); they are
  /// the mountings in use (a new calibration identifier), the frame is the heads' datum again, the
  /// worker's span starts again, and results solved against the old ones are not applied.
  std::array<Quat, kMaxHeads> pending_nominal = core::filled<Quat, kMaxHeads>(Quat::Identity());
  bool have_pending_nominal = false;
  std::uint64_t nominal_gen = 0;
  void applyNominal(TimeUs t) {
    have_pending_nominal = false;
    core::PipelineConfig p = pcfg;
    for (int k = 0; k < p.heads.n_heads; ++k) p.heads.head[static_cast<std::size_t>(k)].q_Si_B = pending_nominal[static_cast<std::size_t>(k)];
    eng->flushCore();  // the rows so far, with the old mountings
    core_base.add(pipe().health());
    if (!configureCore(p)) {  // cannot happen for unit quaternions; keep the old ones
      configureCore(pcfg);
      if (core_handed) pipe().handMountings(handed_q);
      ++c.mountings_refused;
      return;
    }
    pcfg = p;
    for (int k = 0; k < kMaxHeads; ++k) handed_q[static_cast<std::size_t>(k)] = pcfg.heads.head[static_cast<std::size_t>(k)].q_Si_B;
    core_handed = false;
    mounting_prev = mounting_version;
    mounting_version = ++max_version;
    n_history = 0;  // nothing to revert to across new nominal mountings
    held_cal.have = false;
    mounting_from_t = t;
    frame_active = false;
    q_frame = q_frame_old = Quat::Identity();
    frame_from_t = t;
    ++nominal_gen;
    ++c.mountings_applied;
    if (cfg.calibration.enabled) {
      WorkItem& it = worker_mountings;
      it.kind = WorkItem::kMountings;
      it.t = t;
      it.solve_id = nominal_gen;
      it.q_Si_B = pending_nominal;
      worker_mountings_pending = true;
      flushWorkerMountings();
    }
    saveState(t, nullptr);
  }

  void onOrbit(const void* data, int size) {
    if (!io::decodeInput(io::InputKind::kOrbit, data, size, msg)) return reject(undecodable(io::inputTypeName(io::InputKind::kOrbit), data, size));
    const io::OrbitSample& o = msg.orbit;
    seqCheck(ch_orbit, o.seq);
    if (!checked(msg)) return;
    // The orbit feeds the thermal prediction and the attitude-domain estimate (the stars' aberration).
    if (!cfg.thermal_model && !(cfg.calibration.enabled && worker.wantsOrbit())) return reject(Reject::kNoConsumer);
    if (!core_ready) return reject(Reject::kNoMountings);
    stream::Sample x;
    x.kind = stream::Sample::Kind::kOrbit;
    x.t = o.utime;
    x.orbit_frame = o.frame;
    x.r_orbit = Vec3(o.r_m[0], o.r_m[1], o.r_m[2]);
    x.v_orbit = Vec3(o.v_m_s[0], o.v_m_s[1], o.v_m_s[2]);
    admit(ch_orbit, &x, 1, o.utime);
  }

  /// The core configured with `p`, and the overlay's thermal model set again (configure() drops it).
  bool configureCore(const core::PipelineConfig& p) {
    if (!eng->configure(p, nullptr)) return false;
    if (cfg.thermal_model) eng->setThermalModel(*cfg.thermal_model, nullptr);
    return true;
  }

  // ---------------------------------------------------------------------------------------------
  bool startCore() {
    if (!configureCore(pcfg)) return false;
    core_ready = true;
    for (int k = 0; k < kMaxHeads; ++k) handed_q[static_cast<std::size_t>(k)] = pcfg.heads.head[static_cast<std::size_t>(k)].q_Si_B;
    applyState();
    if (cfg.calibration.enabled &&
        !worker.start(pcfg, workerSpanOptions(cfg), [this] {  // on the worker thread, whenever its ring is empty
          printFrameChanges();
          writeStateIfNew();
        }))
      return false;  // cannot happen: configure() asked the worker first
    return true;
  }

  /// The worker's span options from the node's configuration.
  static calib::SpanOptions workerSpanOptions(const NodeConfig& c) {
    calib::SpanOptions so;
    so.acc_white_noise_radps2 = c.acc_white_noise_radps2;
    so.decimation_s = c.calibration.decimation_s;
    so.max_observations = c.calibration.max_observations;
    return so;
  }

  /// New nominal mountings for the worker: they must reach it, and before any later item (those belong
  /// to the new span). Replay waits like any item; live never waits: while the ring is full the item
  /// stays here, and the items after it are dropped (counted) until it is in.
  WorkItem worker_mountings;
  bool worker_mountings_pending = false;
  bool flushWorkerMountings() {
    if (!worker_mountings_pending) return true;
    if (!worker.push(worker_mountings)) {
      if (mode == Mode::kLive) return false;
      ++c.ring_waits;
      while (!worker.push(worker_mountings)) std::this_thread::yield();
    }
    worker_mountings_pending = false;
    return true;
  }

  void pushRing(const WorkItem& it) {
    if (!cfg.calibration.enabled) return;
    if (!flushWorkerMountings()) {
      ++c.ring_dropped;
      return;
    }
    if (!worker.push(it)) {
      if (mode == Mode::kLive) {
        ++c.ring_dropped;
        return;
      }
      ++c.ring_waits;  // replay is not real time: wait for the worker (deterministic input)
      while (!worker.push(it)) std::this_thread::yield();
    }
    c.ring_high_water = std::max<std::uint64_t>(c.ring_high_water, worker.fill());
  }

  /// Hands out everything the assembler may give now: the engine steps the core (hook and feed below)
  /// and publishes the rows (rows); then the samples its assembler refused are moved from used.
  void drain() {
    eng->run();  // a push source never fails; kPending when it holds nothing, kDone once closed
    account();
  }
  /// Samples the assembler refused, moved from used: kLate and kTooManyHeads (kAssembler), a tag far
  /// from its neighbours (kTimeJump), the same head twice at a tag (kDuplicate).
  void account() {
    const auto& ac = eng->counters();
    auto take = [&](std::uint64_t now_count, std::uint64_t& seen, Reject r) {
      if (now_count <= seen) return;
      c.used -= now_count - seen;
      c.rejected[static_cast<std::size_t>(r)] += now_count - seen;
      seen = now_count;
    };
    take(ac.rejected[static_cast<std::size_t>(stream::Reject::kLate)] +
             ac.rejected[static_cast<std::size_t>(stream::Reject::kTooManyHeads)],
         asm_refused, Reject::kAssembler);
    take(ac.rejected[static_cast<std::size_t>(stream::Reject::kTimeJump)], asm_outliers, Reject::kTimeJump);
    take(ac.rejected[static_cast<std::size_t>(stream::Reject::kDuplicate)], asm_duplicates, Reject::kDuplicate);
    c.stars_dropped = stars_dropped_push + ac.rejected[static_cast<std::size_t>(stream::Reject::kTooManyStars)];
  }
  std::uint64_t asm_refused = 0, asm_outliers = 0, asm_duplicates = 0, stars_dropped_push = 0;

  /// The node's work between the engine's core steps (real-time thread).
  struct Hook final : stream::StepHook {
    Impl* m = nullptr;
    void beforeHeads(const core::HeadEpoch& e) override { m->beforeHeads(e.t); }
    void afterStep(stream::Sample::Kind kind, TimeUs t, core::Status, double ns) override { m->afterStep(kind, t, ns); }
  } hook;
  /// The worker's inputs: head epochs as the core's validator leaves them and the accelerometer samples
  /// the core accepted - what `boresight calibrate`'s feed takes from the same engine.
  struct Feed final : stream::InputObserver {
    Impl* m = nullptr;
    void onHeads(const core::HeadEpoch& e, core::Status) override {
      WorkItem& it = m->item;
      it.kind = WorkItem::kHeads;
      it.t = e.t;
      it.heads = e;
      m->pushRing(it);
    }
    void onAcc(TimeUs t, const Vec3& a_A, core::Status st) override {
      if (!core::accepted(st)) return;
      WorkItem& it = m->item;
      it.kind = WorkItem::kAcc;
      it.t = t;
      it.a_A = a_A;
      m->pushRing(it);
    }
    /// The attitude-domain estimate takes the orbit (the stars' aberration), as calibrate's feed does.
    bool wantsOrbit() const override { return m->worker.wantsOrbit(); }
    void onOrbit(const model::OrbitSample& o) override {
      WorkItem& it = m->item;
      it.kind = WorkItem::kOrbit;
      it.t = o.t;
      it.orbit = o;
      m->pushRing(it);
    }
  } feed;
  WorkItem item;  ///< scratch (a work item holds a head epoch)
  /// The published messages of each row the core completes.
  struct Rows final : stream::RowSink {
    Impl* m = nullptr;
    bool begin(const core::PipelineConfig&) override { return true; }
    bool write(const core::PipelineRow& r) override {
      m->publishRow(r);
      return true;
    }
    bool end() override { return true; }
  } rows;

  /// At a head-epoch boundary, before the core steps the epoch at t: new nominal mountings, a ground
  /// command, a finished calibration.
  void beforeHeads(TimeUs t) {
    if (have_pending_nominal) applyNominal(t);
    if (pending_cmd != 0) runCommand(t);
    applyMailbox(t);
  }

  void afterStep(stream::Sample::Kind kind, TimeUs t, double ns) {
    switch (kind) {
      case stream::Sample::Kind::kHead: afterHeads(t, ns); break;
      case stream::Sample::Kind::kAccel:
        lat.add(ns);
        ++c.accel_steps;
        break;
      case stream::Sample::Kind::kStar:
        lat.add(ns);
        ++c.star_epochs;
        break;
      case stream::Sample::Kind::kOrbit: ++c.orbit_steps; break;  // the core's thermal prediction
    }
  }

  /// After the core stepped the head epoch at t (the feed has pushed it to the worker): the worker's
  /// schedule, the health message.
  void afterHeads(TimeUs t, double ns) {
    lat.add(ns);
    lat_heads.add(ns);
    ++c.head_epochs;
    ++head_epoch_index;
    last_epoch_t = t;
    if (cfg.calibration.enabled) {
      if (!have_first_head) {
        have_first_head = true;
        first_head_t = t;
        next_cal_t = t + static_cast<TimeUs>(cfg.calibration.min_span_s * 1e6);
      }
      // Replay: one calibration in flight at a time (the lockstep waits for it; several queued behind a
      // jump in the data would have the worker, the solver and this thread wait on each other).
      if (t >= next_cal_t && !(mode == Mode::kReplay && !due.empty())) {
        next_cal_t += static_cast<TimeUs>(cfg.calibration.cadence_s * 1e6);
        if (next_cal_t <= t) next_cal_t = t + static_cast<TimeUs>(cfg.calibration.cadence_s * 1e6);
        WorkItem& s = item;
        s.kind = WorkItem::kSolve;
        s.t = t;
        s.solve_id = next_solve_id++;
        if (mode == Mode::kReplay)
          due.push({s.solve_id, head_epoch_index + static_cast<std::uint64_t>(cfg.calibration.apply_lag_epochs)});
        pushRing(s);
      }
    }
    if (t >= next_health) {
      if (next_health != std::numeric_limits<TimeUs>::min()) publishHealth(t);
      next_health = t + static_cast<TimeUs>(cfg.health_period_s * 1e6);
    }
  }

  /// At a head-epoch boundary: a finished calibration goes to the core. Replay: the one due at this
  /// epoch is waited for; live: whatever is ready.
  void applyMailbox(TimeUs t) {
    if (!cfg.calibration.enabled) return;
    if (mode == Mode::kReplay) {
      if (due.empty() || due.front().second > head_epoch_index) return;
      while (!worker.ready()) std::this_thread::yield();
      due.popFront();
    } else if (!worker.ready()) {
      return;
    }
    takeMailbox(t);
  }

  /// from_t: the first row time the new mountings (and a frame change) apply to.
  void takeMailbox(TimeUs from_t) {
    Mailbox& mail = worker.mailbox();
    boresight_lcm::calibration_t& m = mail.msg;
    m.applied = 0;
    const bool stale = mail.nominal_gen != nominal_gen;  // solved against nominal mountings replaced since
    if (stale) ++c.calibrations_superseded;
    if (mail.ok && cfg.calibration.apply && !stale) {
      if (cfg.calibration.hold_for_command) {  // until a ground command accepts it (the latest one is held)
        held_cal.have = true;
        held_cal.q = mail.q_Si_B;
        held_cal.msg = m;
        held_cal.common_determined = mail.common_determined;
        held_cal.chi2 = mail.chi2_per_dof_max;
        ++c.calibrations_held;
      } else {
        applyResult(mail.q_Si_B, m, mail.common_determined, mail.chi2_per_dof_max, from_t);
      }
    }
    if (!mail.ok) {
      ++c.calibrations_refused;
      last_reason = mail.reason;
    }
    ++c.solves;
    c.solve_cpu_s_sum += mail.cpu_s;
    c.solve_cpu_s_max = std::max(c.solve_cpu_s_max, mail.cpu_s);
    c.solve_wall_s_max = std::max(c.solve_wall_s_max, mail.wall_s);
    c.solve_observations_max = std::max(c.solve_observations_max, mail.observations);
    c.solve_observation_bytes_max = std::max(c.solve_observation_bytes_max, mail.observation_bytes);
    m.seq = seq_cal++;
    publish(cfg.channels.calibration, m.utime, m);
    ++c.calibrations_published;
    worker.release();
  }

  /// The calibration in use before each applied one (what a revert command goes back to), newest last.
  struct InUse {
    std::uint64_t id = 0;
    std::array<Quat, kMaxHeads> q = core::filled<Quat, kMaxHeads>(Quat::Identity());
    bool handed = false;  ///< false: the core's running means were in use (nothing handed yet)
    bool frame_active = false;
    Quat q_frame = Quat::Identity();
    TimeUs frame_epoch = 0;
  };
  std::array<InUse, 8> history{};
  int n_history = 0;
  std::uint64_t max_version = 0;  ///< calibration identifiers are never given twice
  /// hold_for_command: the latest result waiting for a ground command.
  struct Held {
    bool have = false;
    std::array<Quat, kMaxHeads> q = core::filled<Quat, kMaxHeads>(Quat::Identity());
    boresight_lcm::calibration_t msg{};
    bool common_determined = false;
    double chi2 = std::numeric_limits<double>::quiet_NaN();
  } held_cal;

  /// Hands a result's mountings to the core (the datum keeps the relative part), under a new identifier,
  /// with the frame change where configured and allowed; m.applied and its common rotation are filled.
  /// chi2: the fit's largest chi-square per degree of freedom (NaN: the solver has none).
  void applyResult(const std::array<Quat, kMaxHeads>& q, boresight_lcm::calibration_t& m, bool common_determined, double chi2,
                   TimeUs from_t) {
    if (pipe().handMountings(q) != core::Status::kOk) return;
    if (n_history == static_cast<int>(history.size())) {  // the oldest goes
      for (std::size_t i = 1; i < history.size(); ++i) history[i - 1] = history[i];
      --n_history;
    }
    InUse& h = history[static_cast<std::size_t>(n_history++)];
    h.id = mounting_version;
    h.q = handed_q;
    h.handed = core_handed;
    h.frame_active = frame_active;
    h.q_frame = q_frame;
    h.frame_epoch = frame_epoch;
    handed_q = q;
    core_handed = true;
    m.applied = 1;
    mounting_prev = mounting_version;
    mounting_version = ++max_version;
    mounting_from_t = from_t;
    ++c.calibrations_applied;
    // The common part the datum kept out: the handed rotation minus the correction in use (slot 0).
    const auto& al = pipe().fusion().relativeAlignment();
    const Vec3 raw = quatLog(q[0].conjugate() * pcfg.heads.head[0].q_Si_B);
    const Vec3 common = raw - al.c_B[0];
    for (int k = 0; k < 3; ++k) m.common_rotation_B_arcsec[k] = common[k] / kRadPerArcsec;
    // The fused attitude now is C_I_B' Exp(common) to first order (B': the accelerometer datum the
    // solver's mountings refer to), so C_I_B' = C_I_Bpub Exp(-common). A frame change needs the common
    // rotation determined about all three axes, and at least frame_change_min_interval_s of data time
    // since the last one; else it is refused (counted and logged) and only the relative part is applied.
    FrameVerdict fv = FrameVerdict::kOk;
    if (cfg.calibration.apply_common_rotation) {
      if (!common.allFinite() || !common_determined) fv = FrameVerdict::kNotDetermined;
      else if (std::isfinite(chi2) && chi2 > cfg.calibration.frame_change_max_chi2_per_dof) fv = FrameVerdict::kChi2;
      else if (frame_active && frame_epoch != 0 &&  // the last change, this run's or the state file's
               static_cast<double>(from_t - frame_epoch) * 1e-6 < cfg.calibration.frame_change_min_interval_s)
        fv = FrameVerdict::kTooSoon;
      if (fv != FrameVerdict::kOk) ++c.frame_changes_refused;
      if (fv == FrameVerdict::kOk) {
        q_frame_old = q_frame;
        q_frame = quatExp(-common).normalized();
        frame_from_t = from_t;
        frame_active = true;
        frame_epoch = from_t;
        ++c.frame_changes;
      }
      logEvent(fv == FrameVerdict::kOk        ? LogKind::kFrameChange
               : fv == FrameVerdict::kTooSoon ? LogKind::kFrameTooSoon
               : fv == FrameVerdict::kChi2    ? LogKind::kFrameChi2
                                              : LogKind::kFrameNotDetermined,
               from_t, m.utime, common / kRadPerArcsec, 0);
    }
    saveState(m.utime, &m);
  }

  /// Ground commands (BORESIGHT_COMMAND): checked on arrival, carried out at the next head-epoch boundary.
  ChannelGate ch_cmd{};
  int pending_cmd = 0;  ///< 1 accept, 2 revert
  void onCommand(const void* data, int size) {
    boresight_lcm::node_command_t m;
    if (m.decode(data, 0, size) != size) return reject(undecodable("node_command_t", data, size));
    seqCheck(ch_cmd, m.seq);
    if (!core_ready) return reject(Reject::kNoMountings);
    if (m.command == 1) {
      if (!held_cal.have || (m.calibration_utime != 0 && m.calibration_utime != held_cal.msg.utime)) return reject(Reject::kCommand);
    } else if (m.command == 2) {
      if (m.calibration_id <= 0 || static_cast<std::uint64_t>(m.calibration_id) != mounting_version || n_history == 0)
        return reject(Reject::kCommand);
    } else {
      return reject(Reject::kCommand);
    }
    pending_cmd = m.command;
    ++c.used;
  }
  void runCommand(TimeUs t) {
    const int cmd = pending_cmd;
    pending_cmd = 0;
    if (cmd == 1 && held_cal.have) {
      held_cal.have = false;
      boresight_lcm::calibration_t m = held_cal.msg;
      applyResult(held_cal.q, m, held_cal.common_determined, held_cal.chi2, t);
      if (!m.applied) return;
      ++c.commands_accepted;
      logEvent(LogKind::kAccepted, t, m.utime, Vec3::Zero(), mounting_version);
      m.seq = seq_cal++;
      publish(cfg.channels.calibration, m.utime, m);  // again, now applied
      ++c.calibrations_published;
    } else if (cmd == 2 && n_history > 0) {
      const InUse h = history[static_cast<std::size_t>(--n_history)];
      if (h.handed) {
        if (pipe().handMountings(h.q) != core::Status::kOk) return;
      } else {
        pipe().releaseMountings();  // the running means again, as before anything was handed
      }
      core_handed = h.handed;
      const std::uint64_t from = mounting_version;
      handed_q = h.q;
      mounting_prev = mounting_version;
      mounting_version = h.id;
      mounting_from_t = t;
      if (frame_active || h.frame_active) {
        q_frame_old = q_frame;
        q_frame = h.q_frame;
        frame_from_t = t;
        frame_active = h.frame_active;
        frame_epoch = h.frame_epoch;
      }
      ++c.commands_reverted;
      logEvent(LogKind::kReverted, t, 0, Vec3::Zero(), from);
      saveState(t, nullptr);
    }
  }

  // ---------------------------------------------------------------------------------------------
  // The state file (NodeConfig::state_file). The real-time thread fills a slot under a sequence lock
  // when a calibration is applied; the worker thread (or finish(), after the join) writes it as a model
  // overlay, atomically (io::writeOverlay: whole or not at all).
  struct StateSlot {
    std::array<Quat, kMaxHeads> q_Si_B{};
    std::array<Vec3, kMaxHeads> sigma_rad{};
    TimeUs cal_t = 0, frame_t = 0;
    Quat q_frame = Quat::Identity();
    std::uint64_t version = 0;
  };
  StateSlot state_slot;
  std::atomic<std::uint64_t> state_seq{0};  ///< odd while the slot is written; +2 per state
  std::uint64_t state_written = 0;          ///< the sequence last written (worker, then finish())
  bool frame_active = false;                ///< the published attitude is rotated (a frame change or the state)
  TimeUs frame_epoch = 0;                   ///< data time of the last frame change (the state's after a restart)

  /// cal: the applied calibration (its sigmas); nullptr: mountings without one (new nominal ones, a
  /// revert), sigmas not determined.
  void saveState(TimeUs cal_t, const boresight_lcm::calibration_t* cal) {
    if (cfg.state_file.empty()) return;
    const std::uint64_t s0 = state_seq.load(std::memory_order_relaxed);
    state_seq.store(s0 + 1, std::memory_order_release);
    std::atomic_thread_fence(std::memory_order_release);
    StateSlot& st = state_slot;
    for (int k = 0; k < kMaxHeads; ++k) {
      st.q_Si_B[static_cast<std::size_t>(k)] = handed_q[static_cast<std::size_t>(k)];
      for (int a = 0; a < 3; ++a)
        st.sigma_rad[static_cast<std::size_t>(k)][a] =
            cal ? cal->sigma_arcsec[k][a] * kRadPerArcsec : std::numeric_limits<double>::quiet_NaN();
    }
    st.cal_t = cal_t;
    st.frame_t = frame_active ? frame_epoch : 0;
    st.q_frame = frame_active ? q_frame : Quat::Identity();
    st.version = mounting_version;
    state_seq.store(s0 + 2, std::memory_order_release);
  }

  /// Writes the state when the slot holds a newer one (not the real-time thread).
  void writeStateIfNew() {
    if (cfg.state_file.empty()) return;
    const std::uint64_t s1 = state_seq.load(std::memory_order_acquire);
    if (s1 == state_written || (s1 & 1u)) return;
    const StateSlot st = state_slot;
    std::atomic_thread_fence(std::memory_order_acquire);
    if (state_seq.load(std::memory_order_relaxed) != s1) return;  // rewritten meanwhile: next time
    model::Overlay o;
    o.written_by = "boresightd (state file)";
    o.note = "the last calibration boresightd applied and the frame it publishes in; read at its start";
    for (int k = 0; k < pcfg.heads.n_heads; ++k) {
      model::MountingEntry e;
      e.head = pcfg.heads.head[static_cast<std::size_t>(k)].id;
      e.q_Si_B = st.q_Si_B[static_cast<std::size_t>(k)].normalized();
      e.datum = model::MountingDatum::Accelerometer;
      e.epoch = st.cal_t;
      e.sigma_rad = st.sigma_rad[static_cast<std::size_t>(k)];
      o.mountings.push_back(e);
    }
    model::PublishedFrame f;
    f.q_B_Bpub = st.q_frame.normalized();
    f.epoch = st.frame_t;
    f.calibration = static_cast<std::int64_t>(st.version);
    o.published_frame = f;
    std::string err;
    if (!io::writeOverlay(cfg.state_file, o, &err))
      std::fprintf(stderr, "boresightd: state file not written: %s\n", err.c_str());
    state_written = s1;
  }

  /// The state read at start (configure): handed to the core when it starts.
  bool have_state = false;
  std::array<Quat, kMaxHeads> state_q{};
  model::PublishedFrame state_frame;

  bool readState(std::string* error) {
    if (cfg.state_file.empty()) return true;
    std::ifstream probe(cfg.state_file);
    if (!probe) return true;  // none yet: the first run
    model::Overlay o;
    std::string err;
    if (!io::readOverlay(cfg.state_file, o, &err)) {
      if (error) *error = "state_file: " + err;
      return false;
    }
    if (!o.published_frame) {
      if (error) *error = "state_file: " + cfg.state_file + ": no published_frame (not a boresightd state file)";
      return false;
    }
    for (int k = 0; k < pcfg.heads.n_heads; ++k) {
      const int id = pcfg.heads.head[static_cast<std::size_t>(k)].id;
      auto it = std::find_if(o.mountings.begin(), o.mountings.end(), [&](const model::MountingEntry& e) { return e.head == id; });
      if (it == o.mountings.end()) {
        if (error) *error = "state_file: " + cfg.state_file + ": no mounting for head " + std::to_string(id);
        return false;
      }
      state_q[static_cast<std::size_t>(k)] = it->q_Si_B;
    }
    state_frame = *o.published_frame;
    have_state = true;
    return true;
  }

  /// At the core's start: the state's calibration and frame go on.
  void applyState() {
    if (!have_state) return;
    if (state_frame.calibration > 0 && pipe().handMountings(state_q) == core::Status::kOk) {
      handed_q = state_q;
      core_handed = true;
      mounting_version = mounting_prev = max_version = static_cast<std::uint64_t>(state_frame.calibration);
    }
    const Quat qf = state_frame.q_B_Bpub.normalized();
    if (qf.angularDistance(Quat::Identity()) > 0) {
      q_frame = q_frame_old = qf;
      frame_from_t = std::numeric_limits<TimeUs>::min();
      frame_active = true;
      frame_epoch = state_frame.epoch;
    }
    std::fprintf(stderr,
                 "boresightd: state from %s: calibration %lld in use, published frame rotated %.2f arcsec from the heads' "
                 "datum\n",
                 cfg.state_file.c_str(), static_cast<long long>(state_frame.calibration),
                 qf.angularDistance(Quat::Identity()) / kRadPerArcsec);
  }

  template <typename Msg>
  void publish(const std::string& ch, TimeUs t, const Msg& m) {
    if (!enc.publish(out, ch, t, m)) c.outputs_failed = enc.failed();
  }

  boresight_lcm::fused_attitude_t att_msg{};
  boresight_lcm::boresight_monitor_t mon_msg{};
  boresight_lcm::node_health_t health_msg{};

  void publishRow(core::PipelineRow row) {
    ++c.rows;
    if (frame_active) toPublishedFrame(row, row.t >= frame_from_t ? q_frame : q_frame_old);
    encodeAttitude(row, seq_att++, static_cast<int32_t>(row.t < mounting_from_t ? mounting_prev : mounting_version), att_msg);
    publish(cfg.channels.attitude, row.t, att_msg);
    encodeMonitor(row, seq_mon++, pipe(), last_epoch_t, mon_msg);
    publish(cfg.channels.monitor, row.t, mon_msg);
  }

  /// Replay publishes nothing that depends on the wall clock or thread timing (latency, ring fill):
  /// those are in the summary only, so two replays publish identical payloads.
  bool wallClockFree() const { return mode == Mode::kReplay; }

  void publishHealth(TimeUs t) {
    const LatencySummary l = lat.summary();
    core::Health ch = pipe().health();
    ch.add(core_base);
    encodeHealth(t, seq_health++, c, wallClockFree() ? nullptr : &l, ch, health_msg);
    publish(cfg.channels.health, t, health_msg);
  }

  // ---------------------------------------------------------------------------------------------
  /// Stops the worker (and its solver). publish: results that arrive meanwhile are published (finish);
  /// otherwise (destructor) they are discarded.
  void stopWorker(bool publish) {
    if (!worker.running()) return;
    auto serveMail = [&] {
      if (!worker.ready()) return;
      if (publish) takeMailbox(last_epoch_t + 1);
      else worker.release();
    };
    WorkItem s;
    s.kind = WorkItem::kStop;
    while (!worker.push(s)) {
      serveMail();
      std::this_thread::yield();
    }
    while (!worker.done()) {
      serveMail();
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    worker.join();
    serveMail();
  }
};

Node::Node() : impl_(new Impl) {}
Node::~Node() { impl_->stopWorker(false); }

bool Node::configure(const NodeConfig& cfg, Mode mode, Output* out, std::string* error) {
  Impl& m = *impl_;
  if (m.configured) {
    if (error) *error = "node: configure() twice";
    return false;
  }
  if (cfg.calibration.enabled &&
      cfg.calibration.apply_lag_epochs / cfg.pipeline.crn_attitude.fs_hz >= cfg.calibration.cadence_s) {
    if (error) *error = cfg.file + ": calibration.apply_lag_epochs: must be shorter than cadence_s at the head rate";
    return false;
  }
  if (cfg.calibration.enabled && cfg.calibration.method == CalibrationConfig::Method::kAttitude) {
    const std::string e = cfg.raw_config ? cfg.raw_config->validate() : "no estimator configuration (NodeConfig::raw_config)";
    if (!e.empty()) {
      if (error) *error = cfg.file + ": calibration.method: attitude: " + e;
      return false;
    }
  }
  // A configuration the calibration worker cannot run is refused here with the worker's reason (before:
  // a worker that refused its span builder's configuration never calibrated, and a replay waited for it).
  if (cfg.calibration.enabled && !CalibrationWorker::check(cfg.pipeline, Impl::workerSpanOptions(cfg), error)) {
    if (error) *error = cfg.file + ": " + *error;
    return false;
  }
  m.cfg = cfg;
  m.mode = mode;
  m.out = out;
  m.pcfg = cfg.pipeline;
  stream::AssemblerConfig ac;
  m.lookahead_us = static_cast<TimeUs>(std::llround(cfg.lookahead_s * 1e6));
  m.ch_acc.sensor = ChannelGate::kAccelerometer;
  m.ch_orbit.sensor = ChannelGate::kOrbit;
  std::array<ChannelGate*, 2 * kMaxHeads + 1> active{};
  int n_active = 0;
  for (auto& ch : m.ch_head) active[static_cast<std::size_t>(n_active++)] = &ch;
  for (auto& ch : m.ch_stars) active[static_cast<std::size_t>(n_active++)] = &ch;
  active[static_cast<std::size_t>(n_active++)] = &m.ch_acc;
  m.gate.configure(m.lookahead_us, cfg.time_jump_confirm, active.data(), n_active);
  m.gate_sink.m = &m;
  ac.lookahead_us = m.lookahead_us;
  ac.max_buffered = 4096;  // the heap's reserve: no allocation while stepping
  m.eng = std::make_unique<stream::Engine>(ac);
  auto src = std::make_unique<stream::PushSource>("node");
  src->init(256);
  m.src = src.get();
  m.eng->addSource(std::move(src));
  m.hook.m = m.feed.m = m.rows.m = &m;
  m.eng->setHook(&m.hook);
  m.eng->addSink(&m.rows);
  if (cfg.calibration.enabled) m.eng->addObserver(&m.feed);
  m.enc.init(8192);
  m.worker.init(cfg.ring_capacity);
  if (cfg.calibration.enabled && cfg.calibration.method == CalibrationConfig::Method::kAttitude)
    m.worker.setAttitudeDomain(*cfg.raw_config, cfg.calibration.raw_passes, cfg.raw_not_determined_rad, cfg.calibration.raw_harmonics);
  if (!m.readState(error)) return false;
  m.configured = true;
  if (!cfg.mountings_from_log && !m.startCore()) {
    if (error) *error = cfg.file + ": the core refuses the platform configuration";
    return false;
  }
  return true;
}

void Node::onMessage(const std::string& ch, const void* data, int size) {
  Impl& m = *impl_;
  if (!m.configured || m.finished) return;
  ++m.c.received;
  const Channels& c = m.cfg.channels;
  if (size < 0) m.reject(Reject::kMalformed);
  else if (ch == c.star_head) m.onHead(data, size);
  else if (ch == c.accel) m.onAccel(data, size);
  else if (ch == c.star_vectors) m.onStars(data, size);
  else if (ch == c.mountings) m.onMountings(data, size);
  else if (ch == c.orbit) m.onOrbit(data, size);
  else if (ch == c.command) m.onCommand(data, size);
  else m.reject(Reject::kOtherChannel);
}

void Node::onGarbage() {
  Impl& m = *impl_;
  if (!m.configured || m.finished) return;
  ++m.c.received;
  m.reject(Reject::kMalformed);
}

void Node::finish() {
  Impl& m = *impl_;
  if (!m.configured || m.finished) return;
  m.finished = true;
  m.dropHeld();  // a jump that the end of the data left unconfirmed
  m.src->close();
  if (m.core_ready) {
    m.drain();  // the source is closed: the engine hands out the rest, flushes the core, publishes the rows
    // Replay: calibrations still due are applied (published) at the end, in order.
    if (m.cfg.calibration.enabled && m.mode == Node::Mode::kReplay) {
      while (!m.due.empty()) {
        while (!m.worker.ready()) std::this_thread::yield();
        m.due.popFront();
        m.takeMailbox(m.last_epoch_t + 1);
      }
    }
  }
  m.stopWorker(true);
  m.printFrameChanges();  // the worker has joined: what it has not written yet
  m.writeStateIfNew();
  m.publishHealth(m.last_epoch_t);
}

const Counters& Node::counters() const { return impl_->c; }
LatencySummary Node::stepLatency() const { return impl_->lat.summary(); }
LatencySummary Node::headStepLatency() const { return impl_->lat_heads.summary(); }
core::Health Node::coreHealth() const {
  core::Health h = impl_->pipe().health();
  h.add(impl_->core_base);
  return h;
}
std::string Node::lastCalibrationReason() const { return std::string(impl_->last_reason.data()); }
const core::Pipeline& Node::pipeline() const { return impl_->eng->pipeline(); }
TimeUs Node::dataTime() const { return impl_->gate.now(); }
std::uint64_t Node::mountingVersion() const { return impl_->mounting_version; }
Quat Node::frameRotation() const { return impl_->q_frame; }

bool replayLog(Node& node, const std::string& path, std::string* error, const std::atomic<bool>* stop) {
  io::LcmLogReader r;
  if (!r.open(path, error)) return false;
  io::LcmLogReader::RawEvent ev;
  while ((!stop || !stop->load(std::memory_order_relaxed)) && r.nextRaw(ev)) {
    if (ev.size < 0) node.onGarbage();
    else node.onMessage(*ev.channel, ev.data, ev.size);
  }
  node.finish();
  return true;
}

}  // namespace boresight::node

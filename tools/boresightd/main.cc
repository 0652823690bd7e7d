// boresightd: the LCM node. Live on an LCM URL, or replaying a log as fast as possible (lockstep,
// deterministic). Parses options, runs boresight::node::Node, prints and writes the summary.
#include <boresight/io/files.h>
#include <boresight/io/lcm_log.h>
#include <boresight/node/node.h>
#include <boresight/stream/replay.h>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "../process_memory.h"
#include "boresight_lcm/boresight_monitor_t.hpp"
#include "boresight_lcm/calibration_t.hpp"
#include "boresight_lcm/fused_attitude_t.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <new>
#include <memory>
#include <string>
#include <utility>

namespace {

std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop.store(true); }

const char* kHelp =
    "boresightd: the boresight LCM node. Subscribes to the star-sensor head (STAR_HEAD), accelerometer\n"
    "(ACCEL), star-vector (STAR_VECTORS), nominal-mounting (NOMINAL_MOUNTINGS) and orbit (ORBIT)\n"
    "channels, steps the real-time core per epoch and publishes the fused attitude\n"
    "(BORESIGHT_ATTITUDE), the inter-boresight monitor (BORESIGHT_MONITOR), each calibration of the\n"
    "worker thread (BORESIGHT_CALIBRATION) and its health (BORESIGHT_HEALTH); channel names, rates and the\n"
    "calibration cadence come from the configuration (config/boresightd.yaml).\n"
    "\n"
    "  --replay LOG  reads LOG as fast as possible into the same handlers, deterministically: the worker\n"
    "                runs in lockstep on data time, so two runs publish identical payloads.\n"
    "  --record OUT  writes every published message into the LCM log OUT (event time = data time).\n"
    "  --csv FILE    one row per published attitude: data time, mounting version, heads used, the\n"
    "                inter-boresight deviations and the head corrections in use (arcsec), for\n"
    "                `boresight plot` (meant for replays: live, it is written on the real-time thread).\n"
    "  --summary-json FILE  the final summary: counters, rejected per reason, lost, latency, ring,\n"
    "                frame changes and the last published calibration (angles, sigma, CRLB).\n"
    "  Live (no --replay): lcm::LCM on the configured URL (udpm://239.255.76.67:7667?ttl=0 by default);\n"
    "  SIGINT / SIGTERM stop it cleanly. Played with `lcm-logplayer` faster than real time, multicast\n"
    "  loses datagrams in the receive buffer: the `lost` counter (sequence gaps) shows how many.\n"
    "\n"
    "Exit status: 0 done, 1 a run-time error (unreadable log, configuration refused), 2 bad options.\n";

class LcmOutput : public boresight::node::Output {
 public:
  lcm::LCM* lcm = nullptr;
  std::unique_ptr<boresight::io::LcmLogWriter> rec;
  std::uint64_t published = 0;
  const boresight::node::Channels* channels = nullptr;
  std::FILE* csv = nullptr;
  boresight_lcm::fused_attitude_t last_att{};
  bool have_cal = false;
  boresight_lcm::calibration_t last_cal{};
  void publish(const std::string& ch, boresight::TimeUs t, const void* data, int size) override {
    ++published;
    if (lcm) lcm->publish(ch, data, static_cast<unsigned>(size));
    if (rec) rec->writeRaw(ch, t, data, size);
    if (!channels) return;
    if (ch == channels->calibration) {
      have_cal = last_cal.decode(data, 0, size) == size;
    } else if (csv && ch == channels->attitude) {
      if (last_att.decode(data, 0, size) != size) last_att = boresight_lcm::fused_attitude_t{};
    } else if (csv && ch == channels->monitor) {
      boresight_lcm::boresight_monitor_t m;
      if (m.decode(data, 0, size) != size || m.utime != last_att.utime) return;
      std::fprintf(csv, "%.3f,%d,%d", static_cast<double>(m.utime) * 1e-6, last_att.mounting_version, last_att.heads_used);
      // pairs of the first three head slots (1-2, 1-3, 2-3), indexed as the core does
      for (const auto& ab : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
        std::fprintf(csv, ",%.3f", m.iba_dev_rad[boresight::core::pairIndex(ab.first, ab.second)] * boresight::kArcsecPerRad);
      for (int k = 0; k < 3; ++k) {
        const boresight::Quat q(m.q_corr_B[k][0], m.q_corr_B[k][1], m.q_corr_B[k][2], m.q_corr_B[k][3]);
        const double w = std::min(1.0, std::abs(q.w()));
        const double angle = 2 * std::acos(w) * boresight::kArcsecPerRad;
        std::fprintf(csv, ",%.3f", angle);
      }
      std::fputc('\n', csv);
    }
  }
};

/// Live: the raw bytes of every subscribed message go to the node's handlers (they decode).
struct RawHandler {
  boresight::node::Node* n;
  void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& ch) {
    n->onMessage(ch, rbuf->data, static_cast<int>(rbuf->data_size));
  }
};

int run(int argc, char** argv);

}  // namespace

// Bad input never aborts: whatever escapes ends the program with exit status 1 and the reason.
int main(int argc, char** argv) {
  boresight::tools::returnLargeBuffersToTheSystem();
  try {
    return run(argc, argv);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "boresightd: out of memory\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "boresightd: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "boresightd: failed with an unknown exception\n");
  }
  return 1;
}

namespace {

int run(int argc, char** argv) {
  CLI::App app{kHelp, "boresightd"};
  std::string config, replay, record, summary_json, csv;
  app.add_option("--config", config, "node configuration (YAML; names the platform file)")->required();
  app.add_option("--replay", replay, "replay this LCM log instead of subscribing");
  app.add_option("--record", record, "write every published message into this LCM log");
  app.add_option("--summary-json", summary_json, "write the final summary (counters, latency, last calibration) here");
  app.add_option("--csv", csv, "write one row per published attitude (IBA deviations, corrections) here");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  // From the start: a stop request during the set-up or the replay ends the run with its summary.
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  using namespace boresight;
  node::NodeConfig cfg;
  std::string err;
  // Outputs never destroy inputs (--record over --replay would truncate the log being read).
  if (!io::checkOutputs({config, replay}, {{"--record", record}, {"--csv", csv}, {"--summary-json", summary_json}},
                        &err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  if (!node::loadNodeConfig(config, cfg, &err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  // ... nor the files the configuration names.
  if (!io::checkOutputs({config, replay, cfg.platform_file, cfg.overlay},
                        {{"--record", record}, {"--csv", csv}, {"--summary-json", summary_json}}, &err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  for (const auto& l : cfg.model_in_use) std::printf("%s\n", l.c_str());
  if (!replay.empty()) {  // the data's rates against the platform's, before anything is computed
    stream::ReplayInputs in;
    in.lcm.push_back(replay);
    if (!io::checkInputFile(replay, io::kMaxLcmLogBytes, "LCM log", &err) ||
        !stream::checkSampleRates(in, {}, cfg.pipeline, &err)) {
      std::fprintf(stderr, "boresightd: %s\n", err.c_str());
      return 1;
    }
  }
  LcmOutput out;
  std::unique_ptr<lcm::LCM> lcm;
  if (replay.empty()) {
    lcm = std::make_unique<lcm::LCM>(cfg.lcm_url);
    if (!lcm->good()) {
      std::fprintf(stderr, "boresightd: %s: lcm_url: cannot open '%s'\n", config.c_str(), cfg.lcm_url.c_str());
      return 1;
    }
    out.lcm = lcm.get();
  }
  if (!record.empty()) {
    out.rec = std::make_unique<io::LcmLogWriter>();
    if (!out.rec->open(record, &err)) {
      std::fprintf(stderr, "boresightd: %s\n", err.c_str());
      return 1;
    }
  }
  out.channels = &cfg.channels;
  io::AtomicFile csv_file;  // the CSV, the record and the summary appear whole, or not at all
  if (!csv.empty()) {
    if (!csv_file.open(csv, &err)) {
      std::fprintf(stderr, "boresightd: %s\n", err.c_str());
      return 1;
    }
    out.csv = csv_file.file();
    std::fprintf(out.csv, "time_s,mounting_version,heads_used,iba_12_dev_arcsec,iba_13_dev_arcsec,iba_23_dev_arcsec,"
                          "corr_1_arcsec,corr_2_arcsec,corr_3_arcsec\n");
  }
  node::Node n;
  if (!n.configure(cfg, replay.empty() ? node::Node::Mode::kLive : node::Node::Mode::kReplay, &out, &err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (!replay.empty()) {
    if (!node::replayLog(n, replay, &err, &g_stop)) {
      std::fprintf(stderr, "boresightd: %s\n", err.c_str());
      return 1;
    }
  } else {
    RawHandler handler{&n};
    for (const auto* ch : {&cfg.channels.star_head, &cfg.channels.accel, &cfg.channels.star_vectors,
                           &cfg.channels.mountings, &cfg.channels.orbit, &cfg.channels.command})
      lcm->subscribe(*ch, &RawHandler::onMessage, &handler);
    std::fprintf(stderr, "boresightd: listening on %s (Ctrl-C stops)\n", cfg.lcm_url.c_str());
    while (!g_stop.load()) lcm->handleTimeout(100);
    n.finish();
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool interrupted = !replay.empty() && g_stop.load();
  const node::Counters& c0 = n.counters();
  if (!replay.empty() && !interrupted && c0.received == 0) {
    std::fprintf(stderr, "boresightd: %s: an empty LCM log (no event): nothing to replay\n", replay.c_str());
    return 1;
  }
  if (!replay.empty() && !interrupted && c0.head_epochs == 0) {
    std::string why;
    for (int r = 0; r < io::kRejectCount; ++r)
      if (c0.rejected[std::size_t(r)])
        why += (why.empty() ? "" : ", ") + std::to_string(c0.rejected[std::size_t(r)]) + " " +
               io::rejectKey(io::Reject(r));
    std::fprintf(stderr,
                 "boresightd: %s: no %s message the node could use (%llu messages received%s%s): nothing was "
                 "computed\n",
                 replay.c_str(), cfg.channels.star_head.c_str(), static_cast<unsigned long long>(c0.received),
                 why.empty() ? "" : ", rejected: ", why.c_str());
    return 1;
  }
  if (out.rec && !out.rec->close(&err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  out.csv = nullptr;
  if (!csv.empty() && !csv_file.commit(&err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }

  const node::Counters& c = n.counters();
  const node::LatencySummary l = n.stepLatency();
  nlohmann::ordered_json j;
  j["received"] = c.received;
  j["used"] = c.used;
  nlohmann::ordered_json rej = nlohmann::ordered_json::object();
  for (int r = 0; r < io::kRejectCount; ++r) rej[io::rejectKey(io::Reject(r))] = c.rejected[std::size_t(r)];
  j["rejected"] = rej;
  j["lost"] = c.lost;
  j["calibrations_published"] = c.calibrations_published;
  j["calibrations_applied"] = c.calibrations_applied;
  j["frame_changes"] = c.frame_changes;
  if (out.have_cal) {  // the last published calibration (arcsec; sigma null where not determined)
    const auto& k = out.last_cal;
    nlohmann::ordered_json lc;
    lc["utime"] = k.utime;
    lc["span_s"] = static_cast<double>(k.span_end_utime - k.span_start_utime) * 1e-6;
    lc["epochs"] = k.epochs;
    lc["status"] = k.status == 0 ? "ok" : "refused";
    if (k.status != 0) lc["reason"] = n.lastCalibrationReason();
    lc["applied"] = k.applied != 0;
    nlohmann::ordered_json heads = nlohmann::ordered_json::array();
    for (int h = 0; h < k.n_heads && h < 4; ++h) {
      nlohmann::ordered_json x;
      x["id"] = k.head_id[h];
      for (const char* key : {"error_angles_arcsec", "sigma_arcsec", "crlb_arcsec"}) {
        const auto& v = std::string(key) == "error_angles_arcsec" ? k.error_angles_arcsec[h]
                        : std::string(key) == "sigma_arcsec"      ? k.sigma_arcsec[h]
                                                                  : k.crlb_arcsec[h];
        nlohmann::ordered_json a = nlohmann::ordered_json::array();
        for (int i = 0; i < 3; ++i) a.push_back(std::isfinite(v[i]) ? nlohmann::ordered_json(v[i]) : nlohmann::ordered_json());
        x[key] = a;
      }
      x["observable"] = {k.observable[h][0] != 0, k.observable[h][1] != 0, k.observable[h][2] != 0};
      heads.push_back(x);
    }
    lc["heads"] = heads;
    lc["common_rotation_B_arcsec"] = {k.common_rotation_B_arcsec[0], k.common_rotation_B_arcsec[1], k.common_rotation_B_arcsec[2]};
    j["last_calibration"] = lc;
  }  // calibration.apply_common_rotation: published in the accelerometer datum
  {
    const Quat qf = n.frameRotation();
    j["frame_rotation_q_B_Bpub"] = {qf.w(), qf.x(), qf.y(), qf.z()};
  }
  j["worker"] = {{"solves", c.solves},
                 {"cpu_s_mean", c.solves ? c.solve_cpu_s_sum / static_cast<double>(c.solves) : 0.0},
                 {"cpu_s_max", c.solve_cpu_s_max},
                 {"wall_s_max", c.solve_wall_s_max},
                 {"observations_max", c.solve_observations_max},
                 {"observation_mb_max", static_cast<double>(c.solve_observation_bytes_max) / 1048576.0}};
  j["ring_high_water"] = c.ring_high_water;
  j["ring_dropped"] = c.ring_dropped;
  j["outputs_failed"] = c.outputs_failed;
  j["ring_waits"] = c.ring_waits;
  j["step_latency_us"] = {{"p50", l.p50_us}, {"p99", l.p99_us}, {"p99.9", l.p999_us}, {"max", l.max_us}, {"n", l.n}};
  const node::LatencySummary lh = n.headStepLatency();
  j["head_step_latency_us"] = {{"p50", lh.p50_us}, {"p99", lh.p99_us}, {"p99.9", lh.p999_us}, {"max", lh.max_us}, {"n", lh.n}};
  j["wall_s"] = wall;
  j["messages_per_s"] = wall > 0 ? static_cast<double>(c.received) / wall : 0.0;
  j["head_epochs"] = c.head_epochs;
  j["accel_steps"] = c.accel_steps;
  j["orbit_steps"] = c.orbit_steps;
  j["star_epochs"] = c.star_epochs;
  j["rows"] = c.rows;
  j["time_resyncs"] = c.time_resyncs;
  j["held"] = c.held;
  j["frame_changes_refused"] = c.frame_changes_refused;
  j["mountings_applied"] = c.mountings_applied;
  j["calibrations_superseded"] = c.calibrations_superseded;
  j["calibrations_held"] = c.calibrations_held;
  j["commands_accepted"] = c.commands_accepted;
  j["commands_reverted"] = c.commands_reverted;
  j["seq_restarts"] = c.seq_restarts;
  j["stars_dropped"] = c.stars_dropped;
  j["published"] = out.published;
  const core::Health h = n.coreHealth();
  nlohmann::ordered_json ch = nlohmann::ordered_json::object();
  for (int s = 0; s < core::kStatusCount; ++s)
    if (h.by_status[std::size_t(s)]) ch[core::statusName(core::Status(s))] = h.by_status[std::size_t(s)];
  j["core_health"] = ch;
  const bool balanced = c.received == c.used + c.rejectedTotal();
  j["accounted"] = balanced;
  j["model_in_use"] = cfg.model_in_use;
  std::printf("boresightd: %llu messages received, %llu used, %llu rejected, %llu lost; %llu head epochs, "
              "%llu calibrations; %.2f s wall (%.0f messages/s); step latency p50 %.2f us, p99 %.2f us, "
              "p99.9 %.2f us, max %.1f us (head epochs: p50 %.2f us, p99 %.2f us, p99.9 %.2f us)\n",
              static_cast<unsigned long long>(c.received), static_cast<unsigned long long>(c.used),
              static_cast<unsigned long long>(c.rejectedTotal()), static_cast<unsigned long long>(c.lost),
              static_cast<unsigned long long>(c.head_epochs), static_cast<unsigned long long>(c.calibrations_published),
              wall, wall > 0 ? static_cast<double>(c.received) / wall : 0.0, l.p50_us, l.p99_us, l.p999_us, l.max_us,
              n.headStepLatency().p50_us, n.headStepLatency().p99_us, n.headStepLatency().p999_us);
  for (int r = 0; r < io::kRejectCount; ++r)
    if (c.rejected[std::size_t(r)])
      std::printf("  rejected %s: %llu\n", io::rejectKey(io::Reject(r)),
                  static_cast<unsigned long long>(c.rejected[std::size_t(r)]));
  if (interrupted) j["interrupted"] = true;
  if (!summary_json.empty() && !io::writeFileAtomic(summary_json, j.dump(2) + "\n", &err)) {
    std::fprintf(stderr, "boresightd: %s\n", err.c_str());
    return 1;
  }
  if (out.have_cal && out.last_cal.status != 0)
    std::printf("  last calibration refused: %s\n", n.lastCalibrationReason().c_str());
  if (interrupted) {
    std::fprintf(stderr, "boresightd: %s: replay stopped by a signal; the outputs and the summary cover what was read\n",
                 replay.c_str());
    return 1;
  }
  if (!balanced) {
    std::fprintf(stderr, "boresightd: internal error: received != used + rejected\n");
    return 1;
  }
  return 0;
}

}  // namespace

// The audit over recorded telemetry: see include/boresight/audit/run.h.
#include <boresight/audit/reference.h>
#include <boresight/audit/run.h>
#include "collector_impl.h"
#include <boresight/io/core_config.h>
#include <boresight/io/product_stream.h>
#include <boresight/model/effects.h>
#include <boresight/model/orbit_context.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>

namespace boresight::audit {
namespace {

/// Says how far the replay has come, every `every_s` of data time.
class Progress final : public stream::InputObserver {
 public:
  Progress(std::function<void(const std::string&)> f, double every_s) : f_(std::move(f)), every_s_(every_s) {}
  void onHeads(const core::HeadEpoch& e, core::Status) override {
    if (!f_) return;
    if (!started_) {
      t0_ = e.t;
      started_ = true;
      return;
    }
    const double data_s = toSeconds(e.t - t0_);
    if (data_s >= next_s_) {
      next_s_ = (std::floor(data_s / every_s_) + 1) * every_s_;
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0_).count();
      char b[160];
      std::snprintf(b, sizeof b, "audit: %.1f h of data replayed (%.1f s)", data_s / 3600.0, wall);
      f_(b);
    }
  }

 private:
  std::function<void(const std::string&)> f_;
  double every_s_;
  double next_s_ = every_s_;
  bool started_ = false;
  TimeUs t0_ = 0;
  std::chrono::steady_clock::time_point w0_ = std::chrono::steady_clock::now();
};

}  // namespace

bool runAudit(const RunRequest& req, RunOutput& out, std::string* error) {
  out = RunOutput{};
  stream::ReplayRequest rq;
  rq.program = "boresight audit";
  rq.config = req.config;
  rq.overlay = req.overlay;
  rq.uses.accelerometer = true;  // the angular-acceleration family then sees the corrected accelerometer
  rq.uses.thermal = true;        // the heads' mountings follow the thermal terms (AuditOptions::applied_thermal)
  rq.uses.data_events = true;    // the expected missing-sample runs: the data events' null
  rq.inputs = req.inputs;
  rq.strict = req.strict;
  rq.lookahead_s = req.lookahead_s;
  rq.star_vectors = false;       // SCV1A: listed as ignored below
  stream::Replay rp;
  if (!stream::openReplay(rq, rp, error)) return false;
  io::PlatformConfig& pc = rp.pc;
  out.overlay = rp.overlay;
  stream::ReplayInputs& in = rp.in;
  stream::Engine& engine = *rp.engine;
  out.truth_given = req.truth.has_value();
  // Sort what the replay does not read: outside reference, its clock; the orbit files are the engine's
  // (in.orbit, also listed as ignored); the rest is ignored.
  std::vector<std::string> sca1b, clk1b, gni, gnv;
  std::vector<std::pair<std::string, std::string>> ignored;
  for (const auto& [f, product] : in.ignored) {
    if (product == "SCA1B") sca1b.push_back(f);
    else if (product == "CLK1B") clk1b.push_back(f);
    else if (product == "GNI1B") gni.push_back(f);
    else if (product == "GNV1B") gnv.push_back(f);
    else ignored.emplace_back(f, product);
  }
  in.ignored = ignored;
  for (const auto& [f, product] : ignored)
    out.notes.push_back(f + ": " + product +
                        " is not an input of audit (SCA1A, ACC1A, QSA1B, GNI1B/GNV1B, SCA1B, CLK1B, LCM log): ignored");
  // The orbit: GNI1B (inertial, exact) when given, else GNV1B (through the Earth rotation angle); an LCM
  // log's ORBIT messages too. Read by the engine in time order with the rest (the collector takes it).
  const std::vector<std::string> orbit = gni.empty() ? gnv : gni;
  in.orbit = orbit;
  if (!gni.empty())
    for (const auto& f : gnv) out.notes.push_back(f + ": GNV1B not used: GNI1B gives the orbit");
  if (!clk1b.empty() && sca1b.empty())
    for (const auto& f : clk1b) out.notes.push_back(f + ": CLK1B is used only with an SCA1B reference: ignored");
  for (const auto& f : sca1b)
    if (!checkSca1b(f, error)) return false;
  for (const auto& f : clk1b)
    if (!checkClk1b(f, error)) return false;

  for (const auto& f : in.sca) out.inputs.push_back(f + ": SCA1A heads");
  for (const auto& f : in.acc) out.inputs.push_back(f + ": accelerometer");
  for (const auto& f : in.qsa) out.inputs.push_back(f + ": QSA1B nominal mountings");
  for (const auto& f : in.lcm) out.inputs.push_back(f + ": LCM log");
  for (const auto& f : orbit) out.inputs.push_back(f + ": orbit context");

  // The observers before the sources (the engine opens the orbit files for an observer that wants the
  // orbit): the reference's samples up to each head epoch first, then the progress, then the collector
  // (configured below, once the replay has settled the mountings).
  Collector collector;
  ClockMap clock;
  if (!sca1b.empty() && !loadClk1b(clk1b, clock, error)) return false;
  ReferenceFeed reference(collector, clock);
  if (!sca1b.empty()) {
    if (!reference.open(sca1b, error)) return false;
    out.reference_time_base = reference.timeBase();
    for (const auto& f : sca1b) out.inputs.push_back(f + ": SCA1B outside reference (" + out.reference_time_base + ")");
    for (const auto& f : clk1b) out.inputs.push_back(f + ": CLK1B receiver clock");
    engine.addObserver(&reference);
  }
  Progress progress(req.progress, req.progress_every_s > 0 ? req.progress_every_s : 6 * 3600.0);
  engine.addObserver(&progress);
  engine.addObserver(&collector);
  engine.addSink(&collector);

  if (!stream::startReplay(rp, error)) return false;
  AuditOptions options = req.options;
  bool thermal_terms = false;
  if (out.overlay.thermal_model)
    for (const auto& h : out.overlay.thermal_model->head) thermal_terms = thermal_terms || h.valid;
  if (thermal_terms) {
    if (orbit.empty() && in.lcm.empty()) {
      if (error) *error = req.overlay + ": thermal terms need the orbit among the inputs (GNI1B or GNV1B files, or an LCM log's ORBIT messages)";
      return false;
    }
    options.applied_thermal = out.overlay.thermal_model;
  }
  // The noise-level tests compare first differences with the configured model's (a coloured part of
  // the noise in use adds little to them): per head var - autocovariance(head epoch interval).
  if (pc.pipeline.crn_attitude.fs_hz > 0)
    for (int s = 0; s < pc.noise_in_use.n_heads && s < pc.pipeline.heads.n_heads; ++s) {
      const auto k = static_cast<std::size_t>(s);
      const auto& h = pc.noise_in_use.head[k];
      if (!h[0].set || !h[1].set || !h[2].set) continue;
      const double dt = 1.0 / pc.pipeline.crn_attitude.fs_hz;
      auto diff2 = [&](const model::NoiseModel& m) { return m.variance() - m.autocovariance(dt); };
      options.configured_diff_cross2[k] = 0.5 * (diff2(h[0].noise.model) + diff2(h[1].noise.model));
      options.configured_diff_about2[k] = diff2(h[2].noise.model);
    }
  {  // the configured slow noise (Gauss-Markov terms; a power law's slow part is not carried here)
    double wsum = 0, tsum = 0;
    for (int s = 0; s < pc.noise_in_use.n_heads && s < core::kMaxHeads; ++s) {
      const auto k = static_cast<std::size_t>(s);
      double v[3] = {0, 0, 0};
      for (int a = 0; a < 3; ++a) {
        const auto& ax = pc.noise_in_use.head[k][static_cast<std::size_t>(a)];
        if (!ax.set) continue;
        for (const auto& t : ax.noise.model.terms)
          if (t.kind == model::NoiseKind::GaussMarkov && t.sigma > 0 && t.tau_s > 0) {
            v[a] += t.sigma * t.sigma;
            wsum += t.sigma * t.sigma;
            tsum += t.sigma * t.sigma * t.tau_s;
          }
      }
      options.configured_gm_cross[k] = std::sqrt(0.5 * (v[0] + v[1]));
      options.configured_gm_about[k] = std::sqrt(v[2]);
    }
    if (wsum > 0) options.configured_gm_tau_s = tsum / wsum;
  }
  options.data_events = pc.events;  // the data events' null: the platform file's (or the overlay's) expected runs
  if (!collector.configure(pc.pipeline, options, error)) return false;
  if (engine.run() != stream::Engine::Result::kDone) {
    if (error) *error = engine.error();
    return false;
  }
  if (!reference.error().empty()) {
    if (error) *error = reference.error();
    return false;
  }
  out.counters = engine.counters();
  out.orbit_samples = engine.orbitSamples() - collector.orbitUnusable();
  out.orbit_rejected = collector.orbitUnusable();
  for (std::size_t i = 0; i < engine.sourceCount(); ++i)
    if (std::find(orbit.begin(), orbit.end(), engine.source(i).name()) != orbit.end())
      out.orbit_rejected += engine.counters(i).rejectedTotal();
  // Every record is used or rejected with a reason: the rejected ones per source, with the first lines.
  for (std::size_t i = 0; i < engine.sourceCount(); ++i) {
    const auto& c = engine.counters(i);
    if (c.rejectedTotal() == 0) continue;
    std::string s = engine.source(i).name() + ": " + std::to_string(c.read) + " read, " + std::to_string(c.used()) + " used";
    for (int r = 0; r < stream::kRejectCount; ++r)
      if (c.rejected[static_cast<std::size_t>(r)])
        s += ", " + std::to_string(c.rejected[static_cast<std::size_t>(r)]) + " " + io::rejectText(stream::Reject(r));
    out.notes.push_back(s);
    const auto issues = engine.source(i).issues();
    for (std::size_t k = 0; k < issues.size() && k < 5; ++k) out.notes.push_back("  rejected " + issues[k]);
  }
  out.health = engine.health();
  out.epochs = engine.epochs();
  out.rows = engine.rows();
  out.span_s = toSeconds(engine.lastEpoch() - engine.firstEpoch());
  out.first_epoch = engine.firstEpoch();
  out.last_epoch = engine.lastEpoch();
  out.reference_samples = reference.fed();
  out.reference_dropped = reference.dropped();
  if (out.counters.used_heads == 0) {
    if (error) *error = "no star sensor samples in the inputs";
    return false;
  }
  if (!sca1b.empty())
    out.notes.push_back("outside reference: " + std::to_string(out.reference_samples) + " SCA1B samples, " +
                        out.reference_time_base +
                        (out.reference_dropped ? ", " + std::to_string(out.reference_dropped) +
                                                     " dropped (bad quaternion or out of time order)"
                                               : std::string()));
  if (out.orbit_samples > 0)
    out.notes.push_back("orbit context: " + std::to_string(out.orbit_samples) + " samples from " +
                        (!gni.empty()   ? std::string("GNI1B")
                         : !gnv.empty() ? std::string("GNV1B (Earth-fixed, rotated by the Earth rotation angle)")
                                        : std::string("the LCM log's ORBIT messages")) +
                        (out.orbit_rejected ? ", " + std::to_string(out.orbit_rejected) + " rejected" : std::string()));
  else
    out.notes.push_back("no orbit context (GNI1B / GNV1B, ORBIT messages): no orbit-harmonic tests");
  if (options.applied_thermal) {
    const auto& ci = collector.impl();
    out.notes.push_back("thermal terms of " + req.overlay + " applied to " + std::to_string(ci.thermal_applied) + " head epochs" +
                        (ci.thermal_no_orbit ? " (" + std::to_string(ci.thermal_no_orbit) + " without an orbit sample within 60 s: plain mountings)"
                                             : std::string()));
  }
  out.result = analyse(collector, options, req.truth ? &*req.truth : nullptr);
  out.platform = pc;
  out.model_in_use = io::modelInUseLines(pc, out.overlay);
  for (const auto& w : io::validityWarnings(out.overlay, engine.firstEpoch(), engine.lastEpoch()))
    out.model_in_use.push_back("warning: " + w);
  return true;
}

}  // namespace boresight::audit

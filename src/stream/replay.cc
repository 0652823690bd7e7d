// Replay setup: inputs by content, configuration for them, sources.
#include <boresight/stream/replay.h>
#include <boresight/io/lcm_log.h>
#include <boresight/core/plausibility.h>
#include <boresight/io/files.h>
#include <boresight/stream/sources.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace boresight::stream {
namespace {

/// The earliest head tag among the first head samples of the inputs (the QSA1B reference time).
bool firstHeadTag(const ReplayInputs& in, const io::ReadOptions& opt, TimeUs& t) {
  bool found = false;
  auto take = [&](Source& s) {
    Sample x;
    Reject why;
    for (int k = 0; k < 100000; ++k) {
      auto n = s.next(x, why);
      if (n == Source::Next::kSample && x.kind == Sample::Kind::kHead) {
        if (!found || x.t < t) t = x.t;
        found = true;
        return;
      }
      if (n != Source::Next::kSample && n != Source::Next::kRejected) return;
    }
  };
  for (const auto& f : in.sca) {
    Sca1aSource s;
    if (s.open(f, opt, nullptr)) take(s);
  }
  for (const auto& f : in.lcm) {
    LcmLogSource s;
    if (s.open(f, nullptr)) take(s);
  }
  return found;
}

/// The median interval (s) between consecutive distinct tags of one kind (per head for heads) among
/// the first samples of the inputs, and how many intervals it is the median of (0: none).
struct RateScan {
  double median_s = 0;
  std::size_t n = 0;
  std::string file;  ///< the first input scanned
};
RateScan scanRate(const ReplayInputs& in, const io::ReadOptions& opt, Sample::Kind kind) {
  RateScan r;
  std::vector<double> dt;
  constexpr int kSamples = 4000;
  auto take = [&](Source& s, const std::string& f) {
    std::map<int, TimeUs> last;  // per head id (0 for the accelerometer)
    Sample x;
    Reject why;
    int got = 0;
    for (int k = 0; k < 200000 && got < kSamples; ++k) {
      const auto n = s.next(x, why);
      if (n == Source::Next::kRejected) continue;
      if (n != Source::Next::kSample) break;
      if (x.kind != kind) continue;
      ++got;
      const int key = kind == Sample::Kind::kHead ? x.head_id : 0;
      auto it = last.find(key);
      if (it != last.end() && x.t > it->second) dt.push_back(toSeconds(x.t - it->second));
      last[key] = x.t;
    }
    if (r.file.empty() && got > 0) r.file = f;
  };
  if (kind == Sample::Kind::kHead)
    for (const auto& f : in.sca) {
      Sca1aSource s;
      if (s.open(f, opt, nullptr)) take(s, f);
    }
  if (kind == Sample::Kind::kAccel)
    for (const auto& f : in.acc) {
      Acc1aSource s;
      if (s.open(f, opt, nullptr)) take(s, f);
    }
  for (const auto& f : in.lcm) {
    LcmLogSource s;
    if (s.open(f, nullptr)) take(s, f);
  }
  if (dt.empty()) return r;
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  r.median_s = dt[dt.size() / 2];
  r.n = dt.size();
  return r;
}

/// Whether an LCM log carries accelerometer messages (looked for in its first 100 000 events).
bool lcmHasAccel(const std::string& f) {
  LcmLogSource s;
  if (!s.open(f, nullptr)) return false;
  Sample x;
  Reject why;
  for (int k = 0; k < 100000; ++k) {
    auto n = s.next(x, why);
    if (n == Source::Next::kSample && x.kind == Sample::Kind::kAccel) return true;
    if (n != Source::Next::kSample && n != Source::Next::kRejected) return false;
  }
  return false;
}

}  // namespace

bool classifyInputs(const std::vector<std::string>& files, ReplayInputs& in, std::string* error) {
  in = ReplayInputs{};
  std::vector<std::string> seen;
  for (const auto& f : files) {
    const std::string real = io::resolvedPath(f);
    for (std::size_t k = 0; k < seen.size(); ++k)
      if (seen[k] == real) {
        if (error) *error = f + ": given twice (as " + files[k] + " too): every sample would be counted twice";
        return false;
      }
    seen.push_back(real);
    FileKind k = identifyFile(f);
    if (k.type == FileKind::Type::kUnknown) {
      if (error) *error = k.reason;
      return false;
    }
    if (k.type == FileKind::Type::kLcmLog) {
      in.lcm.push_back(f);
      continue;
    }
    switch (k.product) {
      case io::Product::SCA1A: in.sca.push_back(f); break;
      case io::Product::ACC1A:
      case io::Product::ACT1A: in.acc.push_back(f); break;
      case io::Product::QSA1B: in.qsa.push_back(f); break;
      case io::Product::SCV1A: in.scv.push_back(f); break;
      case io::Product::GNV1B:
      case io::Product::GNI1B:
        in.orbit.push_back(f);
        in.ignored.emplace_back(f, k.product_name);
        break;
      default: in.ignored.emplace_back(f, k.product_name); break;
    }
  }
  if (!in.lcm.empty() && !(in.sca.empty() && in.acc.empty() && in.scv.empty())) {
    const bool sca = !in.sca.empty(), acc = !in.acc.empty();
    if (error)
      *error = in.lcm.front() + " is an LCM log and " + (sca ? in.sca : acc ? in.acc : in.scv).front() +
               " is a Level-1 " + (sca ? "SCA1A" : acc ? "ACC1A" : "SCV1A") +
               " file: give either Level-1 files or LCM logs (they carry the same samples; mixing them would feed "
               "the core twice)";
    return false;
  }
  for (const auto& f : in.qsa) {
    auto p = io::readProduct<io::QsaRecord>(f);
    if (!p.ok) {
      if (error) *error = p.error;
      return false;
    }
    in.qsa_records.insert(in.qsa_records.end(), p.records.begin(), p.records.end());
    if (p.rejected_count > 0) {
      // The mountings must not come from a file with damaged lines: one bad alignment is a rotated head.
      if (error)
        *error = (p.rejected.empty() ? f + ": a rejected line" : p.rejected.front().str()) + " (" +
                 std::to_string(p.rejected_count) + " of the QSA1B lines rejected): the mountings cannot be taken from it";
      return false;
    }
    if (p.records.empty()) {
      if (error) *error = f + ":" + std::to_string(p.header.line_count + 1) + ": a QSA1B file without alignment records";
      return false;
    }
  }
  return true;
}

bool prepareConfig(const ReplayInputs& in, const io::ReadOptions& opt, io::PlatformConfig& pc, std::string* error) {
  if (in.sca.empty() && in.lcm.empty()) {
    std::string names;
    for (const auto* v : {&in.acc, &in.qsa, &in.scv})
      for (const auto& f : *v) names += (names.empty() ? "" : ", ") + f;
    for (const auto& [f, p] : in.ignored) names += (names.empty() ? "" : ", ") + f + " (" + p + ")";
    if (error) *error = "no star sensor input (SCA1A file or LCM log) among the inputs (" + names + ")";
    return false;
  }
  if (pc.mounting_from_qsa1b && in.qsa_records.empty() && !in.lcm.empty()) {
    // No QSA1B file: an LCM log's first NOMINAL_MOUNTINGS message carries them, as boresightd takes them
    // (mountings: log) - the same message, the same rule (io::applyNominalMountings); the overlay's
    // mountings stay.
    for (const auto& f : in.lcm) {
      io::NominalMountings m;
      if (!io::firstNominalMountings(f, m)) continue;
      std::uint32_t keep = 0;
      for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
        if (pc.mounting_source[static_cast<std::size_t>(s)].rfind("overlay", 0) == 0) keep |= 1u << s;
      Reject why = Reject::kMalformed;
      if (!io::applyNominalMountings(m, pc.pipeline.heads, keep, why)) {
        if (error)
          *error = f + ": its NOMINAL_MOUNTINGS message cannot give the platform's mountings (" + io::rejectKey(why) +
                   ": " + (why == Reject::kUnknownHead ? "a configured head is not in it" : "not a rotation") + ")";
        return false;
      }
      for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
        if (!((keep >> s) & 1u))
          pc.mounting_source[static_cast<std::size_t>(s)] = f + ": the first NOMINAL_MOUNTINGS message";
      pc.mounting_from_qsa1b = false;
      break;
    }
  }
  if (pc.mounting_from_qsa1b) {
    if (in.qsa_records.empty()) {
      std::string names;
      for (const auto& [f, p] : in.ignored) names += (names.empty() ? "" : ", ") + f + " (" + p + ")";
      for (const auto& f : in.lcm) names += (names.empty() ? "" : ", ") + f + " (LCM log)";
      if (error)
        *error = "the platform takes the mountings from QSA1B (heads.mounting: qsa1b): give a QSA1B file, or an LCM "
                 "log with a NOMINAL_MOUNTINGS message (none among " +
                 (names.empty() ? std::string("the inputs") : names) + ")";
      return false;
    }
    TimeUs t0 = 0;
    if (!firstHeadTag(in, opt, t0)) {
      std::string names;
      for (const auto* v : {&in.sca, &in.lcm})
        for (const auto& f : *v) names += (names.empty() ? "" : ", ") + f;
      if (error) *error = "no star sensor samples in " + names + " (every record rejected, or none there)";
      return false;
    }
    if (!io::applyQsa1bMounting(pc, in.qsa_records, t0, error)) {
      std::string names;
      for (const auto& f : in.qsa) names += (names.empty() ? "" : ", ") + f;
      if (error) *error = names + ": " + *error;
      return false;
    }
  }
  bool have_acc = !in.acc.empty();
  for (const auto& f : in.lcm) have_acc = have_acc || lcmHasAccel(f);
  if (!have_acc) pc.pipeline.use_accelerometer = false;
  return checkSampleRates(in, opt, pc.pipeline, error);
}

bool checkSampleRates(const ReplayInputs& in, const io::ReadOptions& opt, const core::PipelineConfig& cfg,
                      std::string* error) {
  struct Stream {
    Sample::Kind kind;
    const char* key;
    double fs_hz;
    const char* what;
  };
  const Stream streams[] = {
      {Sample::Kind::kHead, "crn_attitude.fs_hz", cfg.crn_attitude.fs_hz, "each head"},
      {Sample::Kind::kAccel, "crn_acc.fs_hz", cfg.crn_acc.fs_hz, "the accelerometer"}};
  for (const Stream& st : streams) {
    if (st.kind == Sample::Kind::kAccel && !cfg.use_accelerometer) continue;
    const RateScan r = scanRate(in, opt, st.kind);
    if (r.n < 3 || plausibility::rateMatches(r.median_s, st.fs_hz)) continue;
    if (error) {
      char b[640];
      std::snprintf(b, sizeof b,
                    "%s: %s is sampled every %.4g s (%.4g Hz, the median of %zu intervals) but the platform's %s is "
                    "%.4g Hz: the CRN filters are designed for the configured rate, so the rates, angular "
                    "accelerations and their sigmas would be off by the ratio (set %s: %.4g, or give data at %.4g Hz)",
                    r.file.c_str(), st.what, r.median_s, 1.0 / r.median_s, r.n, st.key, st.fs_hz, st.key,
                    1.0 / r.median_s, st.fs_hz);
      *error = b;
    }
    return false;
  }
  return true;
}

bool addSources(const ReplayInputs& in, const io::ReadOptions& opt_in, bool prefetch, Engine& engine, std::string* error) {
  // The readers gate the heads' quaternions with the core's tolerance: a record is refused once, there.
  io::ReadOptions opt = opt_in;
  opt.quat_norm_tolerance = engine.pipeline().config().heads.unit_norm_tolerance;
  auto add = [&](std::unique_ptr<Source> s) {
    if (prefetch) s = std::make_unique<PrefetchSource>(std::move(s));
    engine.addSource(std::move(s));
  };
  for (const auto& f : in.sca) {
    auto s = std::make_unique<Sca1aSource>();
    if (!s->open(f, opt, error)) return false;
    add(std::move(s));
  }
  for (const auto& f : in.acc) {
    auto s = std::make_unique<Acc1aSource>();
    if (!s->open(f, opt, error)) return false;
    add(std::move(s));
  }
  for (const auto& f : in.scv) {
    auto s = std::make_unique<ScvSource>();
    if (!s->open(f, opt, error)) return false;
    add(std::move(s));
  }
  if (engine.wantsOrbit())
    for (const auto& f : in.orbit) {
      auto s = std::make_unique<OrbitFileSource>();
      if (!s->open(f, opt, error)) return false;
      add(std::move(s));
    }
  for (const auto& f : in.lcm) {
    auto s = std::make_unique<LcmLogSource>();
    if (!s->open(f, error)) return false;
    s->setQuatTolerance(opt.quat_norm_tolerance);
    add(std::move(s));
  }
  return true;
}

bool openReplay(const ReplayRequest& rq, Replay& r, std::string* error) {
  r = Replay{};
  if (!io::loadPlatformConfig(rq.config, r.pc, error)) return false;
  if (!rq.overlay.empty() && !io::applyOverlay(rq.overlay, rq.program, rq.uses, r.pc, r.overlay, error)) return false;
  if (!classifyInputs(rq.inputs, r.in, error)) return false;
  if (!rq.star_vectors) {
    for (const auto& f : r.in.scv) r.in.ignored.emplace_back(f, "SCV1A");
    r.in.scv.clear();
  }
  if (rq.strict) r.opt.on_error = io::OnError::Stop;
  if (!prepareConfig(r.in, r.opt, r.pc, error)) return false;
  AssemblerConfig acfg;
  acfg.lookahead_us = static_cast<TimeUs>(std::llround(rq.lookahead_s * 1e6));
  r.engine = std::make_unique<Engine>(acfg);
  if (!r.engine->configure(r.pc.pipeline, error)) return false;
  if (rq.thermal_in_core && r.overlay.thermal_model && !r.engine->setThermalModel(*r.overlay.thermal_model, error)) return false;
  return true;
}

bool startReplay(Replay& r, std::string* error) {
  if (!r.engine) {
    if (error) *error = "startReplay before openReplay";
    return false;
  }
  return addSources(r.in, r.opt, true, *r.engine, error);
}

}  // namespace boresight::stream

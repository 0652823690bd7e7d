// Replay setup: inputs by content, configuration for them, sources.
#include <boresight/stream/replay.h>
#include <boresight/stream/sources.h>

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
  for (const auto& f : files) {
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
  }
  return true;
}

bool prepareConfig(const ReplayInputs& in, const io::ReadOptions& opt, io::PlatformConfig& pc, std::string* error) {
  if (in.sca.empty() && in.lcm.empty()) {
    if (error) *error = "no star sensor input (SCA1A file or LCM log) among the inputs";
    return false;
  }
  if (pc.mounting_from_qsa1b) {
    if (in.qsa_records.empty()) {
      if (error) *error = "the platform takes the mountings from QSA1B (heads.mounting: qsa1b): give a QSA1B file";
      return false;
    }
    TimeUs t0 = 0;
    if (!firstHeadTag(in, opt, t0)) {
      if (error) *error = "no star sensor samples in the inputs";
      return false;
    }
    if (!io::applyQsa1bMounting(pc, in.qsa_records, t0, error)) return false;
  }
  bool have_acc = !in.acc.empty();
  for (const auto& f : in.lcm) have_acc = have_acc || lcmHasAccel(f);
  if (!have_acc) pc.pipeline.use_accelerometer = false;
  return true;
}

bool addSources(const ReplayInputs& in, const io::ReadOptions& opt, bool prefetch, Engine& engine, std::string* error) {
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
  for (const auto& f : in.lcm) {
    auto s = std::make_unique<LcmLogSource>();
    if (!s->open(f, error)) return false;
    add(std::move(s));
  }
  return true;
}

}  // namespace boresight::stream

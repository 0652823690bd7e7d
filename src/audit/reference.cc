// The outside reference (SCA1B, CLK1B): see include/boresight/audit/reference.h.
#include <boresight/audit/reference.h>
#include <boresight/io/product_stream.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace boresight::audit {

double ClockMap::epsAt(TimeUs t) const {
  const auto& r = records;
  if (r.empty()) return 0.0;
  if (t <= r.front().t) return r.front().eps_time;
  // First record at or after t (records in time order, as CLK1B files are).
  auto it = std::lower_bound(r.begin(), r.end(), t, [](const io::ClkRecord& c, TimeUs v) { return c.t < v; });
  if (it == r.end()) return r.back().eps_time;
  const auto& a = *(it - 1);
  const auto& b = *it;
  double f = double(t - a.t) / double(std::max<TimeUs>(1, b.t - a.t));
  return a.eps_time + f * (b.eps_time - a.eps_time);
}

TimeUs ClockMap::toReceiver(TimeUs t_gps) const {
  if (records.empty()) return t_gps;
  TimeUs t = t_gps;
  for (int i = 0; i < 3; ++i) t = t_gps - static_cast<TimeUs>(std::llround(epsAt(t) * 1e6));
  return t;
}

bool checkProduct(const std::string& path, io::Product want, std::string* error) {
  io::LineStream probe;
  if (!probe.open(path, {}, error, 4096)) return false;
  if (probe.header().product != want) {
    if (error) {
      const std::string name = want == io::Product::SCA1B ? "SCA1B" : want == io::Product::CLK1B ? "CLK1B" : "requested";
      *error = path + ":1: " + probe.header().product_name + " is not " + (name == "SCA1B" ? "an " : "a ") + name +
               " product";
    }
    return false;
  }
  return true;
}

bool loadClk1b(const std::vector<std::string>& paths, ClockMap& out, std::string* error) {
  out.records.clear();
  for (const auto& p : paths) {
    auto c = io::readProduct<io::ClkRecord>(p);
    if (!c.ok) {
      if (error) *error = c.error;
      return false;
    }
    for (const auto& r : c.records)
      if (r.qualflg.value == 0) out.records.push_back(r);
  }
  std::stable_sort(out.records.begin(), out.records.end(),
                   [](const io::ClkRecord& a, const io::ClkRecord& b) { return a.t < b.t; });
  return true;
}

bool readSca1b(const std::string& path, std::vector<io::Sca1bRecord>& out, std::string* error) {
  io::LineStream probe;
  if (!probe.open(path, {}, error, 4096)) return false;
  if (probe.header().binary) {
    auto p = io::readProduct<io::Sca1bRecord>(path);
    if (!p.ok) {
      if (error) *error = p.error;
      return false;
    }
    out = std::move(p.records);
    return true;
  }
  io::ProductStream<io::Sca1bRecord> st;
  if (!st.open(path, {}, error)) return false;
  io::Sca1bRecord rec;
  while (st.next(rec)) out.push_back(rec);
  if (!st.ok()) {
    if (error) *error = st.error();
    return false;
  }
  return true;
}

std::vector<TimedAttitude> referenceSamples(const std::vector<io::Sca1bRecord>& recs) {
  std::vector<TimedAttitude> ref;
  ref.reserve(recs.size());
  for (const auto& s : recs) ref.push_back({toSeconds(s.t), quatFromScalarFirst(s.q).normalized()});
  return ref;
}

AttitudeDifference compareAttitudes(const std::vector<TimedAttitude>& fused, const std::vector<TimedAttitude>& ref,
                                    double shift_s) {
  AttitudeDifference c;
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  for (const auto& s : ref) {
    double t = s.t_s + shift_s;
    auto it = std::lower_bound(fused.begin(), fused.end(), t,
                               [](const TimedAttitude& a, double v) { return a.t_s < v; });
    if (it == fused.begin() || it == fused.end()) continue;
    auto prev = it - 1;
    if (it->t_s - prev->t_s > 1.5) continue;
    double f = (t - prev->t_s) / (it->t_s - prev->t_s);
    Quat q = prev->q_I_B.slerp(f, it->q_I_B);
    Eigen::AngleAxisd d(q.conjugate() * s.q_I_B);
    double ang = d.angle() > kPi ? d.angle() - 2 * kPi : d.angle();
    Vec3 e = ang * d.axis() * kArcsecPerRad;
    sum += e;
    sum2 += e.cwiseProduct(e);
    ++c.n;
  }
  if (c.n > 0) {
    c.mean = sum / c.n;
    c.sd = ((sum2 / c.n - c.mean.cwiseProduct(c.mean)).cwiseMax(0.0) * (c.n / std::max(1.0, c.n - 1.0))).cwiseSqrt();
  }
  return c;
}

ShiftScan scanTimeShift(const std::vector<TimedAttitude>& fused, const std::vector<TimedAttitude>& ref) {
  ShiftScan out;
  const AttitudeDifference c0 = compareAttitudes(fused, ref, 0.0);
  out.at_zero = out.best = c0;
  if (c0.n == 0) return out;
  std::map<int, AttitudeDifference> seen;
  seen[0] = c0;
  auto eval = [&](int k) {
    auto it = seen.find(k);
    if (it == seen.end()) it = seen.emplace(k, compareAttitudes(fused, ref, k * 0.01)).first;
    return it->second;
  };
  auto pick = [&](int lo, int hi, int step, int& best_k) {
    double best = c0.mean.norm();
    for (int k = lo; k <= hi; k += step) {
      AttitudeDifference c = eval(k);
      if (c.n >= c0.n / 2 && c.mean.norm() < best) {
        best = c.mean.norm();
        best_k = k;
      }
    }
  };
  int coarse_k = 0, best_k = 0;
  pick(-100, 100, 10, coarse_k);
  pick(std::max(-100, coarse_k - 10), std::min(100, coarse_k + 10), 1, best_k);
  // The full scan's rule (first strict minimum in grid order) over every point evaluated.
  double best = c0.mean.norm();
  best_k = 0;
  for (const auto& [k, c] : seen)
    if (c.n >= c0.n / 2 && c.mean.norm() < best) {
      best = c.mean.norm();
      best_k = k;
    }
  out.best = seen[best_k];
  out.best_shift_s = best_k * 0.01;
  return out;
}

// ---- ReferenceFeed ----

/// One open SCA1B file: a text stream, or a binary file read whole.
struct ReferenceFeed::Reader {
  io::ProductStream<io::Sca1bRecord> stream;
  bool binary = false;
  std::vector<io::Sca1bRecord> whole;
  std::size_t pos = 0;
  std::string path;
};

ReferenceFeed::ReferenceFeed(Collector& c, ClockMap clock)
    : ReferenceFeed([&c](TimeUs t, const Quat& q) { c.addReference(t, q); }, std::move(clock)) {}
ReferenceFeed::ReferenceFeed(Sink sink, ClockMap clock) : sink_(std::move(sink)), clock_(std::move(clock)) {}
ReferenceFeed::~ReferenceFeed() = default;

std::string ReferenceFeed::timeBase() const {
  return clock_.empty() ? "GPS time tags taken as receiver time (no CLK1B)"
                        : "GPS time tags mapped to receiver time through CLK1B";
}

bool ReferenceFeed::open(const std::vector<std::string>& sca1b, std::string* error) {
  for (const auto& f : sca1b)
    if (!checkSca1b(f, error)) return false;
  files_ = sca1b;
  file_ = 0;
  reader_.reset();
  return true;
}

bool ReferenceFeed::next(TimeUs& t_rcv, Quat& q) {
  for (;;) {
    if (!reader_) {
      if (file_ >= files_.size()) return false;
      reader_ = std::make_unique<Reader>();
      reader_->path = files_[file_++];
      io::LineStream probe;
      if (!probe.open(reader_->path, {}, &error_, 4096)) return false;
      if (probe.header().binary) {
        auto p = io::readProduct<io::Sca1bRecord>(reader_->path);
        if (!p.ok) {
          error_ = p.error;
          return false;
        }
        reader_->binary = true;
        reader_->whole = std::move(p.records);
      } else if (!reader_->stream.open(reader_->path, {}, &error_)) {
        return false;
      }
    }
    io::Sca1bRecord rec;
    bool got = false;
    if (reader_->binary) {
      if (reader_->pos < reader_->whole.size()) {
        rec = reader_->whole[reader_->pos++];
        got = true;
      }
    } else {
      got = reader_->stream.next(rec);
      if (!got && !reader_->stream.ok()) {
        error_ = reader_->stream.error();
        return false;
      }
    }
    if (!got) {
      dropped_ += reader_->stream.rejectedCount();  // lines the reader refused (its gates included)
      reader_.reset();
      continue;
    }
    const Quat qr = quatFromScalarFirst(rec.q);
    const double n = qr.norm();
    const TimeUs t = clock_.toReceiver(rec.t);
    if (!std::isfinite(n) || std::abs(n - 1.0) > 1e-3 || (fed_ > 0 && t <= last_t_)) {
      ++dropped_;
      continue;
    }
    t_rcv = t;
    q = qr.normalized();
    return true;
  }
}

bool ReferenceFeed::feedUntil(TimeUs t_rcv) {
  if (!error_.empty()) return false;
  for (;;) {
    if (!have_pending_) {
      if (!next(pending_t_, pending_q_)) return error_.empty();
      have_pending_ = true;
    }
    if (pending_t_ > t_rcv) return true;
    sink_(pending_t_, pending_q_);
    last_t_ = pending_t_;
    ++fed_;
    have_pending_ = false;
  }
}

bool ReferenceFeed::feedAll(std::string* error) {
  if (!feedUntil(std::numeric_limits<TimeUs>::max())) {
    if (error) *error = error_;
    return false;
  }
  return true;
}

void ReferenceFeed::onHeads(const core::HeadEpoch& e, core::Status) { feedUntil(e.t); }
void ReferenceFeed::onEnd() { feedUntil(std::numeric_limits<TimeUs>::max()); }

}  // namespace boresight::audit

// CSV row sink (printf-identical numbers through std::to_chars), the batch ring buffer and the SCA1B writer.
#include <boresight/stream/sinks.h>

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace boresight::stream {
namespace {

constexpr std::size_t kFlushBytes = 1u << 16;

void putNum(std::string& b, double v, std::chars_format fmt, int prec) {
  char tmp[64];
  auto r = std::to_chars(tmp, tmp + sizeof tmp, v, fmt, prec);
  b.append(tmp, static_cast<std::size_t>(r.ptr - tmp));
}

/// ",value" or "," when not finite (as the original fprintf code).
void field(std::string& b, double v, std::chars_format fmt, int prec) {
  b.push_back(',');
  if (std::isfinite(v)) putNum(b, v, fmt, prec);
}

void putInt(std::string& b, long long v, int min_digits = 0) {
  char tmp[32];
  auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  for (int k = static_cast<int>(r.ptr - tmp); k < min_digits; ++k) b.push_back('0');
  b.append(tmp, static_cast<std::size_t>(r.ptr - tmp));
}

}  // namespace

CsvRowSink::~CsvRowSink() = default;  // an uncommitted temporary file is removed (io::AtomicFile)

bool CsvRowSink::begin(const core::PipelineConfig& cfg) {
  if (!file_.open(path_, &error_)) return false;
  f_ = file_.file();
  const auto& hs = cfg.heads;
  n_heads_ = hs.n_heads;
  buf_.reserve(kFlushBytes + 4096);
  buf_ = "time_s,q0,q1,q2,q3,w_x,w_y,w_z,a_sc_x,a_sc_y,a_sc_z,a_acc_x,a_acc_y,a_acc_z";
  for (int s1 = 0; s1 < hs.n_heads; ++s1)
    for (int s2 = s1 + 1; s2 < hs.n_heads; ++s2) {
      const std::string p = std::to_string(hs.head[std::size_t(s1)].id) + std::to_string(hs.head[std::size_t(s2)].id);
      buf_ += ",iba_" + p + "_deg,iba_" + p + "_dev_arcsec";
    }
  buf_ += ",heads_used,rate_bridged,w_sigma_x,w_sigma_y,w_sigma_z,a_sc_sigma_x,a_sc_sigma_y,a_sc_sigma_z,acc_bridged,"
          "a_acc_sigma_bridge,q_sigma_x_arcsec,q_sigma_y_arcsec,q_sigma_z_arcsec,q_corr_xy,q_corr_xz,q_corr_yz\n";
  return true;
}

bool CsvRowSink::write(const core::PipelineRow& r) {
  if (!f_) return false;
  std::int64_t sec = r.t / kUsPerSecond, us = r.t % kUsPerSecond;
  if (us < 0) us += kUsPerSecond, --sec;
  putInt(buf_, sec);
  buf_.push_back('.');
  putInt(buf_, us, 6);
  double q[4];
  quatToScalarFirst(r.q_I_B, q);
  for (double v : q) field(buf_, v, std::chars_format::general, 17);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < 3; ++k) field(buf_, r.has_rates ? r.w_B[k] : nan, std::chars_format::scientific, 9);
  for (int k = 0; k < 3; ++k) field(buf_, r.has_rates ? r.a_sc_B[k] : nan, std::chars_format::scientific, 9);
  for (int k = 0; k < 3; ++k) field(buf_, r.has_acc ? r.a_acc_B[k] : nan, std::chars_format::scientific, 9);
  for (int s1 = 0; s1 < n_heads_; ++s1)
    for (int s2 = s1 + 1; s2 < n_heads_; ++s2) {
      const auto p = static_cast<std::size_t>(core::pairIndex(s1, s2));
      field(buf_, r.iba_rad[p] / kRadPerDeg, std::chars_format::fixed, 9);
      field(buf_, r.iba_dev_rad[p] * kArcsecPerRad, std::chars_format::fixed, 3);
    }
  buf_.push_back(',');
  putInt(buf_, r.heads_used);
  buf_.push_back(',');
  putInt(buf_, r.rate_bridged);
  for (int k = 0; k < 3; ++k) field(buf_, r.has_rates ? r.w_sigma_B[k] : nan, std::chars_format::scientific, 3);
  for (int k = 0; k < 3; ++k) field(buf_, r.has_rates ? r.a_sc_sigma_B[k] : nan, std::chars_format::scientific, 3);
  buf_.push_back(',');
  putInt(buf_, r.acc_bridged);
  field(buf_, r.has_acc ? r.a_acc_sigma_bridge : nan, std::chars_format::scientific, 3);
  // the fused attitude's covariance P_B: 1-sigma about each body axis and the correlations
  const Vec3 sd = r.P_B.diagonal().cwiseMax(0.0).cwiseSqrt();
  for (int k = 0; k < 3; ++k) field(buf_, r.heads_used > 0 ? sd[k] * kArcsecPerRad : nan, std::chars_format::fixed, 4);
  for (const auto& [i, j] : {std::pair<int, int>{0, 1}, {0, 2}, {1, 2}}) {
    const double c = sd[i] > 0 && sd[j] > 0 ? r.P_B(i, j) / (sd[i] * sd[j]) : nan;
    field(buf_, r.heads_used > 0 ? c : nan, std::chars_format::fixed, 4);
  }
  buf_.push_back('\n');
  ++rows_;
  with_rates_ += r.has_rates;
  with_acc_ += r.has_acc;
  return buf_.size() < kFlushBytes || flushBuffer();
}

bool CsvRowSink::flushBuffer() {
  if (std::fwrite(buf_.data(), 1, buf_.size(), f_) != buf_.size()) {
    error_ = path_ + ": write failed: " + std::strerror(errno);
    return false;
  }
  buf_.clear();
  return true;
}

bool CsvRowSink::end() {
  if (!f_) return false;
  if (!flushBuffer()) return false;
  return defer_ || commit(&error_);
}

bool CsvRowSink::commit(std::string* error) {
  if (!f_) return true;
  f_ = nullptr;
  return file_.commit(error);
}

BatchBufferSink::BatchBufferSink(std::size_t capacity) : ring_(capacity) {}

bool BatchBufferSink::write(const core::PipelineRow& row) {
  ring_.pushOverwrite(row);
  ++written_;
  return true;
}

}  // namespace boresight::stream

namespace boresight::stream {

CsvStarSink::~CsvStarSink() = default;

bool CsvStarSink::begin(const core::PipelineConfig&) {
  if (!file_.open(path_, &error_)) return false;
  f_ = file_.file();
  std::fputs("time_s,q0,q1,q2,q3,sigma_x_arcsec,sigma_y_arcsec,sigma_z_arcsec,stars_in,stars_used,"
             "residual_rms_arcsec,d_fused_x_arcsec,d_fused_y_arcsec,d_fused_z_arcsec\n",
             f_);
  return true;
}

bool CsvStarSink::writeStars(const StarSolution& s) {
  if (!f_) return true;
  const core::WahbaSolution& w = s.wahba;
  std::int64_t sec = w.t / kUsPerSecond, us = w.t % kUsPerSecond;
  if (us < 0) us += kUsPerSecond, --sec;
  double q[4];
  quatToScalarFirst(w.q_I_B, q);
  // covariance about the body axes: C_B_SR P_SR C_SR_B, C_B_SR = C_B_I C_I_SR
  const Mat3 C_B_SR = w.q_I_B.toRotationMatrix().transpose() * w.q_I_SR.toRotationMatrix();
  const Mat3 P_B = C_B_SR * w.P_SR * C_B_SR.transpose();
  std::fprintf(f_, "%lld.%06lld,%.17g,%.17g,%.17g,%.17g,%.4f,%.4f,%.4f,%d,%d,%.4f", static_cast<long long>(sec),
               static_cast<long long>(us), q[0], q[1], q[2], q[3], std::sqrt(P_B(0, 0)) * kArcsecPerRad,
               std::sqrt(P_B(1, 1)) * kArcsecPerRad, std::sqrt(P_B(2, 2)) * kArcsecPerRad, w.stars_in, w.stars_used,
               w.residual_rms_rad * kArcsecPerRad);
  if (s.has_fused) {
    const Vec3 d = core::quatLog(s.q_I_B_fused.conjugate() * w.q_I_B) * kArcsecPerRad;
    std::fprintf(f_, ",%.4f,%.4f,%.4f\n", d.x(), d.y(), d.z());
  } else {
    std::fputs(",,,\n", f_);
  }
  ++rows_;
  return true;
}

bool CsvStarSink::end() {
  if (!f_) return true;
  return defer_ || commit(&error_);
}

bool CsvStarSink::commit(std::string* error) {
  if (!f_) return true;
  f_ = nullptr;
  return file_.commit(error);
}

}  // namespace boresight::stream

namespace boresight::stream {

Sca1bSink::Sca1bSink(std::string path, char satellite, double max_gap_s, std::function<double(TimeUs)> gps_minus_tag_s)
    : path_(std::move(path)), max_gap_s_(max_gap_s), eps_(std::move(gps_minus_tag_s)), satellite_(satellite) {}

bool Sca1bSink::begin(const core::PipelineConfig& cfg) {
  for (int s = 0; s < cfg.heads.n_heads; ++s) {
    const int id = cfg.heads.head[static_cast<std::size_t>(s)].id;
    if (id < 1 || id > 3) {
      error_ = path_ + ": head id " + std::to_string(id) +
               " has no bit in SCA1B's sca_id (GRACE-FO's cameras 1, 2 and 3): the platform's heads cannot be written as SCA1B";
      return false;
    }
    bit_[static_cast<std::size_t>(s)] = 1 << (id - 1);
  }
  return writer_.open(path_, io::makeProduct<io::Sca1bRecord>(io::Product::SCA1B, satellite_), &error_, 16384, true);
}

void Sca1bSink::emit(TimeUs t_gps, const Quat& q_in, std::uint32_t mask, double qual_rss, bool one_head) {
  Quat q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // quatangle = cos(theta/2), theta in [0, 180 deg], as the product has it
  io::Sca1bRecord r;
  r.t = t_gps;
  r.satellite = satellite_;
  r.sca_id = 0;
  for (std::size_t s = 0; s < bit_.size(); ++s)
    if ((mask >> s) & 1u) r.sca_id |= bit_[s];
  quatToScalarFirst(q, r.q);
  r.qual_rss = qual_rss;
  r.qualflg = io::Bits{one_head ? 8u : 0u, 8};
  writer_.add(r);
}

bool Sca1bSink::write(const core::PipelineRow& row) {
  if (row.heads_used <= 0 || !row.q_I_B.coeffs().allFinite()) return true;
  const TimeUs t = row.t + (eps_ ? static_cast<TimeUs>(std::llround(eps_(row.t) * 1e6)) : 0);
  const double rss = 0.5 * std::sqrt(std::max(0.0, row.P_B.trace()));
  const bool one = row.heads_used == 1;
  // the first whole second at or after t
  const auto ceilSecond = [](TimeUs x) {
    TimeUs s = x / kUsPerSecond * kUsPerSecond;
    if (s < x) s += kUsPerSecond;
    return s;
  };
  const bool first = !have_prev_;
  if (first) {
    have_prev_ = true;
    next_s_ = ceilSecond(t);
  } else if (t <= prev_t_) {
    ++out_of_order_;  // the rows are in time order; a GPS conversion that does not keep it is not followed
    return true;
  }
  // whole seconds strictly between the previous row and this one (next_s_ > prev_t_ always)
  const bool bridged = !first && toSeconds(t - prev_t_) <= max_gap_s_;
  for (; next_s_ <= t; next_s_ += kUsPerSecond) {
    if (next_s_ == t) {
      emit(t, row.q_I_B, row.heads_mask, rss, one);
    } else if (bridged) {
      const double f = static_cast<double>(next_s_ - prev_t_) / static_cast<double>(t - prev_t_);
      emit(next_s_, prev_q_.slerp(f, row.q_I_B), prev_mask_ | row.heads_mask, std::max(prev_rss_, rss), prev_one_ || one);
    } else {
      ++holes_;
    }
  }
  prev_t_ = t;
  prev_q_ = row.q_I_B;
  prev_mask_ = row.heads_mask;
  prev_rss_ = rss;
  prev_one_ = one;
  return true;
}

bool Sca1bSink::commit(std::string* error) {
  if (!error_.empty()) {
    if (error) *error = error_;
    return false;
  }
  return writer_.close(error);
}

}  // namespace boresight::stream

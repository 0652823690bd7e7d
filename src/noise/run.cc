// `boresight noise` over recorded telemetry: see include/boresight/noise/run.h.
#include <boresight/core/rotation.h>
#include <boresight/io/core_config.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/model/parallel.h>
#include <boresight/noise/joint_white.h>
#include <boresight/noise/run.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

namespace boresight::noise {
namespace {

constexpr double kArcsec = kArcsecPerRad;

/// A series that keeps at most `cap` samples: when full, every other sample is dropped and from then
/// on only every second (fourth, ...) input is kept. Decimation by whole factors keeps white noise
/// white and a Gauss-Markov term Gauss-Markov, so the kept series has the same noise model.
class CappedSeries {
 public:
  CappedSeries() = default;
  explicit CappedSeries(std::size_t cap) : cap_(std::max<std::size_t>(cap, 16)) {}
  void push(double t, double y) {
    if (count_++ % stride_ != 0) return;
    if (s_.size() >= cap_) {
      std::size_t k = 0;
      for (std::size_t i = 0; i < s_.size(); i += 2, ++k) {
        s_.t_s[k] = s_.t_s[i];
        s_.y[k] = s_.y[i];
      }
      s_.t_s.resize(k);
      s_.y.resize(k);
      stride_ *= 2;
      if ((count_ - 1) % stride_ != 0) return;
    }
    s_.t_s.push_back(t);
    s_.y.push_back(y);
  }
  /// A gap in the input (a missing sample): the decimation counts input slots, so the kept samples
  /// stay on a regular grid of the input's.
  void skip() { ++count_; }
  const model::NoiseSeries& series() const { return s_; }
  int stride() const { return static_cast<int>(stride_); }

 private:
  std::size_t cap_ = std::size_t{1} << 16;
  std::uint64_t count_ = 0, stride_ = 1;
  model::NoiseSeries s_;
};

const char* const kHeadAxis[3] = {"cross_x", "cross_y", "about_boresight"};

/// Per head axis: the head against the information-weighted fused attitude of the other heads, in the
/// head's axes, at epochs where every configured head is present (the contamination is then fixed).
class HeadResiduals final : public stream::InputObserver {
 public:
  HeadResiduals(const core::HeadSetConfig& hs, std::size_t cap) : n_(hs.n_heads), geo_(headSeriesGeometry(hs)) {
    for (int i = 0; i < n_; ++i) {
      ids_[static_cast<std::size_t>(i)] = hs.head[static_cast<std::size_t>(i)].id;
      q_Si_B_[static_cast<std::size_t>(i)] = hs.head[static_cast<std::size_t>(i)].q_Si_B;
      for (int k = 0; k < 3; ++k) series_[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = CappedSeries(cap);
    }
    diff_sum_.setZero();
  }

  void onHeads(const core::HeadEpoch& e, core::Status) override {
    ++epochs_;
    if (n_ < 2) return;
    std::array<Quat, core::kMaxHeads> q_B{};
    std::uint32_t mask = 0;
    for (int s = 0; s < e.n; ++s) {
      const auto& hs = e.sample[static_cast<std::size_t>(s)];
      for (int k = 0; k < n_; ++k)
        if (ids_[static_cast<std::size_t>(k)] == hs.head_id) {
          q_B[static_cast<std::size_t>(k)] = hs.q_I_Si.normalized() * q_Si_B_[static_cast<std::size_t>(k)];
          mask |= 1u << k;
        }
    }
    const std::uint32_t full = (1u << n_) - 1;
    if (t0_ < 0) t0_ = e.t;
    const double t = toSeconds(e.t - t0_);
    if (mask != full) {
      for (auto& h : series_)
        for (auto& a : h) a.skip();
      have_prev_ = false;
      return;
    }
    ++full_;
    Eigen::Matrix<double, 3 * core::kMaxHeads, 1> cur = Eigen::Matrix<double, 3 * core::kMaxHeads, 1>::Zero();
    for (int i = 0; i < n_; ++i) {
      // the other heads' body attitudes as rotation vectors about a reference (one of them)
      const int ref = i == 0 ? 1 : 0;
      const Quat q_ref = q_B[static_cast<std::size_t>(ref)];
      Vec3 acc = Vec3::Zero();
      Mat3 Wsum = Mat3::Zero();
      for (int j = 0; j < n_; ++j) {
        if (j == i) continue;
        const Vec3 nu = core::quatLog(q_ref.conjugate() * q_B[static_cast<std::size_t>(j)]);
        acc += geo_.W[static_cast<std::size_t>(j)] * nu;
        Wsum += geo_.W[static_cast<std::size_t>(j)];
      }
      const Quat q_o = q_ref * core::quatExp(Wsum.inverse() * acc);
      // head i against what the others predict for it, in head i's frame, along its axes
      const Vec3 r = core::quatLog((q_o * q_Si_B_[static_cast<std::size_t>(i)].conjugate()).conjugate() *
                                   (q_B[static_cast<std::size_t>(i)] * q_Si_B_[static_cast<std::size_t>(i)].conjugate()));
      const Vec3 ra = geo_.E[static_cast<std::size_t>(i)].transpose() * r * kArcsec;
      cur.segment<3>(3 * i) = ra;
      for (int k = 0; k < 3; ++k) series_[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)].push(t, ra[k]);
    }
    // consecutive full epochs (no epoch missing between them, the shortest interval seen): their
    // differences hold the white parts of every series (joint_white.h)
    if (have_prev_) {
      const TimeUs dt = e.t - prev_t_;
      if (dt > 0 && (min_dt_ < 0 || dt < min_dt_)) min_dt_ = dt;
      if (dt > 0 && 2 * dt <= 3 * min_dt_) {
        const auto d = (cur - prev_).eval();
        diff_sum_.noalias() += d * d.transpose();
        ++diffs_;
      }
    }
    prev_ = cur;
    prev_t_ = e.t;
    have_prev_ = true;
  }

  int heads() const { return n_; }
  int id(int i) const { return ids_[static_cast<std::size_t>(i)]; }
  const CappedSeries& series(int i, int k) const { return series_[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)]; }
  /// d residual_i[k] / d n_j[l]
  double weight(int i, int k, int j, int l) const { return geo_.G(3 * i + k, 3 * j + l); }
  const HeadSeriesGeometry& geometry() const { return geo_; }
  /// The sum of d d^T over the differences of consecutive full epochs (3 H x 3 H, arcsec^2), and their count.
  Eigen::MatrixXd diffSum() const { return diff_sum_.topLeftCorner(3 * n_, 3 * n_); }
  std::uint64_t diffs() const { return diffs_; }
  std::uint64_t epochs() const { return epochs_; }
  std::uint64_t fullEpochs() const { return full_; }

 private:
  int n_;
  std::array<int, core::kMaxHeads> ids_{};
  std::array<Quat, core::kMaxHeads> q_Si_B_{};
  HeadSeriesGeometry geo_;
  std::array<std::array<CappedSeries, 3>, core::kMaxHeads> series_{};
  std::uint64_t epochs_ = 0, full_ = 0, diffs_ = 0;
  TimeUs t0_ = -1, prev_t_ = 0, min_dt_ = -1;
  bool have_prev_ = false;
  Eigen::Matrix<double, 3 * core::kMaxHeads, 1> prev_ = Eigen::Matrix<double, 3 * core::kMaxHeads, 1>::Zero();
  Eigen::Matrix<double, 3 * core::kMaxHeads, 3 * core::kMaxHeads> diff_sum_;
};

/// The accelerometer: raw first differences (white level) and block means of star minus accelerometer
/// angular acceleration in the accelerometer frame (low-frequency part).
class AccSeries final : public stream::InputObserver, public stream::RowSink {
 public:
  AccSeries(const core::PipelineConfig& cfg, std::size_t cap, double block_s)
      : C_A_B_(cfg.C_B_A.transpose()), block_us_(static_cast<TimeUs>(std::llround(block_s * 1e6))) {
    for (auto& d : diffs_) d = CappedSeries(cap);
    for (auto& b : blocks_) b = CappedSeries(cap);
    row_period_us_ = cfg.crn_attitude.output_period_us > 0 ? cfg.crn_attitude.output_period_us : kUsPerSecond;
  }
  void onAcc(TimeUs t, const Vec3& a_A, core::Status) override {
    ++samples_;
    if (t0_ < 0) t0_ = t;
    // non-overlapping pairs (a_{2m+1} - a_{2m}): independent differences of the white part
    if (have_prev_ && !odd_) {
      const Vec3 d = a_A - prev_;
      for (int k = 0; k < 3; ++k) diffs_[static_cast<std::size_t>(k)].push(toSeconds(t - t0_), d[k]);
    }
    odd_ = !odd_;
    prev_ = a_A;
    have_prev_ = true;
  }
  bool begin(const core::PipelineConfig&) override { return true; }
  bool write(const core::PipelineRow& row) override {
    if (!row.has_rates || !row.has_acc) return true;
    const Vec3 d = C_A_B_ * (row.a_acc_B - row.a_sc_B);
    if (!d.allFinite()) return true;
    if (t0_rows_ < 0) t0_rows_ = row.t;
    const TimeUs b = (row.t - t0_rows_) / block_us_;
    if (b != block_) {
      closeBlock();
      block_ = b;
    }
    sum_ += d;
    ++count_;
    return true;
  }
  bool end() override {
    closeBlock();
    return true;
  }
  std::string error() const override { return {}; }
  const CappedSeries& diffs(int k) const { return diffs_[static_cast<std::size_t>(k)]; }
  const CappedSeries& blocks(int k) const { return blocks_[static_cast<std::size_t>(k)]; }
  std::uint64_t samples() const { return samples_; }
  std::uint64_t completeBlocks() const { return complete_; }
  double blockSeconds() const { return static_cast<double>(block_us_) * 1e-6; }

 private:
  void closeBlock() {
    // only complete blocks (every row present): their means share one noise model
    const auto expected = static_cast<std::uint64_t>(block_us_ / row_period_us_);
    if (block_ >= 0 && count_ >= expected && count_ > 0) {
      const Vec3 m = sum_ / static_cast<double>(count_);
      const double t = (static_cast<double>(block_) + 0.5) * blockSeconds();
      for (int k = 0; k < 3; ++k) blocks_[static_cast<std::size_t>(k)].push(t, m[k]);
      ++complete_;
    }
    sum_.setZero();
    count_ = 0;
  }
  Mat3 C_A_B_;
  TimeUs block_us_, row_period_us_ = kUsPerSecond;
  std::array<CappedSeries, 3> diffs_, blocks_;
  Vec3 prev_ = Vec3::Zero(), sum_ = Vec3::Zero();
  bool have_prev_ = false, odd_ = false;
  std::uint64_t samples_ = 0, count_ = 0, complete_ = 0;
  TimeUs t0_ = -1, t0_rows_ = -1, block_ = -1;
};

/// The band in which a fit of this series can determine correlation times and corners.
void band(AxisResult& a, const model::NoiseFitOptions& o) {
  a.f_det_lo = a.span_s > 0 ? o.band_lo / a.span_s : 0;
  a.f_det_hi = a.interval_s > 0 ? 1.0 / (a.interval_s * o.band_hi) : 0;
}

/// A head axis's white level from the joint fit of every head axis (joint_white.h).
struct JointAxis {
  double level = 0, sigma = 0;
  bool determined = false, converged = false;
  /// standard error of the white variance the other heads add to this axis's series (from the joint
  /// covariance): the fitted level's own standard error takes it in (the fit holds that part fixed)
  double contamination_var_se = 0;
};

/// `joint`: when the series cannot show a coloured part, its white level is the joint fit's (from the
/// differences of consecutive samples: content slower than one interval, which a whole-variance fit
/// would put into the white level, cancels), with the whole-variance fit kept as the second candidate.
void fitAxis(AxisResult& a, const model::NoiseSeries& s, const NoiseOptions& opt, const model::NoiseModel& fixed,
             const JointAxis* joint = nullptr) {
  a.samples = s.size();
  a.span_s = s.span();
  a.interval_s = s.medianInterval();
  model::NoiseFitOptions fo;
  fo.fixed = fixed;
  fo.likelihood = opt.likelihood;
  fo.skip_when_no_colour = !opt.every_structure;
  band(a, fo);
  a.contamination = fixed;
  if (s.size() < 16) {
    a.selection = model::NoiseSelection{};
    a.notes.push_back("too few samples (" + std::to_string(s.size()) + ") to fit a noise model");
    return;
  }
  // Structures with a coloured part only where the series is long enough to show one.
  std::vector<model::NoiseStructure> st;
  for (auto x : opt.structures) {
    const bool coloured = x != model::NoiseStructure::White;
    if (coloured && (s.size() < 200 || !(a.f_det_hi > a.f_det_lo))) continue;
    st.push_back(x);
  }
  const bool white_only = st.size() < opt.structures.size();
  if (white_only)
    a.notes.push_back("the span (" + std::to_string(static_cast<long long>(std::llround(a.span_s))) +
                      " s) cannot determine a coloured part: only the white level is fitted");
  const Eigen::MatrixXd X = Eigen::MatrixXd::Ones(static_cast<Eigen::Index>(s.size()), 1);  // the mean (a misalignment, a bias)
  a.selection = model::selectNoise(s, st, X, fo);
  if (a.fitted() && a.selection.chosen().f_det_hi > 0) {  // the band of the likelihood used (Whittle: the longest run)
    a.f_det_lo = a.selection.chosen().f_det_lo;
    a.f_det_hi = a.selection.chosen().f_det_hi;
  }
  if (white_only && joint != nullptr) {
    // The differences see the white parts only (the slow content cancels); the levels of all head
    // axes come from them at once (joint_white.h), so what the other heads add is not subtracted
    // axis by axis.
    const model::NoiseFit d = model::fitWhiteFromDifferences(s);
    if (d.converged && a.fitted()) {
      model::NoiseFit f = d;
      model::NoiseParam& p = f.params.front();
      p.value = joint->level;
      p.sigma = joint->sigma;
      p.log_sigma = p.value > 0 ? p.sigma / p.value : std::numeric_limits<double>::infinity();
      p.determined = joint->determined;
      if (!joint->determined) p.note = "the heads' geometry cannot separate this axis's white level from another head's";
      f.model = model::NoiseModel::white(p.value);
      f.cov = Eigen::MatrixXd::Constant(1, 1, p.log_sigma * p.log_sigma);
      const double whole = a.selection.chosen().model.terms.front().sigma;
      char b[360];
      std::snprintf(b, sizeof b,
                    "white level from the differences of consecutive samples of every head axis at once %.3g +- %.2g (a "
                    "fit of this series' whole variance gives %.3g with the other heads' part: the rest is content slower "
                    "than one interval that a %.0f s span cannot resolve)",
                    p.value, p.sigma, whole, a.span_s);
      a.notes.push_back(b);
      a.selection.fits.insert(a.selection.fits.begin(), f);
      a.selection.best = 0;
    }
  } else if (joint != nullptr && joint->converged) {
    // own variance = series white variance - the other heads' (fixed in the fit, but estimated): its
    // uncertainty adds to the level's by the delta method
    if (a.fitted() && std::isfinite(joint->contamination_var_se) && joint->contamination_var_se > 0) {
      for (auto& f : a.selection.fits)
        for (std::size_t i = 0; i < f.params.size(); ++i) {
          auto& p = f.params[i];
          if (p.name != "white.sigma" || !(p.value > 0) || !std::isfinite(p.sigma)) continue;
          p.sigma = std::hypot(p.sigma, joint->contamination_var_se / (2 * p.value));
          p.log_sigma = p.sigma / p.value;
          // the fit's covariance (log scale) says the same as the parameter
          const auto k = static_cast<Eigen::Index>(i);
          if (k < f.cov.rows() && k < f.cov.cols()) f.cov(k, k) = p.log_sigma * p.log_sigma;
          if (k < f.cov_fit.rows() && k < f.cov_fit.cols()) f.cov_fit(k, k) = p.log_sigma * p.log_sigma;  // logPsd's
        }
    }
    char b[200];
    std::snprintf(b, sizeof b, "white level from the differences of every head axis at once: %.3g +- %.2g%s", joint->level,
                  joint->sigma, joint->determined ? "" : " (not determined by the heads' geometry)");
    a.notes.push_back(b);
  }
  const std::string choice = uncertainChoiceNote(bandSpectrum(a));
  if (!choice.empty()) a.notes.push_back(choice);
  if (s.size() >= 64) {
    std::size_t seg = 32;
    std::size_t longest = 0, run = 1;
    for (std::size_t i = 1; i < s.size(); ++i) {
      run = std::abs(s.t_s[i] - s.t_s[i - 1] - a.interval_s) <= 0.1 * a.interval_s ? run + 1 : 1;
      longest = std::max(longest, run);
    }
    while (seg * 2 <= std::min(longest, s.size() / 4)) seg *= 2;
    a.spectrum = model::welchPsdGapped(s, a.interval_s, seg);
  }
}

/// A model with every term's level scaled by |w| (the noise of w n).
model::NoiseModel scaled(const model::NoiseModel& m, double w) {
  model::NoiseModel o = m;
  for (auto& t : o.terms) t.sigma *= std::abs(w);
  return o;
}

}  // namespace

std::vector<BandPoint> bandSpectrum(const AxisResult& a) {
  std::vector<BandPoint> out;
  if (!a.fitted() || !(a.f_det_lo > 0 && a.f_det_hi > a.f_det_lo) || !(a.interval_s > 0)) return out;
  constexpr int kPoints = 12;
  for (int q = 0; q < kPoints; ++q) {
    BandPoint p;
    p.f_hz = a.f_det_lo * std::pow(a.f_det_hi / a.f_det_lo, q / double(kPoints - 1));
    std::tie(p.chosen_log_psd, p.chosen_se) = a.selection.chosen().logPsd(p.f_hz, a.interval_s);
    std::tie(p.averaged_log_psd, p.averaged_se) = a.selection.averagedLogPsd(p.f_hz, a.interval_s);
    out.push_back(p);
  }
  return out;
}

std::string uncertainChoiceNote(const std::vector<BandPoint>& band) {
  // Where the candidates disagree, the chosen model's own standard errors understate what the data say
  // of the spectrum (a simpler model is stiffer): say where and by how much.
  double worst = 0, at = 0;
  for (const BandPoint& q : band)
    if (std::isfinite(q.averaged_se) && q.chosen_se > 0 && q.averaged_se / q.chosen_se > worst) {
      worst = q.averaged_se / q.chosen_se;
      at = q.f_hz;
    }
  if (!(worst > 2)) return {};
  char b[400];
  std::snprintf(b, sizeof b,
                "the choice between the candidates is uncertain: at %.2g Hz the spectrum's standard error with it (the "
                "fitted candidates averaged with Akaike weights) is %.1f times the chosen model's own (noise.json "
                "band_spectrum)",
                at, worst);
  return b;
}

bool runNoise(const NoiseRequest& req, NoiseOutput& out, std::string* error) {
  out = NoiseOutput{};
  stream::ReplayRequest rq;
  rq.program = "boresight noise";
  rq.config = req.config;
  rq.overlay = req.overlay;
  rq.uses = io::OverlayUses{};  // noise and mountings
  rq.inputs = req.inputs;
  rq.strict = req.strict;
  rq.lookahead_s = req.lookahead_s;
  rq.star_vectors = false;
  stream::Replay rp;
  if (!stream::openReplay(rq, rp, error)) return false;
  io::PlatformConfig& pc = rp.pc;
  const io::OverlayUse& ovu = rp.overlay;
  const stream::ReplayInputs& in = rp.in;
  stream::Engine& engine = *rp.engine;
  out.platform = pc.platform;
  for (const auto& [f, product] : in.ignored)
    out.notes.push_back(f + ": " + product + " is not an input of noise (SCA1A, ACC1A, QSA1B, LCM log): ignored");
  for (const auto& f : in.sca) out.inputs.push_back(f + ": SCA1A heads");
  for (const auto& f : in.acc) out.inputs.push_back(f + ": accelerometer");
  for (const auto& f : in.qsa) out.inputs.push_back(f + ": QSA1B nominal mountings");
  for (const auto& f : in.lcm) out.inputs.push_back(f + ": LCM log");

  if (!stream::startReplay(rp, error)) return false;
  HeadResiduals heads(pc.pipeline.heads, req.options.max_samples);
  AccSeries acc(pc.pipeline, req.options.max_samples, req.options.acc_block_s);
  engine.addObserver(&heads);
  engine.addObserver(&acc);
  engine.addSink(&acc);
  const auto w0 = std::chrono::steady_clock::now();
  if (engine.run() != stream::Engine::Result::kDone) {
    if (error) *error = engine.error();
    return false;
  }
  out.counters = engine.counters();
  // Every record is used or rejected with a reason: per source "NAME: N read, M used, K REASON" and
  // the first rejected lines (as process, calibrate and audit say it).
  for (std::size_t i = 0; i < engine.sourceCount(); ++i) {
    const auto& c = engine.counters(i);
    std::string s = engine.source(i).name() + ": " + std::to_string(c.read) + " read, " + std::to_string(c.used()) + " used";
    for (int r = 0; r < stream::kRejectCount; ++r)
      if (c.rejected[static_cast<std::size_t>(r)])
        s += ", " + std::to_string(c.rejected[static_cast<std::size_t>(r)]) + " " + io::rejectText(stream::Reject(r));
    out.sources.push_back(s);
    const auto issues = engine.source(i).issues();
    for (std::size_t k = 0; k < issues.size() && k < 5; ++k) out.sources.push_back("    rejected " + issues[k]);
  }
  out.health = engine.health();
  out.epochs = engine.epochs();
  out.full_epochs = heads.fullEpochs();
  out.acc_samples = acc.samples();
  out.span_s = toSeconds(engine.lastEpoch() - engine.firstEpoch());
  out.t0 = engine.firstEpoch();
  out.t1 = engine.lastEpoch();
  out.model_in_use = io::modelInUseLines(pc, ovu);
  for (const auto& w : io::validityWarnings(ovu, out.t0, out.t1)) out.notes.push_back(w);
  if (out.counters.used_heads == 0) {
    if (error) *error = "no star sensor samples in the inputs";
    return false;
  }
  if (req.progress) {
    char b[160];
    std::snprintf(b, sizeof b, "noise: %.1f h replayed in %.1f s; fitting", out.span_s / 3600.0,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
    req.progress(b);
  }

  // Heads: every axis, then again with the other heads' fitted models as their contamination.
  const int n = heads.heads();
  const auto& hs = pc.pipeline.heads;
  std::vector<AxisResult> head_axes(static_cast<std::size_t>(3 * n));
  // The configured model of an axis (the platform file's noise section, or the overlay's), in arcsec.
  auto configuredOf = [&](int i, int k) {
    const auto& ax = pc.noise_in_use.head[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)];
    if (!ax.set) {
      const auto& h = hs.head[static_cast<std::size_t>(i)];
      return model::NoiseModel::white((k == 2 ? h.sigma_roll_rad : h.sigma_cross_rad) * kArcsec);
    }
    return scaled(ax.noise.model, kArcsec);
  };
  // The model of head j's axis l used for the contamination: the configured one at first.
  std::vector<model::NoiseModel> current(static_cast<std::size_t>(3 * n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) current[static_cast<std::size_t>(3 * i + k)] = configuredOf(i, k);
  if (n < 2)
    out.notes.push_back("one head: its noise cannot be told from the attitude (a second head is needed)");
  if (n >= 2 && heads.fullEpochs() == 0)
    out.notes.push_back("no epoch with every configured head present: no head noise series");
  // The white levels of every head axis at once, from the differences of consecutive epochs: they set
  // the white part of what the other heads add to each series (joint_white.h).
  // W(a, b): the squared weight of the other heads' axis b in series a (0 within a head): what their
  // variances (white or coloured, per frequency) add to series a.
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int a = 0; a < 3 * n; ++a)
    for (int b = 0; b < 3 * n; ++b)
      if (b / 3 != a / 3) W(a, b) = heads.geometry().G(a, b) * heads.geometry().G(a, b);
  std::vector<JointAxis> joint(static_cast<std::size_t>(3 * n));
  bool have_joint = false;
  if (n >= 2 && heads.diffs() >= 2) {
    Eigen::VectorXd start(3 * n);
    for (int a = 0; a < 3 * n; ++a) {
      const double w = current[static_cast<std::size_t>(a)].whiteVariance();
      start[a] = w > 0 ? w : current[static_cast<std::size_t>(a)].variance();
    }
    const JointWhite jw = fitJointWhite(heads.diffSum(), static_cast<double>(heads.diffs()), heads.geometry().G, start);
    have_joint = jw.converged;
    for (int a = 0; a < 3 * n; ++a) {
      auto& j = joint[static_cast<std::size_t>(a)];
      j.level = jw.level(a);
      j.sigma = jw.levelSigma(a);
      j.determined = jw.determined[static_cast<std::size_t>(a)];
      j.converged = jw.converged;
      // the other heads' white variance in series a: sum_b G(a, b)^2 s_b over the other heads' axes
      const Eigen::VectorXd g = W.row(a).transpose();
      double v = 0;
      for (int b = 0; b < 3 * n; ++b)
        for (int c = 0; c < 3 * n; ++c)
          if (g[b] != 0 && g[c] != 0) v += g[b] * jw.cov(b, c) * g[c];
      j.contamination_var_se = v > 0 ? std::sqrt(v) : (std::isfinite(v) ? 0.0 : v);
    }
    char b[240];
    std::snprintf(b, sizeof b,
                  "head white levels: one fit of all %d axes from %llu differences of consecutive epochs (%s after %d "
                  "iterations%s%s)",
                  3 * n, static_cast<unsigned long long>(heads.diffs()), jw.converged ? "converged" : "not converged",
                  jw.iterations, jw.message.empty() ? "" : ": ", jw.message.c_str());
    out.notes.push_back(b);
  }
  // The other heads' coloured parts in each series, relaxed between passes. A series' coloured PSD is
  // its own axis's plus sum_b G(a, b)^2 times the other heads' axes' (W: that matrix over other heads),
  // so fitting each axis with the others' last models is the iteration own' = P - W own, whose error
  // is multiplied by -W every pass: with W's spectral radius near 1 (three heads: 1.0-1.1) it does not
  // settle but swings - all colour in the own model in one pass, none in the next (found by
  // ACatalogueGaussMarkovHeadErrorIsRecoveredAxisByAxis: cross-boresight levels 1.3-1.5" for a true
  // 1", contamination 0.03-0.05"). Relaxed: the input of the next pass is (1 - w) times the last
  // input plus w times the pass's own fits (terms with their variances scaled: the PSDs mix
  // linearly), w = 1 / (1 + spectral radius of W), which puts the first relaxed input on the fixed
  // point of the mode that swings and damps the others.
  std::vector<std::vector<model::MarkovTerm>> coloured(static_cast<std::size_t>(3 * n));
  for (std::size_t a = 0; a < coloured.size(); ++a) coloured[a] = current[a].markovTerms();
  double relax = 1.0;
  if (n >= 2) {
    const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(W, false).eigenvalues();
    const double rho = ev.size() > 0 ? ev.cwiseAbs().maxCoeff() : 0.0;
    if (std::isfinite(rho)) relax = 1.0 / (1.0 + rho);
  }
  // What the other heads add to series (i, k): their coloured terms as relaxed over the passes, and
  // one white term from the joint levels (when the joint fit converged). The coloured terms (power laws
  // expanded) are merged into one Gauss-Markov term per half decade of correlation time (variances
  // summed, the time their variance-weighted geometric mean): the fit's state then holds a few terms for
  // the other heads instead of every term of six axes' models (up to 60; the exact likelihood costs the
  // square of the state per sample). The merge changes the spectrum of a part that is already small
  // (the other heads' coloured noise through the fusion weights) by less than the spread of the merged
  // times, within a factor of 1.8 of the mean.
  auto contaminationOf = [&](int i, int k) {
    model::NoiseModel fixed;
    if (!req.options.model_other_heads) return fixed;
    double white = 0;
    std::map<int, std::pair<double, double>> bins;  // half decade -> (variance, variance * log tau)
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      for (int l = 0; l < 3; ++l) {
        const double w = heads.weight(i, k, j, l);
        model::NoiseModel m = current[static_cast<std::size_t>(3 * j + l)];
        if (have_joint) {
          const double lv = joint[static_cast<std::size_t>(3 * j + l)].level;
          white += w * w * lv * lv;
        } else {
          white += w * w * m.whiteVariance();
        }
        for (const auto& t : coloured[static_cast<std::size_t>(3 * j + l)]) {
          const double v = w * w * t.var;
          if (!(v > 0) || !(t.tau_s > 0)) continue;
          auto& b = bins[static_cast<int>(std::floor(2 * std::log10(t.tau_s)))];
          b.first += v;
          b.second += v * std::log(t.tau_s);
        }
      }
    }
    if (white > 0) fixed.terms.push_back(model::NoiseTerm::white(std::sqrt(white)));
    for (const auto& [bin, b] : bins) fixed.terms.push_back(model::NoiseTerm::gaussMarkov(std::sqrt(b.first), std::exp(b.second / b.first)));
    return fixed;
  };
  const int passes = n >= 2 ? 1 + std::max(0, req.options.contamination_passes) : 0;
  for (int pass = 0; pass < passes && heads.fullEpochs() > 0; ++pass) {
    // The passes before the last only supply the other heads' models for the next one: they use the
    // Whittle likelihood (milliseconds per fit; the gap-free runs taken as independent); the last one
    // uses the likelihood asked for.
    NoiseOptions pass_opt = req.options;
    if (pass + 1 < passes) pass_opt.likelihood = model::NoiseLikelihood::Whittle;
    model::parallelFor(static_cast<std::size_t>(3 * n), model::defaultThreads(), [&](std::size_t idx) {
      const int i = static_cast<int>(idx) / 3, k = static_cast<int>(idx) % 3;
      const model::NoiseModel fixed = contaminationOf(i, k);
      AxisResult a;
      a.sensor = "head " + std::to_string(heads.id(i));
      a.axis = kHeadAxis[k];
      a.unit = "arcsec";
      a.series = "the head against the fused attitude of the other heads, head axes";
      a.decimation = heads.series(i, k).stride();
      a.configured = configuredOf(i, k);
      fitAxis(a, heads.series(i, k).series(), pass_opt, fixed, have_joint ? &joint[idx] : nullptr);
      head_axes[idx] = std::move(a);
    });
    for (std::size_t idx = 0; idx < head_axes.size(); ++idx) {
      if (!head_axes[idx].fitted()) continue;
      current[idx] = head_axes[idx].selection.chosen().model;
      auto& c = coloured[idx];
      for (auto& t : c) t.var *= 1.0 - relax;
      for (auto t : current[idx].markovTerms()) {
        t.var *= relax;
        c.push_back(t);
      }
    }
    if (req.progress) {
      char b[160];
      std::snprintf(b, sizeof b, "noise: heads, pass %d of %d (%s likelihood) done at %.1f s", pass + 1, passes,
                    model::noiseLikelihoodName(pass_opt.likelihood),
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count());
      req.progress(b);
    }
  }
  for (auto& a : head_axes)
    if (!a.sensor.empty()) out.axes.push_back(std::move(a));

  // Accelerometer: the white level per A axis from the raw differences; the slow part from blocks.
  if (acc.samples() > 0) {
    std::vector<AxisResult> acc_axes(6);
    model::parallelFor(6, model::defaultThreads(), [&](std::size_t idx) {
      const int k = static_cast<int>(idx % 3);
      AxisResult a;
      a.sensor = "accelerometer";
      a.axis = std::string(1, "xyz"[k]);
      a.unit = "rad/s^2";
      if (pc.noise_in_use.acc[static_cast<std::size_t>(k)].set) a.configured = pc.noise_in_use.acc[static_cast<std::size_t>(k)].noise.model;
      if (idx < 3) {
        // a_{2m+1} - a_{2m} = w_{2m+1} - w_{2m} + (signal and slow noise change over one sample):
        // white with twice the per-sample variance; thruster pulses are outliers, so the level is a
        // robust one (median absolute deviation) before the likelihood fit of the clipped series.
        const model::NoiseSeries& d = acc.diffs(k).series();
        model::NoiseSeries c;
        std::vector<double> v(d.y.begin(), d.y.end());
        double mad = 0;
        if (!v.empty()) {
          std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
          const double med = v[v.size() / 2];
          for (auto& x : v) x = std::abs(x - med);
          std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
          mad = 1.4826 * v[v.size() / 2];
        }
        std::size_t clipped = 0;
        for (std::size_t i = 0; i < d.size(); ++i) {
          if (std::abs(d.y[i]) > 5 * mad) {
            ++clipped;
            continue;
          }
          c.t_s.push_back(d.t_s[i]);
          c.y.push_back(d.y[i] / std::sqrt(2.0));  // per-sample scale
        }
        a.series = "independent first differences of the raw samples / sqrt(2) (white level)";
        a.decimation = acc.diffs(k).stride();
        NoiseOptions o = req.options;
        o.structures.assign(1, model::NoiseStructure::White);
        fitAxis(a, c, o, model::NoiseModel());
        a.notes.push_back(std::to_string(clipped) + " differences beyond 5 robust sigmas left out (thruster pulses)");
        a.notes.push_back("clipping at 5 sigma lowers a Gaussian level by 1e-5 relative: negligible");
      } else {
        a.series = "block means (" + std::to_string(static_cast<int>(acc.blockSeconds())) +
                   " s) of accelerometer minus star-sensor angular acceleration, A frame (slow part)";
        a.decimation = acc.blocks(k).stride();
        fitAxis(a, acc.blocks(k).series(), req.options, model::NoiseModel());
        a.notes.push_back("the white part of this series is the star sensors' (differentiated attitude noise at the block "
                          "scale), not the accelerometer's; its coloured part is the accelerometer's slow noise");
      }
      acc_axes[idx] = std::move(a);
    });
    if (acc.completeBlocks() < 50)
      out.notes.push_back("accelerometer: " + std::to_string(acc.completeBlocks()) + " complete blocks of " +
                          std::to_string(static_cast<int>(acc.blockSeconds())) +
                          " s star-minus-accelerometer: too short a span for its slow noise");
    for (auto& a : acc_axes) out.axes.push_back(std::move(a));
  } else {
    out.notes.push_back("no accelerometer samples: no accelerometer noise");
  }
  return true;
}

}  // namespace boresight::noise

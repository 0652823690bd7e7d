#include "boresight/core/pipeline.h"
#include "boresight/core/plausibility.h"

#include "boresight/core/clones.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace boresight::core {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

Status Pipeline::configure(const PipelineConfig& cfg) {
  configured_ = false;
  thermal_ = ThermalPredictor{};  // a thermal model belongs to the head set it was set for
  Status s = validator_.configure(cfg.heads);
  if (s == Status::kOk) s = fusion_.configure(cfg.heads);
  if (s == Status::kOk) s = means_.configure(cfg.heads);
  if (s == Status::kOk && cfg.heads.n_heads >= 2) s = monitor_.configure(cfg.heads, cfg.deformation);
  if (s == Status::kOk) s = rates_.configure(cfg.crn_attitude);
  if (s == Status::kOk && cfg.use_accelerometer) {
    CrnConfig c = cfg.crn_acc;
    c.output_period_us = 0;  // evaluated on the rows' tags only
    s = acc_.configure(c, cfg.C_B_A);
  }
  if (s == Status::kOk) {
    WahbaConfig w;
    w.heads = cfg.heads;
    w.reference_slot = cfg.wahba_reference_slot;
    s = wahba_.configure(w);
  }
  if (s != Status::kOk) return s;
  if (cfg.crn_attitude.output_period_us <= 0 || cfg.alignment_update_epochs < 1) return Status::kInvalidConfig;
  if (cfg.acc_correction.on && !(cfg.acc_correction.M.allFinite() && cfg.acc_correction.bias_A.allFinite()))
    return Status::kInvalidConfig;
  cfg_ = cfg;
  head_dt_us_ = rates_.stream().samplingIntervalUs();
  gain_w_ = rates_.noiseGain(1);
  gain_a_ = rates_.noiseGain(2);
  configured_ = true;
  reset();
  return Status::kOk;
}

void Pipeline::reset() {
  validator_.reset();
  last_valid_ = false;
  fusion_.reset();
  means_.reset();
  monitor_.reset();
  rates_.reset();
  acc_.reset();
  wahba_.reset();
  thermal_.reset();
  resetThermalAnchors();
  handed_ = false;
  align_countdown_ = 0;
  have_grid_ = false;
  last_grid_ = 0;
  pending_.clear();
  rate_cursor_ = acc_cursor_ = 0;
  acc_next_check_ = std::numeric_limits<TimeUs>::min();
  ready_.clear();
  health_.clear();
}

Health Pipeline::health() const {
  Health h = health_;
  h.add(validator_.health());
  h.add(fusion_.health());
  h.add(means_.health());
  h.add(monitor_.health());
  h.add(rates_.health());
  h.add(acc_.health());
  h.add(wahba_.health());
  h.add(thermal_.health());
  return h;
}

void Pipeline::emitOldest() {
  if (pending_.empty()) return;
  if (ready_.pushOverwrite(pending_.front().row))  // nobody pops: the oldest ready row went
    health_.record(Status::kCapacityExceeded);
  pending_.popFront();
  if (rate_cursor_ > 0) --rate_cursor_;
  if (acc_cursor_ > 0) --acc_cursor_;
}

void Pipeline::resolve() {
  const bool have_att = rates_.stream().hasSamples();
  const TimeUs att_newest = rates_.stream().newestTime();
  const TimeUs rate_deadline = rates_.stream().delayUs() + 2 * head_dt_us_;
  // rows are in time order: the rate deadline and the accelerometer's readiness both move forward,
  // so each scan starts at its cursor (the first row still waiting) and stops at the next one waiting
  for (; rate_cursor_ < pending_.size(); ++rate_cursor_) {
    Pending& p = pending_[rate_cursor_];
    if (p.rate_done) continue;
    if (!(have_att && att_newest - p.row.t > rate_deadline)) break;
    p.rate_done = true;
  }
  const CrnStream<3>& as = acc_.stream();
  // not ready while fewer than M samples follow the tag (a row deferred by this test is only evaluated
  // at a later sample: it never loses its window, the ring holds 1024 samples)
  const TimeUs acc_wait = static_cast<TimeUs>(as.kernel().half) * as.samplingIntervalUs() - as.samplingIntervalUs() / 2;
  for (; acc_cursor_ < pending_.size(); ++acc_cursor_) {
    Pending& p = pending_[acc_cursor_];
    if (p.acc_done) continue;
    if (as.hasSamples() && as.newestTime() - p.row.t < acc_wait) break;  // surely not ready yet (cheap)
    AccOutput a;
    const Status s = acc_.evaluateAt(p.row.t, a);
    if (s == Status::kOk) {
      p.row.a_acc_B = a.a_X;
      p.row.has_acc = true;
      p.row.acc_bridged = a.bridged;
      p.row.a_acc_sigma_bridge = a.sigma_bridge;
      p.acc_done = true;
    } else if (s == Status::kUnavailable) {
      p.acc_done = true;
    } else {
      break;  // later rows are not ready either
    }
  }
  while (!pending_.empty()) {
    const Pending& p = pending_.front();
    if (!(p.rate_done && p.acc_done)) break;
    emitOldest();
  }
  // the accelerometer time from which the first row still waiting for it can be ready
  acc_next_check_ = std::numeric_limits<TimeUs>::max();  // none waiting: new rows come with stepHeads
  for (std::size_t i = acc_cursor_; i < pending_.size(); ++i) {
    const Pending& p = pending_[i];
    if (p.acc_done) continue;
    acc_next_check_ = p.row.t + acc_wait;
    break;
  }
}

BORESIGHT_CLONES Status Pipeline::stepHeads(const HeadEpoch& in) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    last_valid_ = false;
    return Status::kNotConfigured;
  }
  Status s = validator_.step(in);
  last_valid_ = s == Status::kOk;
  if (s != Status::kOk) return s;
  const ValidHeads& v = validator_.output();
  PairRelatives rel;  // C_Sa_Sb of every pair, once per epoch for the means and the monitor
  formPairRelatives(v, cfg_.heads.n_heads, rel);
  means_.step(v, rel);
  if (cfg_.fusion_alignment == FusionAlignment::kRunningMeans && !handed_ && --align_countdown_ <= 0) {
    HeadAlignment a;
    if (means_.alignment(a)) {
      fusion_.setRelativeAlignment(a);
      align_countdown_ = cfg_.alignment_update_epochs;
    }  // else (start-up): nominal mountings, try again at the next epoch
  }
  s = fusion_.step(v);
  if (s != Status::kOk) return s;
  if (cfg_.heads.n_heads >= 2) monitor_.step(v, rel);
  if (thermal_.configured()) predictBlindPairs(v);
  const FusedAttitude& f = fusion_.output();

  // is this head epoch an output epoch? (same rule as the rate filter's centre taps)
  const TimeUs P = cfg_.crn_attitude.output_period_us;
  const TimeUs g = f.t >= 0 ? (f.t + P / 2) / P : -((-f.t + P / 2) / P);
  const TimeUs off = f.t - g * P;
  if (off <= head_dt_us_ / 2 && off >= -head_dt_us_ / 2 && (!have_grid_ || g > last_grid_)) {
    have_grid_ = true;
    last_grid_ = g;
    if (pending_.full()) {
      health_.record(Status::kCapacityExceeded);
      emitOldest();
    }
    Pending& p = pending_.emplaceBack();
    p = Pending{};
    p.row.t = f.t;
    p.row.q_I_B = f.q_I_B;
    p.row.P_B = f.P_B;
    p.row.heads_used = f.heads_used;
    p.row.heads_mask = f.mask;
    for (int a = 0; a < cfg_.heads.n_heads; ++a)
      for (int b = a + 1; b < cfg_.heads.n_heads; ++b) {
        const auto k = static_cast<std::size_t>(pairIndex(a, b));
        const PairDeformation& d = monitor_.pair(a, b);
        p.row.iba_rad[k] = d.valid ? d.iba_rad : kNaN;
        p.row.iba_dev_rad[k] = d.valid ? d.iba_dev_rad : kNaN;
      }
    p.acc_done = !cfg_.use_accelerometer;
  }

  const Status rs = rates_.step(f.t, f.q_I_B);
  for (int i = 0; i < rates_.numOutputs(); ++i) {
    const RateOutput& r = rates_.output(i);
    for (std::size_t j = 0; j < pending_.size(); ++j) {
      Pending& p = pending_[j];
      if (p.row.t != r.t) continue;
      setRates(p.row, r);
      p.rate_done = true;
      break;
    }
  }
  resolve();
  return accepted(rs) ? Status::kOk : rs;
}

Status Pipeline::stepAcc(TimeUs t, const Vec3& a_A) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  if (!cfg_.use_accelerometer) return Status::kOk;
  if (a_A.allFinite() && !plausibility::angularAccelPlausible(a_A)) {  // NaN: the filter's own count
    health_.record(Status::kImplausible);
    return Status::kImplausible;
  }
  // The calibration of the accelerometer (an overlay's terms): 9 multiply-adds, no allocation.
  const Status s = cfg_.acc_correction.on ? acc_.step(t, Vec3(cfg_.acc_correction.M * (a_A - cfg_.acc_correction.bias_A)))
                                          : acc_.step(t, a_A);
  // only when the oldest row waiting for the accelerometer may have become ready (or a gap changed it)
  if (accepted(s) && (s != Status::kOk || t >= acc_next_check_)) resolve();
  return s;
}

Status Pipeline::stepStars(const StarEpoch& in) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  if (cfg_.heads.n_heads >= 2) {
    const int R = cfg_.wahba_reference_slot;
    for (int k = 0; k < cfg_.heads.n_heads; ++k) {
      if (k == R) continue;
      Mat3 C, Q;
      if (monitor_.relativeFor(R, k, cfg_.wahba_correction, in.t, C, Q) == Status::kOk) wahba_.setRelative(k, C, Q);
    }
  }
  return wahba_.step(in);
}

Status Pipeline::handMountings(const std::array<Quat, kMaxHeads>& q_Si_B) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  HeadAlignment a;
  if (!means_.alignmentFromMountings(q_Si_B, a)) return Status::kInvalidConfig;
  const Status s = fusion_.setRelativeAlignment(a);
  if (s == Status::kOk) handed_ = true;
  return s;
}

void Pipeline::releaseMountings() {
  if (!handed_) return;
  handed_ = false;
  align_countdown_ = 0;  // from the running means at the next head epoch
  if (cfg_.fusion_alignment != FusionAlignment::kRunningMeans) fusion_.setRelativeAlignment(HeadAlignment{});
}

void Pipeline::flush() {
  while (!pending_.empty()) {
    Pending& p = pending_.front();
    if (!p.acc_done) {
      AccOutput a;
      if (acc_.evaluateAt(p.row.t, a) == Status::kOk) {
        p.row.a_acc_B = a.a_X;
        p.row.has_acc = true;
        p.row.acc_bridged = a.bridged;
        p.row.a_acc_sigma_bridge = a.sigma_bridge;
      }
    }
    if (!p.rate_done) {
      RateOutput r;
      if (rates_.evaluateAt(p.row.t, r) == Status::kOk) setRates(p.row, r);
    }
    emitOldest();
  }
}

void Pipeline::setRates(PipelineRow& row, const RateOutput& r) const {
  row.w_B = r.w_X;
  row.a_sc_B = r.alpha_X;
  row.has_rates = true;
  row.rate_bridged = r.bridged;
  // (squares, not std::hypot: its overflow care costs ~25 instructions a call, and these are far
  // from overflow)
  const double bw2 = r.w_sigma_bridge * r.w_sigma_bridge, ba2 = r.alpha_sigma_bridge * r.alpha_sigma_bridge;
  for (int k = 0; k < 3; ++k) {
    const double v = std::max(row.P_B(k, k), 0.0);
    row.w_sigma_B[k] = std::sqrt(v * gain_w_ * gain_w_ + bw2);
    row.a_sc_sigma_B[k] = std::sqrt(v * gain_a_ * gain_a_ + ba2);
  }
}

bool Pipeline::popRow(PipelineRow& out) {
  return ready_.pop(out);
}

}  // namespace boresight::core

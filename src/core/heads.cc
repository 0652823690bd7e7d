#include "boresight/core/heads.h"

#include "boresight/core/clones.h"

#include "boresight/core/rotation.h"

#include <cmath>

namespace boresight::core {

const char* statusName(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kNotConfigured: return "not_configured";
    case Status::kInvalidConfig: return "invalid_config";
    case Status::kNonFinite: return "non_finite";
    case Status::kNonUnitQuaternion: return "non_unit_quaternion";
    case Status::kTimeBackwards: return "time_backwards";
    case Status::kDuplicateTime: return "duplicate_time";
    case Status::kIrregularTime: return "irregular_time";
    case Status::kGapRestarted: return "gap_restarted";
    case Status::kGapBridged: return "gap_bridged";
    case Status::kUnknownHead: return "unknown_head";
    case Status::kDuplicateHead: return "duplicate_head";
    case Status::kTooFewStars: return "too_few_stars";
    case Status::kNumericalFailure: return "numerical_failure";
    case Status::kNoValidInput: return "no_valid_input";
    case Status::kNotReady: return "not_ready";
    case Status::kUnavailable: return "unavailable";
    case Status::kCapacityExceeded: return "capacity_exceeded";
    case Status::kImplausible: return "implausible";
    case Status::kCount_: break;
  }
  return "unknown_status";
}

std::uint64_t Health::rejected() const {
  std::uint64_t r = 0;
  for (int i = 0; i < kStatusCount; ++i) {
    const auto s = static_cast<Status>(i);
    if (accepted(s) || s == Status::kNotReady) continue;
    r += by_status[static_cast<std::size_t>(i)];
  }
  return r;
}

void Health::add(const Health& other) {
  for (std::size_t i = 0; i < by_status.size(); ++i) by_status[i] += other.by_status[i];
}

Status validate(const HeadSetConfig& cfg) {
  if (cfg.n_heads < 1 || cfg.n_heads > kMaxHeads) return Status::kInvalidConfig;
  if (!(cfg.unit_norm_tolerance > 0) || !(cfg.unit_norm_tolerance < 0.1)) return Status::kInvalidConfig;
  if (!(cfg.relative_time_constant_s >= 0) || !std::isfinite(cfg.relative_time_constant_s) || cfg.relative_min_epochs < 1)
    return Status::kInvalidConfig;
  for (int s = 0; s < cfg.n_heads; ++s) {
    const HeadConfig& h = cfg.head[static_cast<std::size_t>(s)];
    if (h.id <= 0) return Status::kInvalidConfig;
    for (int o = 0; o < s; ++o)
      if (cfg.head[static_cast<std::size_t>(o)].id == h.id) return Status::kInvalidConfig;
    if (!allFinite(h.q_Si_B) || std::abs(h.q_Si_B.norm() - 1.0) > 1e-6) return Status::kInvalidConfig;
    if (!allFinite(h.boresight_Si) || std::abs(h.boresight_Si.norm() - 1.0) > 1e-9) return Status::kInvalidConfig;
    if (!(h.sigma_cross_rad > 0) || !(h.sigma_roll_rad > 0) || !(h.sigma_star_rad > 0)) return Status::kInvalidConfig;
    if (!std::isfinite(h.sigma_cross_rad) || !std::isfinite(h.sigma_roll_rad) || !std::isfinite(h.sigma_star_rad))
      return Status::kInvalidConfig;
  }
  return Status::kOk;
}

Status HeadInputValidator::configure(const HeadSetConfig& cfg) {
  configured_ = false;
  const Status s = validate(cfg);
  if (s != Status::kOk) return s;
  cfg_ = cfg;
  configured_ = true;
  reset();
  return Status::kOk;
}

void HeadInputValidator::reset() {
  have_last_ = false;
  last_t_ = 0;
  out_ = ValidHeads{};
  health_.clear();
}

BORESIGHT_CLONES Status HeadInputValidator::step(const HeadEpoch& in) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  if (have_last_ && in.t < last_t_) {
    health_.record(Status::kTimeBackwards);
    return Status::kTimeBackwards;
  }
  if (have_last_ && in.t == last_t_) {
    health_.record(Status::kDuplicateTime);
    return Status::kDuplicateTime;
  }
  // built in place in out_ (the previous epoch's output is restored on rejection: rare)
  const TimeUs prev_t = out_.t;
  const std::uint32_t prev_mask = out_.mask;
  ValidHeads& v = out_;
  v.t = in.t;
  v.mask = 0;
  Status first_reason = Status::kNoValidInput;
  int n = in.n;
  if (n < 0) n = 0;
  if (n > kMaxHeads) {
    health_.record(Status::kCapacityExceeded);
    n = kMaxHeads;
  }
  for (int k = 0; k < n; ++k) {
    const HeadSample& hs = in.sample[static_cast<std::size_t>(k)];
    Status r = Status::kOk;
    double norm = 0;
    const int slot = slotOf(cfg_, hs.head_id);
    if (slot < 0) {
      r = Status::kUnknownHead;
    } else if (!allFinite(hs.q_I_Si) || !std::isfinite(hs.sigma_scale) || hs.sigma_scale <= 0) {
      r = Status::kNonFinite;
    } else if (norm = hs.q_I_Si.norm(), std::abs(norm - 1.0) > cfg_.unit_norm_tolerance) {
      r = Status::kNonUnitQuaternion;
    } else if (v.has(slot)) {
      r = Status::kDuplicateHead;
    }
    if (r != Status::kOk) {
      health_.record(r);
      if (first_reason == Status::kNoValidInput) first_reason = r;
      continue;
    }
    const auto us = static_cast<std::size_t>(slot);
    const double inv = 1.0 / norm;
    v.q_I_Si[us] = Quat(hs.q_I_Si.w() * inv, hs.q_I_Si.x() * inv, hs.q_I_Si.y() * inv, hs.q_I_Si.z() * inv);
    v.sigma_scale[us] = hs.sigma_scale;
    v.mask |= 1u << slot;
  }
  if (v.mask == 0) {
    // the slots of prev_mask were not written (no valid head): restoring t and mask restores out_
    v.t = prev_t;
    v.mask = prev_mask;
    if (first_reason == Status::kNoValidInput) health_.record(Status::kNoValidInput);
    return first_reason;
  }
  have_last_ = true;
  last_t_ = in.t;
  health_.record(Status::kOk);
  return Status::kOk;
}

}  // namespace boresight::core

// The audit's Collector: every input reduced to time-bin sums (collector_impl.h), plus sample-level
// events (sign flips, outliers, missing runs).
#include <boresight/core/rotation.h>
#include "collector_impl.h"
#include "stats.h"

#include <boresight/model/rotation.h>

#include <algorithm>
#include <cmath>

namespace boresight::audit {
namespace {

constexpr std::size_t kMaxRuns = 5000;  ///< missing runs kept per stream (counted beyond)

void addRun(std::vector<MissingRun>& runs, double start, double end, double samples, bool others) {
  if (runs.size() < kMaxRuns) runs.push_back({start, end, samples, others});
  else runs.back().samples += samples;  // the last entry absorbs the rest (counts stay right)
}

}  // namespace

void Bin::merge(const Bin& o) {
  if (o.n_ep > 0) {
    Eigen::Vector4d s = o.sum_q;
    if (n_ep == 0) {
      q_first = o.q_first;
    } else if (s.dot(q_first.coeffs()) < 0) {
      s = -s;
    }
    sum_q += s;
  }
  n_ep += o.n_ep;
  sum_t += o.sum_t;
  for (int m = 0; m < kMasks; ++m) {
    mask[m].n += o.mask[m].n;
    mask[m].sum += o.mask[m].sum;
  }
  for (int p = 0; p < kMaxPairs; ++p) {
    noise[p].n += o.noise[p].n;
    noise[p].sdd += o.noise[p].sdd;
  }
  for (int k = 0; k < kMaxHeads; ++k) head_n[k] += o.head_n[k];
  n_aa += o.n_aa;
  sum_e += o.sum_e;
  sum_e2 += o.sum_e2;
  sum_asc += o.sum_asc;
  sum_aacc += o.sum_aacc;
  n_jerk += o.n_jerk;
  sum_jerk += o.sum_jerk;
  n_ref += o.n_ref;
  sum_d += o.sum_d;
  sum_d2 += o.sum_d2;
  for (int p = 0; p < kMaxPairs; ++p) {
    iba_n[p] += o.iba_n[p];
    iba_sum[p] += o.iba_sum[p];
  }
  n_acc += o.n_acc;
  sum_a += o.sum_a;
  sum_a2 += o.sum_a2;
}

Bin& Collector::Impl::binAt(TimeUs t) {
  if (t < t0) t = t0;
  auto idx = static_cast<std::size_t>((t - t0) / bin_us);
  while (idx >= static_cast<std::size_t>(opt.max_bins)) {
    // Double the bin length: merge neighbours in place.
    std::vector<Bin> merged((bins.size() + 1) / 2);
    for (std::size_t i = 0; i < bins.size(); ++i) merged[i / 2].merge(bins[i]);
    bins.swap(merged);
    bin_us *= 2;
    idx = static_cast<std::size_t>((t - t0) / bin_us);
  }
  if (idx >= bins.size()) bins.resize(idx + 1);
  return bins[idx];
}

Collector::Collector() : impl_(std::make_unique<Impl>()) {}
Collector::~Collector() = default;

bool Collector::configure(const core::PipelineConfig& cfg, const AuditOptions& opt, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = "audit: " + m;
    return false;
  };
  const int n = cfg.heads.n_heads;
  if (n < 1 || n > kMaxHeads) return fail("the configuration has " + std::to_string(n) + " heads (1.." + std::to_string(kMaxHeads) + ")");
  if (!(opt.false_alarm > 0 && opt.false_alarm < 0.5)) return fail("false-alarm rate must be in (0, 0.5)");
  if (opt.max_bins < 16) return fail("max_bins must be at least 16");
  if (opt.holdout_blocks < 1) return fail("holdout_blocks must be at least 1");
  if (opt.max_harmonic < 0 || opt.max_harmonic > 10) return fail("max_harmonic must be in 0..10");
  if (!(cfg.crn_attitude.fs_hz > 0)) return fail("the head rate (crn_attitude fs) must be positive");
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  m.cfg = cfg;
  m.opt = opt;
  m.n_heads = n;
  m.period_us = static_cast<TimeUs>(std::llround(1e6 / cfg.crn_attitude.fs_hz));
  m.acc_period_us = cfg.crn_acc.fs_hz > 0 ? static_cast<TimeUs>(std::llround(1e6 / cfg.crn_acc.fs_hz)) : 100000;
  m.bin_us = m.period_us;
  for (int k = 0; k < n; ++k) {
    const auto& h = cfg.heads.head[k];
    m.ids[k] = h.id;
    m.C_B_S[k] = h.q_Si_B.toRotationMatrix().transpose();
    const Vec3 b = h.boresight_Si.normalized();
    const Mat3 cov_S = h.sigma_cross_rad * h.sigma_cross_rad * (Mat3::Identity() - b * b.transpose()) +
                       h.sigma_roll_rad * h.sigma_roll_rad * b * b.transpose();
    m.cov_model_B[k] = m.C_B_S[k] * cov_S * m.C_B_S[k].transpose();
  }
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const int p = pairOf(i, j, n);
      m.pair_cov_inv[p] = (1.5 * (m.cov_model_B[i] + m.cov_model_B[j])).inverse();
    }
  m.chi2_median0 = stats::chi2Quantile(0.5, 3);
  m.chi2_median.fill(m.chi2_median0);
  m.chi2_count.fill(0);
  const double p_sample = stats::normalSf2(std::max(3.0, opt.outlier_min_sigma));
  m.outlier_chi2 = stats::chi2Quantile(p_sample, 3);
  m.configured = true;
  return true;
}

void Collector::onHeads(const core::HeadEpoch& e, core::Status) {
  Impl& m = *impl_;
  if (!m.configured || e.n <= 0) return;
  if (!m.have_t0) {
    m.have_t0 = true;
    m.t0 = e.t;
  }
  if (e.t < m.t_last) return;  // the engine keeps time order; be safe
  m.t_last = e.t;
  EpochRecord r;
  r.t = e.t;
  for (int s = 0; s < e.n; ++s) {
    const auto& hs = e.sample[static_cast<std::size_t>(s)];
    int slot = -1;
    for (int k = 0; k < m.n_heads; ++k)
      if (m.ids[k] == hs.head_id) slot = k;
    if (slot < 0) continue;
    const Quat q = hs.q_I_Si.normalized();
    // Sign reversal between consecutive samples of one head, away from a scalar-part crossing (a product
    // that keeps q0 >= 0 reverses there legitimately).
    if (m.seen[slot] && q.coeffs().dot(m.last_q[slot].coeffs()) < 0 && std::abs(q.w()) > 0.05 &&
        std::abs(m.last_q[slot].w()) > 0.05) {
      ++m.flips[slot];
      if (m.flip_times_s.size() < kMaxRuns) m.flip_times_s.push_back(m.secs(e.t));
    }
    // Missing samples of this head since its previous one.
    if (m.seen[slot]) {
      const TimeUs dt = e.t - m.last_tag[slot];
      if (dt > m.period_us * 3 / 2) {
        const double missing = std::round(static_cast<double>(dt) / static_cast<double>(m.period_us)) - 1;
        const bool others = m.have_epoch && m.last_epoch_t > m.last_tag[slot];
        addRun(m.head_runs[slot], m.secs(m.last_tag[slot]), m.secs(e.t), missing, others);
      }
    } else if (m.have_epoch && e.t - m.first_epoch_t > m.period_us * 3 / 2) {
      // The seam at the start: the other heads delivered from first_epoch_t, this one only from now
      // (a head switched on late, or out at the start of the data): its samples from first_epoch_t on
      // are missing. The run's bounds are the neighbouring samples' times, as inside the data. One
      // sample is not a run: a file or an excerpt may begin inside an epoch (cut between its heads).
      const double missing = std::round(static_cast<double>(e.t - m.first_epoch_t) / static_cast<double>(m.period_us));
      addRun(m.head_runs[slot], m.secs(m.first_epoch_t) - static_cast<double>(m.period_us) * 1e-6, m.secs(e.t), missing, true);
    }
    m.seen[slot] = true;
    m.last_tag[slot] = e.t;
    m.last_q[slot] = q;
    ++m.samples[slot];
    r.mask |= 1u << slot;
    r.q_B[slot] = q * m.cfg.heads.head[slot].q_Si_B;
  }
  // Applied thermal terms: the heads' mountings at this epoch's argument of latitude.
  if (m.opt.applied_thermal && r.mask != 0) {
    double u = 0;
    if (!m.argumentOfLatitude(e.t, u)) {
      ++m.thermal_no_orbit;
    } else {
      const core::ThermalHarmonicModel& th = *m.opt.applied_thermal;
      const int d = th.datum_slot;
      for (int k = 0; k < m.n_heads; ++k) {
        const core::ThermalHeadModel& hm = th.head[static_cast<std::size_t>(k)];
        if (!((r.mask >> k) & 1u) || k == d || !hm.valid || d < 0 || d >= m.n_heads) continue;
        Vec3 delta = hm.constant_rad;
        for (int n = 0; n < th.n_harmonics; ++n) {
          const double a = th.order[static_cast<std::size_t>(n)] * u;
          delta += hm.cos_rad[static_cast<std::size_t>(n)] * std::cos(a) + hm.sin_rad[static_cast<std::size_t>(n)] * std::sin(a);
        }
        const Mat3 C0_kd = m.C_B_S[k].transpose() * m.C_B_S[d];  // C_Sk_B C_B_Sd
        const Quat q_I_Sk = r.q_B[k] * m.cfg.heads.head[k].q_Si_B.conjugate();
        r.q_B[k] = q_I_Sk * (core::quatExp(-C0_kd * delta) * m.cfg.heads.head[k].q_Si_B);
      }
      ++m.thermal_applied;
    }
  }
  if (r.mask == 0) return;
  if (m.have_epoch) {
    const TimeUs dt = e.t - m.last_epoch_t;
    r.consecutive_prev = dt <= m.period_us * 3 / 2;
    if (dt > m.period_us * 3 / 2) {
      const double missing = std::round(static_cast<double>(dt) / static_cast<double>(m.period_us)) - 1;
      addRun(m.epoch_gaps, m.secs(m.last_epoch_t), m.secs(e.t), missing, false);
    }
  }
  if (!m.have_epoch) m.first_epoch_t = e.t;
  m.have_epoch = true;
  m.last_epoch_t = e.t;
  ++m.head_epochs;
  for (int i = 0; i < m.n_heads; ++i)
    for (int j = i + 1; j < m.n_heads; ++j) {
      if (!((r.mask >> i) & 1u) || !((r.mask >> j) & 1u)) continue;
      const int p = pairOf(i, j, m.n_heads);
      r.rho[p] = model::quatLog(r.q_B[j].conjugate() * r.q_B[i]);
    }
  m.pushEpoch(r);
}

void Collector::Impl::pushEpoch(const EpochRecord& e) {
  // ring[0] = k-1, ring[1] = k, ring[2] = k+1 (newest)
  if (ring_n == 3) {
    ring[0] = ring[1];
    ring[1] = ring[2];
    ring[2] = e;
  } else {
    ring[ring_n++] = e;
  }
  if (ring_n < 2) return;
  const int newest = ring_n - 1;
  // chi2 of the middle epoch (needs both neighbours consecutive)
  if (ring_n == 3) {
    EpochRecord& a = ring[0];
    EpochRecord& b = ring[1];
    const EpochRecord& c = ring[2];
    b.chi2.fill(0);
    if (b.consecutive_prev && c.consecutive_prev) {
      for (int i = 0; i < n_heads; ++i)
        for (int j = i + 1; j < n_heads; ++j) {
          const std::uint32_t pm = (1u << i) | (1u << j);
          if ((a.mask & pm) != pm || (b.mask & pm) != pm || (c.mask & pm) != pm) continue;
          const int p = pairOf(i, j, n_heads);
          const Vec3 d = b.rho[p] - 0.5 * (a.rho[p] + c.rho[p]);
          const double raw = d.dot(pair_cov_inv[p] * d);
          auto& w = chi2_warmup[static_cast<std::size_t>(p)];
          if (chi2_count[p] < static_cast<std::uint64_t>(kGateWarmup)) {
            w[static_cast<std::size_t>(chi2_count[p]++)] = raw;  // b.chi2 stays 0: not decided
            if (chi2_count[p] == static_cast<std::uint64_t>(kGateWarmup)) {
              std::nth_element(w.begin(), w.begin() + kGateWarmup / 2, w.end());
              chi2_median[p] = std::max(w[kGateWarmup / 2], 1e-12);
            }
            continue;
          }
          b.chi2[p] = raw * (chi2_median0 / chi2_median[p]);
          chi2_median[p] *= raw > chi2_median[p] ? 1.02 : 1.0 / 1.02;
          ++chi2_count[p];
        }
    }
    // ring[0]'s own chi2 was computed when it was the middle; finalise it once its successor's is known.
    finalizeEpoch(0);
  } else if (newest == 1) {
    ring[0].chi2.fill(0);  // the first epoch has no predecessor
  }
}

void Collector::Impl::finalizeEpoch(int k) {
  EpochRecord& e = ring[static_cast<std::size_t>(k)];
  const EpochRecord* next = (k + 1 < ring_n) ? &ring[static_cast<std::size_t>(k + 1)] : nullptr;
  // Outliers: the pair's chi2 above the threshold and a local maximum in time (a wrong sample also
  // raises its neighbours' second differences, by a quarter).
  std::uint32_t bad_pairs = 0;
  for (int p = 0; p < kMaxPairs; ++p) {
    if (!(e.chi2[p] > outlier_chi2)) continue;
    if (next && next->chi2[p] > e.chi2[p]) continue;
    if (have_prev_final && prev_final.chi2[p] > e.chi2[p]) continue;
    bad_pairs |= 1u << p;
  }
  std::uint32_t bad_heads = 0;
  if (bad_pairs) {
    for (int h = 0; h < n_heads; ++h) {
      if (!((e.mask >> h) & 1u)) continue;
      int in = 0, flagged = 0;
      for (int o = 0; o < n_heads; ++o) {
        if (o == h || !((e.mask >> o) & 1u)) continue;
        const int p = pairOf(std::min(h, o), std::max(h, o), n_heads);
        ++in;
        flagged += (bad_pairs >> p) & 1u;
      }
      if (in >= 2 && flagged == in) bad_heads |= 1u << h;
    }
    const double ts = secs(e.t);
    if (bad_heads) {
      for (int h = 0; h < n_heads; ++h)
        if ((bad_heads >> h) & 1u) ++outliers[h];
    } else {
      ++outliers_unattributed;  // two heads: the pair cannot tell which head was wrong
      for (int h = 0; h < n_heads; ++h)
        if ((e.mask >> h) & 1u) bad_heads |= 1u << h;
    }
    if (outlier_times_s.size() < 5000) outlier_times_s.push_back(ts);
  }
  const std::uint32_t mask = e.mask & ~bad_heads;
  Bin& b = binAt(e.t);
  if (__builtin_popcount(mask) >= 1) {
    // mean body attitude of the epoch
    Eigen::Vector4d s = Eigen::Vector4d::Zero();
    Quat first = Quat::Identity();
    bool have = false;
    for (int h = 0; h < n_heads; ++h) {
      if (!((mask >> h) & 1u)) continue;
      Eigen::Vector4d c = e.q_B[h].coeffs();
      if (!have) {
        first = e.q_B[h];
        have = true;
      } else if (c.dot(first.coeffs()) < 0) {
        c = -c;
      }
      s += c;
      b.head_n[h] += 1;
    }
    Quat qe(s.normalized());
    Eigen::Vector4d qc = qe.coeffs();
    if (b.n_ep == 0) b.q_first = qe;
    else if (qc.dot(b.q_first.coeffs()) < 0) qc = -qc;
    b.sum_q += qc;
    b.n_ep += 1;
    b.sum_t += secs(e.t);
  }
  if (__builtin_popcount(mask) >= 2) {
    int r0 = 0;
    while (!((mask >> r0) & 1u)) ++r0;
    MaskSum& ms = b.mask[mask];
    int row = 0;
    for (int o = r0 + 1; o < n_heads; ++o) {
      if (!((mask >> o) & 1u)) continue;
      ms.sum.segment<3>(3 * row) += e.rho[pairOf(r0, o, n_heads)];
      ++row;
    }
    ms.n += 1;
  }
  // noise: first differences with the previous epoch (both clean)
  if (have_prev_final) {
    const EpochRecord& prev = prev_final;
    if (e.consecutive_prev) {
      for (int i = 0; i < n_heads; ++i)
        for (int j = i + 1; j < n_heads; ++j) {
          const std::uint32_t pm = (1u << i) | (1u << j);
          if ((mask & pm) != pm || (prev.mask & pm) != pm) continue;
          const int p = pairOf(i, j, n_heads);
          if (prev.chi2[p] > outlier_chi2) continue;
          const Vec3 d = e.rho[p] - prev.rho[p];
          b.noise[p].n += 1;
          b.noise[p].sdd += d * d.transpose();
        }
    }
  }
  e.mask = mask;  // an outlier head does not serve as the next epoch's predecessor
  prev_final = e;
  have_prev_final = true;
}

void Collector::onAcc(TimeUs t, const Vec3& a_in, core::Status) {
  Impl& m = *impl_;
  if (!m.configured || !a_in.allFinite()) return;
  // The engine hands the samples as measured; the core corrects them (an overlay's accelerometer terms,
  // core::AccCorrection) and so does the audit's own use of them (the short-span rate route).
  const core::AccCorrection& ac = m.cfg.acc_correction;
  const Vec3 a_A = ac.on ? Vec3(ac.M * (a_in - ac.bias_A)) : a_in;
  if (!m.have_acc_span) {
    m.have_acc_span = true;
    m.acc_first = t;
  }
  m.acc_final = std::max(m.acc_final, t);
  ++m.acc_samples;
  if (!m.inStarCover(t)) {
    ++m.acc_outside;
    m.have_acc = false;  // a run of samples outside the star data is not an accelerometer gap
    return;
  }
  if (m.have_acc) {
    const TimeUs dt = t - m.last_acc_t;
    if (dt > m.acc_period_us * 3 / 2)
      addRun(m.acc_gaps, m.secs(m.last_acc_t), m.secs(t),
             std::round(static_cast<double>(dt) / static_cast<double>(m.acc_period_us)) - 1, false);
  }
  m.have_acc = true;
  m.last_acc_t = t;
  Bin& b = m.binAt(t);
  b.n_acc += 1;
  b.sum_a += a_A;
  b.sum_a2 += a_A.cwiseProduct(a_A);
}

void Collector::onEnd() {
  Impl& m = *impl_;
  if (!m.configured) return;
  // The seam at the end: a head whose samples stopped while the others went on (a head lost before the
  // end of the data), or that never delivered while the others did, has a run up to the last epoch.
  // One sample is not a run: the data may end inside an epoch (the real excerpts are cut by lines).
  if (m.have_epoch && !m.ended) {
    m.ended = true;
    const double period_s = static_cast<double>(m.period_us) * 1e-6;
    for (int k = 0; k < m.n_heads; ++k) {
      if (m.seen[static_cast<std::size_t>(k)]) {
        const TimeUs dt = m.last_epoch_t - m.last_tag[static_cast<std::size_t>(k)];
        if (dt > m.period_us * 3 / 2)
          addRun(m.head_runs[static_cast<std::size_t>(k)], m.secs(m.last_tag[static_cast<std::size_t>(k)]), m.secs(m.last_epoch_t) + period_s,
                 std::round(static_cast<double>(dt) / static_cast<double>(m.period_us)), true);
      } else {
        addRun(m.head_runs[static_cast<std::size_t>(k)], m.secs(m.first_epoch_t) - period_s, m.secs(m.last_epoch_t) + period_s,
               std::round(static_cast<double>(m.last_epoch_t - m.first_epoch_t) / static_cast<double>(m.period_us)) + 1,
               true);
      }
    }
  }
  // finalise what the ring still holds: its epochs have no successor, so no outlier decision
  if (m.ring_n == 3) {
    m.ring[2].chi2.fill(0);
    m.finalizeEpoch(1);
    m.finalizeEpoch(2);
  } else if (m.ring_n == 2) {
    m.ring[1].chi2.fill(0);
    m.ring[0].chi2.fill(0);
    m.finalizeEpoch(0);
    m.finalizeEpoch(1);
  } else if (m.ring_n == 1) {
    m.ring[0].chi2.fill(0);
    m.finalizeEpoch(0);
  }
  m.ring_n = 0;
}

bool Collector::write(const core::PipelineRow& row) {
  Impl& m = *impl_;
  if (!m.configured) return true;
  if (!m.inStarCover(row.t)) {
    ++m.rows_outside;
    return true;
  }
  ++m.rows;
  Bin& b = m.binAt(row.t);
  for (int p = 0; p < kMaxPairs; ++p)
    if (std::isfinite(row.iba_dev_rad[static_cast<std::size_t>(p)])) {
      b.iba_n[p] += 1;
      b.iba_sum[p] += row.iba_dev_rad[static_cast<std::size_t>(p)];
    }
  if (row.has_rates && row.has_acc && row.a_sc_B.allFinite() && row.a_acc_B.allFinite()) {
    const Vec3 e = row.a_acc_B - row.a_sc_B;
    b.n_aa += 1;
    b.sum_e += e;
    b.sum_e2 += e.cwiseProduct(e);
    b.sum_asc += row.a_sc_B;
    b.sum_aacc += row.a_acc_B;
    // the jerk from the accelerometer (far less noisy than the star-derived angular acceleration)
    // rows come on the CRN's output grid (1 s on GRACE-FO), not at every head epoch
    if (m.have_prev_row && row.t - m.prev_row_t <= 3 * kUsPerSecond && row.t > m.prev_row_t) {
      b.n_jerk += 1;
      b.sum_jerk += (row.a_acc_B - m.prev_asc) / (static_cast<double>(row.t - m.prev_row_t) * 1e-6);
    }
    m.have_prev_row = true;
    m.prev_row_t = row.t;
    m.prev_asc = row.a_acc_B;
  } else {
    m.have_prev_row = false;
  }
  // outside reference at the row's epoch: interpolated between its neighbours (at most 2.5 s apart)
  if (!m.ref.empty()) {
    while (m.ref_cursor + 1 < m.ref.size() && m.ref[m.ref_cursor + 1].first <= row.t) ++m.ref_cursor;
    const auto& a = m.ref[m.ref_cursor];
    if (a.first <= row.t && m.ref_cursor + 1 < m.ref.size()) {
      const auto& c = m.ref[m.ref_cursor + 1];
      if (c.first - a.first <= 2500000 && c.first > a.first) {
        const double f = static_cast<double>(row.t - a.first) / static_cast<double>(c.first - a.first);
        const Quat q_ref = a.second.slerp(f, c.second);
        // the rotation from the fused attitude to the reference, body axes (as process --compare-sca1b)
        const Vec3 d = model::quatLog(row.q_I_B.conjugate() * q_ref);
        if (d.allFinite()) {
          b.n_ref += 1;
          b.sum_d += d;
          b.sum_d2 += d.cwiseProduct(d);
          ++m.ref_used;
        }
      }
    }
  }
  return true;
}

bool Collector::Impl::argumentOfLatitude(TimeUs t, double& u) const {
  if (orbit.empty()) return false;
  auto it = std::lower_bound(orbit.begin(), orbit.end(), t, [](const model::OrbitSample& o, TimeUs x) { return o.t < x; });
  const model::OrbitSample* best = nullptr;
  if (it != orbit.end()) best = &*it;
  if (it != orbit.begin() && (!best || t - std::prev(it)->t < best->t - t)) best = &*std::prev(it);
  if (!best || std::llabs(best->t - t) > 60 * kUsPerSecond) return false;
  u = best->u_rad + best->u_rate_rad_s * static_cast<double>(t - best->t) * 1e-6;
  return true;
}

std::uint64_t Collector::orbitUnusable() const { return impl_->orbit_unusable; }

void Collector::addOrbit(const model::OrbitSample& o) {
  Impl& m = *impl_;
  if (!std::isfinite(o.u_rad) || !std::isfinite(o.u_rate_rad_s)) {
    ++m.orbit_unusable;
    return;
  }
  if (!m.orbit.empty() && std::llabs(o.t - m.orbit.back().t) < 10 * kUsPerSecond) return;
  if (!m.orbit.empty() && o.t < m.orbit.back().t) {  // out of order (several files): kept sorted
    const auto it = std::lower_bound(m.orbit.begin(), m.orbit.end(), o.t, [](const model::OrbitSample& a, TimeUs x) { return a.t < x; });
    if ((it != m.orbit.end() && std::llabs(it->t - o.t) < 10 * kUsPerSecond) ||
        (it != m.orbit.begin() && std::llabs(std::prev(it)->t - o.t) < 10 * kUsPerSecond))
      return;
    m.orbit.insert(it, o);
    return;
  }
  m.orbit.push_back(o);
}

void Collector::addReference(TimeUs t, const Quat& q_I_B) {
  Impl& m = *impl_;
  if (!q_I_B.coeffs().allFinite()) return;
  if (!m.ref.empty() && t <= m.ref.back().first) return;  // time order
  Quat q = q_I_B.normalized();
  if (!m.ref.empty() && q.coeffs().dot(m.ref.back().second.coeffs()) < 0) q.coeffs() = -q.coeffs();
  m.ref.emplace_back(t, q);
}

}  // namespace boresight::audit

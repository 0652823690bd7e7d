// The node's output messages (encode.h).
#include "encode.h"

#include <algorithm>
#include <cmath>

namespace boresight::node {
namespace {
std::int64_t toI64(std::uint64_t v) { return static_cast<std::int64_t>(v); }
}  // namespace

void toPublishedFrame(core::PipelineRow& row, const Quat& q_B_Bpub) {
  const Mat3 R = q_B_Bpub.conjugate().toRotationMatrix();  // C_B'_B
  row.q_I_B = (row.q_I_B * q_B_Bpub).normalized();
  row.P_B = R * row.P_B * R.transpose();
  row.w_B = R * row.w_B;
  row.a_sc_B = R * row.a_sc_B;  // a_acc_B is already in B' (the configured C_B_A defines it)
}

void encodeAttitude(const core::PipelineRow& row, std::int32_t seq, std::int32_t mounting_version,
                    boresight_lcm::fused_attitude_t& a) {
  a = boresight_lcm::fused_attitude_t{};
  a.utime = row.t;
  a.seq = seq;
  a.q_I_B[0] = row.q_I_B.w();
  a.q_I_B[1] = row.q_I_B.x();
  a.q_I_B[2] = row.q_I_B.y();
  a.q_I_B[3] = row.q_I_B.z();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.P_B[i][j] = row.P_B(i, j);
  a.heads_used = static_cast<int8_t>(row.heads_used);
  a.has_rates = row.has_rates ? 1 : 0;
  a.has_acc = row.has_acc ? 1 : 0;
  for (int k = 0; k < 3; ++k) {
    a.w_B[k] = row.w_B[k];
    a.alpha_sc_B[k] = row.a_sc_B[k];
    a.alpha_acc_B[k] = row.a_acc_B[k];
    a.w_sigma_B[k] = row.w_sigma_B[k];  // per axis of B (a frame change is arcseconds: the same)
    a.alpha_sc_sigma_B[k] = row.a_sc_sigma_B[k];
  }
  a.rate_bridged = static_cast<int16_t>(row.rate_bridged);
  a.acc_bridged = static_cast<int16_t>(row.acc_bridged);
  a.alpha_acc_sigma_bridge = row.a_acc_sigma_bridge;
  a.mounting_version = mounting_version;
}

void encodeMonitor(const core::PipelineRow& row, std::int32_t seq, const core::Pipeline& pipe, TimeUs pair_t,
                   boresight_lcm::boresight_monitor_t& mm) {
  mm = boresight_lcm::boresight_monitor_t{};
  const core::HeadSetConfig& heads = pipe.config().heads;
  mm.utime = row.t;
  mm.seq = seq;
  mm.n_heads = static_cast<int8_t>(heads.n_heads);
  const auto& al = pipe.fusion().relativeAlignment();
  for (int k = 0; k < core::kMaxHeads; ++k) {
    const bool used = k < heads.n_heads;
    mm.head_id[k] = static_cast<int8_t>(used ? heads.head[static_cast<std::size_t>(k)].id : 0);
    const Quat q = used ? core::quatExp(al.c_B[static_cast<std::size_t>(k)]) : Quat::Identity();
    mm.q_corr_B[k][0] = q.w();
    mm.q_corr_B[k][1] = q.x();
    mm.q_corr_B[k][2] = q.y();
    mm.q_corr_B[k][3] = q.z();
  }
  for (int p = 0; p < core::kMaxPairs; ++p) {
    mm.iba_rad[p] = row.iba_rad[static_cast<std::size_t>(p)];
    mm.iba_dev_rad[p] = row.iba_dev_rad[static_cast<std::size_t>(p)];
  }
  mm.corrections_valid = al.mask != 0 ? 1 : 0;
  // The pair corrections at the latest head epoch (what the star-vector solution uses).
  mm.pair_utime = pair_t;
  const core::BoresightMonitor& mon = pipe.monitor();
  for (int a = 0; a < heads.n_heads; ++a)
    for (int b = a + 1; b < heads.n_heads; ++b) {
      const int p = core::pairIndex(a, b);
      const core::FilteredDeformation f = mon.filtered(a, b);
      if (!f.valid) continue;  // source 0, zeros: the ground matrix
      Mat3 C, cov;
      mon.relativeFor(a, b, core::RelativeCorrection::kFilteredThreeAxis, pair_t, C, cov);
      // Set at this epoch: by the pair's own epoch (filtered) or by the thermal model; otherwise held
      // (a head blind without a thermal model, or the model without orbit input for max_orbit_age_s).
      const bool fresh = f.t == pair_t;
      mm.pair_source[p] = static_cast<int8_t>(!fresh ? 3 : f.predicted ? 2 : 1);
      for (int k = 0; k < 3; ++k) {
        mm.pair_delta_rad[p][k] = f.delta_Si[k];
        mm.pair_sigma_rad[p][k] = std::sqrt(std::max(0.0, cov(k, k)));
      }
    }
}

void encodeHealth(TimeUs t, std::int32_t seq, const Counters& c, const LatencySummary* lat, const core::Health& core,
                  boresight_lcm::node_health_t& h) {
  h = boresight_lcm::node_health_t{};
  h.utime = t;
  h.seq = seq;
  h.received = toI64(c.received);
  h.used = toI64(c.used);
  // The first 16 reasons: all the node counts (node.cc asserts it); the rest are the replay engine's.
  for (int r = 0; r < 16 && r < kRejectCount; ++r) h.rejected[r] = toI64(c.rejected[static_cast<std::size_t>(r)]);
  h.lost = toI64(c.lost);
  h.epochs = toI64(c.head_epochs + c.accel_steps);
  h.calibrations_published = static_cast<int32_t>(c.calibrations_published);
  h.ring_high_water = lat ? static_cast<int32_t>(c.ring_high_water) : 0;
  h.ring_dropped = toI64(c.ring_dropped);
  if (lat) {
    h.step_latency_us[0] = lat->p50_us;
    h.step_latency_us[1] = lat->p99_us;
    h.step_latency_us[2] = lat->p999_us;
    h.step_latency_us[3] = lat->max_us;
  }
  for (int s = 0; s < core::kStatusCount; ++s) h.core_status[s] = toI64(core.by_status[static_cast<std::size_t>(s)]);
}

}  // namespace boresight::node

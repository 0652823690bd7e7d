// The pipeline's thermal-model hook (Pipeline::setThermalModel, stepOrbit): kept apart from
// pipeline.cc so that the per-epoch wiring there stays one call.
#include "boresight/core/pipeline.h"

namespace boresight::core {

Status Pipeline::setThermalModel(const ThermalHarmonicModel& model) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  const Status s = thermal_.configure(cfg_.heads, model);
  resetThermalAnchors();
  return s;
}

Status Pipeline::stepOrbit(TimeUs t, double u_rad, double u_rate_rad_s, double beta_rad) {
  if (!configured_) {
    health_.record(Status::kNotConfigured);
    return Status::kNotConfigured;
  }
  if (!thermal_.configured()) return Status::kOk;
  return thermal_.stepOrbit(t, u_rad, u_rate_rad_s, beta_rad);
}

void Pipeline::resetThermalAnchors() {
  for (ThermalAnchor& a : thermal_anchor_) a = ThermalAnchor{};
}

void Pipeline::predictBlindPairs(const ValidHeads& v) {
  const int n = cfg_.heads.n_heads;
  double u = 0, cos_beta = 1;
  const bool have_u = thermal_.orbitAt(v.t, u, cos_beta);
  const bool anchored = thermal_.model().mode == ThermalPredictionMode::kAnchored;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      ThermalAnchor& A = thermal_anchor_[static_cast<std::size_t>(pairIndex(a, b))];
      if (v.has(a) && v.has(b)) {  // seen: the monitor's own filter serves; remember where we were
        A.blind = false;
        A.anchor_ok = false;
        A.u_seen_ok = have_u;
        A.u_seen = u;
        A.cos_beta_seen = cos_beta;
        continue;
      }
      if (!have_u) {  // no orbit input within max_orbit_age_s: the monitor holds its estimate
        health_.record(Status::kUnavailable);
        continue;
      }
      Vec3 d;
      Mat3 P;
      if (thermal_.predictPair(a, b, u, cos_beta, d, P) != Status::kOk) continue;  // a head without a model
      if (anchored) {
        if (!A.blind) {  // first epoch without the pair: anchor on the filter's held value
          A.blind = true;
          A.anchor_ok = false;
          const FilteredDeformation f = monitor_.filtered(a, b);
          Vec3 d0;
          Mat3 P0;
          if (f.valid && !f.predicted && A.u_seen_ok &&
              thermal_.predictPair(a, b, A.u_seen, A.cos_beta_seen, d0, P0) == Status::kOk) {
            A.offset = f.delta_Si - d0;
            A.cov = f.cov_Si;
            A.anchor_ok = true;
          }
        }
        if (A.anchor_ok) {  // the filter's level plus the model's change since (first order)
          d += A.offset;
          P += A.cov;
        }
      }
      monitor_.setPredictedDeformation(a, b, v.t, d, P);
    }
}

}  // namespace boresight::core

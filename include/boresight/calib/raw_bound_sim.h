// The raw-data bound and the attitude-domain estimate (calib/raw_bound.h) on a simulation: a sink that
// feeds the truth to the bound (every delivered head sample, every accelerometer sample with the true
// angular acceleration and rate), a sink that records what the instruments delivered for estimateRaw,
// and a head's true constant error in the accelerometer datum. Header-only, so that boresight_calib does
// not link the simulator; users link boresight_sim.
#pragma once

#include <boresight/calib/raw_bound.h>
#include <boresight/core/rotation.h>
#include <boresight/sim/simulator.h>

#include <cstddef>
#include <map>

namespace boresight::calib {

class RawBoundSimSink : public sim::SimSink {
 public:
  RawBoundSimSink(RawBound& bound, const sim::Simulator& s) : bound_(bound), start_(s.scenario().start) {
    for (std::size_t i = 0; i < s.heads().size(); ++i) index_[s.heads()[i].config().id] = i;
  }
  void head(const sim::HeadSampleOut& h) override {
    const auto it = index_.find(h.head);
    if (h.blind != sim::kBlindNone || it == index_.end()) return;
    bound_.head(seconds(h.tag), it->second);
  }
  void accel(const sim::AccSampleOut& a) override { bound_.accel(seconds(a.tag), a.a_B_true, a.w_B_true); }

 private:
  double seconds(TimeUs t) const { return static_cast<double>(t - start_) * 1e-6; }
  RawBound& bound_;
  TimeUs start_;
  std::map<int, std::size_t> index_;
};

/// Records the delivered samples (blinded head samples are not delivered) as RawData.
class RawDataSimSink : public sim::SimSink {
 public:
  /// aberration: give each head sample the observer velocity of the aberration the simulation put in
  /// it (its annual and orbital parts as the head's effects have them), so that estimateRaw removes it.
  explicit RawDataSimSink(const sim::Simulator& s, bool aberration = false)
      : sim_(s), start_(s.scenario().start), aberration_(aberration) {
    for (std::size_t i = 0; i < s.heads().size(); ++i) index_[s.heads()[i].config().id] = static_cast<int>(i);
  }
  void head(const sim::HeadSampleOut& h) override {
    const auto it = index_.find(h.head);
    if (h.blind != sim::kBlindNone || it == index_.end()) return;
    RawData::Head e = RawData::Head::sample(seconds(h.tag), it->second, h.q_I_Si);
    if (aberration_) {
      const auto& eff = sim_.heads()[static_cast<std::size_t>(it->second)].effects();
      const model::OrbitContext c = sim_.context(h.t_true_s);
      Vec3 v = Vec3::Zero();
      if (eff.aberration_annual) v += c.v_earth_I;
      if (eff.aberration_orbital) v += c.v_sat_I;
      e.setObserverVelocity(v);
    }
    data.heads.push_back(e);
  }
  void accel(const sim::AccSampleOut& a) override {
    data.acc.push_back(RawData::Acc::sample(seconds(a.tag), a.ang_A));
  }
  RawData data;

 private:
  double seconds(TimeUs t) const { return static_cast<double>(t - start_) * 1e-6; }
  const sim::Simulator& sim_;
  TimeUs start_;
  bool aberration_;
  std::map<int, int> index_;
};

/// A head's true constant error in the accelerometer datum (Si axes, rad) - what calibrate and
/// estimateRaw estimate: Exp(r) = C_Si_B(true) C_B_A(true) C_B_A(nominal)^T C_Si_B(nominal)^T with the
/// head's mounting error and relative misalignment and the accelerometer's misalignment.
inline Vec3 trueErrorInDatum(const model::HeadModel& h, const model::AccelModel& acc) {
  const Mat3 C_Si_B_true = (core::quatExp(h.effects().misalignment_rad) * h.qSiBTrue()).toRotationMatrix();
  return core::so3Log(Mat3(C_Si_B_true * acc.C_A_B_true().transpose() * acc.config().C_A_B *
                           h.config().q_Si_B.toRotationMatrix().transpose()));
}

}  // namespace boresight::calib

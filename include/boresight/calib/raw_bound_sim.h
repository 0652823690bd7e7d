// Feeds a simulation's truth to the raw-data bound (calib/raw_bound.h): every delivered head sample and
// every accelerometer sample with the true angular acceleration and rate. Header-only, so that
// boresight_calib does not link the simulator; users link boresight_sim.
#pragma once

#include <boresight/calib/raw_bound.h>
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

}  // namespace boresight::calib

// boresight::node - the node's outputs as LCM messages (private to the node library): the fused
// attitude and the boresight monitor of a core row, the health summary, and the encoder that turns a
// message into bytes for an Output. Allocation-free after Encoder::init: every call runs on the
// real-time thread.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/node/node.h>

#include "boresight_lcm/boresight_monitor_t.hpp"
#include "boresight_lcm/fused_attitude_t.hpp"
#include "boresight_lcm/node_health_t.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace boresight::node {

/// A row moved into the published frame B' (a frame change): q_I_B' = q_I_B q_B_B', its covariance,
/// rate and spacecraft angular acceleration rotated into B' (the accelerometer's is already in B').
void toPublishedFrame(core::PipelineRow& row, const Quat& q_B_Bpub);

/// The fused attitude of a row (in the frame the row is in), under the calibration identifier it was
/// computed with.
void encodeAttitude(const core::PipelineRow& row, std::int32_t seq, std::int32_t mounting_version,
                    boresight_lcm::fused_attitude_t& a);

/// The monitor of a row: inter-boresight angles, the relative alignment the fusion uses, and each
/// pair's three-axis correction at the core's latest head epoch pair_t (filtered, predicted by the
/// thermal model, or held with a growing sigma).
void encodeMonitor(const core::PipelineRow& row, std::int32_t seq, const core::Pipeline& pipe, TimeUs pair_t,
                   boresight_lcm::boresight_monitor_t& m);

/// The health summary; lat: the step latency (nullptr: recorded as 0, as a replay does so that its
/// payloads do not depend on the wall clock); ring_high_water likewise only when lat is given.
void encodeHealth(TimeUs t, std::int32_t seq, const Counters& c, const LatencySummary* lat, const core::Health& core,
                  boresight_lcm::node_health_t& h);

/// Encodes messages into one buffer sized once and hands the bytes to an Output.
class Encoder {
 public:
  void init(std::size_t bytes) { buf_.assign(bytes, 0); }
  /// False (counted in failed()) when the message does not fit or does not encode.
  template <typename Msg>
  bool publish(Output* out, const std::string& channel, TimeUs t, const Msg& m) {
    const int n = m.getEncodedSize();
    if (n <= 0 || static_cast<std::size_t>(n) > buf_.size() || m.encode(buf_.data(), 0, n) != n) {
      ++failed_;
      return false;
    }
    if (out) out->publish(channel, t, buf_.data(), n);
    return true;
  }
  std::uint64_t failed() const { return failed_; }

 private:
  std::vector<std::uint8_t> buf_;
  std::uint64_t failed_ = 0;
};

}  // namespace boresight::node

// The node's output messages alone (src/node/encode.h): a row in the published frame, the attitude
// and health messages field by field through the encoder and back, the encoder's refusal of a message
// that does not fit.
#include "encode.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {
using namespace boresight;

struct Capture final : node::Output {
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> msgs;
  void publish(const std::string& channel, TimeUs, const void* data, int size) override {
    const auto* p = static_cast<const std::uint8_t*>(data);
    msgs.emplace_back(channel, std::vector<std::uint8_t>(p, p + size));
  }
};

core::PipelineRow someRow() {
  core::PipelineRow r;
  r.t = 123456789;
  r.q_I_B = Quat(0.9, 0.1, -0.3, 0.2).normalized();
  r.P_B = Vec3(1e-10, 4e-10, 9e-10).asDiagonal();
  r.P_B(0, 1) = r.P_B(1, 0) = 2e-11;
  r.w_B = Vec3(1e-3, -2e-3, 5e-4);
  r.a_sc_B = Vec3(1e-6, 2e-6, -3e-6);
  r.a_acc_B = Vec3(4e-6, 5e-6, 6e-6);
  r.w_sigma_B = Vec3(1e-6, 2e-6, 3e-6);
  r.a_sc_sigma_B = Vec3(1e-7, 2e-7, 3e-7);
  r.heads_used = 3;
  r.has_rates = true;
  r.has_acc = true;
  r.rate_bridged = 2;
  r.acc_bridged = 1;
  r.a_acc_sigma_bridge = 7e-8;
  return r;
}

TEST(NodeEncode, APublishedFrameRotatesTheAttitudeAndTheBodyVectorsButNotTheAccelerometers) {
  const core::PipelineRow r0 = someRow();
  core::PipelineRow r = r0;
  const Quat qf = core::quatExp(Vec3(0, 0, 20 * kRadPerArcsec));  // q_B_B': 20" about z
  node::toPublishedFrame(r, qf);
  EXPECT_LT(r.q_I_B.angularDistance(r0.q_I_B * qf), 1e-15);
  // a body vector keeps its inertial direction: C_I_B' w_B' = C_I_B w_B
  EXPECT_LT((r.q_I_B * r.w_B - r0.q_I_B * r0.w_B).norm(), 1e-15);
  EXPECT_LT((r.q_I_B * r.a_sc_B - r0.q_I_B * r0.a_sc_B).norm(), 1e-18);
  EXPECT_GT((r.w_B - r0.w_B).norm(), 1e-9) << "the rate is expressed in B'";
  EXPECT_EQ(r.a_acc_B, r0.a_acc_B) << "the accelerometer's is already in B'";
  // the covariance too: the same in inertial axes, C_I_B' P_B' C_B'_I = C_I_B P_B C_B_I
  const Mat3 A = r.q_I_B.toRotationMatrix(), A0 = r0.q_I_B.toRotationMatrix();
  EXPECT_LT((A * r.P_B * A.transpose() - A0 * r0.P_B * A0.transpose()).norm(), 1e-24);
  EXPECT_GT((r.P_B - r0.P_B).norm(), 1e-17) << "and different in B'";
}

TEST(NodeEncode, TheAttitudeMessageCarriesEveryFieldOfTheRow) {
  const core::PipelineRow r = someRow();
  boresight_lcm::fused_attitude_t a;
  node::encodeAttitude(r, 41, 5, a);
  node::Encoder enc;
  enc.init(8192);
  Capture cap;
  ASSERT_TRUE(enc.publish(&cap, "ATT", r.t, a));
  ASSERT_EQ(cap.msgs.size(), 1u);
  boresight_lcm::fused_attitude_t b;
  const auto& bytes = cap.msgs[0].second;
  ASSERT_EQ(b.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_EQ(b.utime, r.t);
  EXPECT_EQ(b.seq, 41);
  EXPECT_EQ(b.mounting_version, 5);
  EXPECT_DOUBLE_EQ(b.q_I_B[0], r.q_I_B.w());  // scalar first
  EXPECT_DOUBLE_EQ(b.q_I_B[3], r.q_I_B.z());
  EXPECT_DOUBLE_EQ(b.P_B[0][1], 2e-11);
  EXPECT_DOUBLE_EQ(b.w_B[1], -2e-3);
  EXPECT_DOUBLE_EQ(b.alpha_sc_B[2], -3e-6);
  EXPECT_DOUBLE_EQ(b.alpha_acc_B[0], 4e-6);
  EXPECT_DOUBLE_EQ(b.w_sigma_B[2], 3e-6);
  EXPECT_DOUBLE_EQ(b.alpha_sc_sigma_B[1], 2e-7);
  EXPECT_EQ(b.heads_used, 3);
  EXPECT_EQ(b.has_rates, 1);
  EXPECT_EQ(b.has_acc, 1);
  EXPECT_EQ(b.rate_bridged, 2);
  EXPECT_EQ(b.acc_bridged, 1);
  EXPECT_DOUBLE_EQ(b.alpha_acc_sigma_bridge, 7e-8);
}

TEST(NodeEncode, AMessageThatDoesNotFitIsCountedNotPublished) {
  boresight_lcm::fused_attitude_t a;
  node::encodeAttitude(someRow(), 0, 0, a);
  node::Encoder enc;
  enc.init(static_cast<std::size_t>(a.getEncodedSize()) - 1);
  Capture cap;
  EXPECT_FALSE(enc.publish(&cap, "ATT", 0, a));
  EXPECT_EQ(enc.failed(), 1u);
  EXPECT_TRUE(cap.msgs.empty());
}

TEST(NodeEncode, HealthRecordsWallClockFiguresOnlyWhenGiven) {
  node::Counters c;
  c.received = 10;
  c.used = 7;
  c.rejected[static_cast<std::size_t>(io::Reject::kLate)] = 3;
  c.head_epochs = 4;
  c.accel_steps = 2;
  c.ring_high_water = 99;
  core::Health ch;
  ch.by_status[1] = 6;
  node::LatencySummary l{1.5, 2.5, 3.5, 4.5, 100};
  boresight_lcm::node_health_t h;
  node::encodeHealth(77, 3, c, &l, ch, h);
  EXPECT_EQ(h.utime, 77);
  EXPECT_EQ(h.seq, 3);
  EXPECT_EQ(h.received, 10);
  EXPECT_EQ(h.used, 7);
  EXPECT_EQ(h.rejected[static_cast<int>(io::Reject::kLate)], 3);
  EXPECT_EQ(h.epochs, 6);
  EXPECT_EQ(h.core_status[1], 6);
  EXPECT_EQ(h.ring_high_water, 99);
  EXPECT_DOUBLE_EQ(h.step_latency_us[2], 3.5);
  node::encodeHealth(77, 3, c, nullptr, ch, h);  // a replay: nothing from the wall clock
  EXPECT_EQ(h.ring_high_water, 0);
  for (double v : h.step_latency_us) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(h.received, 10);
}

}  // namespace

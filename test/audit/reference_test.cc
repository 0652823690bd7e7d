// The outside reference: the receiver clock map and its inverse, the attitude comparison and its
// time-shift scan (process --compare-sca1b), and the feed into the audit in the receiver time base.
#include <boresight/audit/reference.h>
#include <boresight/core/rotation.h>
#include <boresight/io/level1.h>

#include "test_files.h"

#include <cmath>
#include <string>
#include <vector>

using namespace boresight;
using namespace boresight::audit;
using boresight::core::quatExp;

namespace {

io::ClkRecord clk(double t_s, double eps_s) {
  io::ClkRecord r;
  r.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  r.eps_time = eps_s;
  return r;
}

/// Attitude rotating about body y at `rate` rad/s from a fixed start.
Quat attitudeAt(double t_s, double rate) {
  return Quat(Eigen::AngleAxisd(0.3, Vec3(1, 0, 0))) * quatExp(Vec3(0, rate * t_s, 0));
}

}  // namespace

TEST(ClockMap, InterpolatesHoldsAtTheEndsAndInverts) {
  ClockMap m;
  EXPECT_EQ(m.toReceiver(123456789), 123456789);  // empty: GPS taken as receiver time
  m.records = {clk(1000, 0.10), clk(1010, 0.20), clk(1020, 0.20)};
  EXPECT_DOUBLE_EQ(m.epsAt(static_cast<TimeUs>(990e6)), 0.10);   // before the first record
  EXPECT_NEAR(m.epsAt(static_cast<TimeUs>(1005e6)), 0.15, 1e-12);
  EXPECT_DOUBLE_EQ(m.epsAt(static_cast<TimeUs>(1030e6)), 0.20);  // after the last
  for (double t_rcv : {995.0, 1000.0, 1004.3, 1009.95, 1010.0, 1015.0, 1040.0}) {
    const TimeUs r = static_cast<TimeUs>(std::llround(t_rcv * 1e6));
    const TimeUs g = r + static_cast<TimeUs>(std::llround(m.epsAt(r) * 1e6));
    EXPECT_NEAR(double(m.toReceiver(g)), double(r), 1.0) << t_rcv;
  }
}

TEST(CompareAttitudes, MeanOfAConstantRotationAndTheLatencyScan) {
  const double rate = 1.1e-3;  // rad/s about y, like GRACE-FO's pitch rate
  std::vector<TimedAttitude> fused, ref, rotated;
  for (int i = 0; i <= 40; ++i) fused.push_back({1000.0 + 0.5 * i, attitudeAt(1000.0 + 0.5 * i, rate)});
  // A reference rotated by 10" about body z: the mean is that rotation (reference -> fused: minus it).
  const Vec3 e(0, 0, 10 * kRadPerArcsec);
  for (int i = 2; i <= 18; ++i) rotated.push_back({1000.0 + i, attitudeAt(1000.0 + i, rate) * quatExp(e)});
  AttitudeDifference d = compareAttitudes(fused, rotated, 0.0);
  EXPECT_EQ(d.n, 17);
  EXPECT_NEAR(d.mean.z(), 10.0, 1e-6);
  EXPECT_NEAR(d.mean.x(), 0.0, 1e-6);
  EXPECT_NEAR(d.sd.z(), 0.0, 1e-6);
  // A reference late by 0.55 s (its tag t shows the attitude of t - 0.55): at zero shift a pitch
  // difference of rate * 0.55 s (~125"); the scan finds -0.55 s and removes it.
  for (int i = 2; i <= 18; ++i) ref.push_back({1000.0 + i, attitudeAt(1000.0 + i - 0.55, rate)});
  ShiftScan s = scanTimeShift(fused, ref);
  EXPECT_NEAR(s.at_zero.mean.y(), -rate * 0.55 * kArcsecPerRad, 0.5);
  EXPECT_NEAR(s.best_shift_s, -0.55, 1e-9);
  EXPECT_NEAR(s.best.mean.norm(), 0.0, 0.2);
  EXPECT_EQ(s.best.n, 17);
  // Reference epochs outside the fused span, or across a fused gap over 1.5 s, are not compared.
  std::vector<TimedAttitude> gappy;
  for (const auto& f : fused)
    if (f.t_s < 1005.0 || f.t_s > 1007.0) gappy.push_back(f);
  EXPECT_EQ(compareAttitudes(gappy, rotated, 0.0).n, 17 - 3);  // 1005, 1006, 1007 in the gap 1004.5-1007.5
  EXPECT_EQ(compareAttitudes({}, rotated, 0.0).n, 0);
  EXPECT_EQ(scanTimeShift({}, rotated).best_shift_s, 0.0);
}

TEST(ReferenceFeed, ReceiverTimeInterleavedWithTheHeadsBadSamplesDropped) {
  const std::string dir = testutil::makeTempDir("reference_feed");
  auto f = io::makeProduct<io::Sca1bRecord>(io::Product::SCA1B, 'C');
  auto add = [&](double t_s, Quat q) {
    io::Sca1bRecord r;
    r.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
    quatToScalarFirst(q, r.q);
    f.records.push_back(r);
  };
  for (int i = 0; i < 10; ++i) add(2000.0 + i, attitudeAt(2000.0 + i, 1e-3));
  add(2005.5, attitudeAt(2005.5, 1e-3));              // out of time order: dropped
  add(2010.0, Quat(0.0, 0.0, 0.0, 0.0));              // not a rotation: dropped (by the reader's gate)
  add(2011.0, attitudeAt(2011.0, 1e-3));
  std::string err;
  const std::string path = dir + "/SCA1B_test.txt";  // no date in the name: the tags are seconds past the epoch
  ASSERT_TRUE(io::writeProduct(path, f, &err)) << err;

  ClockMap clock;
  clock.records = {clk(1990, 0.5), clk(2020, 0.5)};  // receiver time = GPS - 0.5 s
  std::vector<std::pair<TimeUs, Quat>> got;
  ReferenceFeed feed([&](TimeUs t, const Quat& q) { got.emplace_back(t, q); }, clock);
  ASSERT_TRUE(feed.open({path}, &err)) << err;
  EXPECT_TRUE(feed.clockApplied());
  EXPECT_NE(feed.timeBase().find("CLK1B"), std::string::npos);
  core::HeadEpoch e;
  e.t = static_cast<TimeUs>(2003.0e6);
  feed.onHeads(e, core::Status::kOk);
  // GPS 2000..2003 are receiver 1999.5..2002.5: four samples up to a head epoch at receiver 2003.
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got.front().first, static_cast<TimeUs>(1999.5e6));
  EXPECT_EQ(got.back().first, static_cast<TimeUs>(2002.5e6));
  feed.onEnd();
  ASSERT_EQ(got.size(), 11u);
  EXPECT_EQ(feed.fed(), 11u);
  EXPECT_EQ(feed.dropped(), 2u);
  EXPECT_EQ(got.back().first, static_cast<TimeUs>(2010.5e6));
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_GT(got[i].first, got[i - 1].first);
  EXPECT_NEAR(got[3].second.angularDistance(attitudeAt(2003.0, 1e-3)), 0.0, 1e-12);

  // Without CLK1B the GPS tags are taken as receiver time, and the feed says so.
  std::vector<TimeUs> t2;
  ReferenceFeed plain([&](TimeUs t, const Quat&) { t2.push_back(t); }, ClockMap{});
  ASSERT_TRUE(plain.open({path}, &err)) << err;
  EXPECT_FALSE(plain.clockApplied());
  EXPECT_NE(plain.timeBase().find("no CLK1B"), std::string::npos);
  ASSERT_TRUE(plain.feedAll(&err)) << err;
  ASSERT_EQ(t2.size(), 11u);
  EXPECT_EQ(t2.front(), static_cast<TimeUs>(2000e6));

  // A file that is not SCA1B, a missing one: file:line: reason.
  ReferenceFeed bad([](TimeUs, const Quat&) {}, ClockMap{});
  EXPECT_FALSE(bad.open({dir + "/missing_SCA1B.txt"}, &err));
  EXPECT_NE(err.find(dir + "/missing_SCA1B.txt:0: cannot open"), std::string::npos) << err;
  auto g = io::makeProduct<io::ClkRecord>(io::Product::CLK1B, 'C');
  ASSERT_TRUE(io::writeProduct(dir + "/CLK1B_2023-06-01_C_04.txt", g, &err)) << err;
  EXPECT_FALSE(bad.open({dir + "/CLK1B_2023-06-01_C_04.txt"}, &err));
  EXPECT_NE(err.find("CLK1B_2023-06-01_C_04.txt:1: CLK1B is not an SCA1B product"), std::string::npos) << err;
}

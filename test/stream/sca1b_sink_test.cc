// The SCA1B writer of `boresight process --sca1b`: the fused attitude resampled to whole GPS seconds.
// The rows follow a rotation at a constant body rate, so the slerp between two rows is the truth at the
// whole second (a geodesic); a gap longer than 1.5 row periods leaves a hole, never an interpolated
// record; sca_id, qual_rss and qualflg come from the rows' heads and covariance; the GPS conversion
// moves the records; the written file reads back record for record.
#include <boresight/core/rotation.h>
#include <boresight/io/level1.h>
#include <boresight/stream/sinks.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <cmath>
#include <string>
#include <vector>

using namespace boresight;

namespace {

constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;  // 2023-06-01 00:00 GPS
const Quat kQ0 = Quat(0.3, -0.2, 0.9, 0.25).normalized();
const Vec3 kRate(2e-3, -1.5e-3, 1.1e-3);  // rad/s, body axes: 0.2 deg/s, a manoeuvre's rate

Quat truthAt(double t_rel_s) { return kQ0 * core::quatExp(kRate * t_rel_s); }

double angleArcsec(const Quat& a, const Quat& b) {
  return 2 * std::asin(std::min(1.0, (a.conjugate() * b).vec().norm())) * kArcsecPerRad;
}

/// The rows' 1-sigma per axis: up and down, so the larger of two neighbours is not always the later.
double sigmaArcsec(int k) { return 1 + 0.4 * (k % 3); }

core::PipelineConfig threeHeads(int last_id = 3) {
  core::PipelineConfig c;
  c.heads.n_heads = 3;
  for (int s = 0; s < 3; ++s) c.heads.head[static_cast<std::size_t>(s)].id = s == 2 ? last_id : s + 1;
  return c;
}

core::PipelineRow row(double t_rel_s, std::uint32_t mask, double sigma_rad) {
  core::PipelineRow r;
  r.t = kT0 + static_cast<TimeUs>(std::llround(t_rel_s * 1e6));
  r.q_I_B = truthAt(t_rel_s);
  if (static_cast<int>(t_rel_s) % 2) r.q_I_B.coeffs() = -r.q_I_B.coeffs();  // the sign is not the writer's business
  r.heads_mask = mask;
  r.heads_used = __builtin_popcount(mask);
  r.P_B = Mat3::Identity() * sigma_rad * sigma_rad;
  return r;
}

}  // namespace

TEST(Sca1bSink, WholeSecondsFollowTheRotationGapsAreHolesAndTheHeadsAreNamed) {
  const std::string path = testutil::makeTempDir("sca1b_sink") + "/SCA1B.txt";
  stream::Sca1bSink sink(path, 'D', 1.5);
  ASSERT_TRUE(sink.begin(threeHeads()));
  // rows 0.3 s past every second from 0.3 to 40.3 s; none in (20.3, 27.3): a 7 s gap
  // heads: all three up to 10.3 s, heads 1 and 3 from 11.3 to 30.3 s, head 2 alone after
  for (int k = 0; k <= 40; ++k) {
    if (k > 20 && k < 27) continue;
    const std::uint32_t mask = k <= 10 ? 7u : k <= 30 ? 5u : 2u;
    ASSERT_TRUE(sink.write(row(k + 0.3, mask, sigmaArcsec(k) * kRadPerArcsec)));
  }
  ASSERT_TRUE(sink.end());
  std::string err;
  ASSERT_TRUE(sink.commit(&err)) << err;
  // whole seconds 1..20 and 28..40; 21..27 are in the gap
  EXPECT_EQ(sink.records(), 33u);
  EXPECT_EQ(sink.holeSeconds(), 7u);

  const auto f = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(f.ok) << f.error;
  ASSERT_EQ(f.records.size(), 33u);
  double worst = 0;
  for (const auto& r : f.records) {
    ASSERT_EQ(r.t % kUsPerSecond, 0);
    const auto s = static_cast<int>((r.t - kT0) / kUsPerSecond);
    EXPECT_TRUE((s >= 1 && s <= 20) || (s >= 28 && s <= 40)) << s;
    EXPECT_EQ(r.satellite, 'D');
    EXPECT_GE(r.q[0], 0.0) << "quatangle is cos(theta/2), theta in [0, 180 deg]";
    worst = std::max(worst, angleArcsec(quatFromScalarFirst(r.q), truthAt(s)));
    // between rows k-1+0.3 and k+0.3: the heads of both rows, the larger covariance
    const int k = s;
    const std::uint32_t m_lo = (k - 1) <= 10 ? 7u : (k - 1) <= 30 ? 5u : 2u, m_hi = k <= 10 ? 7u : k <= 30 ? 5u : 2u;
    const std::uint32_t m = m_lo | m_hi;
    const int sca_id = ((m & 1u) ? 1 : 0) | ((m & 2u) ? 2 : 0) | ((m & 4u) ? 4 : 0);
    EXPECT_EQ(r.sca_id, sca_id) << s;
    EXPECT_NEAR(r.qual_rss, 0.5 * std::sqrt(3.0) * std::max(sigmaArcsec(k - 1), sigmaArcsec(k)) * kRadPerArcsec, 1e-15) << s;
    EXPECT_EQ(r.qualflg.value, (m_lo == 2u || m_hi == 2u) ? 8u : 0u) << s;
  }
  EXPECT_LT(worst, 1e-6) << "arcsec: the slerp of a constant-rate rotation is the rotation";
  // the header states the records' span (start_time_epoch_secs / stop_time_epoch_secs)
  EXPECT_EQ(f.header.coverage_start_s, static_cast<double>(kT0 / kUsPerSecond + 1));
  EXPECT_EQ(f.header.coverage_stop_s, static_cast<double>(kT0 / kUsPerSecond + 40));
  // record for record as held
  const auto g = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(g.ok);
  EXPECT_EQ(f.records, g.records);
}

TEST(Sca1bSink, TheGpsConversionMovesTheRecordsAndRowsOnWholeSecondsAreWrittenAsTheyAre) {
  const std::string path = testutil::makeTempDir("sca1b_sink_gps") + "/SCA1B.txt";
  // receiver time 0.3 s ahead of GPS: every row lands on a whole GPS second
  stream::Sca1bSink sink(path, 'C', 1.5, [](TimeUs) { return -0.3; });
  ASSERT_TRUE(sink.begin(threeHeads()));
  std::vector<core::PipelineRow> rows;
  for (int k = 0; k < 10; ++k) rows.push_back(row(k + 0.3, 7u, kRadPerArcsec));
  for (const auto& r : rows) ASSERT_TRUE(sink.write(r));
  std::string err;
  ASSERT_TRUE(sink.commit(&err)) << err;
  const auto f = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(f.ok) << f.error;
  ASSERT_EQ(f.records.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(f.records[i].t, kT0 + static_cast<TimeUs>(i) * kUsPerSecond);
    EXPECT_LT(angleArcsec(quatFromScalarFirst(f.records[i].q), rows[i].q_I_B), 1e-9);
  }
  // a row whose GPS time is not after the previous one is counted, not written
  ASSERT_TRUE(sink.write(rows[3]));
  EXPECT_EQ(sink.rowsOutOfOrder(), 1u);
  EXPECT_EQ(sink.records(), rows.size());
  // rows without heads are not attitudes
  stream::Sca1bSink empty(path, 'C', 1.5);
  ASSERT_TRUE(empty.begin(threeHeads()));
  core::PipelineRow none = row(0.0, 0u, kRadPerArcsec);
  ASSERT_TRUE(empty.write(none));
  EXPECT_EQ(empty.records(), 0u);
}

TEST(Sca1bSink, AHeadIdWithoutAnSca1bBitIsRefusedBeforeTheReplay) {
  stream::Sca1bSink sink(testutil::makeTempDir("sca1b_sink_id") + "/SCA1B.txt", 'C', 1.5);
  EXPECT_FALSE(sink.begin(threeHeads(5)));
  EXPECT_NE(sink.error().find("head id 5 has no bit in SCA1B's sca_id"), std::string::npos) << sink.error();
  std::string err;
  EXPECT_FALSE(sink.commit(&err));
  EXPECT_EQ(err, sink.error());
}

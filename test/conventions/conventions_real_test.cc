// The conventions of include/boresight/core/conventions.h, proven on the real GRACE-FO samples.
// Each check also runs the rejected alternative and requires it to fail clearly, so the test can
// tell a right convention from a wrong one rather than merely accepting the data.
#include <boresight/core/conventions.h>
#include <boresight/io/level1.h>
#include <boresight/io/sca_geometry.h>

#include "real_data.h"

#include <cmath>
#include <cstdio>
#include <map>

using namespace boresight;
using namespace boresight::io;
using boresight::test::realFile;

namespace {

const char* kSca1a = "gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt";
const char* kQsa1b = "gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt";
const char* kSca1b = "gracefo/2023-06-01_L1B/SCA1B_2023-06-01_C_04.txt";
const char* kAcc1a = "gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt";
const char* kAct1b = "gracefo/2023-06-01_L1B/ACT1B_2023-06-01_C_04.txt";

std::vector<Sca1aRecord> transposed(std::vector<Sca1aRecord> v) {
  for (auto& r : v)
    for (int i = 1; i < 4; ++i) r.q[i] = -r.q[i];  // q -> q*: R(q*) = R(q)^T
  return v;
}

double angleArcsec(const Mat3& a, const Mat3& b) {
  Eigen::AngleAxisd d(a.transpose() * b);
  return std::abs(d.angle()) * kArcsecPerRad;
}

}  // namespace

TEST(ConventionsReal, Sca1aQuaternionIsHeadToInertial) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto sca = readProduct<Sca1aRecord>(realFile(kSca1a));
  ASSERT_TRUE(sca.ok) << sca.error;
  auto right = interBoresightAngles(sca.records);
  auto wrong = interBoresightAngles(transposed(sca.records));
  ASSERT_EQ(right.size(), 3u);
  for (std::size_t i = 0; i < right.size(); ++i) {
    std::printf("heads %d-%d: %zu epochs, q_I_S reading %.6f deg +- %.2f\", transposed reading +- %.0f\"\n",
                right[i].head_a, right[i].head_b, right[i].epochs, right[i].mean_deg, right[i].std_arcsec,
                wrong[i].std_arcsec);
    EXPECT_GE(right[i].epochs, 30u);
    EXPECT_LT(right[i].std_arcsec, 8.0) << "inter-boresight angle must be constant to a few arcsec";
    EXPECT_GT(wrong[i].std_arcsec, 500.0) << "the transposed reading must scatter";
  }
}

TEST(ConventionsReal, Qsa1bQuaternionIsBodyToHeadAndMatchesFlight) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto sca = readProduct<Sca1aRecord>(realFile(kSca1a));
  auto qsa = readProduct<QsaRecord>(realFile(kQsa1b));
  ASSERT_TRUE(sca.ok && qsa.ok) << sca.error << qsa.error;
  ASSERT_EQ(qsa.records.size(), 3u);
  auto pairs = interBoresightAngles(sca.records, &qsa.records);
  // The other reading of QSA1B (q_B_S): boresight in B = R(q) z.
  std::map<int, Vec3> b_other;
  for (const auto& q : qsa.records) b_other[q.sensor] = quatFromScalarFirst(q.q).normalized() * Vec3::UnitZ();
  std::printf("QSA1B (2018-05-22) versus flight (2023-06-01), GRACE C:\n");
  for (const auto& p : pairs) {
    ASSERT_TRUE(p.nominal_deg && p.offset_arcsec);
    double other = std::acos(b_other[p.head_a].dot(b_other[p.head_b])) / kRadPerDeg;
    std::printf("  heads %d-%d: flight %.6f deg, QSA1B %.6f deg, offset %+.1f arcsec (q_B_S reading: %.3f deg)\n",
                p.head_a, p.head_b, p.mean_deg, *p.nominal_deg, *p.offset_arcsec, other);
    EXPECT_LT(std::abs(*p.offset_arcsec), 180.0) << "alignment and flight must agree to arcminutes";
    EXPECT_GT(std::abs(other - p.mean_deg), 10.0) << "the other reading must disagree grossly";
  }
}

TEST(ConventionsReal, Sca1bIsBodyToInertialThroughQsa1b) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto sca = readProduct<Sca1aRecord>(realFile(kSca1a));
  auto qsa = readProduct<QsaRecord>(realFile(kQsa1b));
  auto scb = readProduct<Sca1bRecord>(realFile(kSca1b));
  ASSERT_TRUE(sca.ok && qsa.ok && scb.ok);
  std::map<int, Mat3> C_S_B;
  for (const auto& q : qsa.records) C_S_B[q.sensor] = quatFromScalarFirst(q.q).normalized().toRotationMatrix();
  std::map<std::int64_t, Mat3> sca1b;
  for (const auto& r : scb.records) sca1b[r.t / kUsPerSecond] = quatFromScalarFirst(r.q).normalized().toRotationMatrix();
  // SCA1A tags are receiver time at ~x.03 s and ~x.53 s; take the x.03 samples against SCA1B at x.
  int n = 0;
  double worst_right = 0, best_wrong = 1e9;
  for (const auto& r : sca.records) {
    std::int64_t sec = r.t / kUsPerSecond, frac = r.t % kUsPerSecond;
    if (frac > 100000) continue;
    auto it = sca1b.find(sec);
    if (it == sca1b.end()) continue;
    Mat3 C_I_S = quatFromScalarFirst(r.q).normalized().toRotationMatrix();
    Mat3 C_I_B = C_I_S * C_S_B[r.head];
    worst_right = std::max(worst_right, angleArcsec(C_I_B, it->second));
    best_wrong = std::min(best_wrong, angleArcsec(C_I_B, it->second.transpose()));
    ++n;
  }
  std::printf("SCA1A head attitude through QSA1B vs SCA1B over %d samples: worst %.0f arcsec "
              "(transposed SCA1B: best %.0f arcsec)\n", n, worst_right, best_wrong);
  EXPECT_GE(n, 30);
  EXPECT_LT(worst_right, 600.0);
  EXPECT_GT(best_wrong, 36000.0);
}

TEST(ConventionsReal, Acc1aAxesAreSrfYzx) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto acc = readProduct<FlaggedRecord>(realFile(kAcc1a));
  auto act = readProduct<Acc1bRecord>(realFile(kAct1b));
  ASSERT_TRUE(acc.ok && act.ok) << acc.error << act.error;
  // Mean linear acceleration of the 10 Hz ACC1A samples (accelerometer frame) versus ACT1B (SRF) over
  // the same first seconds: the default rotation must map one onto the other axis by axis.
  Vec3 a_A = Vec3::Zero(), a_B = Vec3::Zero();
  int na = 0, nb = 0;
  for (const auto& r : acc.records) {
    a_A += Vec3(r.value[0], r.value[1], r.value[2]);
    ++na;
  }
  const TimeUs t_end = acc.records.back().t;
  for (const auto& r : act.records)
    if (r.t <= t_end) {
      a_B += Vec3(r.lin[0], r.lin[1], r.lin[2]);
      ++nb;
    }
  ASSERT_GT(na, 50);
  ASSERT_GT(nb, 5);
  a_A /= na;
  a_B /= nb;
  Vec3 mapped = accToBodyDefault() * a_A;
  std::printf("ACC1A mean (A) %.4g %.4g %.4g -> SRF %.4g %.4g %.4g; ACT1B (SRF) %.4g %.4g %.4g\n", a_A.x(), a_A.y(),
              a_A.z(), mapped.x(), mapped.y(), mapped.z(), a_B.x(), a_B.y(), a_B.z());
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(mapped[i], a_B[i], 0.05 * std::abs(a_B[i]) + 2e-9) << "axis " << i;
  // The identity mapping must not fit (the large x/y component sits on a different axis).
  EXPECT_GT((a_A - a_B).norm(), 0.5 * a_B.norm());
}

// Physical plausibility gates (core/plausibility.h) in the readers: a well-formed record whose value
// cannot be (a QSA1B alignment scaled by 2 or with a component zeroed, an angular acceleration of 1e308,
// an orbit radius of 1e30 m, a head quaternion off unit norm, a time tag far outside the file's day) is
// rejected with "file:line: implausible ..." and counted apart, by the whole-file and the streaming
// readers alike; and the limits on what a reader reads (line length, header size, an endless input).
#include <boresight/core/pipeline.h>
#include <boresight/core/plausibility.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <string>

using namespace boresight;
using namespace boresight::io;

namespace {

/// 2023-06-01 00:00:00 GPS as a tag.
constexpr TimeUs kDay = 738849600LL * kUsPerSecond;

template <typename Rec>
std::string write(const std::string& dir, const std::string& name, Product p, const std::vector<Rec>& recs) {
  auto f = makeProduct<Rec>(p, 'C');
  f.records = recs;
  const std::string path = dir + "/" + name;
  EXPECT_TRUE(testutil::writeFile(path, formatProduct(f)));
  return path;
}

/// Both readers agree: `good` records, `bad` implausible ones whose reasons contain `why`.
template <typename Rec>
void expectGate(const std::string& path, std::size_t good, std::size_t bad, const std::string& why,
                const ReadOptions& opt = {}) {
  const auto f = readProduct<Rec>(path, opt);
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_EQ(f.records.size(), good);
  EXPECT_EQ(f.rejected_count, bad);
  EXPECT_EQ(f.implausible_count, bad);
  for (const auto& i : f.rejected) {
    EXPECT_NE(i.reason.find("implausible"), std::string::npos) << i.str();
    EXPECT_NE(i.reason.find(why), std::string::npos) << i.str();
    EXPECT_GT(i.line, f.header.line_count) << i.str();
    EXPECT_EQ(i.str().rfind(path + ":", 0), 0u) << i.str();
  }
  ProductStream<Rec> s;
  std::string err;
  ASSERT_TRUE(s.open(path, opt, &err)) << err;
  Rec r;
  std::size_t n = 0;
  while (s.next(r)) ++n;
  EXPECT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(n, good);
  EXPECT_EQ(s.implausibleCount(), bad);
  EXPECT_EQ(s.rejectedCount(), bad);
}

}  // namespace

TEST(Plausibility, QuaternionGateKnowsScaledZeroedAndImpossibleQuaternions) {
  using plausibility::checkQuaternion;
  using plausibility::Quaternion;
  const double unit[4] = {0.5, -0.5, 0.5, -0.5}, scaled[4] = {1, -1, 1, -1}, zeroed[4] = {0.5, 0, 0.5, -0.5},
               zeros[4] = {0, 0, 0, 0}, big[4] = {2, 0, 0, 0}, nan[4] = {std::nan(""), 0, 0, 1};
  EXPECT_EQ(checkQuaternion(unit, 1e-6), Quaternion::kOk);
  EXPECT_EQ(checkQuaternion(scaled, 1e-6), Quaternion::kNorm);
  EXPECT_EQ(checkQuaternion(zeroed, 1e-6), Quaternion::kNorm);
  EXPECT_EQ(checkQuaternion(zeros, 1e-6), Quaternion::kZero);
  EXPECT_EQ(checkQuaternion(big, 1e-6), Quaternion::kComponent);
  const double slightly[4] = {1.001, 0, 0, 0};
  EXPECT_EQ(checkQuaternion(slightly, 1e-6), Quaternion::kNorm);
  EXPECT_EQ(checkQuaternion(nan, 1e-6), Quaternion::kNonFinite);
  EXPECT_TRUE(plausibility::rateMatches(0.5, 2.0));
  EXPECT_FALSE(plausibility::rateMatches(1.0, 2.0));
  EXPECT_FALSE(plausibility::rateMatches(std::nan(""), 2.0));
}

TEST(Plausibility, Qsa1bScaledOrZeroedAlignmentIsRejectedWithItsLine) {
  const std::string dir = testutil::makeTempDir("gate_qsa");
  std::vector<QsaRecord> q(3);
  const double a[4] = {0.5, -0.5, 0.5, -0.5};
  for (int i = 0; i < 3; ++i) {
    q[std::size_t(i)].sensor = i + 1;
    for (int k = 0; k < 4; ++k) q[std::size_t(i)].q[k] = a[k];
  }
  for (double& v : q[1].q) v *= 2;  // scaled by 2: was normalised silently before
  q[2].q[1] = 0;                    // a component zeroed: 7900 sigma from the baseline before
  const std::string path = write(dir, "QSA1B_2023-06-01_C_04.txt", Product::QSA1B, q);
  expectGate<QsaRecord>(path, 1, 2, "alignment quaternion");
  // Break the gate (tolerance of 1): both would pass again - the gate is what refuses them.
  EXPECT_EQ(plausibility::checkQuaternion(q[1].q, 1.01), plausibility::Quaternion::kOk);
}

TEST(Plausibility, AngularAccelerationOf1e308IsRejectedInAcc1a) {
  const std::string dir = testutil::makeTempDir("gate_acc");
  std::vector<FlaggedRecord> recs(4);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    recs[i].t = kDay + static_cast<TimeUs>(i) * 100000;
    recs[i].prod_flag = Bits{0x3Fu | (1u << 26), 32};
    for (int b = 0; b < 6; ++b) recs[i].value[std::size_t(b)] = 1e-6;
  }
  recs[1].value[acc_bits::kAngY] = 1e308;
  recs[2].value[acc_bits::kLinX] = -5.0;  // 5 m/s^2 of non-gravitational acceleration
  const std::string path = write(dir, "ACC1A_2023-06-01_C_04.txt", Product::ACC1A, recs);
  expectGate<FlaggedRecord>(path, 2, 2, "acceleration");
  expectGate<Acc1aRecord>(path, 2, 2, "acceleration");
  const auto f = readProduct<FlaggedRecord>(path);
  ASSERT_EQ(f.rejected.size(), 2u);
  EXPECT_NE(f.rejected[0].reason.find("angular acceleration y = 1e+308 rad/s^2"), std::string::npos) << f.rejected[0].reason;
  // The core's own gate (it may be linked alone): the same value is not a sample.
  core::Pipeline p;
  core::PipelineConfig cfg;
  cfg.heads.n_heads = 1;
  cfg.heads.head[0].id = 1;
  ASSERT_EQ(p.configure(cfg), core::Status::kOk);
  EXPECT_EQ(p.stepAcc(kDay, Vec3(0, 1e308, 0)), core::Status::kImplausible);
  EXPECT_EQ(p.health().count(core::Status::kImplausible), 1u);
  EXPECT_NE(p.stepAcc(kDay + 100000, Vec3(0, 1e-6, 0)), core::Status::kImplausible);
}

TEST(Plausibility, OrbitRadiusOf1e30IsRejectedInGni1b) {
  const std::string dir = testutil::makeTempDir("gate_gni");
  std::vector<GnvRecord> recs(3);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    recs[i].t = kDay + static_cast<TimeUs>(i) * kUsPerSecond;
    recs[i].coord_ref = 'I';
    recs[i].pos[0] = 6.88e6;
    recs[i].vel[1] = 7.59e3;
  }
  recs[1].pos[2] = 1e30;
  recs[2].vel[0] = 3e5;  // 300 km/s
  const std::string path = write(dir, "GNI1B_2023-06-01_C_04.txt", Product::GNI1B, recs);
  expectGate<GnvRecord>(path, 1, 2, "orbit");
}

TEST(Plausibility, HeadQuaternionGateUsesTheConfiguredTolerance) {
  const std::string dir = testutil::makeTempDir("gate_sca");
  std::vector<Sca1aRecord> recs(4);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    recs[i].t = kDay + static_cast<TimeUs>(i) * 500000;
    recs[i].head = 1;
  }
  for (double& v : recs[2].q) v *= 1.001;  // |q| - 1 = 1e-3
  const std::string path = write(dir, "SCA1A_2023-06-01_C_04.txt", Product::SCA1A, recs);
  expectGate<Sca1aRecord>(path, 3, 1, "quaternion norm off 1");
  ReadOptions loose;
  loose.quat_norm_tolerance = 1e-2;  // a platform file's heads.unit_norm_tolerance
  expectGate<Sca1aRecord>(path, 4, 0, "", loose);
}

TEST(Plausibility, ATimeTagFarOutsideTheFilesDayIsRejected) {
  const std::string dir = testutil::makeTempDir("gate_time");
  std::vector<Sca1aRecord> recs(5);
  for (std::size_t i = 0; i < recs.size(); ++i) {
    recs[i].t = kDay + static_cast<TimeUs>(i) * 500000;
    recs[i].head = 1;
  }
  recs[2].t += 100000000LL * kUsPerSecond;  // 1e8 s (3 years) ahead
  recs[3].t -= 3LL * 86400 * kUsPerSecond;  // three days before the file's day
  const std::string named = write(dir, "SCA1A_2023-06-01_C_04.txt", Product::SCA1A, recs);
  expectGate<Sca1aRecord>(named, 3, 2, "outside");
  // Without a date in the name there is no window: the records pass the reader (the assembler's
  // time base then takes the outlier out, see stream tests).
  const std::string plain = write(dir, "heads.txt", Product::SCA1A, recs);
  ReadOptions o;
  o.product = Product::SCA1A;
  expectGate<Sca1aRecord>(plain, 5, 0, "", o);
  TimeUs day = 0;
  ASSERT_TRUE(dateFromFileName("x/SCA1A_2023-06-01_C_04.txt", day));
  EXPECT_EQ(day, kDay);
  EXPECT_FALSE(dateFromFileName("SCA1A_x.txt", day));
}

TEST(ReaderLimits, LongLineHeaderAndEndlessInputAreRefusedWithTheLimit) {
  const std::string dir = testutil::makeTempDir("gate_limits");
  std::vector<Sca1aRecord> recs(2);
  recs[0].t = kDay;
  recs[1].t = kDay + 500000;
  auto f = makeProduct<Sca1aRecord>(Product::SCA1A, 'C');
  f.records = recs;
  std::string text = formatProduct(f);
  // A header that promises 10^18 records: nothing is sized from it.
  const auto p = text.find("num_records: 2");
  ASSERT_NE(p, std::string::npos);
  std::string promising = text;
  promising.replace(p, 14, "num_records: 1000000000000000000");
  ASSERT_TRUE(testutil::writeFile(dir + "/SCA1A_2023-06-01_C_04.txt", promising));
  const auto pf = readProduct<Sca1aRecord>(dir + "/SCA1A_2023-06-01_C_04.txt");
  ASSERT_TRUE(pf.ok) << pf.error;
  EXPECT_EQ(pf.records.size(), 2u);
  EXPECT_EQ(pf.header.declared_records.value_or(0), 1000000000000000000LL);
  // A line of 100 KiB (binary data, an endless line): the stream refuses the file with the limit.
  ASSERT_TRUE(testutil::writeFile(dir + "/SCA1A_2023-06-02_C_04.txt", text + std::string(100 << 10, '7') + "\n"));
  ProductStream<Sca1aRecord> s;
  std::string err;
  ASSERT_TRUE(s.open(dir + "/SCA1A_2023-06-02_C_04.txt", {}, &err)) << err;
  Sca1aRecord r;
  int n = 0;
  while (s.next(r)) ++n;
  EXPECT_EQ(n, 2);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.error().find("line longer than 64 KiB"), std::string::npos) << s.error();
  // A header that never ends, and /dev/zero: refused at the header limit, not read to the end.
  ASSERT_TRUE(testutil::writeFile(dir + "/SCA1A_2023-06-03_C_04.txt", "header:\n" + std::string(3 << 20, '\n')));
  LineStream ls;
  EXPECT_FALSE(ls.open(dir + "/SCA1A_2023-06-03_C_04.txt", {}, &err));
  EXPECT_NE(err.find("header longer than 1024 KiB"), std::string::npos) << err;
  EXPECT_FALSE(ls.open("/dev/zero", {}, &err));
  EXPECT_NE(err.find("KiB"), std::string::npos) << err;
  std::string whole;
  EXPECT_FALSE(readFileToString("/dev/zero", whole, &err, 1u << 20));
  EXPECT_NE(err.find("more than 1048576 bytes"), std::string::npos) << err;
  const auto z = readProduct<Sca1aRecord>("/dev/zero");  // unknown product by name: 64 MiB at most
  EXPECT_FALSE(z.ok);
  EXPECT_NE(z.error.find("limit"), std::string::npos) << z.error;
}

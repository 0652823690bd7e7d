#include <boresight/io/level1.h>

#include "real_data.h"

using namespace boresight;
using namespace boresight::io;
using boresight::test::realFile;

TEST(Sca1aReal, ParsesAndDeinterleaves) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto f = readProduct<Sca1aRecord>(realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt"));
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_EQ(f.header.style, HeaderStyle::Yaml);
  EXPECT_EQ(f.header.product, Product::SCA1A);
  EXPECT_EQ(f.header.satellite, 'C');
  ASSERT_TRUE(f.header.declared_records.has_value());
  EXPECT_EQ(*f.header.declared_records, 518400);  // the full day's count: not what the excerpt holds
  EXPECT_EQ(f.rejected_count, 0u);
  EXPECT_EQ(f.records.size(), 100u);
  int per_head[4] = {0, 0, 0, 0};
  for (const auto& r : f.records) per_head[r.head]++;
  EXPECT_EQ(per_head[1], 34);
  EXPECT_EQ(per_head[2], 33);
  EXPECT_EQ(per_head[3], 33);
  // Spot values, first line of the file:
  // 738849600 29992 C 1 P -0.2800946131535094 -0.5818990067536707 0.6977387079265291 0.3100020129489717 0 47 1 0 0 11000001 11000000
  const auto& r = f.records.front();
  EXPECT_EQ(r.t, 738849600LL * 1000000 + 29992);
  EXPECT_EQ(r.head, 1);
  EXPECT_EQ(r.q[0], -0.2800946131535094);
  EXPECT_EQ(r.q[3], 0.3100020129489717);
  EXPECT_EQ(r.nstars, 47);
  EXPECT_EQ(r.mode.value, 0b11000001u);
  EXPECT_EQ(r.qualflg.value, 0b11000000u);
}

TEST(Acc1aReal, AngularAccelerationPresentAndNonZero) {
  BORESIGHT_REQUIRE_REAL_DATA();
  auto f = readProduct<FlaggedRecord>(realFile("gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt"));
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_EQ(f.records.size(), 100u);
  EXPECT_EQ(f.rejected_count, 0u);
  for (const auto& r : f.records) {
    ASSERT_TRUE(r.has(acc_bits::kAngX) && r.has(acc_bits::kAngY) && r.has(acc_bits::kAngZ));
    EXPECT_NE(r.value[acc_bits::kAngX], 0.0);
    EXPECT_NE(r.value[acc_bits::kAngZ], 0.0);
    EXPECT_EQ(r.time_ref, 'R');
  }
  EXPECT_EQ(f.records[0].value[acc_bits::kAngZ], -0.000781349539756775);
  EXPECT_EQ(f.records[0].t, 738849600LL * 1000000 + 7739);
}

TEST(RoundTrip, Sca1aAndAcc1aRealFilesAreExact) {
  BORESIGHT_REQUIRE_REAL_DATA();
  {
    auto a = readProduct<Sca1aRecord>(realFile("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt"));
    ASSERT_TRUE(a.ok);
    auto b = parseProduct<Sca1aRecord>(formatProduct(a), "SCA1A_roundtrip.txt");
    ASSERT_TRUE(b.ok) << b.error;
    EXPECT_EQ(b.rejected_count, 0u);
    EXPECT_EQ(a.records, b.records);
    EXPECT_EQ(*b.header.declared_records, 100);  // the written header tells the truth
  }
  for (const char* p : {"gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt", "gracefo/2023-06-01_L1A/AHK1A_2023-06-01_C_04.txt",
                        "gracefo/2023-06-01_L1B/AHK1B_2023-06-01_C_04.txt", "gracefo/2023-06-01_L1A/ACT1A_2023-06-01_C_04.txt",
                        "grace/2003-09-14_ascii/AHK1B_2003-09-14_A_00.asc"}) {
    auto a = readProduct<FlaggedRecord>(realFile(p));
    ASSERT_TRUE(a.ok) << a.error;
    EXPECT_EQ(a.rejected_count, 0u) << p << ": " << (a.rejected.empty() ? "" : a.rejected[0].str());
    EXPECT_GT(a.records.size(), 50u) << p;
    std::string name = p;
    name = name.substr(name.find_last_of('/') + 1);
    auto b = parseProduct<FlaggedRecord>(formatProduct(a), name);
    ASSERT_TRUE(b.ok) << b.error;
    EXPECT_EQ(a.records, b.records) << p;
  }
}

TEST(RoundTrip, SynthesisedHeaders) {
  for (char sat : {'C', 'A'}) {
    auto f = makeProduct<Sca1aRecord>(Product::SCA1A, sat);
    Sca1aRecord r;
    r.t = 123456789012345;
    r.q[0] = 0.5;
    r.q[1] = -0.5;
    r.q[2] = 0.5;
    r.q[3] = 1.0 / 3.0;
    f.records.push_back(r);
    r.head = 3;
    r.t = -5;  // before the epoch: floor division of the microseconds
    f.records.push_back(r);
    std::string text = formatProduct(f);
    ReadOptions exact;  // a non-unit quaternion on purpose: the codec alone
    exact.plausibility_gates = false;
    auto g = parseProduct<Sca1aRecord>(text, "SCA1A_x.txt", exact);
    ASSERT_TRUE(g.ok) << g.error << "\n" << text;
    EXPECT_EQ(g.header.satellite, sat);
    EXPECT_EQ(g.records, f.records);
  }
}

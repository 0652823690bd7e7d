// The compact ACC1A record: the same values as the general prod_flag reader on the real files,
// exact round trips, and a clear rejection of fields outside its layout.
#include <boresight/io/level1.h>

#include "real_data.h"

using namespace boresight;
using namespace boresight::io;
using boresight::test::realFile;

TEST(Acc1aCompactReal, AgreesWithTheGeneralReader) {
  BORESIGHT_REQUIRE_REAL_DATA();
  for (const char* p : {"gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt", "gracefo/2023-06-03_L1A/ACC1A_2023-06-03_C_04.txt",
                        "gracefo/2023-06-01_L1A/ACT1A_2023-06-01_C_04.txt"}) {
    auto g = readProduct<FlaggedRecord>(realFile(p));
    auto c = readProduct<Acc1aRecord>(realFile(p));
    ASSERT_TRUE(g.ok && c.ok) << g.error << c.error;
    EXPECT_EQ(c.rejected_count, 0u) << p;
    ASSERT_EQ(g.records.size(), c.records.size()) << p;
    for (std::size_t i = 0; i < c.records.size(); ++i) {
      const FlaggedRecord& a = g.records[i];
      const Acc1aRecord& b = c.records[i];
      EXPECT_EQ(a.t, b.t);
      EXPECT_EQ(a.prod_flag, b.prod_flag);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(a.value[std::size_t(k)], b.lin[k]);
        EXPECT_EQ(a.value[std::size_t(3 + k)], b.ang[k]);
      }
      EXPECT_EQ(a.value[26], b.counters[0]);
    }
    auto back = parseProduct<Acc1aRecord>(formatProduct(c), "ACC1A_rt.txt");
    ASSERT_TRUE(back.ok) << back.error;
    EXPECT_EQ(back.records, c.records) << p;
  }
}

TEST(Acc1aCompact, RejectsFieldsOutsideItsLayoutWithAReason) {
  auto f = makeProduct<Acc1aRecord>(Product::ACC1A, 'C');
  std::string text = formatProduct(f);
  // bit 6 (bias_vol) set: seven values follow
  text += "738849600 7739 R C 00000000 00000000000000000000000001111111 1e-6 2e-6 3e-6 4e-6 5e-6 6e-6 7\n";
  text += "738849600 107733 R C 00000000 00000100000000000000000000111111 1e-5 2e-7 3e-7 1e-5 1e-4 -7e-4 0\n";
  auto r = parseProduct<Acc1aRecord>(text, "ACC1A_x.txt");
  ASSERT_TRUE(r.ok);
  ASSERT_EQ(r.records.size(), 1u);
  ASSERT_EQ(r.rejected_count, 1u);
  EXPECT_NE(r.rejected[0].reason.find("bit 6 is outside the ACC1A science layout"), std::string::npos)
      << r.rejected[0].str();
  EXPECT_EQ(r.records[0].ang[2], -7e-4);
  EXPECT_EQ(r.records[0].counters[0], 0.0);
  // The general reader takes the same line.
  auto g = parseProduct<FlaggedRecord>(text, "ACC1A_x.txt");
  EXPECT_EQ(g.rejected_count, 0u);
  EXPECT_EQ(g.records.size(), 2u);
}

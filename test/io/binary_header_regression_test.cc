// Regression (found by fuzz_acc1b): an ASCII product whose kept header has a second block after the
// first END OF HEADER, written as GRACE binary, must read back as binary with its records.
#include <boresight/io/level1.h>

#include <gtest/gtest.h>

using namespace boresight::io;

TEST(BinaryHeader, RepeatedHeaderBlockDoesNotHideTheFormatOrCount) {
  std::string text =
      "PRODUCER AGENCY               : NASA\n"
      "SATELLITE NAME                : GRACE A\n"
      "END OF HEADER\n"
      "FILE FORMAT 0=BINARY 1=ASCII  : 1\n"        // a second block: kept as header lines
      "NUMBER OF DATA RECORDS        : 7\n"
      "END OF HEADER\n"
      "116769600 A 1e-6 2e-6 3e-6 4e-6 5e-6 6e-6 7 8 9 00000000\n";
  auto f = parseProduct<Acc1bRecord>(text, "ACC1B_2003-09-14_A_00.asc");
  ASSERT_TRUE(f.ok) << f.error;
  ASSERT_EQ(f.records.size(), 1u);
  ProductFile<Acc1bRecord> b = f;
  b.header.binary = true;
  auto back = parseProduct<Acc1bRecord>(formatProduct(b), "ACC1B_2003-09-14_A_00.dat");
  ASSERT_TRUE(back.ok) << back.error;
  EXPECT_TRUE(back.header.binary);
  ASSERT_TRUE(back.header.declared_records.has_value());
  EXPECT_EQ(*back.header.declared_records, 1);
  EXPECT_EQ(back.records, f.records);
}

// Regression (found by fuzz_gnv with 20-30 s per reader): a fixed header whose first key merely starts
// with "header:" was written as if YAML (a YAML record count inserted, none in the fixed style), so the
// product read back without a declared count. The writer now takes the style as the reader does.
TEST(FixedHeader, AFirstKeyStartingWithHeaderColonStaysFixedAndGetsItsCount) {
  const std::string text =
      "header:x                      : not YAML\n"
      "SATELLITE NAME                : GRACE-FO 1\n"
      "END OF HEADER\n";
  for (const std::string& body : {std::string(), std::string("620611200 C E 6800000 0 0 0 0 0 0 7600 0 0 0 0 00000000\n")}) {
    SCOPED_TRACE(body.empty() ? "no records" : "one record");
    auto f = parseProduct<GnvRecord>(text + body, "GNV1B_2019-09-01_C_04.txt");
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_EQ(f.header.style, HeaderStyle::Fixed);
    EXPECT_EQ(f.records.size(), body.empty() ? 0u : 1u);
    EXPECT_EQ(f.rejected_count, 0u);
    const std::string out = formatProduct(f);
    auto back = parseProduct<GnvRecord>(out, "GNV1B_2019-09-01_C_04.txt");
    ASSERT_TRUE(back.ok) << back.error;
    ASSERT_TRUE(back.header.declared_records.has_value()) << out;
    EXPECT_EQ(*back.header.declared_records, static_cast<std::int64_t>(f.records.size()));
    EXPECT_EQ(out.find("num_records"), std::string::npos) << "no YAML entry in a fixed header:\n" << out;
  }
}

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

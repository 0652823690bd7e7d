#include <boresight/io/level1.h>
#include <boresight/io/text_scan.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

using namespace boresight::io;

TEST(FieldScanner, ParsesNumbersExactly) {
  FieldScanner s("0.1 -2.5e-07 12 1e+33");
  double a, b, d;
  int c;
  ASSERT_TRUE(s.f64(a, "a"));
  ASSERT_TRUE(s.f64(b, "b"));
  ASSERT_TRUE(s.integer(c, "c"));
  ASSERT_TRUE(s.f64(d, "d"));
  EXPECT_EQ(a, 0.1);
  EXPECT_EQ(b, -2.5e-07);
  EXPECT_EQ(c, 12);
  EXPECT_EQ(d, 1e33);
  EXPECT_TRUE(s.finish());
}

TEST(FieldScanner, RejectsWithReasons) {
  {
    FieldScanner s("1.0 abc");
    double v;
    ASSERT_TRUE(s.f64(v, "first"));
    EXPECT_FALSE(s.f64(v, "second"));
    EXPECT_EQ(s.reason(), "field 2 (second): not a number: 'abc'");
  }
  {
    FieldScanner s("nan");
    double v;
    EXPECT_FALSE(s.f64(v, "q0"));
    EXPECT_NE(s.reason().find("non-finite"), std::string::npos);
  }
  {
    FieldScanner s("1");
    double v;
    ASSERT_TRUE(s.f64(v, "a"));
    EXPECT_FALSE(s.f64(v, "b"));
    EXPECT_NE(s.reason().find("missing"), std::string::npos);
  }
  {
    FieldScanner s("1 2");
    double v;
    ASSERT_TRUE(s.f64(v, "a"));
    EXPECT_FALSE(s.finish());
    EXPECT_NE(s.reason().find("extra"), std::string::npos);
  }
  {
    FieldScanner s("0102");
    Bits b;
    EXPECT_FALSE(s.bits(b, "flag"));
  }
}

TEST(FieldScanner, BitsAreMostSignificantFirst) {
  Bits b;
  ASSERT_TRUE(FieldScanner::parseBits("00000100000000000000000000111111", b));
  EXPECT_EQ(b.width, 32);
  for (int i = 0; i < 6; ++i) EXPECT_TRUE(b.test(i));
  EXPECT_FALSE(b.test(6));
  EXPECT_TRUE(b.test(26));
}

TEST(LineWriter, ShortestRoundTrip) {
  const double vals[] = {0.1, -0.2800946131535094, 1e-300, 5e-324, std::numeric_limits<double>::max(), 0.0, -0.0,
                         738849600.029992, 1.0 / 3.0};
  std::string line;
  LineWriter w(line);
  for (double v : vals) w.f64(v);
  FieldScanner s(line);
  for (double v : vals) {
    double r;
    ASSERT_TRUE(s.f64(r, "v")) << s.reason();
    EXPECT_EQ(std::memcmp(&r, &v, sizeof r), 0) << v;
  }
}

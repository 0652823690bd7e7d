// io::ChunkedProductWriter: a product written in chunks reads back as the same records, and its header
// states what is known only at the end - the record count and, when asked, the records' time span - in
// both header styles (GRACE-FO's YAML, GRACE's fixed header); with no records the span stays blank and
// the file still reads.
#include <boresight/io/chunked_writer.h>
#include <boresight/io/files.h>
#include <boresight/io/level1.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace boresight;

namespace {

constexpr TimeUs kT0 = 738849600LL * kUsPerSecond;  // 2023-06-01 00:00:00 GPS

io::Sca1bRecord rec(TimeUs t, char sat) {
  io::Sca1bRecord r;
  r.t = t;
  r.satellite = sat;
  r.sca_id = 5;
  r.q[0] = 0.5, r.q[1] = 0.5, r.q[2] = -0.5, r.q[3] = 0.5;
  r.qual_rss = 1e-6;
  return r;
}

std::string readText(const std::string& path) {
  std::string text, err;
  EXPECT_TRUE(io::readBounded(path, 1u << 20, "product", text, &err)) << err;
  return text;
}

}  // namespace

TEST(ChunkedProductWriter, TheYamlHeaderStatesTheCountAndTheRecordsTimeSpan) {
  const std::string path = testutil::makeTempDir("chunked_yaml") + "/SCA1B_2023-06-01_C_04.txt";
  io::ChunkedProductWriter<io::Sca1bRecord> w;
  std::string err;
  ASSERT_TRUE(w.open(path, io::makeProduct<io::Sca1bRecord>(io::Product::SCA1B, 'C'), &err, 7, true)) << err;
  // 100 records one second apart from 00:00:05, in chunks of 7 (the last one partial)
  for (int k = 0; k < 100; ++k) w.add(rec(kT0 + (5 + k) * kUsPerSecond, 'C'));
  EXPECT_EQ(w.written(), 100u);
  ASSERT_TRUE(w.close(&err)) << err;
  const auto f = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(f.ok) << f.error;
  ASSERT_EQ(f.records.size(), 100u);
  EXPECT_EQ(f.records.front().t, kT0 + 5 * kUsPerSecond);
  EXPECT_EQ(f.records.back().t, kT0 + 104 * kUsPerSecond);
  ASSERT_TRUE(f.header.declared_records.has_value());
  EXPECT_EQ(*f.header.declared_records, 100);
  EXPECT_EQ(f.header.coverage_start_s, 738849605.0);
  EXPECT_EQ(f.header.coverage_stop_s, 738849704.0);
  const std::string text = readText(path);
  EXPECT_NE(text.find("    time_coverage_start: 2023-06-01T00:00:05.00"), std::string::npos) << text.substr(0, 600);
  EXPECT_NE(text.find("    time_coverage_stop: 2023-06-01T00:01:44.00"), std::string::npos);
}

TEST(ChunkedProductWriter, TheFixedHeaderStatesTheFirstAndLastObservation) {
  const std::string path = testutil::makeTempDir("chunked_fixed") + "/SCA1B_2003-09-14_A_00.asc";
  constexpr TimeUs t0 = 116769600LL * kUsPerSecond;  // 2003-09-14 00:00:00 GPS (the GRACE excerpt's first)
  io::ChunkedProductWriter<io::Sca1bRecord> w;
  std::string err;
  ASSERT_TRUE(w.open(path, io::makeProduct<io::Sca1bRecord>(io::Product::SCA1B, 'A'), &err, 4, true)) << err;
  for (int k = 0; k < 60; ++k) w.add(rec(t0 + 5 * k * kUsPerSecond, 'A'));
  ASSERT_TRUE(w.close(&err)) << err;
  const auto f = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_EQ(f.records.size(), 60u);
  const std::string text = readText(path);
  // as the GRACE excerpt's header has them
  EXPECT_NE(text.find("TIME FIRST OBS(SEC PAST EPOCH): 116769600.000000 (2003-09-14 00:00:00.00)"), std::string::npos)
      << text.substr(0, 900);
  EXPECT_NE(text.find("TIME LAST OBS(SEC PAST EPOCH) : 116769895.000000 (2003-09-14 00:04:55.00)"), std::string::npos);
  EXPECT_NE(text.find("NUMBER OF DATA RECORDS        : 60"), std::string::npos);
}

TEST(ChunkedProductWriter, WithNoRecordsTheSpanStaysBlankAndTheFileReads) {
  const std::string path = testutil::makeTempDir("chunked_empty") + "/SCA1B_2023-06-01_C_04.txt";
  io::ChunkedProductWriter<io::Sca1bRecord> w;
  std::string err;
  ASSERT_TRUE(w.open(path, io::makeProduct<io::Sca1bRecord>(io::Product::SCA1B, 'C'), &err, 16, true)) << err;
  ASSERT_TRUE(w.close(&err)) << err;
  const auto f = io::readProduct<io::Sca1bRecord>(path);
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_TRUE(f.records.empty());
  EXPECT_TRUE(std::isnan(f.header.coverage_start_s));
  EXPECT_TRUE(std::isnan(f.header.coverage_stop_s));
  ASSERT_TRUE(f.header.declared_records.has_value());
  EXPECT_EQ(*f.header.declared_records, 0);
}

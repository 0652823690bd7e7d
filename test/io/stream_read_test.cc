// The streaming readers against the whole-file readers on the same bytes: ProductStream (records,
// rejected lines and their numbers, with buffers far smaller than the file) and the block-parallel
// summarizeProduct (counts, times, issues across block boundaries, any thread count).
#include <boresight/io/any_product.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>
#include <boresight/io/sca_geometry.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <cstdio>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

using namespace boresight;
using namespace boresight::io;

namespace {

std::string tempDir() { return testutil::makeTempDir("boresight_streamio"); }

void writeFile(const std::string& path, const std::string& text) {
  ASSERT_TRUE(testutil::writeFile(path, text)) << path;
}

/// An ACC1A text of n records with malformed, blank and long lines sprinkled in (and optionally a
/// last line cut in half without its newline).
std::string acc1aText(int n, bool cut_last, std::vector<std::size_t>* bad_lines = nullptr) {
  auto f = makeProduct<FlaggedRecord>(Product::ACC1A, 'C');
  std::string header = formatProduct(f);
  std::size_t line = 0;
  for (char c : header) line += c == '\n';
  std::mt19937 rng(5);
  std::string body;
  char buf[512];
  for (int k = 0; k < n; ++k) {
    ++line;
    if (k % 9973 == 17) {
      body += "738849600 12 R C 00000000 00000000000000000000000000111111 1e-5 abc 1 2 3 4\n";
      if (bad_lines) bad_lines->push_back(line);
      continue;
    }
    if (k % 7919 == 3) {
      body += "   \n";
      continue;
    }
    std::snprintf(buf, sizeof buf,
                  "%d %d R C 00000000 00000100000000000000000000111111 %.15e %.15e %.15e %.15e %.15e %.15e 0\n",
                  738849600 + k / 10, (k % 10) * 100000 + 7739, -1.06e-5 + 1e-9 * (rng() % 1000),
                  -1.8e-7, 2.8e-7, 1.3e-5, 1.192e-4, -7.813e-4);
    body += buf;
  }
  if (cut_last) {
    const std::size_t last = body.rfind('\n', body.size() - 2);
    body.resize(last + 1 + (body.size() - last - 1) / 2);
    if (bad_lines) bad_lines->push_back(line);
  }
  return header + body;
}

}  // namespace

TEST(ProductStream, SameRecordsAndIssuesAsTheWholeFileReader) {
  const std::string d = tempDir();
  const std::string path = d + "/ACC1A_2023-06-01_C_04.txt";
  std::vector<std::size_t> bad;
  const std::string text = acc1aText(60000, true, &bad);
  writeFile(path, text);
  auto whole = parseProduct<FlaggedRecord>(text, path);
  ASSERT_TRUE(whole.ok);
  ASSERT_EQ(whole.rejected_count, bad.size());
  for (std::size_t chunk : {std::size_t(4096), std::size_t(100000), LineStream::kDefaultChunk}) {
    ProductStream<FlaggedRecord> s;
    std::string err;
    ASSERT_TRUE(s.open(path, {}, &err, chunk)) << err;
    FlaggedRecord r;
    std::size_t i = 0;
    while (s.next(r)) {
      ASSERT_LT(i, whole.records.size()) << "extra record t=" << r.t << " chunk " << chunk << " rejected so far " << s.rejectedCount();
      ASSERT_TRUE(r == whole.records[i]) << "record " << i << " chunk " << chunk;
      ++i;
    }
    EXPECT_TRUE(s.ok()) << s.error();
    EXPECT_EQ(i, whole.records.size());
    EXPECT_EQ(s.rejectedCount(), whole.rejected_count);
    ASSERT_EQ(s.rejected().size(), whole.rejected.size());
    for (std::size_t k = 0; k < whole.rejected.size(); ++k) EXPECT_EQ(s.rejected()[k].str(), whole.rejected[k].str());
  }
}

TEST(ProductStream, StrictStopsAtTheFirstBadLineWithItsPlace) {
  const std::string d = tempDir();
  const std::string path = d + "/ACC1A_2023-06-01_C_04.txt";
  std::vector<std::size_t> bad;
  writeFile(path, acc1aText(200, false, &bad));
  ReadOptions o;
  o.on_error = OnError::Stop;
  ProductStream<FlaggedRecord> s;
  std::string err;
  ASSERT_TRUE(s.open(path, o, &err, 4096));
  FlaggedRecord r;
  std::size_t n = 0;
  while (s.next(r)) ++n;
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(n, 16u);
  EXPECT_EQ(s.error().rfind(path + ":" + std::to_string(bad.front()) + ": ", 0), 0u) << s.error();
}

TEST(ProductStream, RefusesWhatItCannotRead) {
  const std::string d = tempDir();
  std::string err;
  ProductStream<Sca1aRecord> s;
  writeFile(d + "/SCA1A_empty.txt", "");
  EXPECT_FALSE(s.open(d + "/SCA1A_empty.txt", {}, &err));
  EXPECT_NE(err.find("SCA1A_empty.txt:1: empty file"), std::string::npos) << err;
  writeFile(d + "/ACC1A_x.txt", acc1aText(10, false));
  EXPECT_FALSE(s.open(d + "/ACC1A_x.txt", {}, &err));  // an ACC1A is not read as SCA1A
  EXPECT_NE(err.find("ACC1A"), std::string::npos) << err;
  EXPECT_FALSE(s.open(d + "/missing.txt", {}, &err));
  EXPECT_NE(err.find("missing.txt:0: cannot open"), std::string::npos) << err;
}

TEST(SummarizeProduct, BlocksAndThreadsGiveTheWholeFileSummary) {
  const std::string d = tempDir();
  const std::string path = d + "/ACC1A_2023-06-01_C_04.txt";
  // About 14 MB: several 4 MB blocks, bad lines in each, a cut last line.
  std::vector<std::size_t> bad;
  const std::string text = acc1aText(90000, true, &bad);
  ASSERT_GT(text.size(), 12u << 20);
  writeFile(path, text);
  const ProductSummary ref = summarizeText(text, path);
  ASSERT_TRUE(ref.ok);
  ASSERT_EQ(ref.rejected_count, bad.size());
  for (int threads : {1, 2, 3, 0}) {
    ReadOptions o;
    o.threads = threads;
    const ProductSummary s = summarizeProduct(path, o);
    EXPECT_TRUE(s.ok) << s.error;
    EXPECT_EQ(s.product, ref.product);
    EXPECT_EQ(s.satellite, ref.satellite);
    EXPECT_EQ(s.records, ref.records) << threads;
    EXPECT_EQ(s.declared_records, ref.declared_records);
    EXPECT_EQ(s.first_time, ref.first_time);
    EXPECT_EQ(s.last_time, ref.last_time);
    EXPECT_EQ(s.rejected_count, ref.rejected_count);
    ASSERT_EQ(s.rejected.size(), ref.rejected.size());
    for (std::size_t k = 0; k < ref.rejected.size(); ++k) {
      EXPECT_EQ(s.rejected[k].str(), ref.rejected[k].str()) << threads;
      EXPECT_EQ(s.rejected[k].line, bad[k]);
    }
  }
}

TEST(ProductStream, MutatedFilesReadAsTheWholeFileReaderReadsThem) {
  // Random byte damage (digits, separators, newlines, NUL, CR) in a file several buffers long:
  // the stream gives the same records and the same rejected lines as parseProduct, whatever the
  // buffer size, and summarizeProduct the same summary as summarizeText.
  const std::string d = tempDir();
  const std::string clean = acc1aText(1500, false);  // ~300 kB: beyond the 64 kB header read
  std::mt19937 rng(17);
  const char junk[] = {'x', ' ', '\n', '\0', '\r', '-', '.', 'e', '9', '\t'};
  for (int trial = 0; trial < 60; ++trial) {
    std::string text = clean;
    const int hits = 1 + static_cast<int>(rng() % 40);
    const std::size_t header_end = text.find("# End of YAML header\n") + 21;
    for (int h = 0; h < hits; ++h) {
      const std::size_t at = header_end + rng() % (text.size() - header_end);
      text[at] = junk[rng() % sizeof junk];
    }
    if (trial % 3 == 0) text.resize(text.size() - rng() % 300);
    const std::string path = d + "/ACC1A_m" + std::to_string(trial) + ".txt";
    writeFile(path, text);
    const auto whole = parseProduct<FlaggedRecord>(text, path);
    ASSERT_TRUE(whole.ok) << whole.error;
    for (std::size_t chunk : {std::size_t(4096), std::size_t(5000)}) {
      ProductStream<FlaggedRecord> s;
      std::string err;
      ASSERT_TRUE(s.open(path, {}, &err, chunk)) << err;
      FlaggedRecord r;
      std::size_t i = 0;
      while (s.next(r)) {
        ASSERT_LT(i, whole.records.size()) << "trial " << trial;
        ASSERT_TRUE(r == whole.records[i]) << "trial " << trial << " record " << i;
        ++i;
      }
      EXPECT_EQ(i, whole.records.size()) << "trial " << trial;
      ASSERT_EQ(s.rejected().size(), whole.rejected.size()) << "trial " << trial;
      for (std::size_t k = 0; k < whole.rejected.size(); ++k)
        EXPECT_EQ(s.rejected()[k].str(), whole.rejected[k].str()) << "trial " << trial;
    }
    const ProductSummary a = summarizeProduct(path), b = summarizeText(text, path);
    EXPECT_EQ(a.records, b.records) << "trial " << trial;
    EXPECT_EQ(a.rejected_count, b.rejected_count) << "trial " << trial;
    EXPECT_EQ(a.first_time, b.first_time) << "trial " << trial;
    EXPECT_EQ(a.last_time, b.last_time) << "trial " << trial;
  }
}

TEST(IbaAccumulator, SameResultsAsTheWholeFileFunctionAndRefusesGoingBack) {
  std::mt19937 rng(9);
  std::normal_distribution<double> n01;
  std::vector<Sca1aRecord> recs;
  for (int k = 0; k < 3000; ++k) {
    for (int h = 1; h <= 3; ++h) {
      if (h == 3 && k % 11 < 3) continue;  // head 3 blind now and then
      Sca1aRecord r;
      r.t = 738849600LL * kUsPerSecond + k * 500000LL;
      r.head = static_cast<std::uint8_t>(h);
      Quat q(Eigen::AngleAxisd(0.001 * k + h, Vec3(0.3 * h, 1, 0.2).normalized()));
      q.coeffs() += 2e-5 * Eigen::Vector4d(n01(rng), n01(rng), n01(rng), n01(rng));
      quatToScalarFirst(q.normalized(), r.q);
      recs.push_back(r);
      if (k == 100 && h == 2) {  // a repeated head in one epoch: the last one counts
        quatToScalarFirst(Quat(Eigen::AngleAxisd(0.3, Vec3::UnitX())), r.q);
        recs.push_back(r);
      }
    }
  }
  std::vector<QsaRecord> qsa(3);
  for (int h = 0; h < 3; ++h) {
    qsa[std::size_t(h)].sensor = h + 1;
    quatToScalarFirst(Quat(Eigen::AngleAxisd(0.8 * h, Vec3::UnitY())), qsa[std::size_t(h)].q);
  }
  const auto ref = interBoresightAngles(recs, &qsa);
  IbaAccumulator acc;
  for (const auto& r : recs) ASSERT_TRUE(acc.add(r));
  const auto got = acc.finish(&qsa);
  ASSERT_EQ(got.size(), 3u);
  ASSERT_EQ(got.size(), ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_EQ(got[i].head_a, ref[i].head_a);
    EXPECT_EQ(got[i].head_b, ref[i].head_b);
    EXPECT_EQ(got[i].epochs, ref[i].epochs);
    EXPECT_EQ(got[i].mean_deg, ref[i].mean_deg);
    EXPECT_EQ(got[i].std_arcsec, ref[i].std_arcsec);
    EXPECT_EQ(got[i].nominal_deg, ref[i].nominal_deg);
    EXPECT_EQ(got[i].offset_arcsec, ref[i].offset_arcsec);
  }
  EXPECT_EQ(got[1].epochs, 3000u - 3000u / 11 * 3 - std::min(3u, 3000u % 11));  // pair 1-3
  IbaAccumulator back;
  EXPECT_TRUE(back.add(recs[10]));
  EXPECT_FALSE(back.add(recs[0]));
}

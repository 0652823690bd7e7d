// Parsing a large body on several threads gives exactly what one thread gives: the same records in
// the same order, the same rejected lines with the same line numbers.
#include <boresight/io/level1.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

using namespace boresight;
using namespace boresight::io;

namespace {

std::string makeSca1a(int records, std::mt19937_64& rng, std::vector<std::size_t>* bad_lines) {
  auto f = makeProduct<Sca1aRecord>(Product::SCA1A, 'C');
  std::normal_distribution<double> n01;
  for (int k = 0; k < records; ++k) {
    Sca1aRecord r;
    r.t = 738849600LL * kUsPerSecond + k * 500000LL / 3;
    r.head = static_cast<std::uint8_t>(1 + k % 3);
    for (double& q : r.q) q = n01(rng);
    const double n = std::sqrt(r.q[0] * r.q[0] + r.q[1] * r.q[1] + r.q[2] * r.q[2] + r.q[3] * r.q[3]);
    for (double& q : r.q) q /= n;  // unit: only the corrupted lines are rejected
    r.nstars = k % 50;
    f.records.push_back(r);
  }
  std::string text = formatProduct(f);
  // Corrupt some record lines (and add blank ones) at random places.
  std::string out;
  std::size_t line = 0, pos = 0;
  std::uniform_int_distribution<int> pick(0, 997);
  while (pos < text.size()) {
    std::size_t e = text.find('\n', pos);
    std::string l = text.substr(pos, e - pos);
    pos = e + 1;
    ++line;
    bool is_record = !l.empty() && l[0] >= '0' && l[0] <= '9';
    int dice = pick(rng);
    if (is_record && dice == 0) {
      l = l.substr(0, l.size() / 2);  // truncated
      bad_lines->push_back(line);
    } else if (is_record && dice == 1) {
      l[l.find(' ') + 1] = 'x';  // non-numeric
      bad_lines->push_back(line);
    } else if (is_record && dice == 2) {
      out += "\n";  // a blank line: skipped, but it counts for the numbering
      ++line;
    }
    out += l;
    out += '\n';
  }
  return out;
}

}  // namespace

TEST(ParallelParse, SameRecordsAndIssuesAsOneThread) {
  std::mt19937_64 rng(7);
  std::vector<std::size_t> bad;
  const std::string text = makeSca1a(120000, rng, &bad);  // ~13 MB: above the parallel threshold
  ASSERT_GT(text.size(), std::size_t(8u << 20));
  ASSERT_GT(bad.size(), 100u);
  ReadOptions one, many;
  one.threads = 1;
  many.threads = 3;
  one.max_issues_kept = many.max_issues_kept = 100000;
  auto a = parseProduct<Sca1aRecord>(text, "SCA1A_x.txt", one);
  auto b = parseProduct<Sca1aRecord>(text, "SCA1A_x.txt", many);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(a.records.size() + bad.size(), 120000u);
  EXPECT_EQ(a.records, b.records);
  ASSERT_EQ(a.rejected_count, bad.size());
  ASSERT_EQ(b.rejected_count, bad.size());
  ASSERT_EQ(a.rejected.size(), b.rejected.size());
  for (std::size_t i = 0; i < a.rejected.size(); ++i) {
    EXPECT_EQ(a.rejected[i].line, bad[i]);
    EXPECT_EQ(b.rejected[i].line, bad[i]);
    EXPECT_EQ(a.rejected[i].reason, b.rejected[i].reason);
  }
  // Automatic mode and Stop mode agree with the single thread too.
  ReadOptions stop;
  stop.on_error = OnError::Stop;
  auto c = parseProduct<Sca1aRecord>(text, "SCA1A_x.txt", stop);
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.error, a.rejected.front().str());
}

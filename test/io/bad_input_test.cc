// Bad input: every malformed line gives "file:line: reason", the caller's skip/stop choice works,
// and no input (garbage, truncation, NaN, CRLF, empty) crashes a reader.
#include <boresight/io/any_product.h>
#include <boresight/io/level1.h>

#include <gtest/gtest.h>

#include <random>

using namespace boresight;
using namespace boresight::io;

namespace {

/// A small valid SCA1B text (YAML header) with n records, line numbers known.
std::string sca1bText(char sat, int n, std::size_t* header_lines) {
  auto f = makeProduct<Sca1bRecord>(Product::SCA1B, sat);
  for (int i = 0; i < n; ++i) {
    Sca1bRecord r;
    r.t = (700000000LL + i) * kUsPerSecond;
    r.satellite = sat;
    r.q[0] = 0.5;
    r.q[1] = -0.5;
    r.q[2] = 0.5;
    r.q[3] = -0.5;
    r.qual_rss = 1e-6;
    f.records.push_back(r);
  }
  std::string text = formatProduct(f);
  if (header_lines) {
    auto h = parseProduct<Sca1bRecord>(text, "SCA1B_x.txt");
    *header_lines = h.header.line_count;
  }
  return text;
}

/// Replace data line k (1-based among records) with `line`.
std::string replaceRecord(const std::string& text, std::size_t header_lines, int k, const std::string& line) {
  std::size_t pos = 0;
  for (std::size_t i = 0; i < header_lines + static_cast<std::size_t>(k) - 1; ++i) pos = text.find('\n', pos) + 1;
  std::size_t e = text.find('\n', pos);
  std::string out = text;
  out.replace(pos, e - pos, line);
  return out;
}

struct BadLine {
  std::string line;
  std::string reason_part;
};

}  // namespace

TEST(BadInput, MalformedLinesGiveFileLineReason) {
  std::size_t hl = 0;
  const std::string good = sca1bText('C', 5, &hl);
  const std::vector<BadLine> cases = {
      {"700000002 C 23 0.5 -0.5 0.5", "field 7 (quatkcoeff): missing"},                               // truncated
      {"700000002 C 23 0.5 -0.5 abc -0.5 1e-06 00000000", "field 6 (quatjcoeff): not a number: 'abc'"},  // non-numeric
      {"700000002 C 23 nan -0.5 0.5 -0.5 1e-06 00000000", "field 4 (quatangle): non-finite number"},    // NaN
      {"700000002 C 23 0.5 -0.5 0.5 -0.5 inf 00000000", "field 8 (qual_rss): non-finite number"},
      {"700000002 C 23 0.5 -0.5 0.5 -0.5 1e-06 00000002", "field 9 (qualflg): not a bit string"},
      {"700000002 C 23 0.5 -0.5 0.5 -0.5 1e-06 00000000 extra", "unexpected extra field"},
      {"7000x0002 C 23 0.5 -0.5 0.5 -0.5 1e-06 00000000", "field 1 (gps_time): not an integer"},
      {"700000002 CC 23 0.5 -0.5 0.5 -0.5 1e-06 00000000", "field 2 (GRACEFO_id): expected one character"},
      {"700000002 C 999 0.5 -0.5 0.5 -0.5 1e-06 00000000", "field 3 (sca_id): outside [-128, 127]"},
      {"700000002 C 23 1e999 -0.5 0.5 -0.5 1e-06 00000000", "number out of range"},
      {std::string("700000002 C 23 0.5 -0.5 \x01\xff 0.5 1e-06 00000000"), "not a number"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.line);
    const std::string text = replaceRecord(good, hl, 3, c.line);
    auto f = parseProduct<Sca1bRecord>(text, "SCA1B_2022-03-08_C_04.txt");
    ASSERT_TRUE(f.ok) << f.error;  // default: skip and count
    EXPECT_EQ(f.records.size(), 4u);
    ASSERT_EQ(f.rejected_count, 1u);
    ASSERT_EQ(f.rejected.size(), 1u);
    EXPECT_EQ(f.rejected[0].line, hl + 3);
    EXPECT_EQ(f.rejected[0].str().rfind("SCA1B_2022-03-08_C_04.txt:" + std::to_string(hl + 3) + ": ", 0), 0u)
        << f.rejected[0].str();
    EXPECT_NE(f.rejected[0].reason.find(c.reason_part), std::string::npos) << f.rejected[0].reason;
  }
}

TEST(BadInput, SkipCountsAndStopStopsAtTheFirstBadLine) {
  std::size_t hl = 0;
  std::string text = sca1bText('A', 6, &hl);
  text = replaceRecord(text, hl, 2, "garbage");
  text = replaceRecord(text, hl, 5, "700000004 A 23 0.5");
  auto skip = parseProduct<Sca1bRecord>(text, "SCA1B_2022-03-08_A_00.asc");
  ASSERT_TRUE(skip.ok);
  EXPECT_EQ(skip.records.size(), 4u);
  EXPECT_EQ(skip.rejected_count, 2u);
  ASSERT_EQ(skip.rejected.size(), 2u);
  EXPECT_EQ(skip.rejected[0].line, hl + 2);
  EXPECT_EQ(skip.rejected[1].line, hl + 5);

  ReadOptions keep_one;
  keep_one.max_issues_kept = 1;
  auto capped = parseProduct<Sca1bRecord>(text, "SCA1B_2022-03-08_A_00.asc", keep_one);
  EXPECT_EQ(capped.rejected_count, 2u);
  EXPECT_EQ(capped.rejected.size(), 1u);

  ReadOptions stop;
  stop.on_error = OnError::Stop;
  auto st = parseProduct<Sca1bRecord>(text, "SCA1B_2022-03-08_A_00.asc", stop);
  EXPECT_FALSE(st.ok);
  EXPECT_EQ(st.records.size(), 1u);
  EXPECT_EQ(st.rejected_count, 1u);
  EXPECT_EQ(st.error, st.rejected[0].str());
  EXPECT_EQ(st.error.rfind("SCA1B_2022-03-08_A_00.asc:" + std::to_string(hl + 2) + ": ", 0), 0u) << st.error;

  ProductSummary s = summarizeText(text, "SCA1B_2022-03-08_A_00.asc", stop);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(s.error, st.error);
}

TEST(BadInput, WholeFileErrors) {
  struct Case {
    std::string text, file, part;
  };
  std::string yaml_no_end = sca1bText('C', 2, nullptr);
  yaml_no_end.erase(yaml_no_end.find("# End of YAML header"));
  std::string fixed_no_end = sca1bText('A', 2, nullptr);
  fixed_no_end.erase(fixed_no_end.find("END OF HEADER"));
  const std::vector<Case> cases = {
      {"", "SCA1B_x.txt", "empty file"},
      {"\n\n  \n", "SCA1B_x.txt", "empty file"},
      {"hello world\n1 2 3\n", "SCA1B_x.txt", "wrong header"},
      {yaml_no_end, "SCA1B_x.txt", "without its end line"},
      {fixed_no_end, "SCA1B_x.txt", "without 'END OF HEADER'"},
      {sca1bText('C', 2, nullptr), "notes.txt", "unknown product"},
      {sca1bText('C', 2, nullptr), "XYZ.txt", "unknown product"},
      {sca1bText('C', 2, nullptr), "ACC1A_2023-06-01_C_04.txt", "cannot be read as SCA1B"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file + " / " + c.part);
    auto f = parseProduct<Sca1bRecord>(c.text, c.file);
    EXPECT_FALSE(f.ok);
    EXPECT_EQ(f.error.rfind(c.file + ":", 0), 0u) << f.error;
    EXPECT_NE(f.error.find(c.part), std::string::npos) << f.error;
    EXPECT_EQ(f.error.find('\n'), std::string::npos);
    ProductSummary s = summarizeText(c.text, c.file);
    if (c.part.find("cannot be read as") != std::string::npos) {
      EXPECT_TRUE(s.ok);  // summarize picks the right reader (ACC1A here): it is a broken ACC1A, rejected lines
      EXPECT_EQ(s.product, "ACC1A");
      EXPECT_EQ(s.rejected_count, 2u);
      continue;
    }
    EXPECT_FALSE(s.ok);
    EXPECT_EQ(s.error.rfind(c.file + ":", 0), 0u) << s.error;
  }
  ProductSummary missing = summarizeProduct("/nonexistent/dir/SCA1B_2023-06-01_C_04.txt");
  EXPECT_FALSE(missing.ok);
  EXPECT_EQ(missing.error.rfind("/nonexistent/dir/SCA1B_2023-06-01_C_04.txt:0: cannot open", 0), 0u) << missing.error;
}

TEST(BadInput, ZeroRecordFileIsValid) {
  const std::string text = sca1bText('C', 0, nullptr);
  auto f = parseProduct<Sca1bRecord>(text, "SCA1B_2022-03-08_C_04.txt");
  ASSERT_TRUE(f.ok) << f.error;
  EXPECT_TRUE(f.records.empty());
  EXPECT_EQ(f.rejected_count, 0u);
  ProductSummary s = summarizeText(text, "SCA1B_2022-03-08_C_04.txt");
  EXPECT_TRUE(s.ok);
  EXPECT_EQ(s.records, 0u);
  EXPECT_FALSE(s.has_time);
}

TEST(BadInput, CrlfLineEndsReadLikeLf) {
  for (char sat : {'C', 'A'}) {
    const std::string lf = sca1bText(sat, 4, nullptr);
    std::string crlf;
    for (char c : lf) {
      if (c == '\n') crlf += '\r';
      crlf += c;
    }
    auto a = parseProduct<Sca1bRecord>(lf, "SCA1B_x.txt");
    auto b = parseProduct<Sca1bRecord>(crlf, "SCA1B_x.txt");
    ASSERT_TRUE(b.ok) << b.error;
    EXPECT_EQ(b.rejected_count, 0u);
    EXPECT_EQ(b.records, a.records);
    EXPECT_EQ(b.header.satellite, sat);
    EXPECT_EQ(b.header.declared_records, a.header.declared_records);
  }
}

TEST(BadInput, BinaryGarbageNeverCrashesAnyReader) {
  std::mt19937_64 rng(7);
  for (int round = 0; round < 300; ++round) {
    std::string junk(static_cast<std::size_t>(rng() % 600), '\0');
    for (auto& c : junk) c = static_cast<char>(rng() & 0xff);
    if (round % 3 == 1) junk = "header:\n" + junk;
    if (round % 3 == 2) junk = "FILE FORMAT 0=BINARY 1=ASCII  : 0\nEND OF HEADER\n" + junk;
    EXPECT_FALSE(parseProduct<Sca1aRecord>(junk, "SCA1A_x.txt").records.size() > junk.size());
    (void)parseProduct<FlaggedRecord>(junk, "ACC1A_x.txt");
    (void)parseProduct<Sca1bRecord>(junk, "SCA1B_x.dat");
    (void)parseProduct<Acc1bRecord>(junk, "ACC1B_x.dat");
    (void)parseProduct<GnvRecord>(junk, "GNV1B_x.dat");
    (void)parseProduct<QsaRecord>(junk, "QSA1B_x.txt");
    (void)parseProduct<ImuRecord>(junk, "IMU1B_x.txt");
    (void)parseProduct<ThrRecord>(junk, "THR1B_x.txt");
    (void)parseProduct<IhkRecord>(junk, "IHK1B_x.txt");
    (void)parseProduct<HrtRecord>(junk, "HRT1B_x.txt");
    (void)parseProduct<TimRecord>(junk, "TIM1B_x.txt");
    (void)parseProduct<ClkRecord>(junk, "CLK1B_x.txt");
    (void)parseGeneric(junk, "KBR1B_x.txt");
    ProductSummary s = summarizeText(junk, "x.dat");
    if (!s.ok) {
      EXPECT_EQ(s.error.rfind("x.dat:", 0), 0u) << s.error;
      EXPECT_EQ(s.error.find('\n'), std::string::npos);
    }
  }
}

TEST(BadInput, BinaryRecordsBadValuesAndTruncation) {
  auto f = makeProduct<Sca1bRecord>(Product::SCA1B, 'A');
  f.header.binary = true;
  for (int i = 0; i < 4; ++i) {
    Sca1bRecord r;
    r.satellite = 'A';
    r.t = (116769600LL + 5 * i) * kUsPerSecond;
    f.records.push_back(r);
  }
  std::string bytes = formatProduct(f);
  const std::size_t data = bytes.size() - 4 * 47;
  bytes[data + 47 + 4] = '\x01';               // record 2: GRACE_id not a letter
  std::memset(&bytes[data + 2 * 47 + 6], 0xff, 8);  // record 3: quatangle NaN
  bytes.resize(bytes.size() - 20);             // record 4 truncated to 27 bytes
  auto g = parseProduct<Sca1bRecord>(bytes, "SCA1B_2003-09-14_A_00.dat");
  ASSERT_TRUE(g.ok) << g.error;
  EXPECT_EQ(g.records.size(), 1u);
  ASSERT_EQ(g.rejected_count, 3u);
  EXPECT_NE(g.rejected[0].reason.find("record 2"), std::string::npos) << g.rejected[0].str();
  EXPECT_NE(g.rejected[0].reason.find("GRACE_id"), std::string::npos);
  EXPECT_NE(g.rejected[1].reason.find("quatangle: non-finite"), std::string::npos) << g.rejected[1].str();
  EXPECT_NE(g.rejected[2].reason.find("truncated record: 27 of 47 bytes"), std::string::npos) << g.rejected[2].str();
  EXPECT_EQ(g.rejected[2].line, g.header.line_count + 4);
  ReadOptions stop;
  stop.on_error = OnError::Stop;
  auto h = parseProduct<Sca1bRecord>(bytes, "SCA1B_2003-09-14_A_00.dat", stop);
  EXPECT_FALSE(h.ok);
  EXPECT_EQ(h.records.size(), 1u);
  EXPECT_EQ(h.error, h.rejected[0].str());
  ProductSummary s = summarizeText(bytes, "SCA1B_2003-09-14_A_00.dat");
  EXPECT_TRUE(s.ok);
  EXPECT_TRUE(s.binary);
  EXPECT_EQ(s.records, 1u);
  EXPECT_EQ(s.rejected_count, 3u);
  // A binary product without a binary reader: a clear refusal.
  std::string kbr = "FILE FORMAT 0=BINARY 1=ASCII  : 0\nEND OF HEADER\n\x01\x02\x03";
  ProductSummary k = summarizeText(kbr, "KBR1B_2003-09-14_X_00.dat");
  EXPECT_FALSE(k.ok);
  EXPECT_NE(k.error.find("binary KBR1B"), std::string::npos) << k.error;
  auto t = parseProduct<ThrRecord>(kbr, "THR1B_2003-09-14_A_00.dat");
  EXPECT_FALSE(t.ok);
  EXPECT_NE(t.error.find("not supported"), std::string::npos) << t.error;
}

TEST(BadInput, ReportFiles) {
  ProductSummary ok = summarizeText("GNV1B_2023-06-01_D_04.dat 738849600 738950159 1 2 3\n", "GNV1B_2023-06-01_D_04.rpt");
  ASSERT_TRUE(ok.ok) << ok.error;
  EXPECT_EQ(ok.product, "GNV1B report");
  EXPECT_EQ(ok.satellite, 'D');
  ProductSummary two = summarizeText("GNV1B_2023-06-01_D_04.dat 1\nGNV1B_2023-06-01_D_04.dat 2\n", "GNV1B.rpt");
  EXPECT_FALSE(two.ok);
  EXPECT_EQ(two.error.rfind("GNV1B.rpt:2: ", 0), 0u) << two.error;
  ProductSummary bad = summarizeText("hello 1 2 3\n", "x.rpt");
  EXPECT_FALSE(bad.ok);
  EXPECT_EQ(bad.error.rfind("x.rpt:1: ", 0), 0u) << bad.error;
  ProductSummary empty = summarizeText("", "x.rpt");
  EXPECT_FALSE(empty.ok);
}

TEST(BadInput, IhkSensorNameTooLongAndHrtWithoutQualflg) {
  auto f = makeProduct<IhkRecord>(Product::IHK1B, 'C');
  IhkRecord r;
  ASSERT_TRUE(r.setSensorName("21"));
  EXPECT_FALSE(r.setSensorName("0123456789abcdefXYZ"));
  EXPECT_EQ(r.sensorName(), "21");
  f.records.push_back(r);
  std::string text = formatProduct(f);
  text += "738849628 983328 G C 00000000 T 24.4 a_name_that_is_far_too_long\n";
  text += "738849628 983328 G C 00000000 T 24.4 two words\n";
  auto g = parseProduct<IhkRecord>(text, "IHK1B_x.txt");
  ASSERT_TRUE(g.ok);
  ASSERT_EQ(g.records.size(), 2u);
  EXPECT_EQ(g.records[1].sensorName(), "two words");
  ASSERT_EQ(g.rejected_count, 1u);
  EXPECT_NE(g.rejected[0].reason.find("too long"), std::string::npos) << g.rejected[0].str();
}

TEST(BadInput, HeaderWithoutRecordCountGetsOneWhenWritten) {
  for (char sat : {'C', 'A'}) {
    std::string text = sca1bText(sat, 3, nullptr);
    const std::string key = sat == 'C' ? "num_records:" : "NUMBER OF DATA RECORDS";
    std::size_t p = text.find(key);
    ASSERT_NE(p, std::string::npos);
    p = text.rfind('\n', p) + 1;
    text.erase(p, text.find('\n', p) - p + 1);
    auto f = parseProduct<Sca1bRecord>(text, "SCA1B_x.txt");
    ASSERT_TRUE(f.ok) << f.error;
    EXPECT_FALSE(f.header.declared_records.has_value());
    auto g = parseProduct<Sca1bRecord>(formatProduct(f), "SCA1B_x.txt");
    ASSERT_TRUE(g.ok) << g.error;
    ASSERT_TRUE(g.header.declared_records.has_value());
    EXPECT_EQ(*g.header.declared_records, 3);
    EXPECT_EQ(g.records, f.records);
  }
}

TEST(BadInput, LeadingBlankLinesKeepLineNumbersRight) {
  std::size_t hl = 0;
  const std::string good = sca1bText('C', 3, &hl);
  std::string text = "\n\n" + replaceRecord(good, hl, 2, "bad line");
  auto f = parseProduct<Sca1bRecord>(text, "SCA1B_x.txt");
  ASSERT_TRUE(f.ok) << f.error;
  ASSERT_EQ(f.rejected.size(), 1u);
  EXPECT_EQ(f.rejected[0].line, hl + 2 + 2);
}

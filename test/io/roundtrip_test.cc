// Write-then-read round trips for every writer: real files (ASCII and converted to GRACE binary),
// synthesised records with awkward values, and writeProduct/readProduct through the file system.
#include <boresight/io/level1.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>

#include "real_data.h"
#include "test_files.h"

using namespace boresight;
using namespace boresight::io;
using boresight::test::realFile;

namespace {

std::string baseName(const std::string& p) { return p.substr(p.find_last_of('/') + 1); }

template <typename Rec>
void expectRealRoundTrip(const std::string& rel) {
  SCOPED_TRACE(rel);
  auto a = readProduct<Rec>(realFile(rel));
  ASSERT_TRUE(a.ok) << a.error;
  ASSERT_EQ(a.rejected_count, 0u) << a.rejected.front().str();
  ASSERT_FALSE(a.records.empty());
  const std::string text = formatProduct(a);
  auto b = parseProduct<Rec>(text, baseName(rel));
  ASSERT_TRUE(b.ok) << b.error;
  EXPECT_EQ(b.rejected_count, 0u);
  EXPECT_EQ(b.header.product, a.header.product);
  EXPECT_EQ(b.header.style, a.header.style);
  EXPECT_EQ(b.records, a.records);
  ASSERT_TRUE(b.header.declared_records.has_value());
  EXPECT_EQ(static_cast<std::size_t>(*b.header.declared_records), a.records.size());
  // Writing again gives the same bytes.
  EXPECT_EQ(formatProduct(b), text);
}

/// ASCII -> binary -> ASCII, values bit-identical, layout size checked.
template <typename Rec>
void expectBinaryRoundTrip(const std::string& rel, std::size_t record_size) {
  SCOPED_TRACE(rel);
  auto a = readProduct<Rec>(realFile(rel));
  ASSERT_TRUE(a.ok) << a.error;
  ASSERT_FALSE(a.records.empty());
  ProductFile<Rec> bin = a;
  bin.header.binary = true;
  const std::string bytes = formatProduct(bin);
  const std::size_t end = bytes.find("END OF HEADER");
  ASSERT_NE(end, std::string::npos);
  const std::size_t data = bytes.find('\n', end) + 1;
  EXPECT_EQ(bytes.size() - data, record_size * a.records.size());
  EXPECT_NE(bytes.find("FILE FORMAT 0=BINARY 1=ASCII  : 0"), std::string::npos);
  std::string name = baseName(rel);
  name = name.substr(0, name.find('.')) + ".dat";
  auto b = parseProduct<Rec>(bytes, name);
  ASSERT_TRUE(b.ok) << b.error;
  EXPECT_TRUE(b.header.binary);
  EXPECT_EQ(b.rejected_count, 0u) << (b.rejected.empty() ? "" : b.rejected.front().str());
  EXPECT_EQ(b.records, a.records);
  EXPECT_EQ(static_cast<std::size_t>(*b.header.declared_records), a.records.size());
  // And back to ASCII.
  b.header.binary = false;
  auto c = parseProduct<Rec>(formatProduct(b), baseName(rel));
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_FALSE(c.header.binary);
  EXPECT_EQ(c.records, a.records);
}

}  // namespace

TEST(RoundTripReal, EveryTypedProductIsExact) {
  BORESIGHT_REQUIRE_REAL_DATA();
  expectRealRoundTrip<Sca1bRecord>("gracefo/2023-06-01_L1B/SCA1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<Sca1bRecord>("grace/2003-09-14_ascii/SCA1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<Acc1bRecord>("gracefo/2023-06-01_L1B/ACT1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<Acc1bRecord>("grace/2003-09-14_ascii/ACC1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<QsaRecord>("grace/2003-09-14_ascii/QSA1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<QsaRecord>("grace/2003-09-14_ascii/QKS1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<QsaRecord>("gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt");
  expectRealRoundTrip<GnvRecord>("gracefo/2023-06-01_L1B/GNV1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<GnvRecord>("gracefo/2023-06-01_L1B/GNI1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<GnvRecord>("grace/2003-09-14_ascii/GNV1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<ImuRecord>("gracefo/2023-06-01_L1A/IMU1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<ImuRecord>("gracefo/2023-06-01_L1B/IMU1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<ThrRecord>("gracefo/2023-06-01_L1A/THR1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<ThrRecord>("gracefo/2023-06-01_L1B/THR1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<ThrRecord>("grace/2003-09-14_ascii/THR1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<IhkRecord>("gracefo/2023-06-01_L1A/IHK1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<IhkRecord>("gracefo/2023-06-01_L1B/IHK1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<IhkRecord>("grace/2003-09-14_ascii/IHK1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<HrtRecord>("gracefo/misc/HRT1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<HrtRecord>("gracefo/misc/HRT1B_2020-01-15_C_04.txt");
  expectRealRoundTrip<TimRecord>("gracefo/2023-06-01_L1B/TIM1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<TimRecord>("grace/2003-09-14_ascii/TIM1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<ClkRecord>("gracefo/2023-06-01_L1B/CLK1B_2023-06-01_C_04.txt");
  expectRealRoundTrip<ClkRecord>("gracefo/misc/CLK1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<ClkRecord>("grace/2003-09-14_ascii/CLK1B_2003-09-14_A_00.asc");
  expectRealRoundTrip<Sca1aRecord>("gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<FlaggedRecord>("gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt");
  expectRealRoundTrip<FlaggedRecord>("gracefo/2023-06-03_L1A/ACC1A_2023-06-03_C_04.txt");
}

TEST(RoundTripReal, AsciiToGraceBinaryAndBack) {
  BORESIGHT_REQUIRE_REAL_DATA();
  expectBinaryRoundTrip<Sca1bRecord>("grace/2003-09-14_ascii/SCA1B_2003-09-14_A_00.asc", 47);
  expectBinaryRoundTrip<Sca1bRecord>("gracefo/2023-06-01_L1B/SCA1B_2023-06-01_C_04.txt", 47);
  expectBinaryRoundTrip<Acc1bRecord>("grace/2003-09-14_ascii/ACC1B_2003-09-14_A_00.asc", 78);
  expectBinaryRoundTrip<Acc1bRecord>("gracefo/2023-06-01_L1B/ACT1B_2023-06-01_C_04.txt", 78);
  expectBinaryRoundTrip<GnvRecord>("grace/2003-09-14_ascii/GNV1B_2003-09-14_A_00.asc", 103);
  expectBinaryRoundTrip<GnvRecord>("gracefo/2023-06-01_L1B/GNI1B_2023-06-01_C_04.txt", 103);
}

TEST(Binary, Sca1bByteLayoutIsBigEndianPacked) {
  auto f = makeProduct<Sca1bRecord>(Product::SCA1B, 'A');
  f.header.binary = true;
  Sca1bRecord r;
  r.t = 116769600LL * kUsPerSecond;  // 0x06F5C340
  r.satellite = 'A';
  r.sca_id = 4;
  r.q[0] = 1.0;   // 3FF0 0000 0000 0000
  r.q[1] = -2.0;  // C000 0000 0000 0000
  r.q[2] = 0.5;
  r.q[3] = 0.25;
  r.qual_rss = 4.139514383199252e-05;
  r.qualflg = Bits{0x81, 8};
  f.records.push_back(r);
  const std::string bytes = formatProduct(f);
  ASSERT_GE(bytes.size(), 47u);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + bytes.size() - 47);
  EXPECT_EQ(p[0], 0x06);
  EXPECT_EQ(p[1], 0xF5);
  EXPECT_EQ(p[2], 0xC3);
  EXPECT_EQ(p[3], 0x40);
  EXPECT_EQ(p[4], 'A');
  EXPECT_EQ(p[5], 4);
  EXPECT_EQ(p[6], 0x3F);
  EXPECT_EQ(p[7], 0xF0);
  EXPECT_EQ(p[14], 0xC0);
  EXPECT_EQ(p[46], 0x81);
  ReadOptions exact;  // the byte layout with values no instrument gives: no plausibility gates
  exact.plausibility_gates = false;
  auto g = parseProduct<Sca1bRecord>(bytes, "SCA1B_2003-09-14_A_00.dat", exact);
  ASSERT_TRUE(g.ok) << g.error;
  ASSERT_EQ(g.records.size(), 1u);
  EXPECT_EQ(g.records[0], r);
}

TEST(Binary, Acc1bByteLayoutIsBigEndianPacked) {
  auto f = makeProduct<Acc1bRecord>(Product::ACC1B, 'B');
  f.header.binary = true;
  Acc1bRecord r;
  r.t = -1 * kUsPerSecond;  // FFFFFFFF
  r.satellite = 'B';
  for (int i = 0; i < 3; ++i) {
    r.lin[i] = 1.0 + i;
    r.ang[i] = -1e-7 * (i + 1);
    r.res[i] = 1e-300 * (i + 1);
  }
  r.ang[0] = 2.0;  // 4000 0000 0000 0000 at offset 29
  r.qualflg = Bits{0x20, 8};
  f.records.push_back(r);
  const std::string bytes = formatProduct(f);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + bytes.size() - 78);
  EXPECT_EQ(p[0], 0xFF);
  EXPECT_EQ(p[3], 0xFF);
  EXPECT_EQ(p[4], 'B');
  EXPECT_EQ(p[5], 0x3F);  // lin_accl_x = 1.0
  EXPECT_EQ(p[29], 0x40);  // ang_accl_x = 2.0
  EXPECT_EQ(p[77], 0x20);
  ReadOptions exact;
  exact.plausibility_gates = false;
  auto g = parseProduct<Acc1bRecord>(bytes, "ACC1B_2003-09-14_B_00.dat", exact);
  ASSERT_TRUE(g.ok) << g.error;
  ASSERT_EQ(g.records.size(), 1u);
  EXPECT_EQ(g.records[0], r);
}

namespace {

double awkward(std::mt19937_64& rng, int i) {
  switch (i % 7) {
    case 0: return std::numeric_limits<double>::denorm_min();
    case 1: return -0.0;
    case 2: return 1e33;
    case 3: return std::numeric_limits<double>::max();
    case 4: return -1.0 / 3.0;
    default: {
      std::uniform_real_distribution<double> u(-1e6, 1e6);
      return u(rng) * std::pow(10.0, static_cast<int>(rng() % 40) - 20);
    }
  }
}

template <typename Rec, typename Fill>
void expectSynthRoundTrip(Product p, Fill fill, bool binary = false) {
  for (char sat : {'C', 'A'}) {
    SCOPED_TRACE(std::string(productName(p)) + " satellite " + sat + (binary ? " binary" : " ascii"));
    std::mt19937_64 rng(42);
    auto f = makeProduct<Rec>(p, sat);
    f.header.binary = binary;
    for (int i = 0; i < 25; ++i) {
      Rec r{};
      fill(r, rng, i);
      r.satellite = sat;
      f.records.push_back(r);
    }
    const std::string text = formatProduct(f);
    ReadOptions exact;  // awkward values no instrument gives: the codec alone, without the plausibility gates
    exact.plausibility_gates = false;
    auto g = parseProduct<Rec>(text, std::string(productName(p)) + "_2024-01-01_" + sat + "_04" + (binary ? ".dat" : ".txt"),
                               exact);
    ASSERT_TRUE(g.ok) << g.error;
    EXPECT_EQ(g.rejected_count, 0u) << (g.rejected.empty() ? "" : g.rejected.front().str());
    EXPECT_EQ(g.header.product, p);
    EXPECT_EQ(g.header.satellite, sat);
    EXPECT_EQ(g.header.binary, binary);
    EXPECT_EQ(g.records, f.records);
    // Through the file system as well.
    const std::string dir = testutil::makeTempDir("boresight_io_rt");
    const std::string path = dir + "/" + std::string(productName(p)) + "_rt_" + sat + (binary ? ".dat" : ".txt");
    std::string err;
    ASSERT_TRUE(writeProduct(path, f, &err)) << err;
    auto h = readProduct<Rec>(path, exact);
    std::filesystem::remove_all(dir);
    ASSERT_TRUE(h.ok) << h.error;
    EXPECT_EQ(h.records, f.records);
  }
}

TimeUs wholeSeconds(std::mt19937_64& rng) { return static_cast<TimeUs>(rng() % 2000000000ULL) * kUsPerSecond - 5 * kUsPerSecond; }
TimeUs anyMicro(std::mt19937_64& rng) { return static_cast<TimeUs>(rng() % 2000000000000000ULL) - 1000; }
Bits bits8(std::mt19937_64& rng) { return Bits{static_cast<std::uint32_t>(rng() & 0xffu), 8}; }

}  // namespace

TEST(RoundTripSynth, EveryWriterWithAwkwardValues) {
  expectSynthRoundTrip<Sca1bRecord>(Product::SCA1B, [](Sca1bRecord& r, std::mt19937_64& g, int i) {
    r.t = wholeSeconds(g);
    r.sca_id = static_cast<std::int32_t>(g() % 128);
    for (int k = 0; k < 4; ++k) r.q[k] = awkward(g, i + k);
    r.qual_rss = awkward(g, i + 4);
    r.qualflg = bits8(g);
  });
  for (bool bin : {false, true}) {
    expectSynthRoundTrip<Sca1bRecord>(Product::SCA1B, [](Sca1bRecord& r, std::mt19937_64& g, int i) {
      r.t = wholeSeconds(g) % (2000000000LL * kUsPerSecond);
      r.sca_id = static_cast<std::int32_t>(g() % 128);
      for (int k = 0; k < 4; ++k) r.q[k] = awkward(g, i + k);
      r.qualflg = bits8(g);
    }, bin);
    for (Product p : {Product::ACC1B, Product::ACT1B})
      expectSynthRoundTrip<Acc1bRecord>(p, [](Acc1bRecord& r, std::mt19937_64& g, int i) {
        r.t = wholeSeconds(g) % (2000000000LL * kUsPerSecond);
        for (int k = 0; k < 3; ++k) {
          r.lin[k] = awkward(g, i + k);
          r.ang[k] = awkward(g, i + k + 3);
          r.res[k] = awkward(g, i + k + 5);
        }
        r.qualflg = bits8(g);
      }, bin);
    for (Product p : {Product::GNV1B, Product::GNI1B})
      expectSynthRoundTrip<GnvRecord>(p, [](GnvRecord& r, std::mt19937_64& g, int i) {
        r.t = wholeSeconds(g) % (2000000000LL * kUsPerSecond);
        r.coord_ref = i % 2 ? 'E' : 'I';
        for (int k = 0; k < 3; ++k) {
          r.pos[k] = awkward(g, i + k);
          r.pos_err[k] = awkward(g, i + k + 1);
          r.vel[k] = awkward(g, i + k + 2);
          r.vel_err[k] = awkward(g, i + k + 3);
        }
        r.qualflg = bits8(g);
      }, bin);
  }
  for (Product p : {Product::QSA1B, Product::QKS1B})
    expectSynthRoundTrip<QsaRecord>(p, [](QsaRecord& r, std::mt19937_64& g, int i) {
      r.t = wholeSeconds(g);
      r.sensor = i % 4;
      for (int k = 0; k < 4; ++k) r.q[k] = awkward(g, i + k);
      r.zero = i % 3 ? 0.0 : awkward(g, i);
      r.qualflg = bits8(g);
    });
  for (Product p : {Product::IMU1A, Product::IMU1B})
    expectSynthRoundTrip<ImuRecord>(p, [](ImuRecord& r, std::mt19937_64& g, int i) {
      r.t = anyMicro(g);
      r.time_ref = i % 2 ? 'R' : 'G';
      r.gyro_id = 1 + i % 3;
      r.filt_ang = awkward(g, i);
      r.qualflg = bits8(g);
    });
  for (Product p : {Product::THR1A, Product::THR1B})
    expectSynthRoundTrip<ThrRecord>(p, [](ThrRecord& r, std::mt19937_64& g, int i) {
      r.t = anyMicro(g);
      r.time_ref = 'G';
      for (int k = 0; k < kThrusters; ++k) {
        r.thrust_count[k] = static_cast<std::int64_t>(g() % 1000000000000000000ULL);  // the scanner reads up to 18 digits
        r.on_time[k] = -static_cast<std::int64_t>(g() % 1000) * (i % 2);
        r.accum_dur[k] = static_cast<std::int64_t>(g() % 4000000000ULL);
      }
      r.qualflg = Bits{static_cast<std::uint32_t>(g() & 0xf), 4};
    });
  for (Product p : {Product::IHK1A, Product::IHK1B})
    expectSynthRoundTrip<IhkRecord>(p, [](IhkRecord& r, std::mt19937_64& g, int i) {
      r.t = anyMicro(g);
      r.sensortype = "TVA?"[i % 4];
      r.value = awkward(g, i);
      static const char* names[] = {"21", "rfsp", "TEMP_SCA_1", "a b c", "123456789012345"};
      ASSERT_TRUE(r.setSensorName(names[i % 5]));
      r.qualflg = bits8(g);
    });
  for (Product p : {Product::HRT1A, Product::HRT1B})
    expectSynthRoundTrip<HrtRecord>(p, [](HrtRecord& r, std::mt19937_64& g, int i) {
      r.t = anyMicro(g);
      for (int k = 0; k < kHrtTemps; ++k) r.temp[k] = awkward(g, i + k);
      const std::uint8_t w = static_cast<std::uint8_t>(i % 9);  // 0 (absent) .. 8 characters
      r.qualflg = Bits{w ? static_cast<std::uint32_t>(g() & ((1u << w) - 1)) : 0u, w};
    });
  expectSynthRoundTrip<TimRecord>(Product::TIM1B, [](TimRecord& r, std::mt19937_64& g, int i) {
    r.t = wholeSeconds(g);
    r.ts_suppid = i % 8;
    r.rcvtime_intg = static_cast<std::int64_t>(g() % 1000000000);
    r.rcvtime_frac = static_cast<std::int64_t>(g() % 1000000000);
    r.first_icu_blknr = i % 2 ? -1 : static_cast<std::int64_t>(g() % 100000);
    r.final_icu_blknr = r.first_icu_blknr;
    r.qualflg = bits8(g);
  });
  for (Product p : {Product::CLK1A, Product::CLK1B})
    expectSynthRoundTrip<ClkRecord>(p, [](ClkRecord& r, std::mt19937_64& g, int i) {
      r.t = wholeSeconds(g);
      r.clock_id = i % 2 ? -1 : 3;
      r.eps_time = awkward(g, i);
      r.eps_err = awkward(g, i + 1);
      r.eps_drift = awkward(g, i + 2);
      r.drift_err = awkward(g, i + 3);
      r.qualflg = bits8(g);
    });
}

TEST(RoundTripSynth, HrtQualflgWidthIsKeptAndAbsenceStaysAbsent) {
  auto f = makeProduct<HrtRecord>(Product::HRT1A, 'C');
  HrtRecord r;
  r.qualflg = Bits{0, 0};
  f.records.push_back(r);
  r.qualflg = Bits{0, 3};
  f.records.push_back(r);
  const std::string text = formatProduct(f);
  auto g = parseProduct<HrtRecord>(text, "HRT1A_x.txt");
  ASSERT_TRUE(g.ok) << g.error;
  ASSERT_EQ(g.records.size(), 2u);
  EXPECT_EQ(g.records[0].qualflg.width, 0);
  EXPECT_EQ(g.records[1].qualflg.width, 3);
  EXPECT_NE(text.find(" 0 000\n"), std::string::npos);
}

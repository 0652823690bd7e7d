// libFuzzer target for the Level-1 readers: one executable; the reader is chosen at run time by the
// environment variable BORESIGHT_FUZZ_READER (header, sca1a, flagged, acc1a, sca1b, acc1b, gnv, qsa,
// imu, thr, ihk, hrt, tim, clk, generic, summary), e.g.
//   BORESIGHT_FUZZ_READER=sca1a build-fuzz/test/fuzz/fuzz_level1 -max_total_time=30 CORPUS
//
// Input layout: byte 0 selects the mode, the rest is the body.
//   bit 0     : ReadOptions::on_error (0 skip, 1 stop)
//   bits 1..2 : 0 the body is a whole file; 1 a valid synthesised ASCII header (fixed style when bit 3
//               is set, else YAML) precedes the body, so the mutations reach the record parser;
//               2 a binary header (FILE FORMAT 0) precedes it (binary readers), else as 1.
// Properties checked beyond "no crash, no sanitizer report":
//   - a successful read without rejected lines writes text that reads back to the same records
//     (ASCII and, for binary readers, binary), and the record count in the written header is right;
//   - every reported issue has a line number inside the text.
#include <boresight/io/any_product.h>
#include <boresight/io/level1.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

using namespace boresight::io;

// A named namespace (not anonymous), shared by all readers.
namespace fuzz_helpers {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz property violated: %s\n", what);
  std::abort();
}

template <typename Rec>
std::string header(Product p, bool fixed, bool binary) {
  auto f = makeProduct<Rec>(p, fixed ? 'A' : 'C');
  f.header.binary = binary;
  return formatProduct(f);
}

std::size_t countLines(std::string_view t) {
  std::size_t n = 1;
  for (char c : t) n += c == '\n';
  return n;
}

template <typename Rec>
void checkIssues(const ProductFile<Rec>& f, std::string_view text) {
  const std::size_t lines = countLines(text);
  for (const auto& i : f.rejected)
    if (i.line > lines + 1 && !f.header.binary) fail("issue line beyond the text");
  if (f.rejected.size() > f.rejected_count) fail("more issues kept than counted");
}

template <typename Rec>
inline constexpr bool kHasBinary = false;
template <>
inline constexpr bool kHasBinary<Sca1bRecord> = true;
template <>
inline constexpr bool kHasBinary<Acc1bRecord> = true;
template <>
inline constexpr bool kHasBinary<GnvRecord> = true;

bool fitsCommon(boresight::TimeUs t, char sat, const Bits& q) {
  return t % boresight::kUsPerSecond == 0 && t / boresight::kUsPerSecond >= INT32_MIN &&
         t / boresight::kUsPerSecond <= INT32_MAX && sat >= 'A' && sat <= 'Z' && q.width == 8;
}
bool fitsBinary(const Sca1bRecord& r) { return fitsCommon(r.t, r.satellite, r.qualflg); }
bool fitsBinary(const Acc1bRecord& r) { return fitsCommon(r.t, r.satellite, r.qualflg); }
bool fitsBinary(const GnvRecord& r) { return fitsCommon(r.t, r.satellite, r.qualflg) && r.coord_ref > ' ' && r.coord_ref <= '~'; }
template <typename Rec>
bool fitsBinary(const Rec&) {
  return false;
}

template <typename Rec>
void roundTrip(const ProductFile<Rec>& f, const std::string& name) {
  if (!f.ok || f.rejected_count != 0) return;
  const std::string out = formatProduct(f);
  auto g = parseProduct<Rec>(out, name);
  if (!g.ok) fail("written product does not read back");
  if (g.rejected_count != 0) fail("written product has rejected lines");
  if (!(g.records == f.records)) fail("round trip changed the records");
  if (!g.header.declared_records || *g.header.declared_records != static_cast<std::int64_t>(f.records.size()))
    fail("written header record count is wrong");
  // The other format. Binary -> ASCII must always be exact; ASCII -> binary when every record fits
  // the binary layout (int32 whole seconds, satellite letter, 8-character flag, printable coord_ref).
  if constexpr (kHasBinary<Rec>) {
    ProductFile<Rec> b = f;
    b.header.binary = !f.header.binary;
    bool representable = true;
    if (b.header.binary)
      for (const auto& r : f.records) representable = representable && fitsBinary(r);
    if (!representable) return;
    auto h = parseProduct<Rec>(formatProduct(b), name);
    if (!h.ok || h.rejected_count != 0) fail("converted product (ASCII <-> binary) does not read back");
    if (h.header.binary != b.header.binary) fail("binary flag lost");
    if (!(h.records == f.records)) fail("ASCII <-> binary conversion changed the records");
  }
}

template <typename Rec>
void runTyped(std::string_view body, std::uint8_t mode, Product p, bool has_binary) {
  ReadOptions opt;
  opt.on_error = (mode & 1) ? OnError::Stop : OnError::Skip;
  opt.max_issues_kept = 8;
  const int kind = (mode >> 1) & 3;
  const bool fixed = (mode >> 3) & 1;
  std::string text;
  if (kind == 0) {
    text.assign(body.data(), body.size());
  } else {
    static const std::string hy = header<Rec>(p, false, false), hf = header<Rec>(p, true, false),
                             hb = has_binary ? header<Rec>(p, true, true) : hf;
    text = kind == 2 ? hb : (fixed ? hf : hy);
    text.append(body.data(), body.size());
  }
  const std::string name = std::string(productName(p)) + "_2023-06-01_C_04.txt";
  auto f = parseProduct<Rec>(text, name, opt);
  checkIssues(f, text);
  roundTrip(f, name);
}

}  // namespace fuzz_helpers
using namespace fuzz_helpers;

namespace fuzz_helpers {

enum class Reader { Header, Sca1a, Flagged, Acc1a, Sca1b, Acc1b, Gnv, Qsa, Imu, Thr, Ihk, Hrt, Tim, Clk, Generic, Summary };
struct NamedReader {
  const char* name;
  Reader reader;
};
constexpr NamedReader kReaders[] = {
    {"header", Reader::Header}, {"sca1a", Reader::Sca1a}, {"flagged", Reader::Flagged}, {"acc1a", Reader::Acc1a},
    {"sca1b", Reader::Sca1b},   {"acc1b", Reader::Acc1b}, {"gnv", Reader::Gnv},         {"qsa", Reader::Qsa},
    {"imu", Reader::Imu},       {"thr", Reader::Thr},     {"ihk", Reader::Ihk},         {"hrt", Reader::Hrt},
    {"tim", Reader::Tim},       {"clk", Reader::Clk},     {"generic", Reader::Generic}, {"summary", Reader::Summary},
};
Reader g_reader = Reader::Header;

void fuzzHeader(std::string_view body) {
  Header h;
  std::size_t off = 12345;
  std::string err;
  if (parseHeader(body, h, &off, &err)) {
    if (off > body.size()) fail("data offset beyond the text");
    if (h.style == HeaderStyle::None) fail("accepted header without a style");
    if (h.lines.size() > h.line_count) fail("more kept header lines than counted ones");
  } else if (err.empty()) {
    fail("header rejected without a reason");
  }
  (void)productFromName(body.substr(0, 5));
  (void)productNameFromPath(body);
}

void fuzzGeneric(std::string_view body, std::uint8_t mode) {
  ReadOptions opt;
  opt.on_error = (mode & 1) ? OnError::Stop : OnError::Skip;
  auto f = parseGeneric(body, (mode & 2) ? "MAG1B_2023-06-01_C_04.txt" : "KBR1B_2003-09-14_X_00.asc", opt);
  checkIssues(f, body);
}

void fuzzSummary(std::string_view body, std::uint8_t mode) {
  static const char* names[8] = {"SCA1A_2023-06-01_C_04.txt", "ACC1B_2003-09-14_A_00.dat", "GNV1B_2023-06-01_C_04.rpt",
                                 "x.dat", "THR1B_2003-09-14_A_00.asc", "KBR1B_2023-06-01_Y_04.txt",
                                 "HRT1A_2023-06-01_C_04.txt", "PROVENANCE.md"};
  ReadOptions opt;
  opt.on_error = (mode & 1) ? OnError::Stop : OnError::Skip;
  ProductSummary s = summarizeText(body, names[(mode >> 1) & 7], opt);
  if (!s.ok && s.error.find('\n') != std::string::npos) fail("multi-line error");
  if (!s.ok && s.error.empty()) fail("failure without an error");
}

}  // namespace fuzz_helpers

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* env = std::getenv("BORESIGHT_FUZZ_READER");
  const std::string want = env ? env : "";
  for (const auto& r : kReaders)
    if (want == r.name) {
      g_reader = r.reader;
      return 0;
    }
  std::fprintf(stderr, "fuzz_level1: set BORESIGHT_FUZZ_READER to one of:");
  for (const auto& r : kReaders) std::fprintf(stderr, " %s", r.name);
  std::fprintf(stderr, " (got '%s')\n", want.c_str());
  std::exit(2);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t mode = data[0];
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (g_reader) {
    case Reader::Header: fuzzHeader(body); break;
    case Reader::Sca1a: runTyped<Sca1aRecord>(body, mode, Product::SCA1A, false); break;
    case Reader::Flagged: runTyped<FlaggedRecord>(body, mode, (mode & 16) ? Product::AHK1A : Product::ACC1A, false); break;
    case Reader::Acc1a: runTyped<Acc1aRecord>(body, mode, (mode & 16) ? Product::ACT1A : Product::ACC1A, false); break;
    case Reader::Sca1b: runTyped<Sca1bRecord>(body, mode, Product::SCA1B, true); break;
    case Reader::Acc1b: runTyped<Acc1bRecord>(body, mode, (mode & 16) ? Product::ACT1B : Product::ACC1B, true); break;
    case Reader::Gnv: runTyped<GnvRecord>(body, mode, (mode & 16) ? Product::GNI1B : Product::GNV1B, true); break;
    case Reader::Qsa: runTyped<QsaRecord>(body, mode, (mode & 16) ? Product::QKS1B : Product::QSA1B, false); break;
    case Reader::Imu: runTyped<ImuRecord>(body, mode, Product::IMU1A, false); break;
    case Reader::Thr: runTyped<ThrRecord>(body, mode, Product::THR1B, false); break;
    case Reader::Ihk: runTyped<IhkRecord>(body, mode, Product::IHK1B, false); break;
    case Reader::Hrt: runTyped<HrtRecord>(body, mode, Product::HRT1A, false); break;
    case Reader::Tim: runTyped<TimRecord>(body, mode, Product::TIM1B, false); break;
    case Reader::Clk: runTyped<ClkRecord>(body, mode, Product::CLK1B, false); break;
    case Reader::Generic: fuzzGeneric(body, mode); break;
    case Reader::Summary: fuzzSummary(body, mode); break;
  }
  return 0;
}

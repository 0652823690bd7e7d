// libFuzzer target for the Level-1 readers: one executable; the reader is chosen at run time by the
// environment variable BORESIGHT_FUZZ_READER (header, sca1a, flagged, acc1a, sca1b, acc1b, gnv, qsa,
// imu, thr, ihk, hrt, tim, clk, generic, summary, stream_sca1a, stream_acc1a, lcmlog, ground_yaml), e.g.
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
// The streaming readers (stream_sca1a, stream_acc1a) write the text to a temporary file and read it
// with io::ProductStream (mode bits 5..6 choose the chunk size, so lines cross chunk boundaries) and
// with the engine's Sca1aSource / Acc1aSource: the stream must give the same records, rejected count,
// kept issues and outcome as the whole-file reader on the same file, and the source must report every
// line once (sample or rejected with its reason).
// The LCM log reader (lcmlog) reads arbitrary bytes as a log file (mode bits 1..2: 0 the bytes as they
// are, 1 behind the event sync word, 2 the body cut into well-formed events on the node's channels with
// arbitrary payloads, so the decoders are reached): no crash; every event is a head, accelerometer,
// star-vector or skipped event (skipped = other channel + undecodable); LcmLogSource through the
// assembler counts every event once as used or rejected (a valid STAR_VECTORS message once per star),
// with the reasons the reader's kinds imply.
// The method C measurement reader (ground_yaml; boresight::ground::parseMeasurement, the sample
// reader for accel_mps2 plus yaml-cpp for the rest) reads the body as the file (mode bits 1..2 = 0) or
// behind a fixed valid measurement that ends with "accel_mps2:" (1) or "accel_mps2: [" (2), so the
// mutations reach the sample reader: never a crash; a refusal is "fuzz.yaml:LINE: reason" with LINE
// inside the text; an accepted file is written by writeMeasurement and reads back with the same
// positions, readings and samples (to the writer's printed precision).
//
// BORESIGHT_FUZZ_MAKE_SEED=FILE (with BORESIGHT_FUZZ_READER=lcmlog): writes a small LCM log seed input
// (heads valid and not, accelerometer samples with and without angular acceleration, star vectors, an
// event on another channel) and exits; run_fuzzers.sh uses it when no `boresight` program is at hand.
#include <boresight/ground/measurement.h>
#include <boresight/io/any_product.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>
#include <boresight/stream/assembler.h>
#include <boresight/stream/sources.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <unistd.h>

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

enum class Reader {
  Header, Sca1a, Flagged, Acc1a, Sca1b, Acc1b, Gnv, Qsa, Imu, Thr, Ihk, Hrt, Tim, Clk, Generic, Summary,
  StreamSca1a, StreamAcc1a, LcmLog, GroundYaml
};
struct NamedReader {
  const char* name;
  Reader reader;
};
constexpr NamedReader kReaders[] = {
    {"header", Reader::Header}, {"sca1a", Reader::Sca1a}, {"flagged", Reader::Flagged}, {"acc1a", Reader::Acc1a},
    {"sca1b", Reader::Sca1b},   {"acc1b", Reader::Acc1b}, {"gnv", Reader::Gnv},         {"qsa", Reader::Qsa},
    {"imu", Reader::Imu},       {"thr", Reader::Thr},     {"ihk", Reader::Ihk},         {"hrt", Reader::Hrt},
    {"tim", Reader::Tim},       {"clk", Reader::Clk},     {"generic", Reader::Generic}, {"summary", Reader::Summary},
    {"stream_sca1a", Reader::StreamSca1a}, {"stream_acc1a", Reader::StreamAcc1a}, {"lcmlog", Reader::LcmLog},
    {"ground_yaml", Reader::GroundYaml},
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

// ---- files for the readers that take a path ----
std::string g_dir;  // a private temporary folder, made once

void writeFile(const std::string& path, std::string_view bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) fail("cannot write the temporary input file");
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size()) fail("short write of the input file");
  std::fclose(f);
}

// ---- streaming Level-1 readers ----
template <typename Rec>
void fuzzStream(std::string_view body, std::uint8_t mode, Product p) {
  ReadOptions opt;
  opt.on_error = (mode & 1) ? OnError::Stop : OnError::Skip;
  opt.max_issues_kept = 8;
  const int kind = (mode >> 1) & 3;
  const bool fixed = (mode >> 3) & 1;
  std::string text;
  if (kind == 0) {
    text.assign(body.data(), body.size());
  } else {
    static const std::string hy = header<Rec>(p, false, false), hf = header<Rec>(p, true, false);
    text = fixed ? hf : hy;
    text.append(body.data(), body.size());
  }
  static const std::size_t chunks[4] = {4096, 4099, 6000, LineStream::kDefaultChunk};
  const std::size_t chunk = chunks[(mode >> 5) & 3];
  const std::string path = g_dir + "/" + productName(p) + "_2023-06-01_C_04.txt";
  writeFile(path, text);

  const auto whole = readProduct<Rec>(path, opt);
  ProductStream<Rec> s;
  std::string err;
  if (!s.open(path, opt, &err, chunk)) {
    if (err.empty()) fail("stream refused the file without a reason");
    if (err.find('\n') != std::string::npos) fail("multi-line stream error");
    // The stream refuses binary files (read whole); anything else it refuses, the whole reader must too.
    if (whole.ok && !whole.header.binary) fail("stream refused a file the whole-file reader reads");
    return;
  }
  if (whole.header.binary) fail("stream opened a binary file");
  std::size_t i = 0;
  Rec r;
  while (s.next(r)) {
    if (i >= whole.records.size()) fail("stream gave more records than the whole-file reader");
    if (!(r == whole.records[i])) fail("stream record differs from the whole-file reader's");
    ++i;
  }
  if (s.ok() != whole.ok) fail("stream and whole-file reader disagree on success");
  if (whole.ok) {
    if (i != whole.records.size()) fail("stream gave fewer records than the whole-file reader");
  } else if (s.error() != whole.error) {
    fail("stream and whole-file reader fail with different errors");
  }
  if (s.rejectedCount() != whole.rejected_count) fail("stream and whole-file reader count different rejected lines");
  if (s.rejected().size() != whole.rejected.size()) fail("stream and whole-file reader keep different issues");
  for (std::size_t k = 0; k < whole.rejected.size(); ++k)
    if (s.rejected()[k].str() != whole.rejected[k].str()) fail("stream issue differs from the whole-file reader's");
}

/// The engine's Level-1 source over the same file: every line reported once, as the reader saw it.
template <typename Src, typename Rec>
void fuzzSource(std::uint8_t mode, Product p) {
  ReadOptions opt;
  opt.on_error = (mode & 1) ? OnError::Stop : OnError::Skip;
  const std::string path = g_dir + "/" + productName(p) + "_2023-06-01_C_04.txt";
  const auto whole = readProduct<Rec>(path, opt);
  Src src;
  std::string err;
  if (!src.open(path, opt, &err)) return;  // refusals are checked on the stream above
  std::size_t samples = 0, malformed = 0, implausible = 0, no_angular = 0, other = 0;
  boresight::stream::Sample x;
  boresight::stream::Reject why = boresight::stream::Reject::kMalformed;
  boresight::stream::Source::Next n;
  while ((n = src.next(x, why)) == boresight::stream::Source::Next::kSample ||
         n == boresight::stream::Source::Next::kRejected) {
    if (n == boresight::stream::Source::Next::kSample) {
      ++samples;
    } else if (why == boresight::stream::Reject::kMalformed) {
      ++malformed;
    } else if (why == boresight::stream::Reject::kImplausible) {  // the reader's gates (core/plausibility.h)
      ++implausible;
    } else if (why == boresight::stream::Reject::kInvalidFlag) {
      ++no_angular;
    } else {
      ++other;
    }
    if (samples + malformed + implausible + no_angular + other > whole.records.size() + whole.rejected_count + 1)
      fail("source reports more lines than the file has");
  }
  if (n == boresight::stream::Source::Next::kPending) fail("a file source is pending");
  if ((n == boresight::stream::Source::Next::kError) == whole.ok) fail("source and whole-file reader disagree on success");
  if (other) fail("a Level-1 source rejected with a reason other than malformed / implausible / no angular acceleration");
  // the whole-file reader counts a line outside a plausibility gate among its rejected lines too
  if (malformed + implausible != whole.rejected_count) fail("source counts different rejected lines");
  if (!whole.ok) return;
  if (samples + no_angular != whole.records.size()) fail("source reports a different number of records");
  if (p == Product::SCA1A && no_angular) fail("SCA1A records rejected as without angular acceleration");
}

// ---- LCM log reader ----
void putBe32(std::string& s, std::uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(static_cast<char>((v >> (8 * k)) & 0xFF));
}
void putBe64(std::string& s, std::uint64_t v) {
  putBe32(s, static_cast<std::uint32_t>(v >> 32));
  putBe32(s, static_cast<std::uint32_t>(v));
}

/// The body cut into events: per event a channel selector byte, a length byte, then that many payload
/// bytes (what is left when the body runs out).
std::string eventsFromBody(std::string_view body) {
  static const char* channels[4] = {kStarHeadChannel, kAccelChannel, "STAR_VECTORS", "OTHER"};
  std::string out;
  std::size_t i = 0;
  std::uint64_t num = 0;
  while (i + 2 <= body.size()) {
    const auto sel = static_cast<std::uint8_t>(body[i]);
    std::size_t len = static_cast<std::uint8_t>(body[i + 1]);
    i += 2;
    len = std::min(len, body.size() - i);
    const char* ch = channels[sel & 3];
    putBe32(out, 0xEDA1DA01u);
    putBe64(out, num++);
    putBe64(out, 1000000ull * num);
    putBe32(out, static_cast<std::uint32_t>(std::strlen(ch)));
    putBe32(out, static_cast<std::uint32_t>(len));
    out += ch;
    out.append(body.data() + i, len);
    i += len;
  }
  return out;
}

void fuzzLcmLog(std::string_view body, std::uint8_t mode) {
  namespace st = boresight::stream;
  const int kind = (mode >> 1) & 3;
  std::string bytes;
  if (kind == 1 || kind == 3) putBe32(bytes, 0xEDA1DA01u);
  if (kind == 2)
    bytes = eventsFromBody(body);
  else
    bytes.append(body.data(), body.size());
  const std::string path = g_dir + "/input.lcmlog";
  writeFile(path, bytes);

  // The reader: every event has a kind; skipped ones are other channels or undecodable.
  LcmLogReader r;
  std::string err;
  const bool opened = r.open(path, &err);
  st::LcmLogSource probe;
  std::string err2;
  if (probe.open(path, &err2) != opened) fail("LcmLogSource and LcmLogReader disagree on opening");
  if (!opened) {
    if (err.empty()) fail("log refused without a reason");
    return;
  }
  std::uint64_t heads_valid = 0, heads_invalid = 0, acc_valid = 0, acc_invalid = 0, skipped = 0, events = 0;
  std::uint64_t star_msgs = 0, star_msgs_invalid = 0, star_vectors = 0;  // a valid message: one sample per star
  std::uint64_t star_msgs_bad = 0;  // flagged valid, with an impossible star: refused whole, one read
  std::uint64_t orbits = 0;         // orbit messages: a sample each, or refused as implausible
  HeadSample h;
  AccelSample a;
  for (;;) {
    const auto k = r.next(h, a);
    if (k == LcmLogReader::Kind::End) break;
    if (++events > bytes.size() + 1) fail("more events than bytes");
    switch (k) {
      case LcmLogReader::Kind::Head: ++((h.flags & 1) ? heads_valid : heads_invalid); break;
      case LcmLogReader::Kind::Accel: ++((a.flags & 1) ? acc_valid : acc_invalid); break;
      case LcmLogReader::Kind::Stars:
        if (r.stars().n_stars < 0 || r.stars().n_stars > StarVectors::kCapacity) fail("star count outside capacity");
        if (!(r.stars().flags & 1) || r.stars().n_stars == 0) {
          ++star_msgs_invalid;
        } else if (checkInput(r.message(), boresight::plausibility::kQuatNormTolerance) == InputFault::kNone) {
          ++star_msgs;
          star_vectors += static_cast<std::uint64_t>(r.stars().n_stars);
        } else {
          ++star_msgs_bad;
        }
        break;
      case LcmLogReader::Kind::Orbit: ++orbits; break;
      case LcmLogReader::Kind::Skipped: ++skipped; break;
      case LcmLogReader::Kind::End: break;
    }
  }
  if (skipped != r.unknownChannel() + r.decodeFailures()) fail("skipped events != other channel + undecodable");
  if (r.next(h, a) != LcmLogReader::Kind::End) fail("reader goes on after its end");

  // The source through the assembler: every event once, used or rejected with its reason.
  st::AssemblerConfig cfg;
  cfg.lookahead_us = (mode & 16) ? 1 : 2 * boresight::kUsPerSecond;
  cfg.max_buffered = (mode & 32) ? 4 : 1u << 16;
  st::EpochAssembler as(cfg);
  as.addSource(&probe);
  st::Sample x;
  std::uint64_t out = 0;
  for (;;) {
    const auto o = as.nextSample(x);
    if (o == st::EpochAssembler::Out::kEnd) break;
    if (o != st::EpochAssembler::Out::kHeads && o != st::EpochAssembler::Out::kAccel && o != st::EpochAssembler::Out::kStars &&
        o != st::EpochAssembler::Out::kOrbit)
      fail("a log source failed or is pending");
    if (++out > events - star_msgs + star_vectors) fail("more samples out than events and stars");
  }
  const st::Counters& c = as.counters();
  auto rej = [&](st::Reject why) { return c.rejected[static_cast<std::size_t>(why)]; };
  // every event is read once, except that a valid STAR_VECTORS message is read as its stars
  if (c.read != events - star_msgs + star_vectors) fail("the source read a different number of events than the reader");
  if (c.read != c.used() + c.rejectedTotal()) fail("read != used + rejected");
  if (c.used() != out) fail("used != samples handed out");
  // Flagged invalid: head and star messages, accelerometer messages without angular acceleration.
  if (rej(st::Reject::kInvalidFlag) != heads_invalid + star_msgs_invalid + acc_invalid)
    fail("invalid messages (flags, no angular acceleration) miscounted");
  if (rej(st::Reject::kMalformed) != r.decodeFailures()) fail("undecodable events miscounted");
  if (rej(st::Reject::kOtherChannel) != r.unknownChannel()) fail("other-channel events miscounted");
  // A sample whose flags say valid is used, or rejected as late, non-finite, not unit, outside a
  // plausibility gate, a time outlier of its source or the same head again at one tag: nothing else.
  if (c.used() + rej(st::Reject::kLate) + rej(st::Reject::kNonFinite) + rej(st::Reject::kNonUnit) +
          rej(st::Reject::kImplausible) + rej(st::Reject::kTimeJump) + rej(st::Reject::kDuplicate) !=
      heads_valid + acc_valid + star_vectors + star_msgs_bad + orbits)
    fail("valid samples lost");
}

/// A valid measurement up to its samples (the ground_yaml reader's prefix for mode kinds 1 and 2).
constexpr const char* kGroundHead =
    "gravity_mps2: 9.80665\n"
    "camera: {focal_length_px: 2800, principal_point_px: [512, 512], pixel_aspect: 1,\n"
    "         focal_length_sigma_px: 0.5, principal_point_sigma_px: 0.05, pixel_aspect_sigma: 2e-05}\n"
    "design_q_s_t: [1, 0, 0, 0]\n"
    "positions:\n"
    "  - name: p\n"
    "    prisms:\n"
    "      - {axis_t: [1, 0, 0], azimuth_deg: 0.1, elevation_deg: -0.05}\n"
    "    targets:\n"
    "      - {azimuth_deg: 30, elevation_deg: 60, centroid_px: [100, 100]}\n"
    "      - {azimuth_cw_deg: -35, zenith_deg: 30, centroid_px: [900, 120]}\n"
    "      - {azimuth_deg: 40, elevation_deg: 55, centroid_px: [880, 900]}\n"
    "      - {azimuth_deg: 25, elevation_deg: 65, centroid_px: [150, 850]}\n"
    "    accel_mps2:";

bool near(double a, double b, double abs_tol) { return std::abs(a - b) <= abs_tol + 1e-12 * std::abs(a); }

void fuzzGroundYaml(std::string_view body, std::uint8_t mode) {
  namespace g = boresight::ground;
  const int kind = (mode >> 1) & 3;
  std::string text = kind == 0 ? std::string() : std::string(kGroundHead) + (kind == 2 ? " [" : "");
  text.append(body.data(), body.size());
  g::Measurement m;
  std::string err;
  if (!g::parseMeasurement(text, "fuzz.yaml", m, &err)) {
    if (err.rfind("fuzz.yaml:", 0) != 0) fail("ground: an error without the file name");
    const char* p = err.c_str() + 10;
    if (*p >= '0' && *p <= '9') {
      const unsigned long line = std::strtoul(p, nullptr, 10);
      if (line < 1 || line > countLines(text) + 1) fail("ground: an error line outside the text");
    }
    return;
  }
  const std::string path = g_dir + "/ground.yaml";
  if (!g::writeMeasurement(path, m, &err)) fail("ground: the writer failed");
  g::Measurement back;
  if (!g::loadMeasurement(path, back, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    fail("ground: an accepted file, written, does not read back");
  }
  if (back.positions.size() != m.positions.size()) fail("ground: positions lost in the round trip");
  for (std::size_t k = 0; k < m.positions.size(); ++k) {
    const g::Position &a = m.positions[k], &b = back.positions[k];
    if (a.name != b.name) fail("ground: a position name changed in the round trip");
    if (a.prisms.size() != b.prisms.size() || a.targets.size() != b.targets.size() ||
        a.accel_mps2.size() != b.accel_mps2.size())
      fail("ground: readings lost in the round trip");
    for (std::size_t i = 0; i < a.accel_mps2.size(); ++i)
      for (int j = 0; j < 3; ++j)
        if (!near(a.accel_mps2[i][j], b.accel_mps2[i][j], 1e-9)) fail("ground: a sample changed in the round trip");
    for (std::size_t i = 0; i < a.targets.size(); ++i)
      if (!near(a.targets[i].u_px, b.targets[i].u_px, 1e-6) || !near(a.targets[i].v_px, b.targets[i].v_px, 1e-6))
        fail("ground: a centroid changed in the round trip");
  }
}

/// A small log for the seed corpus (BORESIGHT_FUZZ_MAKE_SEED).
int writeLcmSeed(const char* path) {
  LcmLogWriter w;
  std::string err;
  if (!w.open(path, &err)) {
    std::fprintf(stderr, "%s\n", err.c_str());
    return 1;
  }
  bool ok = true;
  for (int k = 0; k < 6; ++k) {
    const boresight::TimeUs t = 738849600LL * boresight::kUsPerSecond + k * 500000;
    for (int head = 1; head <= 3; ++head) {
      HeadSample h;
      h.utime = t + (head == 3 && k == 4 ? 3000000 : 0);  // one head sample out of order
      h.head_id = head;
      h.q[0] = 0.5, h.q[1] = 0.5, h.q[2] = -0.5, h.q[3] = 0.5;
      h.star_count = 5 + head;
      h.flags = (k == 2 && head == 2) ? 0 : 1;
      h.seq = k;
      ok = ok && w.write(h);
    }
    for (int j = 0; j < 5; ++j) {
      AccelSample a;
      a.utime = t + j * 100000;
      a.ang_accel[0] = 1e-7 * j;
      a.lin_accel[2] = 1e-6;
      a.flags = (j == 3) ? 2 : 3;
      a.seq = 5 * k + j;
      ok = ok && w.write(a);
    }
    StarVectors sv;
    sv.utime = t;
    sv.n_stars = k % 3;
    for (int i = 0; i < sv.n_stars; ++i) sv.s_head[i][2] = sv.r_inertial[i][0] = 1.0;
    ok = ok && w.write(sv);
  }
  w.close();
  return ok ? 0 : 1;
}

}  // namespace fuzz_helpers

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* env = std::getenv("BORESIGHT_FUZZ_READER");
  const std::string want = env ? env : "";
  for (const auto& r : kReaders)
    if (want == r.name) {
      g_reader = r.reader;
      if (const char* seed = std::getenv("BORESIGHT_FUZZ_MAKE_SEED")) std::exit(writeLcmSeed(seed));
      if (g_reader == Reader::StreamSca1a || g_reader == Reader::StreamAcc1a || g_reader == Reader::LcmLog ||
          g_reader == Reader::GroundYaml) {
        const char* tmp = std::getenv("TMPDIR");
        std::string tmpl = std::string(tmp && *tmp ? tmp : "/tmp") + "/boresight_fuzz_XXXXXX";
        if (!::mkdtemp(tmpl.data())) {
          std::fprintf(stderr, "fuzz_level1: cannot make a temporary folder\n");
          std::exit(2);
        }
        g_dir = tmpl;
        std::atexit([] {
          for (const char* f : {"/SCA1A_2023-06-01_C_04.txt", "/ACC1A_2023-06-01_C_04.txt", "/ACT1A_2023-06-01_C_04.txt",
                                "/input.lcmlog", "/ground.yaml"})
            std::remove((g_dir + f).c_str());
          ::rmdir(g_dir.c_str());
        });
      }
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
    case Reader::StreamSca1a:
      fuzzStream<Sca1aRecord>(body, mode, Product::SCA1A);
      fuzzSource<boresight::stream::Sca1aSource, Sca1aRecord>(mode, Product::SCA1A);
      break;
    case Reader::StreamAcc1a: {
      const Product p = (mode & 16) ? Product::ACT1A : Product::ACC1A;
      fuzzStream<FlaggedRecord>(body, mode, p);
      fuzzSource<boresight::stream::Acc1aSource, FlaggedRecord>(mode, p);
      break;
    }
    case Reader::LcmLog: fuzzLcmLog(body, mode); break;
    case Reader::GroundYaml: fuzzGroundYaml(body, mode); break;
  }
  return 0;
}

// Private: the generic text reader/writer that every record codec plugs into.
//
// A codec is a traits struct:
//   struct Sca1aCodec {
//     using Record = Sca1aRecord;
//     static bool accepts(Product p);                  // products this record type reads
//     static Product defaultProduct();
//     static bool parse(FieldScanner& s, Record& r, Product p);   // false: s.reason() says why
//     static void format(LineWriter& w, const Record& r, Product p);
//     static std::vector<std::string> columns(Product p);          // for synthesised headers
//   };
// and BORESIGHT_IO_INSTANTIATE(Codec) in its .cc file provides readProduct<Record> & co.
//
// A codec whose product also exists as GRACE big-endian binary Level-1B adds
//     static constexpr std::size_t kBinarySize = 47;                      // packed record bytes
//     static bool decode(const unsigned char* p, Record& r, std::string& reason);
//     static void encode(unsigned char* p, const Record& r);
// and parseProduct() reads such files (header FILE FORMAT 0) while formatProduct() writes them when
// header.binary is set.
#pragma once

#include <boresight/io/level1.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <thread>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace boresight::io::detail {

/// Floor division of a microsecond tag into integer seconds and microseconds (0..999999).
inline void splitTime(TimeUs t, std::int64_t& sec, std::int64_t& usec) {
  sec = t / kUsPerSecond;
  usec = t % kUsPerSecond;
  if (usec < 0) {
    usec += kUsPerSecond;
    --sec;
  }
}

/// Reads "intg frac" (seconds, microseconds) into a TimeUs.
inline bool scanTimeIntgFrac(FieldScanner& s, TimeUs& t) {
  std::int64_t sec = 0, usec = 0;
  if (!s.integerIn<std::int64_t>(sec, -4000000000LL, 4000000000LL, "time_intg")) return false;
  if (!s.integerIn<std::int64_t>(usec, 0, 999999, "time_frac")) return false;
  t = sec * kUsPerSecond + usec;
  return true;
}
/// Reads integer GPS seconds into a TimeUs.
inline bool scanTimeSeconds(FieldScanner& s, TimeUs& t) {
  std::int64_t sec = 0;
  if (!s.integerIn<std::int64_t>(sec, -4000000000LL, 4000000000LL, "gps_time")) return false;
  t = sec * kUsPerSecond;
  return true;
}
inline void writeTimeIntgFrac(LineWriter& w, TimeUs t) {
  std::int64_t sec, usec;
  splitTime(t, sec, usec);
  w.integer(sec).integer(usec);
}
/// Whole seconds; a tag that is not whole is written truncated towards -inf (1B products are 1 s).
inline void writeTimeSeconds(LineWriter& w, TimeUs t) {
  std::int64_t sec, usec;
  splitTime(t, sec, usec);
  w.integer(sec);
}
inline bool isSatelliteId(char c) { return c >= 'A' && c <= 'Z'; }

// ---- big-endian packing (GRACE binary Level-1B) ----
namespace be {
inline std::uint64_t load64(const unsigned char* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return v;
}
inline std::uint32_t load32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
inline double f64(const unsigned char* p) {
  std::uint64_t u = load64(p);
  double d;
  std::memcpy(&d, &u, sizeof d);
  return d;
}
inline std::int32_t i32(const unsigned char* p) {
  std::uint32_t u = load32(p);
  std::int32_t v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}
inline void put64(unsigned char* p, std::uint64_t v) {
  for (int i = 7; i >= 0; --i) {
    p[i] = static_cast<unsigned char>(v & 0xffu);
    v >>= 8;
  }
}
inline void putF64(unsigned char* p, double d) {
  std::uint64_t u;
  std::memcpy(&u, &d, sizeof u);
  put64(p, u);
}
inline void putI32(unsigned char* p, std::int32_t v) {
  std::uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  p[0] = static_cast<unsigned char>(u >> 24);
  p[1] = static_cast<unsigned char>(u >> 16);
  p[2] = static_cast<unsigned char>(u >> 8);
  p[3] = static_cast<unsigned char>(u);
}
/// A finite float64 field, or a reason.
inline bool finite(double v, const char* name, std::string& reason) {
  if (v - v == 0.0) return true;
  reason = std::string("field ") + name + ": non-finite number";
  return false;
}
/// GPS seconds (int32 in the files) to TimeUs; the writer truncates to whole seconds and clamps.
inline std::int32_t secondsForBinary(TimeUs t) {
  std::int64_t sec, usec;
  splitTime(t, sec, usec);
  if (sec > INT32_MAX) return INT32_MAX;
  if (sec < INT32_MIN) return INT32_MIN;
  return static_cast<std::int32_t>(sec);
}
}  // namespace be

template <typename C, typename = void>
struct HasBinary : std::false_type {};
template <typename C>
struct HasBinary<C, std::void_t<decltype(C::kBinarySize)>> : std::true_type {};

template <typename C, typename = void>
struct HasPlausible : std::false_type {};
template <typename C>
struct HasPlausible<C, std::void_t<decltype(&C::plausible)>> : std::true_type {};

/// The record's time tag inside the gate's window (when it has one).
template <typename Rec>
bool timePlausible(const Rec& r, const RecordGate& g, std::string* reason) {
  if (!g.has_window || (r.t >= g.t_min && r.t <= g.t_max)) return true;
  if (reason) {
    char b[160];
    std::snprintf(b, sizeof b, "implausible: time tag %.6f s outside %.0f .. %.0f s (%s)", toSeconds(r.t),
                  toSeconds(g.t_min), toSeconds(g.t_max), g.window.c_str());
    *reason = b;
  }
  return false;
}

/// The quaternion gate, with the reason ("implausible: quatangle..quatkcoeff: ...").
inline bool quaternionPlausible(const double* q, double tol, const char* what, std::string* reason) {
  const plausibility::Quaternion v = plausibility::checkQuaternion(q, tol);
  if (v == plausibility::Quaternion::kOk) return true;
  if (reason) {
    char b[200];
    std::snprintf(b, sizeof b, "implausible: %s: %s (|q| - 1 = %.3g, tolerance %.3g)", what,
                  plausibility::quaternionReason(v), plausibility::quaternionNormError(q), tol);
    *reason = b;
  }
  return false;
}
/// Per-axis magnitude gate of a 3-vector (accelerations), with the reason.
inline bool axesPlausible(const double* v, double limit, const char* what, const char* unit, std::string* reason) {
  for (int i = 0; i < 3; ++i)
    if (!(std::abs(v[i]) <= limit)) {
      if (reason) {
        char b[200];
        std::snprintf(b, sizeof b, "implausible: %s %c = %.6g %s, beyond %.3g %s", what, "xyz"[i], v[i], unit, limit, unit);
        *reason = b;
      }
      return false;
    }
  return true;
}

/// Every gate of a codec's record: the time window, then the codec's own (Codec::plausible, when it
/// has one: quaternions, accelerations, orbit).
template <typename Codec>
bool checkWith(const typename Codec::Record& r, Product p, const RecordGate& g, std::string* reason) {
  if (!g.enabled) return true;
  if (!timePlausible(r, g, reason)) return false;
  if constexpr (HasPlausible<Codec>::value) return Codec::plausible(r, p, g, reason);
  return true;
}

/// Synthesised header: YAML for GRACE-FO (satellites C, D), fixed for GRACE (A, B) and static products.
std::vector<std::string> synthHeader(Product p, char satellite, const std::vector<std::string>& columns,
                                     const std::array<std::string, 32>* flag_fields);
/// Header lines for writing: kept lines with the record count and the FILE FORMAT entry (from
/// h.binary) replaced, or synthesised ones. A binary product always gets a fixed header.
std::vector<std::string> headerForWrite(const Header& h, std::size_t records);
/// "file:line: reason" for a ProductFile that could not be read.
void failFile(std::string& error, bool& ok, std::string_view file, std::size_t line, const std::string& reason);
/// Resolve which product a file is; false with *error when unknown.
bool resolveProduct(Header& h, std::string_view file, const ReadOptions& opt, std::string* error);
bool writeText(const std::string& path, const std::string& text, std::string* error);

/// Packed big-endian records after a binary header. Record k (1-based) is reported as line
/// header_lines + k, with the record number and byte offset in the reason; a truncated trailing
/// record is reported, never read past.
template <typename Codec>
void parseBinaryBody(std::string_view body, const ReadOptions& opt, const RecordGate& gate,
                     ProductFile<typename Codec::Record>& f) {
  constexpr std::size_t n = Codec::kBinarySize;
  const auto* p = reinterpret_cast<const unsigned char*>(body.data());
  const std::size_t full = body.size() / n;
  f.records.reserve(full);
  std::string reason;
  auto reject = [&](std::size_t k, const std::string& why) {
    ++f.rejected_count;
    const std::size_t line = f.header.line_count + k + 1;
    std::string r = "record " + std::to_string(k + 1) + " (byte " + std::to_string(k * n) + " after the header): " + why;
    if (f.rejected.size() < opt.max_issues_kept) f.rejected.push_back(ParseIssue{f.file, line, r});
    if (opt.on_error == OnError::Stop) {
      f.ok = false;
      f.error = f.file + ":" + std::to_string(line) + ": " + r;
      return false;
    }
    return true;
  };
  for (std::size_t k = 0; k < full; ++k) {
    typename Codec::Record r{};
    if (Codec::decode(p + k * n, r, reason)) {
      if (checkWith<Codec>(r, f.header.product, gate, &reason)) {
        f.records.push_back(r);
        continue;
      }
      ++f.implausible_count;
    }
    if (!reject(k, reason)) return;
  }
  const std::size_t rest = body.size() - full * n;
  if (rest != 0)
    reject(full, "truncated record: " + std::to_string(rest) + " of " + std::to_string(n) + " bytes");
}

/// Bodies smaller than this are parsed on one thread (ReadOptions::threads == 0).
constexpr std::size_t kParallelMinBytes = 8u << 20;

/// Parses the record lines in [p, end): appends records to f.records, counts and keeps rejected
/// lines (numbered from line_base + 1), and counts the lines seen. With OnError::Stop the first
/// rejected line sets f.ok = false and f.error and ends the parse.
template <typename Codec>
void parseLines(const char* p, const char* end, std::size_t line_base, Product product, const ReadOptions& opt,
                const RecordGate& gate, ProductFile<typename Codec::Record>& f, std::size_t& lines) {
  std::string gate_reason;
  std::size_t line_no = line_base;
  // Reserve from the first record's length: avoids regrowth on full-day files.
  if (p < end && f.records.empty()) {
    const void* nl = std::memchr(p, '\n', static_cast<std::size_t>(end - p));
    std::size_t first_len = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - p) + 1 : 0;
    if (first_len > 8) f.records.reserve(static_cast<std::size_t>(end - p) / first_len + 16);
  }
  while (p < end) {
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    const char* le = nl ? nl : end;
    ++line_no;
    FieldScanner s(p, le);
    p = nl ? nl + 1 : end;
    if (s.atEnd()) continue;  // blank line
    auto& r = f.records.emplace_back();
    const bool formed = Codec::parse(s, r, product) && s.finish();
    if (formed && checkWith<Codec>(r, product, gate, &gate_reason)) continue;
    f.records.pop_back();
    ++f.rejected_count;
    if (formed) ++f.implausible_count;
    const std::string& why = formed ? gate_reason : s.reason();
    if (f.rejected.size() < opt.max_issues_kept) f.rejected.push_back(ParseIssue{f.file, line_no, why});
    if (opt.on_error == OnError::Stop) {
      f.ok = false;
      f.error = f.file + ":" + std::to_string(line_no) + ": " + why;
      break;
    }
  }
  lines = line_no - line_base;
}

template <typename Codec>
ProductFile<typename Codec::Record> parseText(std::string_view text, std::string_view file, const ReadOptions& opt) {
  using Rec = typename Codec::Record;
  ProductFile<Rec> f;
  f.file = std::string(file);
  std::size_t off = 0;
  std::string err;
  if (!parseHeader(text, f.header, &off, &err)) {
    f.ok = false;
    f.error = f.file + ":" + std::to_string(f.header.line_count + 1) + ": " + err;
    return f;
  }
  if (!resolveProduct(f.header, file, opt, &err)) {
    f.ok = false;
    f.error = f.file + ":1: " + err;
    return f;
  }
  if (!Codec::accepts(f.header.product)) {
    f.ok = false;
    f.error = f.file + ":1: product " + f.header.product_name + " cannot be read as " +
              productName(Codec::defaultProduct());
    return f;
  }
  const Product product = f.header.product;
  const RecordGate gate = makeRecordGate(f.header, file, opt);
  if (f.header.binary) {
    if constexpr (HasBinary<Codec>::value) {
      parseBinaryBody<Codec>(text.substr(off), opt, gate, f);
    } else {
      f.ok = false;
      f.error = f.file + ":" + std::to_string(f.header.line_count) + ": binary " + f.header.product_name +
                " (FILE FORMAT 0) is not supported; binary readers exist for SCA1B, ACC1B, ACT1B, GNV1B, GNI1B";
    }
    return f;
  }
  const char* body = text.data() + off;
  const char* end = text.data() + text.size();
  const std::size_t body_size = static_cast<std::size_t>(end - body);
  unsigned threads = opt.threads > 0 ? static_cast<unsigned>(opt.threads) : std::thread::hardware_concurrency();
  if (opt.threads == 0 && body_size < kParallelMinBytes) threads = 1;
  if (opt.on_error == OnError::Stop) threads = 1;  // the first error in file order must win
  threads = std::max(1u, std::min(threads, 8u));
  if (threads == 1) {
    std::size_t lines = 0;
    parseLines<Codec>(body, end, f.header.line_count, product, opt, gate, f, lines);
    return f;
  }
  // Chunks of whole lines, parsed concurrently; results appended in file order. Line numbers of
  // later chunks are known only once the earlier ones are counted, so they are shifted after the join.
  std::vector<const char*> cut{body};
  for (unsigned k = 1; k < threads; ++k) {
    const char* c = body + body_size * k / threads;
    if (c < cut.back()) c = cut.back();
    const void* nl = std::memchr(c, '\n', static_cast<std::size_t>(end - c));
    cut.push_back(nl ? static_cast<const char*>(nl) + 1 : end);
  }
  cut.push_back(end);
  std::vector<ProductFile<Rec>> part(threads);
  std::vector<std::size_t> lines(threads, 0);
  std::vector<std::exception_ptr> failure(threads);
  std::vector<std::thread> pool;
  for (unsigned k = 0; k < threads; ++k) {
    part[k].file = f.file;
    auto work = [&, k] {
      try {
        parseLines<Codec>(cut[k], cut[k + 1], 0, product, opt, gate, part[k], lines[k]);
      } catch (...) {
        failure[k] = std::current_exception();
      }
    };
    if (k + 1 < threads) pool.emplace_back(work);
    else work();
  }
  for (auto& t : pool) t.join();
  for (auto& e : failure)
    if (e) std::rethrow_exception(e);
  std::size_t total = 0;
  for (const auto& pp : part) total += pp.records.size();
  f.records.reserve(total);
  std::size_t base = f.header.line_count;
  for (unsigned k = 0; k < threads; ++k) {
    f.records.insert(f.records.end(), part[k].records.begin(), part[k].records.end());
    f.rejected_count += part[k].rejected_count;
    f.implausible_count += part[k].implausible_count;
    for (auto& issue : part[k].rejected) {
      if (f.rejected.size() >= opt.max_issues_kept) break;
      issue.line += base;
      f.rejected.push_back(std::move(issue));
    }
    base += lines[k];
  }
  return f;
}

template <typename Codec>
std::string formatText(const ProductFile<typename Codec::Record>& f) {
  std::string out;
  Header h = f.header;
  if (h.product == Product::Unknown) h.product = Codec::defaultProduct();
  if constexpr (!HasBinary<Codec>::value) h.binary = false;
  for (const auto& l : headerForWrite(h, f.records.size())) {
    out += l;
    out += '\n';
  }
  if constexpr (HasBinary<Codec>::value) {
    if (h.binary) {
      constexpr std::size_t n = Codec::kBinarySize;
      const std::size_t start = out.size();
      out.resize(start + n * f.records.size());
      auto* p = reinterpret_cast<unsigned char*>(&out[start]);
      for (const auto& r : f.records) {
        Codec::encode(p, r);
        p += n;
      }
      return out;
    }
  }
  out.reserve(out.size() + f.records.size() * 160);
  LineWriter w(out);
  for (const auto& r : f.records) {
    Codec::format(w, r, h.product);
    w.endLine();
  }
  return out;
}

template <typename Codec>
ProductFile<typename Codec::Record> makeEmpty(Product p, char satellite) {
  ProductFile<typename Codec::Record> f;
  f.header.product = p;
  f.header.product_name = productName(p);
  f.header.satellite = satellite;
  f.header.columns = Codec::columns(p);
  f.header.style = (satellite == 'A' || satellite == 'B') ? HeaderStyle::Fixed : HeaderStyle::Yaml;
  return f;
}

}  // namespace boresight::io::detail

#define BORESIGHT_IO_INSTANTIATE(Codec)                                                                        \
  namespace boresight::io {                                                                                    \
  template <>                                                                                                  \
  ProductFile<Codec::Record> parseProduct<Codec::Record>(std::string_view text, std::string_view file,         \
                                                         const ReadOptions& opt) {                             \
    return detail::parseText<Codec>(text, file, opt);                                                          \
  }                                                                                                            \
  template <>                                                                                                  \
  ProductFile<Codec::Record> readProduct<Codec::Record>(const std::string& path, const ReadOptions& opt) {     \
    std::string text, err;                                                                                     \
    if (!readFileToString(path, text, &err, maxFileBytes(productFromName(productNameFromPath(path))))) {      \
      ProductFile<Codec::Record> f;                                                                            \
      f.file = path;                                                                                           \
      f.ok = false;                                                                                            \
      f.error = err;                                                                                           \
      return f;                                                                                                \
    }                                                                                                          \
    return detail::parseText<Codec>(text, path, opt);                                                          \
  }                                                                                                            \
  template <>                                                                                                  \
  std::string formatProduct<Codec::Record>(const ProductFile<Codec::Record>& f) {                              \
    return detail::formatText<Codec>(f);                                                                       \
  }                                                                                                            \
  template <>                                                                                                  \
  bool writeProduct<Codec::Record>(const std::string& path, const ProductFile<Codec::Record>& f,                \
                                   std::string* error) {                                                       \
    return detail::writeText(path, detail::formatText<Codec>(f), error);                                       \
  }                                                                                                            \
  template <>                                                                                                  \
  ProductFile<Codec::Record> makeProduct<Codec::Record>(Product p, char satellite) {                           \
    return detail::makeEmpty<Codec>(p, satellite);                                                             \
  }                                                                                                            \
  template <>                                                                                                  \
  bool parseRecord<Codec::Record>(FieldScanner & s, Codec::Record & r, Product p) {                            \
    return Codec::parse(s, r, p) && s.finish();                                                                \
  }                                                                                                            \
  template <>                                                                                                  \
  bool recordAccepts<Codec::Record>(Product p) {                                                               \
    return Codec::accepts(p);                                                                                  \
  }                                                                                                            \
  template <>                                                                                                  \
  bool checkRecord<Codec::Record>(const Codec::Record& r, Product p, const RecordGate& g, std::string* why) {  \
    return detail::checkWith<Codec>(r, p, g, why);                                                             \
  }                                                                                                            \
  }

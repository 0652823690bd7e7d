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
#pragma once

#include <boresight/io/level1.h>

#include <cstdio>
#include <string>
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

/// Synthesised header: YAML for GRACE-FO (satellites C, D), fixed for GRACE (A, B) and static products.
std::vector<std::string> synthHeader(Product p, char satellite, const std::vector<std::string>& columns,
                                     const std::array<std::string, 32>* flag_fields);
/// Header lines for writing: kept lines with the record count replaced, or synthesised ones.
std::vector<std::string> headerForWrite(const Header& h, std::size_t records);
/// Resolve which product a file is; false with *error when unknown.
bool resolveProduct(Header& h, std::string_view file, const ReadOptions& opt, std::string* error);
bool writeText(const std::string& path, const std::string& text, std::string* error);

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
  const char* p = text.data() + off;
  const char* end = text.data() + text.size();
  std::size_t line_no = f.header.line_count;
  // Reserve from the first record's length: avoids regrowth on full-day files.
  if (p < end) {
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
    Rec r{};
    if (Codec::parse(s, r, product) && s.finish()) {
      f.records.push_back(r);
      continue;
    }
    ++f.rejected_count;
    if (f.rejected.size() < opt.max_issues_kept) f.rejected.push_back(ParseIssue{f.file, line_no, s.reason()});
    if (opt.on_error == OnError::Stop) {
      f.ok = false;
      f.error = f.file + ":" + std::to_string(line_no) + ": " + s.reason();
      return f;
    }
  }
  return f;
}

template <typename Codec>
std::string formatText(const ProductFile<typename Codec::Record>& f) {
  std::string out;
  Header h = f.header;
  if (h.product == Product::Unknown) h.product = Codec::defaultProduct();
  for (const auto& l : headerForWrite(h, f.records.size())) {
    out += l;
    out += '\n';
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
    if (!readFileToString(path, text, &err)) {                                                                 \
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
  }

// Generic reader for Level-1 products without a typed codec: time tag and token count per line.
#include <boresight/io/any_product.h>

#include "product_io.h"

namespace boresight::io {
namespace {

bool isTimeRef(std::string_view t) { return t.size() == 1 && (t[0] == 'R' || t[0] == 'G'); }

bool isSmallInt(std::string_view t, std::int64_t lo, std::int64_t hi) {
  std::int64_t v = 0;
  auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size() && v >= lo && v <= hi;
}

/// Decide whether the second field is the microseconds of the time (see any_product.h).
bool secondFieldIsFraction(const Header& h, std::string_view body) {
  if (h.columns.size() >= 2) return h.columns[1].find("frac") != std::string::npos;
  const char* p = body.data();
  const char* end = p + body.size();
  while (p < end) {
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    const char* le = nl ? nl : end;
    FieldScanner s(p, le);
    p = nl ? nl + 1 : end;
    if (s.atEnd()) continue;
    std::string_view t[4];
    for (auto& x : t) x = s.token();
    if (!isSmallInt(t[1], 0, 999999)) return false;
    return isTimeRef(t[2]) || (t[2].size() == 1 && isTimeRef(t[3]));
  }
  return false;
}

}  // namespace

ProductFile<GenericRecord> parseGeneric(std::string_view text, std::string_view file, const ReadOptions& opt) {
  ProductFile<GenericRecord> f;
  f.file = std::string(file);
  std::size_t off = 0;
  std::string err;
  if (!parseHeader(text, f.header, &off, &err)) {
    detail::failFile(f.error, f.ok, file, f.header.line_count + 1, err);
    return f;
  }
  if (!detail::resolveProduct(f.header, file, opt, &err)) {
    detail::failFile(f.error, f.ok, file, 1, err);
    return f;
  }
  if (f.header.binary) {
    detail::failFile(f.error, f.ok, file, f.header.line_count,
                     "binary " + f.header.product_name + " (FILE FORMAT 0): record layout unknown, cannot be read generically");
    return f;
  }
  const std::string_view body = text.substr(off);
  const bool frac = secondFieldIsFraction(f.header, body);
  const char* p = body.data();
  const char* end = p + body.size();
  std::size_t line_no = f.header.line_count;
  while (p < end) {
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    const char* le = nl ? nl : end;
    ++line_no;
    FieldScanner s(p, le);
    p = nl ? nl + 1 : end;
    if (s.atEnd()) continue;
    GenericRecord r;
    bool good = frac ? detail::scanTimeIntgFrac(s, r.t) : detail::scanTimeSeconds(s, r.t);
    if (good) {
      std::size_t n = frac ? 2 : 1;
      while (!s.token().empty()) ++n;
      r.tokens = static_cast<std::uint16_t>(n > 65535 ? 65535 : n);
      f.records.push_back(r);
      continue;
    }
    ++f.rejected_count;
    if (f.rejected.size() < opt.max_issues_kept) f.rejected.push_back(ParseIssue{f.file, line_no, s.reason()});
    if (opt.on_error == OnError::Stop) {
      detail::failFile(f.error, f.ok, file, line_no, s.reason());
      return f;
    }
  }
  return f;
}

ProductFile<GenericRecord> readGeneric(const std::string& path, const ReadOptions& opt) {
  std::string text, err;
  if (!readFileToString(path, text, &err)) {
    ProductFile<GenericRecord> f;
    f.file = path;
    detail::failFile(f.error, f.ok, path, 0, err.substr(err.find(": ") == std::string::npos ? 0 : err.find(": ") + 2));
    return f;
  }
  return parseGeneric(text, path, opt);
}

}  // namespace boresight::io

// summarizeProduct: identify any Level-1 file (ASCII, GRACE binary, .rpt report) and summarise it.
#include <boresight/io/any_product.h>

#include "product_io.h"

namespace boresight::io {
namespace {

bool endsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::string_view baseName(std::string_view path) {
  std::size_t slash = path.find_last_of('/');
  return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

template <typename Rec>
char satelliteOf(const Rec& r) {
  return r.satellite;
}
char satelliteOf(const GenericRecord&) { return '?'; }

template <typename Rec>
void fill(ProductSummary& s, const ProductFile<Rec>& f) {
  s.product = f.header.product_name;
  s.declared_records = f.header.declared_records;
  s.binary = f.header.binary;
  s.ok = f.ok;
  s.error = f.error;
  s.records = f.records.size();
  s.rejected = f.rejected;
  s.rejected_count = f.rejected_count;
  s.satellite = f.header.satellite;
  if (!f.records.empty()) {
    char c = satelliteOf(f.records.front());
    if (c != '?') s.satellite = c;
    s.has_time = true;
    s.first_time = f.records.front().t;
    s.last_time = f.records.back().t;
  }
}

/// "SCA1A_2023-06-01_C_04.dat" and the like: a Level-1 name, '_', more.
bool isProductFileToken(std::string_view t) {
  return t.size() > 6 && t[5] == '_' && !productNameFromPath(t.substr(0, 5)).empty();
}

/// The first token of the text looks like a report's (cheap: looks at the start only).
bool startsLikeReport(std::string_view text) {
  FieldScanner head(text.substr(0, 256));
  return isProductFileToken(head.token());
}

/// A `.rpt` daily report: one line whose first token is the product's file name.
bool looksLikeReport(std::string_view text, std::string_view* first_token, std::size_t* lines) {
  std::size_t pos = 0, non_blank = 0;
  std::string_view first;
  while (pos < text.size()) {
    std::size_t e = text.find('\n', pos);
    if (e == std::string_view::npos) e = text.size();
    FieldScanner s(text.data() + pos, text.data() + e);
    std::string_view t = s.token();
    if (!t.empty() && ++non_blank == 1) first = t;
    pos = e + 1;
  }
  *first_token = first;
  *lines = non_blank;
  return non_blank == 1 && isProductFileToken(first);
}

void summarizeReport(std::string_view text, ProductSummary& s) {
  std::string_view tok;
  std::size_t lines = 0;
  if (!looksLikeReport(text, &tok, &lines)) {
    s.ok = false;
    if (lines != 1)
      s.error = s.file + ":" + std::to_string(lines == 0 ? 1 : 2) + ": not a daily report: expected exactly one line, found " +
                std::to_string(lines);
    else
      s.error = s.file + ":1: not a daily report: the first field does not name a Level-1 product file (e.g. SCA1A_2023-06-01_C_04.dat)";
    return;
  }
  s.product = productNameFromPath(tok) + " report";
  s.records = 1;
  // "SCA1A_2023-06-01_C_04.dat": the satellite letter is the third '_' part.
  std::size_t a = tok.find('_');
  std::size_t b = a == std::string_view::npos ? a : tok.find('_', a + 1);
  if (b != std::string_view::npos && b + 2 < tok.size() && tok[b + 2] == '_' && detail::isSatelliteId(tok[b + 1]))
    s.satellite = tok[b + 1];
}

}  // namespace

ProductSummary summarizeText(std::string_view text, const std::string& file, const ReadOptions& opt) {
  ProductSummary s;
  s.file = file;
  if (endsWith(file, ".rpt") || startsLikeReport(text)) {
    summarizeReport(text, s);
    return s;
  }
  Header h;
  std::size_t off = 0;
  std::string err;
  if (!parseHeader(text, h, &off, &err)) {
    s.ok = false;
    s.error = file + ":" + std::to_string(h.line_count + 1) + ": not a Level-1 product: " + err;
    return s;
  }
  if (!detail::resolveProduct(h, baseName(file), opt, &err)) {
    s.ok = false;
    s.error = file + ":1: " + err;
    s.declared_records = h.declared_records;
    return s;
  }
  ReadOptions o = opt;
  o.product = h.product == Product::Other ? Product::Unknown : h.product;
  switch (h.product) {
    case Product::SCA1A: fill(s, parseProduct<Sca1aRecord>(text, file, o)); break;
    case Product::ACC1A:
    case Product::ACT1A:
    case Product::AHK1A:
    case Product::AHK1B: fill(s, parseProduct<FlaggedRecord>(text, file, o)); break;
    case Product::SCA1B: fill(s, parseProduct<Sca1bRecord>(text, file, o)); break;
    case Product::ACC1B:
    case Product::ACT1B: fill(s, parseProduct<Acc1bRecord>(text, file, o)); break;
    case Product::QSA1B:
    case Product::QKS1B: fill(s, parseProduct<QsaRecord>(text, file, o)); break;
    case Product::GNV1B:
    case Product::GNI1B: fill(s, parseProduct<GnvRecord>(text, file, o)); break;
    case Product::IMU1A:
    case Product::IMU1B: fill(s, parseProduct<ImuRecord>(text, file, o)); break;
    case Product::THR1A:
    case Product::THR1B: fill(s, parseProduct<ThrRecord>(text, file, o)); break;
    case Product::IHK1A:
    case Product::IHK1B: fill(s, parseProduct<IhkRecord>(text, file, o)); break;
    case Product::HRT1A:
    case Product::HRT1B: fill(s, parseProduct<HrtRecord>(text, file, o)); break;
    case Product::TIM1B: fill(s, parseProduct<TimRecord>(text, file, o)); break;
    case Product::CLK1A:
    case Product::CLK1B: fill(s, parseProduct<ClkRecord>(text, file, o)); break;
    default: fill(s, parseGeneric(text, file, o)); break;
  }
  if (s.product.empty()) s.product = h.product_name;
  return s;
}

ProductSummary summarizeProduct(const std::string& path, const ReadOptions& opt) {
  std::string text, err;
  if (!readFileToString(path, text, &err)) {
    ProductSummary s;
    s.file = path;
    s.ok = false;
    std::size_t c = err.find(": ");
    s.error = path + ":0: " + (c == std::string::npos ? err : err.substr(c + 2));
    return s;
  }
  return summarizeText(text, path, opt);
}

}  // namespace boresight::io

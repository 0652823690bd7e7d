// summarizeProduct: identify any Level-1 file (ASCII, GRACE binary, .rpt report) and summarise it.
#include <boresight/io/any_product.h>

#include <boresight/io/product_stream.h>

#include "product_io.h"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <thread>
#include <unistd.h>

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

/// What one block of lines gave.
struct BlockResult {
  std::size_t lines = 0, records = 0, rejected = 0;
  std::vector<ParseIssue> issues;  ///< line numbers relative to the block (1 = its first line)
  bool has_time = false;
  TimeUs first = 0, last = 0;
  char satellite = '?';
  bool read_error = false;
};

/// Reads [from, to) of the file at fd into buf (appending). False on a read error.
bool preadAll(int fd, std::uint64_t from, std::uint64_t to, std::vector<char>& buf) {
  const std::size_t start = buf.size();
  buf.resize(start + static_cast<std::size_t>(to - from));
  std::size_t got = 0;
  while (got < to - from) {
    const ssize_t n = ::pread(fd, buf.data() + start + got, static_cast<std::size_t>(to - from) - got,
                              static_cast<off_t>(from + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      buf.resize(start + got);
      return false;
    }
    got += static_cast<std::size_t>(n);
  }
  return true;
}

/// The lines that START in body bytes [b, e) (file offsets), parsed as Rec and summarised. A line
/// that runs past e is read to its end. Memory: one block plus the longest line.
template <typename Rec>
void scanBlock(int fd, std::uint64_t body_begin, std::uint64_t body_end, std::uint64_t b, std::uint64_t e,
               Product product, const std::string& file, const ReadOptions& opt, const RecordGate& gate,
               std::vector<char>& buf, BlockResult& res) {
  std::string why;
  buf.clear();
  const std::uint64_t from = b > body_begin ? b - 1 : b;  // one byte before: does a line start at b?
  if (!preadAll(fd, from, e, buf)) {
    res.read_error = true;
    return;
  }
  std::size_t p = 0;
  if (b > body_begin) {
    // A line starts at b only when the byte before is a newline; else skip the rest of that line.
    const void* nl = std::memchr(buf.data(), '\n', buf.size());
    if (!nl) return;  // no line starts in this block
    p = static_cast<std::size_t>(static_cast<const char*>(nl) - buf.data()) + 1;
  }
  const std::size_t block_end = buf.size();  // lines starting before here are ours
  if (p >= block_end) return;
  // Complete the last line.
  if (buf.back() != '\n' && e < body_end) {
    std::uint64_t at = e;
    while (at < body_end) {
      const std::uint64_t to = std::min<std::uint64_t>(at + (64u << 10), body_end);
      const std::size_t before = buf.size();
      if (!preadAll(fd, at, to, buf)) {
        res.read_error = true;
        return;
      }
      if (std::memchr(buf.data() + before, '\n', buf.size() - before)) break;
      if (buf.size() > block_end + kMaxLineBytes) break;  // no record line is that long: the parse says so
      at = to;
    }
  }
  const char* base = buf.data();
  const char* end = base + buf.size();
  Rec r{};
  while (p < block_end) {
    const char* ls = base + p;
    const char* nl = static_cast<const char*>(std::memchr(ls, '\n', static_cast<std::size_t>(end - ls)));
    const char* le = nl ? nl : end;
    p = nl ? static_cast<std::size_t>(nl - base) + 1 : buf.size();
    ++res.lines;
    FieldScanner s(ls, le);
    if (s.atEnd()) continue;
    r = Rec{};
    const bool formed = parseRecord<Rec>(s, r, product);
    if (formed && checkRecord<Rec>(r, product, gate, &why)) {
      if (!res.has_time) {
        res.has_time = true;
        res.first = r.t;
        res.satellite = r.satellite;
      }
      res.last = r.t;
      ++res.records;
      continue;
    }
    ++res.rejected;
    if (!formed && static_cast<std::size_t>(le - ls) > kMaxLineBytes)
      why = "line longer than " + std::to_string(kMaxLineBytes >> 10) + " KiB: not a Level-1 record line";
    else if (!formed)
      why = s.reason();
    if (res.issues.size() < opt.max_issues_kept) res.issues.push_back(ParseIssue{file, res.lines, why});
    if (opt.on_error == OnError::Stop) return;
  }
}

/// Summary of an ASCII product read in blocks on several threads, in constant memory.
template <typename Rec>
void summarizeBlocks(int fd, std::uint64_t body_begin, std::uint64_t body_end, const Header& h, const ReadOptions& opt,
                     ProductSummary& s) {
  constexpr std::uint64_t kBlock = 4u << 20;
  const std::uint64_t body = body_end - body_begin;
  const std::size_t nblocks = static_cast<std::size_t>((body + kBlock - 1) / kBlock);
  unsigned threads = opt.threads > 0 ? static_cast<unsigned>(opt.threads) : std::thread::hardware_concurrency();
  if (opt.threads == 0 && body < detail::kParallelMinBytes) threads = 1;
  if (opt.on_error == OnError::Stop) threads = 1;
  threads = std::max(1u, std::min<unsigned>({threads, 8u, static_cast<unsigned>(std::max<std::size_t>(1, nblocks))}));
  std::vector<BlockResult> res(nblocks);
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  const RecordGate gate = makeRecordGate(h, s.file, opt);
  auto work = [&] {
    std::vector<char> buf;
    buf.reserve(static_cast<std::size_t>(kBlock) + (64u << 10) + 1);
    for (;;) {
      const std::size_t k = next.fetch_add(1);
      if (k >= nblocks || stop.load()) return;
      const std::uint64_t b = body_begin + k * kBlock, e = std::min(body_end, b + kBlock);
      scanBlock<Rec>(fd, body_begin, body_end, b, e, h.product, s.file, opt, gate, buf, res[k]);
      if (opt.on_error == OnError::Stop && (res[k].rejected || res[k].read_error)) stop = true;
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  // Merge in file order; line numbers become absolute.
  std::size_t line_base = h.line_count;
  s.product = h.product_name;
  s.declared_records = h.declared_records;
  s.satellite = h.satellite;
  for (auto& r : res) {
    if (r.read_error) {
      s.ok = false;
      s.error = s.file + ":" + std::to_string(line_base + r.lines + 1) + ": read error";
      return;
    }
    s.records += r.records;
    s.rejected_count += r.rejected;
    for (auto& i : r.issues) {
      if (s.rejected.size() >= opt.max_issues_kept) break;
      i.line += line_base;
      s.rejected.push_back(std::move(i));
    }
    if (r.has_time) {
      if (!s.has_time) {
        s.has_time = true;
        s.first_time = r.first;
        if (r.satellite != '?') s.satellite = r.satellite;
      }
      s.last_time = r.last;
    }
    if (opt.on_error == OnError::Stop && r.rejected) {
      s.ok = false;
      s.error = s.rejected.empty() ? s.file + ": rejected line" : s.rejected.front().str();
      return;
    }
    line_base += r.lines;
  }
}

/// summarizeProduct for typed ASCII products without loading the file; false when the file needs
/// the whole-file path (binary, report, generic products, unreadable header: that path explains).
bool summarizeStreaming(const std::string& path, const ReadOptions& opt, ProductSummary& s) {
  if (endsWith(path, ".rpt")) return false;
  LineStream ls;
  std::string err;
  if (!ls.open(path, opt, &err, 4096)) return false;
  const Header& h = ls.header();
  if (h.binary) return false;
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return false;
  s = ProductSummary{};
  s.file = path;
  const std::uint64_t b = ls.dataOffset(), e = ls.fileSize();
  if (e > maxFileBytes(h.product) || e < b) {  // not a regular file of a plausible size: the whole-file path says why
    ::close(fd);
    return false;
  }
  bool done = true;
  switch (h.product) {
    case Product::SCA1A: summarizeBlocks<Sca1aRecord>(fd, b, e, h, opt, s); break;
    case Product::ACC1A:
    case Product::ACT1A:
    case Product::AHK1A:
    case Product::AHK1B: summarizeBlocks<FlaggedRecord>(fd, b, e, h, opt, s); break;
    case Product::SCA1B: summarizeBlocks<Sca1bRecord>(fd, b, e, h, opt, s); break;
    case Product::ACC1B:
    case Product::ACT1B: summarizeBlocks<Acc1bRecord>(fd, b, e, h, opt, s); break;
    case Product::QSA1B:
    case Product::QKS1B: summarizeBlocks<QsaRecord>(fd, b, e, h, opt, s); break;
    case Product::GNV1B:
    case Product::GNI1B: summarizeBlocks<GnvRecord>(fd, b, e, h, opt, s); break;
    case Product::IMU1A:
    case Product::IMU1B: summarizeBlocks<ImuRecord>(fd, b, e, h, opt, s); break;
    case Product::THR1A:
    case Product::THR1B: summarizeBlocks<ThrRecord>(fd, b, e, h, opt, s); break;
    case Product::IHK1A:
    case Product::IHK1B: summarizeBlocks<IhkRecord>(fd, b, e, h, opt, s); break;
    case Product::HRT1A:
    case Product::HRT1B: summarizeBlocks<HrtRecord>(fd, b, e, h, opt, s); break;
    case Product::TIM1B: summarizeBlocks<TimRecord>(fd, b, e, h, opt, s); break;
    case Product::CLK1A:
    case Product::CLK1B: summarizeBlocks<ClkRecord>(fd, b, e, h, opt, s); break;
    default: done = false; break;
  }
  ::close(fd);
  return done;
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
  // Typed ASCII products are read in blocks (constant memory, several threads); the rest whole.
  {
    ProductSummary s;
    if (summarizeStreaming(path, opt, s)) return s;
  }
  std::string text, err;
  if (!readFileToString(path, text, &err, maxFileBytes(productFromName(productNameFromPath(path))))) {
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

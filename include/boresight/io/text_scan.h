// Field scanning and formatting for whitespace-separated Level-1 ASCII records.
//
// FieldScanner walks one line, field by field, and never throws: every getter returns false and
// leaves a reason ("field 6 (quatangle): not a number: 'abc'") when the field is missing or
// malformed. Numbers go through std::from_chars, which rounds exactly (IEEE nearest).
// LineWriter formats with std::to_chars' shortest round-trip representation, so every value that
// is written reads back bit-identical.
#pragma once

#include <charconv>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

namespace boresight::io {

/// A bit field written as a string of '0'/'1' (most significant first; bit 0 is rightmost).
/// width is the number of characters, kept so that a write reproduces the file's layout.
struct Bits {
  std::uint32_t value = 0;
  std::uint8_t width = 8;
  bool test(int bit) const { return (value >> bit) & 1u; }
  friend bool operator==(const Bits& a, const Bits& b) { return a.value == b.value && a.width == b.width; }
  friend bool operator!=(const Bits& a, const Bits& b) { return !(a == b); }
};

class FieldScanner {
 public:
  FieldScanner(const char* begin, const char* end) : p_(begin), end_(end) {}
  explicit FieldScanner(std::string_view line) : FieldScanner(line.data(), line.data() + line.size()) {}

  /// Next token, or an empty view at the end of the line.
  std::string_view token() {
    while (p_ < end_ && isSpace(*p_)) ++p_;
    const char* b = p_;
    while (p_ < end_ && !isSpace(*p_)) ++p_;
    return std::string_view(b, static_cast<std::size_t>(p_ - b));
  }

  bool f64(double& out, const char* name) {
    ++index_;
    skipSpace();
    if (p_ == end_) return fail(name, "missing", {});
    const char* b = p_;
    if (*b == '+') ++b;  // from_chars rejects a leading '+'; Level-1 files never have one, but be lenient
    auto r = std::from_chars(b, end_, out);
    if (r.ec == std::errc() && (r.ptr == end_ || isSpace(*r.ptr))) {
      p_ = r.ptr;
      if (out - out == 0.0) return true;
      return fail(name, "non-finite number", tokenAt(b));
    }
    std::string_view t = tokenAt(p_);
    if (r.ec == std::errc::result_out_of_range) return fail(name, "number out of range", t);
    return fail(name, "not a number", t);
  }

  template <typename Int>
  bool integer(Int& out, const char* name) {
    ++index_;
    skipSpace();
    if (p_ == end_) return fail(name, "missing", {});
    // Decimal digits with an optional sign; up to 18 digits cannot overflow the int64 accumulator.
    const char* b = p_;
    bool neg = false;
    if (*b == '-' || *b == '+') neg = *b++ == '-';
    const char* d = b;
    std::int64_t v = 0;
    while (d < end_ && static_cast<unsigned>(*d - '0') < 10u && d - b < 18) v = v * 10 + (*d++ - '0');
    const bool delimited = d == end_ || isSpace(*d);
    if (d == b || !delimited) {
      std::string_view t = tokenAt(p_);
      bool digits_only = d > b && d < end_ && static_cast<unsigned>(*d - '0') < 10u;
      return fail(name, digits_only ? "integer out of range" : "not an integer", t);
    }
    if (neg) v = -v;
    if (v < static_cast<std::int64_t>(std::numeric_limits<Int>::min()) ||
        v > static_cast<std::int64_t>(std::numeric_limits<Int>::max()))
      return fail(name, "integer out of range", tokenAt(p_));
    out = static_cast<Int>(v);
    p_ = d;
    return true;
  }

  /// An integer that must lie in [lo, hi].
  template <typename Int>
  bool integerIn(Int& out, Int lo, Int hi, const char* name) {
    if (!integer(out, name)) return false;
    if (out < lo || out > hi) return failRange(name, lo, hi);
    return true;
  }

  /// A single character token (satellite id, time reference, sensor type).
  bool ch(char& out, const char* name) {
    ++index_;
    std::string_view t = token();
    if (t.empty()) return fail(name, "missing", t);
    if (t.size() != 1) return fail(name, "expected one character", t);
    out = t[0];
    return true;
  }

  /// A free-form word (sensor names and the like); at most max_len characters.
  bool word(std::string_view& out, std::size_t max_len, const char* name) {
    ++index_;
    out = token();
    if (out.empty()) return fail(name, "missing", out);
    if (out.size() > max_len) return fail(name, "too long", out);
    return true;
  }

  /// A '0'/'1' string of 1..32 characters.
  bool bits(Bits& out, const char* name) {
    ++index_;
    std::string_view t = token();
    if (t.empty()) return fail(name, "missing", t);
    return parseBits(t, out) ? true : fail(name, "not a bit string", t);
  }

  /// Like bits(), but a missing field gives width 0 (some products omit a trailing flag).
  bool optionalBits(Bits& out, const char* name) {
    ++index_;
    std::string_view t = token();
    if (t.empty()) {
      out = Bits{0, 0};
      return true;
    }
    return parseBits(t, out) ? true : fail(name, "not a bit string", t);
  }

  /// True when only whitespace remains; otherwise records "unexpected extra field".
  bool finish() {
    std::string_view t = token();
    if (t.empty()) return true;
    ++index_;
    return fail("end of record", "unexpected extra field", t);
  }

  bool atEnd() {
    const char* save = p_;
    bool e = token().empty();
    p_ = save;
    return e;
  }

  /// Records a codec's own rejection of the current field ("field N (name): what: 'tok'").
  bool reject(const char* name, const char* what, std::string_view tok = {}) { return fail(name, what, tok); }

  const std::string& reason() const { return reason_; }
  int fieldIndex() const { return index_; }

  static bool parseBits(std::string_view t, Bits& out) {
    if (t.empty() || t.size() > 32) return false;
    std::uint32_t v = 0;
    std::size_t i = 0;
    // Eight characters at a time: all must be '0' or '1'; gather their low bits, first char highest.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"  // GCC 12 cannot see the loop guard for short literals
    for (; i + 8 <= t.size(); i += 8) {
      std::uint64_t w;
      std::memcpy(&w, t.data() + i, 8);
      if ((w & 0xFEFEFEFEFEFEFEFEull) != 0x3030303030303030ull) return false;
      std::uint64_t bitsx = w & 0x0101010101010101ull;  // little-endian: byte 0 is the first char
      // Move byte k's bit to position (7-k) of the top byte.
      std::uint32_t byte = static_cast<std::uint32_t>((bitsx * 0x8040201008040201ull) >> 56);
      v = (v << 8) | byte;
    }
#pragma GCC diagnostic pop
    for (; i < t.size(); ++i) {
      char c = t[i];
      if (c != '0' && c != '1') return false;
      v = (v << 1) | static_cast<std::uint32_t>(c - '0');
    }
    out.value = v;
    out.width = static_cast<std::uint8_t>(t.size());
    return true;
  }

  static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

 private:
  void skipSpace() {
    while (p_ < end_ && isSpace(*p_)) ++p_;
  }
  /// The token starting at b (for messages); leaves the scanner at its end.
  std::string_view tokenAt(const char* b) {
    const char* e = b;
    while (e < end_ && !isSpace(*e)) ++e;
    p_ = e;
    return std::string_view(b, static_cast<std::size_t>(e - b));
  }
  bool fail(const char* name, const char* what, std::string_view tok) {
    reason_.clear();
    reason_ += "field ";
    reason_ += std::to_string(index_);
    reason_ += " (";
    reason_ += name;
    reason_ += "): ";
    reason_ += what;
    if (!tok.empty()) {
      reason_ += ": '";
      reason_.append(tok.data(), tok.size() > 40 ? 40 : tok.size());
      reason_ += tok.size() > 40 ? "...'" : "'";
    }
    return false;
  }
  template <typename Int>
  bool failRange(const char* name, Int lo, Int hi) {
    reason_ = "field " + std::to_string(index_) + " (" + name + "): outside [" + std::to_string(lo) + ", " +
              std::to_string(hi) + "]";
    return false;
  }

  const char* p_;
  const char* end_;
  int index_ = 0;
  std::string reason_;
};

/// Appends fields to a line buffer, separated by single spaces.
class LineWriter {
 public:
  explicit LineWriter(std::string& out) : out_(out) {}

  LineWriter& f64(double v) {
    sep();
    char buf[32];
    auto r = std::to_chars(buf, buf + sizeof buf, v);
    out_.append(buf, static_cast<std::size_t>(r.ptr - buf));
    return *this;
  }
  template <typename Int>
  LineWriter& integer(Int v) {
    sep();
    char buf[24];
    auto r = std::to_chars(buf, buf + sizeof buf, v);
    out_.append(buf, static_cast<std::size_t>(r.ptr - buf));
    return *this;
  }
  LineWriter& ch(char c) {
    sep();
    out_ += c;
    return *this;
  }
  LineWriter& word(std::string_view w) {
    sep();
    out_.append(w.data(), w.size());
    return *this;
  }
  LineWriter& bits(const Bits& b) {
    if (b.width == 0) return *this;  // an omitted optional flag stays omitted
    sep();
    for (int i = b.width - 1; i >= 0; --i) out_ += ((b.value >> i) & 1u) ? '1' : '0';
    return *this;
  }
  void endLine() {
    out_ += '\n';
    first_ = true;
  }

 private:
  void sep() {
    if (!first_) out_ += ' ';
    first_ = false;
  }
  std::string& out_;
  bool first_ = true;
};

}  // namespace boresight::io

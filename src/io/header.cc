// Level-1 header parsing (YAML-style GRACE-FO header and the fixed 80-column GRACE header).
#include <boresight/io/level1.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <sys/stat.h>
#include <cstdio>
#include <cstring>

namespace boresight::io {
namespace {

struct NameEntry {
  const char* name;
  Product product;
};
constexpr NameEntry kNames[] = {
    {"SCA1A", Product::SCA1A}, {"SCA1B", Product::SCA1B}, {"ACC1A", Product::ACC1A},
    {"ACT1A", Product::ACT1A}, {"AHK1A", Product::AHK1A}, {"AHK1B", Product::AHK1B},
    {"ACC1B", Product::ACC1B}, {"ACT1B", Product::ACT1B}, {"QSA1B", Product::QSA1B},
    {"QKS1B", Product::QKS1B}, {"GNV1B", Product::GNV1B}, {"GNI1B", Product::GNI1B},
    {"IMU1A", Product::IMU1A}, {"IMU1B", Product::IMU1B}, {"THR1A", Product::THR1A},
    {"THR1B", Product::THR1B}, {"IHK1A", Product::IHK1A}, {"IHK1B", Product::IHK1B},
    {"HRT1A", Product::HRT1A}, {"HRT1B", Product::HRT1B}, {"TIM1B", Product::TIM1B},
    {"CLK1A", Product::CLK1A}, {"CLK1B", Product::CLK1B}, {"SCV1A", Product::SCV1A},
};

std::string_view trimRight(std::string_view s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}
std::string_view trim(std::string_view s) {
  s = trimRight(s);
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  return s;
}
bool startsWith(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

bool looksLevel1Name(std::string_view n) {
  if (n.size() != 5) return false;
  for (int i = 0; i < 3; ++i)
    if (!std::isupper(static_cast<unsigned char>(n[static_cast<std::size_t>(i)]))) return false;
  return n[3] == '1' && (n[4] == 'A' || n[4] == 'B');
}

bool parseInt64(std::string_view s, std::int64_t& v) {
  s = trim(s);
  auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

bool parseDouble(std::string_view s, double& v) {
  s = trim(s);
  double x = 0;
  auto r = std::from_chars(s.data(), s.data() + s.size(), x);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(x)) return false;
  v = x;
  return true;
}

/// Days from 1970-01-01 of a civil date (proleptic Gregorian).
std::int64_t daysFromCivil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

/// Products whose records carry time tags of the file's day (the time gate applies).
bool timeSeriesProduct(Product p) {
  switch (p) {
    case Product::QSA1B:
    case Product::QKS1B:
    case Product::TIM1B:
    case Product::Other:
    case Product::Unknown: return false;
    default: return true;
  }
}

char satelliteFromPlatform(std::string_view v) {
  v = trim(v);  // "GRACE C", "GRACE A"
  if (startsWith(v, "GRACE") && !v.empty()) {
    char c = v.back();
    if (c >= 'A' && c <= 'Z') return c;
  }
  return '?';
}

/// Next line of text starting at pos (without its '\n'); advances pos. False at the end.
bool nextLine(std::string_view text, std::size_t& pos, std::string_view& line) {
  if (pos >= text.size()) return false;
  std::size_t e = text.find('\n', pos);
  if (e == std::string_view::npos) e = text.size();
  line = text.substr(pos, e - pos);
  pos = e < text.size() ? e + 1 : e;
  return true;
}

/// Fixed header line: a key up to column 30, ':' then the value.
bool fixedKeyValue(std::string_view line, std::string_view& key, std::string_view& value) {
  std::size_t c = line.find(':');
  if (c == std::string_view::npos) return false;
  key = trim(line.substr(0, c));
  value = trim(line.substr(c + 1));
  return true;
}

}  // namespace

Product productFromName(std::string_view name) {
  for (const auto& e : kNames)
    if (name == e.name) return e.product;
  return looksLevel1Name(name) ? Product::Other : Product::Unknown;
}

const char* productName(Product p) {
  for (const auto& e : kNames)
    if (e.product == p) return e.name;
  return p == Product::Other ? "other" : "unknown";
}

std::string productNameFromPath(std::string_view path) {
  std::size_t slash = path.find_last_of('/');
  std::string_view base = slash == std::string_view::npos ? path : path.substr(slash + 1);
  if (base.size() >= 5 && looksLevel1Name(base.substr(0, 5))) return std::string(base.substr(0, 5));
  return {};
}

bool parseHeader(std::string_view text, Header& h, std::size_t* data_offset, std::string* error) {
  h = Header{};
  std::size_t pos = 0;
  std::string_view line;
  // The first non-empty line tells the style.
  std::size_t first = 0;
  while (true) {
    first = pos;
    if (!nextLine(text, pos, line)) {
      if (error) *error = "empty file: no Level-1 header";
      return false;
    }
    ++h.line_count;
    if (!trim(line).empty()) break;
  }
  pos = first;
  --h.line_count;  // leading blank lines count for the data line numbers; the header starts after them
  if (line.size() > kMaxHeaderBytes || first > kMaxHeaderBytes) {
    if (error) *error = "first header line longer than " + std::to_string(kMaxHeaderBytes >> 10) + " KiB: not a Level-1 header";
    return false;
  }
  std::string_view t = trimRight(line);
  auto tooLong = [&] {
    if (pos <= kMaxHeaderBytes) return false;
    if (error) *error = "header longer than " + std::to_string(kMaxHeaderBytes >> 10) + " KiB without its end line: not a Level-1 header";
    return true;
  };
  if (t == "header:") {
    h.style = HeaderStyle::Yaml;
    enum class Section { Other, Variables, FlagMeanings } sec = Section::Other;
    bool in_prod_flag = false;
    while (nextLine(text, pos, line)) {
      if (tooLong()) return false;
      ++h.line_count;
      h.lines.emplace_back(trimRight(line));
      std::string_view l = trimRight(line);
      if (l == "# End of YAML header") {
        *data_offset = pos;
        return true;
      }
      std::string_view s = trim(l);
      std::size_t indent = l.size() - s.size();
      if (startsWith(s, "num_records:")) {
        std::int64_t n;
        if (parseInt64(s.substr(12), n)) h.declared_records = n;
      } else if (startsWith(s, "start_time_epoch_secs:")) {
        parseDouble(s.substr(22), h.coverage_start_s);
      } else if (startsWith(s, "stop_time_epoch_secs:")) {
        parseDouble(s.substr(21), h.coverage_stop_s);
      } else if (indent == 4 && startsWith(s, "platform:")) {
        h.satellite = satelliteFromPlatform(s.substr(9));
      } else if (indent == 2 && s == "variables:") {
        sec = Section::Variables;
      } else if (sec != Section::Other && indent == 4 && startsWith(s, "- ")) {
        std::string_view name = s.substr(2);
        if (!name.empty() && name.back() == ':') name.remove_suffix(1);
        h.columns.emplace_back(name);
        in_prod_flag = name == "prod_flag";
        sec = Section::Variables;
      } else if (sec != Section::Other && in_prod_flag && indent == 8 && s == "flag_meanings:") {
        sec = Section::FlagMeanings;
      } else if (sec == Section::FlagMeanings && startsWith(s, "- bit ")) {
        // "- bit 3 = ang_accl_x"  (ranges such as "bits 29-31" are 'Not defined' and skipped)
        std::string_view rest = s.substr(6);
        std::size_t eq = rest.find('=');
        std::int64_t bit;
        if (eq != std::string_view::npos && parseInt64(rest.substr(0, eq), bit) && bit >= 0 && bit < 32)
          h.flag_fields[static_cast<std::size_t>(bit)] = std::string(trim(rest.substr(eq + 1)));
      } else if (sec == Section::FlagMeanings && indent <= 8) {
        sec = Section::Variables;
      }
    }
    if (error) *error = "YAML header without its end line '# End of YAML header'";
    return false;
  }
  std::string_view key, value;
  if (!fixedKeyValue(t, key, value) || line.find(':') > 40) {
    if (error) *error = "wrong header: expected 'header:' (GRACE-FO YAML) or a fixed 'KEY : value' header";
    return false;
  }
  h.style = HeaderStyle::Fixed;
  bool ended_once = false;
  while (nextLine(text, pos, line)) {
    if (!ended_once && tooLong()) return false;
    std::string_view l = trimRight(line);
    if (ended_once) {
      // The fixed header may be repeated: continue only if the next line is a header line again.
      std::string_view k2, v2;
      if (!(fixedKeyValue(l, k2, v2) && l.find(':') <= 40 && !k2.empty() &&
            std::isupper(static_cast<unsigned char>(k2.front())) && l.find("END OF HEADER") == std::string_view::npos &&
            k2.find(' ') != std::string_view::npos)) {
        break;
      }
      ended_once = false;
    }
    ++h.line_count;
    h.lines.emplace_back(l);
    if (startsWith(l, "END OF HEADER")) {
      ended_once = true;
      *data_offset = pos;
      if (h.binary) return true;  // packed records follow: never look at them as text
      continue;
    }
    if (!fixedKeyValue(l, key, value)) {
      if (error) *error = "fixed header line " + std::to_string(h.line_count) + " has no ':'";
      return false;
    }
    if (key == "NUMBER OF DATA RECORDS") {
      std::int64_t n;
      if (parseInt64(value, n)) h.declared_records = n;
    } else if (key == "SATELLITE NAME") {
      h.satellite = satelliteFromPlatform(value);
    } else if (startsWith(key, "FILE FORMAT")) {
      h.binary = value == "0";
    } else if (key == "FILENAME") {
      std::string n = productNameFromPath(value);
      if (!n.empty()) h.product_name = n;
    }
  }
  if (ended_once) return true;
  if (error) *error = "fixed header without 'END OF HEADER'";
  return false;
}

bool readFileToString(const std::string& path, std::string& out, std::string* error, std::uint64_t max_bytes) {
  out.clear();
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    if (error) *error = path + ": is a directory, not a file";
    return false;
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    if (error) *error = path + ": cannot open: " + std::strerror(errno);
    return false;
  }
  // A device or a pipe has no size to check up front and may never end: a smaller limit.
  if (!S_ISREG(st.st_mode)) max_bytes = std::min<std::uint64_t>(max_bytes, std::uint64_t{64} << 20);
  if (S_ISREG(st.st_mode)) {
    if (static_cast<std::uint64_t>(st.st_size) > max_bytes) {
      std::fclose(f);
      if (error) *error = path + ": " + std::to_string(st.st_size) + " bytes, more than the limit of " + std::to_string(max_bytes) + " bytes for this product";
      return false;
    }
    out.reserve(static_cast<std::size_t>(st.st_size));
  }
  char buf[1 << 16];
  std::size_t got;
  bool over = false;
  while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) {
    if (out.size() + got > max_bytes) {
      over = true;
      break;
    }
    out.append(buf, got);
  }
  bool bad = std::ferror(f) != 0;
  std::fclose(f);
  if (over) {
    out.clear();
    out.shrink_to_fit();
    if (error) *error = path + ": more than " + std::to_string(max_bytes) + " bytes (the limit for this product): refused (an endless input?)";
    return false;
  }
  if (bad) {
    if (error) *error = path + ": read error";
    return false;
  }
  return true;
}

std::uint64_t maxFileBytes(Product p) {
  constexpr std::uint64_t MiB = 1u << 20;
  constexpr std::uint64_t kDays = 31;
  switch (p) {
    case Product::QSA1B:
    case Product::QKS1B: return MiB;
    case Product::SCA1A: return 80 * MiB * kDays;  // 68 MB a day (3 heads at 2 Hz)
    case Product::ACC1A:
    case Product::ACT1A:
    case Product::AHK1A:
    case Product::AHK1B: return 200 * MiB * kDays;  // 177 MB a day at 10 Hz
    case Product::SCV1A: return 1024 * MiB * kDays;  // star vectors: about 0.6 GB a day
    case Product::GNV1B:
    case Product::GNI1B: return 32 * MiB * kDays;
    case Product::Unknown: return 64 * MiB;
    default: return 256 * MiB * kDays;
  }
}

bool dateFromFileName(std::string_view path, TimeUs& day_start) {
  std::size_t slash = path.find_last_of('/');
  std::string_view b = slash == std::string_view::npos ? path : path.substr(slash + 1);
  // "SCA1A_2023-06-01_..."
  if (b.size() < 16 || b[5] != '_' || b[10] != '-' || b[13] != '-' || productNameFromPath(b.substr(0, 5)).empty())
    return false;
  int y = 0, m = 0, d = 0;
  for (std::size_t i : {6u, 7u, 8u, 9u, 11u, 12u, 14u, 15u})
    if (!std::isdigit(static_cast<unsigned char>(b[i]))) return false;
  y = (b[6] - '0') * 1000 + (b[7] - '0') * 100 + (b[8] - '0') * 10 + (b[9] - '0');
  m = (b[11] - '0') * 10 + (b[12] - '0');
  d = (b[14] - '0') * 10 + (b[15] - '0');
  if (m < 1 || m > 12 || d < 1 || d > 31) return false;
  // Days from 2000-01-01; the epoch is 2000-01-01 12:00:00, so the day starts 12 h before it.
  const std::int64_t days = daysFromCivil(y, static_cast<unsigned>(m), static_cast<unsigned>(d)) - daysFromCivil(2000, 1, 1);
  day_start = (days * 86400 - 43200) * kUsPerSecond;
  return true;
}

RecordGate makeRecordGate(const Header& h, std::string_view file, const ReadOptions& opt) {
  RecordGate g;
  g.enabled = opt.plausibility_gates;
  g.quat_norm_tolerance = opt.quat_norm_tolerance;
  if (!timeSeriesProduct(h.product)) return g;
  if (std::isfinite(h.coverage_start_s) && std::isfinite(h.coverage_stop_s) && h.coverage_stop_s >= h.coverage_start_s &&
      std::abs(h.coverage_start_s) < 4e9 && std::abs(h.coverage_stop_s) < 4e9) {
    g.has_window = true;
    g.t_min = static_cast<TimeUs>(std::floor(h.coverage_start_s)) * kUsPerSecond - plausibility::kFileTimeMarginUs;
    g.t_max = static_cast<TimeUs>(std::ceil(h.coverage_stop_s)) * kUsPerSecond + plausibility::kFileTimeMarginUs;
    g.window = "the header's coverage, with a day's margin";
    return g;
  }
  TimeUs day = 0;
  if (dateFromFileName(file, day)) {
    g.has_window = true;
    g.t_min = day - plausibility::kFileTimeMarginUs;
    g.t_max = day + plausibility::kMaxFileSpanUs;
    g.window = "the date in the file name, a day before to 31 days after";
  }
  return g;
}

}  // namespace boresight::io

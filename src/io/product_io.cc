#include "product_io.h"
#include <boresight/io/files.h>

#include <cerrno>
#include <cstring>

namespace boresight::io::detail {
namespace {

const char* ordinal(std::size_t n, char* buf, std::size_t len) {
  const char* suf = "th";
  if (n % 100 < 11 || n % 100 > 13) {
    if (n % 10 == 1) suf = "st";
    if (n % 10 == 2) suf = "nd";
    if (n % 10 == 3) suf = "rd";
  }
  std::snprintf(buf, len, "%zu%s column", n, suf);
  return buf;
}

bool isGraceFo(char sat) { return sat == 'C' || sat == 'D'; }

std::string pad80(std::string s) {
  if (s.size() < 80) s.append(80 - s.size(), ' ');
  return s;
}

std::string fixedLine(const char* key, const std::string& value) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "%-30s: %s", key, value.c_str());
  return pad80(buf);
}

}  // namespace

std::vector<std::string> synthHeader(Product p, char satellite, const std::vector<std::string>& columns,
                                     const std::array<std::string, 32>* flag_fields) {
  std::vector<std::string> out;
  const std::string name = productName(p);
  const std::string level = name.size() == 5 ? std::string(1, name[4]) : "?";
  std::string sat_name = std::string("GRACE ") + satellite;
  if (isGraceFo(satellite)) {
    out.push_back("header:");
    out.push_back("  dimensions:");
    out.push_back("    num_records: 0");
    out.push_back("  global_attributes:");
    out.push_back("    creator_name: boresight");
    out.push_back("    platform: " + sat_name);
    out.push_back("    processing_level: 1" + level);
    out.push_back("    title: " + name + " written by boresight");
    out.push_back("  non-standard_attributes:");
    out.push_back("    epoch_time: 2000-01-01T12:00:00.00");
    out.push_back("  variables:");
    char buf[48];
    for (std::size_t i = 0; i < columns.size(); ++i) {
      out.push_back("    - " + columns[i] + ":");
      if (columns[i] == "prod_flag" && flag_fields) {
        out.push_back("        comment: " + std::string(ordinal(i + 1, buf, sizeof buf)));
        out.push_back("        flag_meanings:");
        for (int b = 0; b < 32; ++b)
          if (!(*flag_fields)[static_cast<std::size_t>(b)].empty())
            out.push_back("          - bit " + std::to_string(b) + " = " + (*flag_fields)[static_cast<std::size_t>(b)]);
        out.push_back("        long_name: Product flag, if bit set to 1, value is present in record, bit 0 is rightmost");
      } else {
        out.push_back("        comment: " + std::string(ordinal(i + 1, buf, sizeof buf)));
      }
    }
    out.push_back("# End of YAML header");
  } else {
    out.push_back(fixedLine("PRODUCER AGENCY", "boresight"));
    out.push_back(fixedLine("FILE FORMAT 0=BINARY 1=ASCII", "1"));
    out.push_back(fixedLine("SATELLITE NAME", sat_name));
    out.push_back(fixedLine("TIME EPOCH (GPS TIME)", "2000-01-01 12:00:00"));
    out.push_back(fixedLine("NUMBER OF DATA RECORDS", "0"));
    out.push_back(fixedLine("FILENAME", name + "_boresight_" + satellite + ".asc"));
    out.push_back(fixedLine("PROCESS LEVEL (1A OR 1B)", "1" + level));
    out.push_back(pad80("END OF HEADER"));
  }
  return out;
}

std::vector<std::string> headerForWrite(const Header& hin, std::size_t records) {
  Header h = hin;
  if (h.binary && h.style != HeaderStyle::Fixed) {
    // GRACE binary products carry the fixed header: drop a YAML one and synthesise.
    h.lines.clear();
    h.style = HeaderStyle::Fixed;
  }
  std::vector<std::string> lines = h.lines;
  if (lines.empty()) {
    lines = synthHeader(h.product, h.satellite == '?' ? 'C' : h.satellite, h.columns,
                        h.columns.empty() ? nullptr : &h.flag_fields);
    if (h.style == HeaderStyle::Fixed && !lines.empty() && lines.front() == "header:") {
      // A GRACE-FO satellite with a fixed header (static products): keep the fixed style.
      lines = synthHeader(h.product, 'A', h.columns, nullptr);
      for (auto& l : lines)
        if (l.rfind("SATELLITE NAME", 0) == 0) l = fixedLine("SATELLITE NAME", std::string("GRACE ") + h.satellite);
    }
  }
  if (h.binary) {
    // Everything after the first END OF HEADER would be taken for records: stop there, before the
    // record count and the format entry are checked (a repeated header must not satisfy them).
    for (std::size_t i = 0; i < lines.size(); ++i)
      if (lines[i].rfind("END OF HEADER", 0) == 0) {
        lines.resize(i + 1);
        break;
      }
  }
  // The written header tells the truth: every record-count entry the reader would take (any
  // indentation, any spacing before ':') gets the real count, and one is added when there is none.
  const std::string n = std::to_string(records);
  bool has_count = false;
  // YAML exactly when the reader takes it so: a first line that is "header:" up to trailing blanks (a
  // fixed header whose first key merely starts with "header:" stays fixed).
  bool yaml = false;
  if (!lines.empty()) {
    std::string_view f = lines.front();
    while (!f.empty() && (f.back() == ' ' || f.back() == '\t' || f.back() == '\r')) f.remove_suffix(1);
    yaml = f == "header:";
  }
  for (auto& l : lines) {
    const std::size_t ind = l.find_first_not_of(" \t");
    const std::string_view t = ind == std::string::npos ? std::string_view() : std::string_view(l).substr(ind);
    if (yaml) {
      if (t.rfind("num_records:", 0) == 0) {
        l = l.substr(0, ind) + "num_records: " + n;
        has_count = true;
      }
      continue;
    }
    const std::size_t colon = t.find(':');
    if (colon == std::string_view::npos) continue;
    std::string_view key = t.substr(0, colon);
    while (!key.empty() && (key.back() == ' ' || key.back() == '\t')) key.remove_suffix(1);
    if (key == "NUMBER OF DATA RECORDS") {
      l = fixedLine("NUMBER OF DATA RECORDS", n);
      has_count = true;
    } else if (key.rfind("FILE FORMAT", 0) == 0) {
      l = fixedLine("FILE FORMAT 0=BINARY 1=ASCII", h.binary ? "0" : "1");
    }
  }
  if (!has_count) {
    if (yaml) {
      lines.insert(lines.begin() + 1, {"  dimensions:", "    num_records: " + n});
    } else {
      std::size_t end = 0;
      while (end < lines.size() && lines[end].rfind("END OF HEADER", 0) != 0) ++end;
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(end), fixedLine("NUMBER OF DATA RECORDS", n));
    }
  }
  if (h.binary) {
    bool has_format = false;
    for (const auto& l : lines) has_format = has_format || l.rfind("FILE FORMAT 0=BINARY 1=ASCII  : 0", 0) == 0;
    if (!has_format) lines.insert(lines.begin(), fixedLine("FILE FORMAT 0=BINARY 1=ASCII", "0"));
  }
  return lines;
}

void failFile(std::string& error, bool& ok, std::string_view file, std::size_t line, const std::string& reason) {
  ok = false;
  error = std::string(file) + ":" + std::to_string(line) + ": " + reason;
}

bool resolveProduct(Header& h, std::string_view file, const ReadOptions& opt, std::string* error) {
  if (opt.product != Product::Unknown) {
    h.product = opt.product;
    h.product_name = productName(opt.product);
    return true;
  }
  std::string from_path = productNameFromPath(file);
  if (!from_path.empty()) h.product_name = from_path;
  h.product = productFromName(h.product_name);
  if (h.product == Product::Unknown) {
    if (error)
      *error = "unknown product: the file name does not start with a Level-1 product name (e.g. SCA1A_...)"
               " and the header names none";
    return false;
  }
  return true;
}

bool writeText(const std::string& path, const std::string& text, std::string* error) {
  return writeFileAtomic(path, text, error);  // whole or not at all
}

}  // namespace boresight::io::detail

// The streaming product writer (chunked_writer.h).
#include <boresight/io/chunked_writer.h>
#include <boresight/io/time_format.h>

#include <cstring>

namespace boresight::io {
namespace {

std::size_t countLines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

/// Byte offset after the first `lines` newlines.
std::size_t afterLines(const std::string& s, std::size_t lines) {
  std::size_t pos = 0;
  for (std::size_t i = 0; i < lines; ++i) {
    const auto nl = s.find('\n', pos);
    if (nl == std::string::npos) return s.size();
    pos = nl + 1;
  }
  return pos;
}

/// Whole seconds of a tag, rounded down.
std::int64_t floorSeconds(TimeUs t) {
  std::int64_t s = t / kUsPerSecond;
  if (s * kUsPerSecond > t) --s;
  return s;
}

constexpr std::size_t kCountWidth = 12, kIsoWidth = 22, kSecsWidth = 12, kFixedWidth = 49;

}  // namespace

template <typename Rec>
ChunkedProductWriter<Rec>::~ChunkedProductWriter() = default;  // not closed: the temporary file goes

template <typename Rec>
std::string ChunkedProductWriter<Rec>::value(Field f) const {
  char buf[96];
  const bool any = written() > 0;
  switch (f) {
    case Field::Count: return std::to_string(count_);
    case Field::StartIso:
    case Field::StopIso: {
      if (!any) return {};
      const CivilTime c = civilFromTime(f == Field::StartIso ? t_first_ : t_last_);
      std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%02d", c.year, c.month, c.day, c.hour, c.minute, c.second,
                    c.microsecond / 10000);
      return buf;
    }
    case Field::StartSecs: return any ? std::to_string(floorSeconds(t_first_)) : std::string();
    case Field::StopSecs: return any ? std::to_string(floorSeconds(t_last_)) : std::string();
    case Field::FirstObs:
    case Field::LastObs: {
      if (!any) return {};
      const TimeUs t = f == Field::FirstObs ? t_first_ : t_last_;
      const CivilTime c = civilFromTime(t);
      std::snprintf(buf, sizeof buf, "%.6f (%04d-%02d-%02d %02d:%02d:%02d.%02d)", static_cast<double>(t) * 1e-6, c.year, c.month,
                    c.day, c.hour, c.minute, c.second, c.microsecond / 10000);
      return buf;
    }
  }
  return {};
}

template <typename Rec>
bool ChunkedProductWriter<Rec>::open(const std::string& path, const ProductFile<Rec>& proto, std::string* error,
                                     std::size_t chunk_records, bool coverage) {
  path_ = path;
  chunk_ = proto;
  chunk_.records.clear();
  chunk_size_ = chunk_records == 0 ? 1 : chunk_records;
  chunk_.records.reserve(chunk_size_);
  std::string header = formatProduct(chunk_);
  header_lines_ = countLines(header);
  count_ = 0;
  t_first_ = t_last_ = 0;
  io_error_ = false;
  slots_.clear();
  const bool yaml = header.rfind("header:", 0) == 0;
  // The coverage lines, blank, beside the lines of their sections (YAML) or before the record count
  // (fixed header); their offsets are taken below with the count's.
  if (coverage) {
    auto insertAfter = [&](const std::string& line, const std::string& add) {
      const auto p = header.find("\n" + line + "\n");
      if (p == std::string::npos) return false;
      header.insert(p + line.size() + 2, add);
      return true;
    };
    if (yaml) {
      const std::string iso(kIsoWidth, ' '), secs(kSecsWidth, ' ');
      if (!insertAfter("  global_attributes:", "    time_coverage_start: " + iso + "\n    time_coverage_stop: " + iso + "\n")) {
        if (error) *error = path_ + ": the header has no global_attributes section for the time coverage";
        return false;
      }
      if (!insertAfter("  non-standard_attributes:",
                       "    start_time_epoch_secs: " + secs + "\n    stop_time_epoch_secs: " + secs + "\n")) {
        if (error) *error = path_ + ": the header has no non-standard_attributes section for the time coverage";
        return false;
      }
    } else {
      const auto p = header.find("NUMBER OF DATA RECORDS");
      if (p != std::string::npos) {
        char line[128];
        std::string add;
        for (const char* key : {"TIME FIRST OBS(SEC PAST EPOCH)", "TIME LAST OBS(SEC PAST EPOCH)"}) {
          std::snprintf(line, sizeof line, "%-30s: %-*s", key, static_cast<int>(kFixedWidth), "");
          add += line;
          add += '\n';
        }
        header.insert(p, add);
      }
    }
  }
  // Every field known only at the end, with a fixed width (the count's widened here in the YAML header).
  struct Key {
    const char* text;
    Field field;
    std::size_t width;  ///< 0: the fixed header's value as synthesised (up to the line's end)
  };
  const std::vector<Key> keys = yaml ? std::vector<Key>{{"    num_records: ", Field::Count, kCountWidth},
                                                        {"    time_coverage_start: ", Field::StartIso, kIsoWidth},
                                                        {"    time_coverage_stop: ", Field::StopIso, kIsoWidth},
                                                        {"    start_time_epoch_secs: ", Field::StartSecs, kSecsWidth},
                                                        {"    stop_time_epoch_secs: ", Field::StopSecs, kSecsWidth}}
                                     : std::vector<Key>{{"NUMBER OF DATA RECORDS", Field::Count, 0},
                                                        {"TIME FIRST OBS(SEC PAST EPOCH)", Field::FirstObs, 0},
                                                        {"TIME LAST OBS(SEC PAST EPOCH)", Field::LastObs, 0}};
  for (const Key& k : keys) {
    const auto p = header.find(k.text);
    if (p == std::string::npos) continue;
    const auto eol = header.find('\n', p);
    std::size_t v = p + std::strlen(k.text);
    if (!yaml) v = header.find(':', p) + 2;  // fixed header: "KEY   : value"
    if (k.width > 0) {
      header.replace(v, eol - v, std::string(k.width, ' '));
      slots_.push_back({k.field, v, k.width});
    } else {
      slots_.push_back({k.field, v, eol - v});
    }
  }
  if (!file_.open(path_, error)) return false;  // whole at close() or not at all (io::AtomicFile)
  body_ = file_.file();
  if (std::fwrite(header.data(), 1, header.size(), body_) != header.size()) io_error_ = true;
  return true;
}

template <typename Rec>
void ChunkedProductWriter<Rec>::flush() {
  if (chunk_.records.empty() || !body_) return;
  const std::string text = formatProduct(chunk_);
  const std::size_t off = afterLines(text, header_lines_);  // the chunk's own header (the proto's)
  if (std::fwrite(text.data() + off, 1, text.size() - off, body_) != text.size() - off) io_error_ = true;
  count_ += chunk_.records.size();
  chunk_.records.clear();
}

template <typename Rec>
bool ChunkedProductWriter<Rec>::close(std::string* error) {
  if (!body_) return true;
  flush();
  bool ok = !io_error_;
  for (const Slot& s : slots_) {
    if (!ok) break;
    std::string v = value(s.field);
    if (v.size() > s.width) v = v.substr(0, s.width);  // cannot happen: the widths hold every value
    v.resize(s.width, ' ');
    ok = std::fseek(body_, static_cast<long>(s.offset), SEEK_SET) == 0 && std::fwrite(v.data(), 1, v.size(), body_) == v.size();
  }
  body_ = nullptr;
  if (!ok) {
    file_.abandon();
    if (error) *error = path_ + ": write failed";
    return false;
  }
  return file_.commit(error);
}

template class ChunkedProductWriter<Sca1aRecord>;
template class ChunkedProductWriter<FlaggedRecord>;
template class ChunkedProductWriter<GnvRecord>;
template class ChunkedProductWriter<ScvRecord>;
template class ChunkedProductWriter<Sca1bRecord>;

}  // namespace boresight::io

// IHK1A / IHK1B: instrument housekeeping, one sensor value per record.
// time_intg time_frac time_ref id qualflg sensortype sensorvalue sensorname
// The header calls sensorname "the entire remaining portion of each record, nominally a short
// string": extra words are joined with single spaces (at most kIhkNameMax characters in all).
#include "product_io.h"

namespace boresight::io {

bool IhkRecord::setSensorName(std::string_view n) {
  if (n.empty() || n.size() > kIhkNameMax) return false;
  std::memcpy(name, n.data(), n.size());
  std::memset(name + n.size(), 0, sizeof name - n.size());
  return true;
}

bool operator==(const IhkRecord& a, const IhkRecord& b) {
  return a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.qualflg == b.qualflg &&
         a.sensortype == b.sensortype && a.value == b.value && a.sensorName() == b.sensorName();
}

namespace {
struct IhkCodec {
  using Record = IhkRecord;
  static bool accepts(Product p) { return p == Product::IHK1A || p == Product::IHK1B; }
  static Product defaultProduct() { return Product::IHK1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    std::string_view word;
    if (!(detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACEFO_id") &&
          s.bits(r.qualflg, "qualflg") && s.ch(r.sensortype, "sensortype") && s.f64(r.value, "sensorvalue") &&
          s.word(word, kIhkNameMax, "sensorname")))
      return false;
    std::size_t len = 0;
    for (bool first = true; first || !s.atEnd(); first = false) {
      if (!first) {
        const std::size_t room = len + 1 < kIhkNameMax ? kIhkNameMax - len - 1 : 0;
        if (!s.word(word, room, "sensorname")) return false;
        r.name[len++] = ' ';
      }
      if (std::memchr(word.data(), '\0', word.size())) return s.reject("sensorname", "contains a NUL byte");
      std::memcpy(r.name + len, word.data(), word.size());
      len += word.size();
    }
    r.name[len] = '\0';
    return true;
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite).bits(r.qualflg).ch(r.sensortype).f64(r.value);
    // A record built in code may hold an empty name; keep the line parseable.
    w.word(r.name[0] ? r.sensorName() : std::string_view("-"));
  }
  static std::vector<std::string> columns(Product) {
    return {"time_intg", "time_frac", "time_ref", "GRACEFO_id", "qualflg", "sensortype", "sensorvalue", "sensorname"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::IhkCodec)

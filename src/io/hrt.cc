// HRT1A / HRT1B: 30 high-resolution temperatures (old fixed header).
// time_intg time_frac time_ref id T1..T30 [qualflg]
// The layout (30 temperatures: MEP, ICU, ACC cage, CFRP frame, MWA, horn, USO, ...) follows the
// HRT1X_t struct of JPL's GraceRead GRACEiolib.h. The trailing qualflg varies in width and may be
// absent: FieldScanner::optionalBits() keeps its width (0 when absent) so a write reproduces it.
#include "product_io.h"

namespace boresight::io {

bool operator==(const HrtRecord& a, const HrtRecord& b) {
  for (int i = 0; i < kHrtTemps; ++i)
    if (a.temp[i] != b.temp[i]) return false;
  return a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.qualflg == b.qualflg;
}

namespace {
struct HrtCodec {
  using Record = HrtRecord;
  static bool accepts(Product p) { return p == Product::HRT1A || p == Product::HRT1B; }
  static Product defaultProduct() { return Product::HRT1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    if (!(detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACE_id")))
      return false;
    for (auto& v : r.temp)
      if (!s.f64(v, "temperature")) return false;
    return s.optionalBits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite);
    for (double v : r.temp) w.f64(v);
    w.bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    std::vector<std::string> c = {"time_intg", "time_frac", "time_ref", "GRACE_id"};
    for (int i = 1; i <= kHrtTemps; ++i) c.push_back("temp_" + std::to_string(i));
    c.emplace_back("qualflg");
    return c;
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::HrtCodec)

// CLK1A / CLK1B: receiver clock offset (GPS time = rcv_time + eps_time).
// rcv_time id clock_id eps_time eps_err eps_drift drift_err qualflg
#include "product_io.h"

namespace boresight::io {

bool operator==(const ClkRecord& a, const ClkRecord& b) {
  return a.t == b.t && a.satellite == b.satellite && a.clock_id == b.clock_id && a.eps_time == b.eps_time &&
         a.eps_err == b.eps_err && a.eps_drift == b.eps_drift && a.drift_err == b.drift_err && a.qualflg == b.qualflg;
}

namespace {
struct ClkCodec {
  using Record = ClkRecord;
  static bool accepts(Product p) { return p == Product::CLK1A || p == Product::CLK1B; }
  static Product defaultProduct() { return Product::CLK1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "GRACEFO_id") && s.integer(r.clock_id, "clock_id") &&
           s.f64(r.eps_time, "eps_time") && s.f64(r.eps_err, "eps_err") && s.f64(r.eps_drift, "eps_drift") &&
           s.f64(r.drift_err, "drift_err") && s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite).integer(r.clock_id).f64(r.eps_time).f64(r.eps_err).f64(r.eps_drift).f64(r.drift_err);
    w.bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"rcv_time", "GRACEFO_id", "clock_id", "eps_time", "eps_err", "eps_drift", "drift_err", "qualflg"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::ClkCodec)

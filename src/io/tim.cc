// TIM1B: OBC time to receiver time mapping.
// obctime id TS_suppid rcvtime_intg rcvtime_frac first_icu_blknr final_icu_blknr qualflg
// rcvtime_frac is kept as written (nanoseconds in GRACE-FO RL04, microseconds in GRACE 2003).
#include "product_io.h"

namespace boresight::io {

bool operator==(const TimRecord& a, const TimRecord& b) {
  return a.t == b.t && a.satellite == b.satellite && a.ts_suppid == b.ts_suppid && a.rcvtime_intg == b.rcvtime_intg &&
         a.rcvtime_frac == b.rcvtime_frac && a.first_icu_blknr == b.first_icu_blknr &&
         a.final_icu_blknr == b.final_icu_blknr && a.qualflg == b.qualflg;
}

namespace {
struct TimCodec {
  using Record = TimRecord;
  static bool accepts(Product p) { return p == Product::TIM1B; }
  static Product defaultProduct() { return Product::TIM1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "GRACEFO_id") && s.integer(r.ts_suppid, "TS_suppid") &&
           s.integerIn<std::int64_t>(r.rcvtime_intg, -4000000000LL, 4000000000LL, "rcvtime_intg") &&
           s.integerIn<std::int64_t>(r.rcvtime_frac, 0, 999999999, "rcvtime_frac") &&
           s.integer(r.first_icu_blknr, "first_icu_blknr") && s.integer(r.final_icu_blknr, "final_icu_blknr") &&
           s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite).integer(r.ts_suppid).integer(r.rcvtime_intg).integer(r.rcvtime_frac);
    w.integer(r.first_icu_blknr).integer(r.final_icu_blknr).bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"obctime", "GRACEFO_id", "TS_suppid", "rcvtime_intg", "rcvtime_frac", "first_icu_blknr", "final_icu_blknr",
            "qualflg"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::TimCodec)

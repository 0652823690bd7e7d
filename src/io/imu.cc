// IMU1A / IMU1B: gyro filtered angles, three gyros interleaved.
// rcvtime_intg rcvtime_frac time_ref GRACEFO_id gyro_id FiltAng qualflg
#include "product_io.h"

namespace boresight::io {

bool operator==(const ImuRecord& a, const ImuRecord& b) {
  return a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.gyro_id == b.gyro_id &&
         a.filt_ang == b.filt_ang && a.qualflg == b.qualflg;
}

namespace {
struct ImuCodec {
  using Record = ImuRecord;
  static bool accepts(Product p) { return p == Product::IMU1A || p == Product::IMU1B; }
  static Product defaultProduct() { return Product::IMU1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACEFO_id") &&
           s.integerIn(r.gyro_id, 0, 99, "gyro_id") && s.f64(r.filt_ang, "FiltAng") && s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite).integer(r.gyro_id).f64(r.filt_ang).bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"rcvtime_intg", "rcvtime_frac", "time_ref", "GRACEFO_id", "gyro_id", "FiltAng", "qualflg"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::ImuCodec)

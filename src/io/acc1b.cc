// ACC1B (GRACE, SRF, angular acceleration present) and ACT1B (GRACE-FO, angular acceleration 0).
// ASCII:  gps_time id lin_accl_x/y/z ang_accl_x/y/z acl_x/y/z_res qualflg
// Binary (GRACE .dat, 78 bytes, big-endian, packed): int32 gps_time, char GRACE_id, 9 x float64 in
// the ASCII order, uint8 qualflg. Checked against JPL's GraceRead ReadACC1BFRecord.c (field by field
// fread_grace(), byte-swapped on little-endian hosts, no padding) and the ACC1B_t struct of GRACEiolib.h.
#include "product_io.h"

namespace boresight::io {

bool operator==(const Acc1bRecord& a, const Acc1bRecord& b) {
  for (int i = 0; i < 3; ++i)
    if (a.lin[i] != b.lin[i] || a.ang[i] != b.ang[i] || a.res[i] != b.res[i]) return false;
  return a.t == b.t && a.satellite == b.satellite && a.qualflg == b.qualflg;
}

namespace {
struct Acc1bCodec {
  using Record = Acc1bRecord;
  static bool accepts(Product p) { return p == Product::ACC1B || p == Product::ACT1B; }
  static Product defaultProduct() { return Product::ACC1B; }
  static bool plausible(const Record& r, Product, const RecordGate&, std::string* reason) {
    return detail::axesPlausible(r.lin, plausibility::kMaxLinearAccelMS2, "linear acceleration", "m/s^2", reason) &&
           detail::axesPlausible(r.ang, plausibility::kMaxAngularAccelRadS2, "angular acceleration", "rad/s^2", reason);
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "GRACEFO_id") && s.f64(r.lin[0], "lin_accl_x") &&
           s.f64(r.lin[1], "lin_accl_y") && s.f64(r.lin[2], "lin_accl_z") && s.f64(r.ang[0], "ang_accl_x") &&
           s.f64(r.ang[1], "ang_accl_y") && s.f64(r.ang[2], "ang_accl_z") && s.f64(r.res[0], "acl_x_res") &&
           s.f64(r.res[1], "acl_y_res") && s.f64(r.res[2], "acl_z_res") && s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite);
    for (double v : r.lin) w.f64(v);
    for (double v : r.ang) w.f64(v);
    for (double v : r.res) w.f64(v);
    w.bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"gps_time",   "GRACEFO_id", "lin_accl_x", "lin_accl_y", "lin_accl_z", "ang_accl_x",
            "ang_accl_y", "ang_accl_z", "acl_x_res",  "acl_y_res",  "acl_z_res",  "qualflg"};
  }

  static constexpr std::size_t kBinarySize = binary_layout::kAcc1b;
  static bool decode(const unsigned char* p, Record& r, std::string& reason) {
    static const char* names[9] = {"lin_accl_x", "lin_accl_y", "lin_accl_z", "ang_accl_x", "ang_accl_y",
                                   "ang_accl_z", "acl_x_res",  "acl_y_res",  "acl_z_res"};
    r.t = static_cast<TimeUs>(detail::be::i32(p)) * kUsPerSecond;
    r.satellite = static_cast<char>(p[4]);
    if (!detail::isSatelliteId(r.satellite)) {
      reason = "field GRACE_id: not a satellite letter (byte " + std::to_string(p[4]) + ")";
      return false;
    }
    double v[9];
    for (int i = 0; i < 9; ++i) {
      v[i] = detail::be::f64(p + 5 + 8 * i);
      if (!detail::be::finite(v[i], names[i], reason)) return false;
    }
    for (int i = 0; i < 3; ++i) {
      r.lin[i] = v[i];
      r.ang[i] = v[3 + i];
      r.res[i] = v[6 + i];
    }
    r.qualflg = Bits{p[77], 8};
    return true;
  }
  static void encode(unsigned char* p, const Record& r) {
    detail::be::putI32(p, detail::be::secondsForBinary(r.t));
    p[4] = static_cast<unsigned char>(r.satellite);
    for (int i = 0; i < 3; ++i) {
      detail::be::putF64(p + 5 + 8 * i, r.lin[i]);
      detail::be::putF64(p + 29 + 8 * i, r.ang[i]);
      detail::be::putF64(p + 53 + 8 * i, r.res[i]);
    }
    p[77] = static_cast<unsigned char>(r.qualflg.value & 0xffu);
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::Acc1bCodec)

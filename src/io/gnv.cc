// GNV1B / GNI1B: GPS navigation orbit, Earth-fixed ('E') or inertial ('I'); 1e33 marks a missing value.
// ASCII:  gps_time id coord_ref xpos ypos zpos xpos_err ypos_err zpos_err xvel yvel zvel
//         xvel_err yvel_err zvel_err qualflg
// Binary (GRACE .dat, 103 bytes, big-endian, packed): int32 gps_time, char GRACE_id, char coord_ref,
// 12 x float64 in the ASCII order, uint8 qualflg (the GNV1B_t struct of JPL's GraceRead GRACEiolib.h).
#include "product_io.h"

namespace boresight::io {

bool operator==(const GnvRecord& a, const GnvRecord& b) {
  for (int i = 0; i < 3; ++i)
    if (a.pos[i] != b.pos[i] || a.pos_err[i] != b.pos_err[i] || a.vel[i] != b.vel[i] || a.vel_err[i] != b.vel_err[i])
      return false;
  return a.t == b.t && a.satellite == b.satellite && a.coord_ref == b.coord_ref && a.qualflg == b.qualflg;
}

namespace {
struct GnvCodec {
  using Record = GnvRecord;
  static bool accepts(Product p) { return p == Product::GNV1B || p == Product::GNI1B; }
  static Product defaultProduct() { return Product::GNV1B; }
  static bool plausible(const Record& r, Product, const RecordGate&, std::string* reason) {
    char b[200];
    if (!plausibility::orbitRadiusPlausible(r.pos)) {
      std::snprintf(b, sizeof b, "implausible: orbit radius %.6g m outside %.3g .. %.3g m", plausibility::norm3(r.pos),
                    plausibility::kMinOrbitRadiusM, plausibility::kMaxOrbitRadiusM);
      if (reason) *reason = b;
      return false;
    }
    if (!plausibility::orbitSpeedPlausible(r.vel)) {
      std::snprintf(b, sizeof b, "implausible: orbit speed %.6g m/s beyond %.3g m/s", plausibility::norm3(r.vel),
                    plausibility::kMaxOrbitSpeedMS);
      if (reason) *reason = b;
      return false;
    }
    return true;
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "GRACEFO_id") && s.ch(r.coord_ref, "coord_ref") &&
           s.f64(r.pos[0], "xpos") && s.f64(r.pos[1], "ypos") && s.f64(r.pos[2], "zpos") &&
           s.f64(r.pos_err[0], "xpos_err") && s.f64(r.pos_err[1], "ypos_err") && s.f64(r.pos_err[2], "zpos_err") &&
           s.f64(r.vel[0], "xvel") && s.f64(r.vel[1], "yvel") && s.f64(r.vel[2], "zvel") &&
           s.f64(r.vel_err[0], "xvel_err") && s.f64(r.vel_err[1], "yvel_err") && s.f64(r.vel_err[2], "zvel_err") &&
           s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite).ch(r.coord_ref);
    for (double v : r.pos) w.f64(v);
    for (double v : r.pos_err) w.f64(v);
    for (double v : r.vel) w.f64(v);
    for (double v : r.vel_err) w.f64(v);
    w.bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"gps_time", "GRACEFO_id", "coord_ref", "xpos",     "ypos",     "zpos",     "xpos_err", "ypos_err",
            "zpos_err", "xvel",       "yvel",      "zvel",     "xvel_err", "yvel_err", "zvel_err", "qualflg"};
  }

  static constexpr std::size_t kBinarySize = binary_layout::kGnv1b;
  static bool decode(const unsigned char* p, Record& r, std::string& reason) {
    static const char* names[12] = {"xpos", "ypos", "zpos", "xpos_err", "ypos_err", "zpos_err",
                                    "xvel", "yvel", "zvel", "xvel_err", "yvel_err", "zvel_err"};
    r.t = static_cast<TimeUs>(detail::be::i32(p)) * kUsPerSecond;
    r.satellite = static_cast<char>(p[4]);
    r.coord_ref = static_cast<char>(p[5]);
    if (!detail::isSatelliteId(r.satellite)) {
      reason = "field GRACE_id: not a satellite letter (byte " + std::to_string(p[4]) + ")";
      return false;
    }
    if (r.coord_ref <= ' ' || r.coord_ref > '~') {
      reason = "field coord_ref: not a printable character (byte " + std::to_string(p[5]) + ")";
      return false;
    }
    double v[12];
    for (int i = 0; i < 12; ++i) {
      v[i] = detail::be::f64(p + 6 + 8 * i);
      if (!detail::be::finite(v[i], names[i], reason)) return false;
    }
    for (int i = 0; i < 3; ++i) {
      r.pos[i] = v[i];
      r.pos_err[i] = v[3 + i];
      r.vel[i] = v[6 + i];
      r.vel_err[i] = v[9 + i];
    }
    r.qualflg = Bits{p[102], 8};
    return true;
  }
  static void encode(unsigned char* p, const Record& r) {
    detail::be::putI32(p, detail::be::secondsForBinary(r.t));
    p[4] = static_cast<unsigned char>(r.satellite);
    p[5] = static_cast<unsigned char>(r.coord_ref);
    for (int i = 0; i < 3; ++i) {
      detail::be::putF64(p + 6 + 8 * i, r.pos[i]);
      detail::be::putF64(p + 30 + 8 * i, r.pos_err[i]);
      detail::be::putF64(p + 54 + 8 * i, r.vel[i]);
      detail::be::putF64(p + 78 + 8 * i, r.vel_err[i]);
    }
    p[102] = static_cast<unsigned char>(r.qualflg.value & 0xffu);
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::GnvCodec)

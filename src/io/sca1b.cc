// SCA1B: combined star camera attitude, GPS time, 1 Hz (GRACE-FO) or 0.2 Hz (GRACE).
// ASCII:  gps_time id sca_id quatangle quaticoeff quatjcoeff quatkcoeff qual_rss qualflg
// Binary (GRACE .dat, 47 bytes, big-endian, packed): int32 gps_time, char GRACE_id, int8 sca_id,
// float64 quatangle, quaticoeff, quatjcoeff, quatkcoeff, qual_rss, uint8 qualflg.
// Layout checked against JPL's GraceRead library (ReadSCA1BFRecord.c reads the fields one by one
// with fread_grace(), which swaps bytes on little-endian hosts, so there is no padding; the SCA1B_t
// struct in GRACEiolib.h gives the types: long gps_time (4 bytes in the files), char, byte, 5 double,
// unsigned char).
#include "product_io.h"

namespace boresight::io {

bool operator==(const Sca1bRecord& a, const Sca1bRecord& b) {
  return a.t == b.t && a.satellite == b.satellite && a.sca_id == b.sca_id && a.q[0] == b.q[0] &&
         a.q[1] == b.q[1] && a.q[2] == b.q[2] && a.q[3] == b.q[3] && a.qual_rss == b.qual_rss &&
         a.qualflg == b.qualflg;
}

namespace {
struct Sca1bCodec {
  using Record = Sca1bRecord;
  static bool accepts(Product p) { return p == Product::SCA1B; }
  static Product defaultProduct() { return Product::SCA1B; }
  static bool plausible(const Record& r, Product, const RecordGate& g, std::string* reason) {
    return detail::quaternionPlausible(r.q, g.quat_norm_tolerance, "quaternion", reason);
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "GRACEFO_id") &&
           s.integerIn(r.sca_id, -128, 127, "sca_id") && s.f64(r.q[0], "quatangle") && s.f64(r.q[1], "quaticoeff") &&
           s.f64(r.q[2], "quatjcoeff") && s.f64(r.q[3], "quatkcoeff") && s.f64(r.qual_rss, "qual_rss") &&
           s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite).integer(r.sca_id).f64(r.q[0]).f64(r.q[1]).f64(r.q[2]).f64(r.q[3]).f64(r.qual_rss).bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"gps_time", "GRACEFO_id", "sca_id", "quatangle", "quaticoeff", "quatjcoeff", "quatkcoeff", "qual_rss", "qualflg"};
  }

  static constexpr std::size_t kBinarySize = binary_layout::kSca1b;
  static bool decode(const unsigned char* p, Record& r, std::string& reason) {
    r.t = static_cast<TimeUs>(detail::be::i32(p)) * kUsPerSecond;
    r.satellite = static_cast<char>(p[4]);
    if (!detail::isSatelliteId(r.satellite)) {
      reason = "field GRACE_id: not a satellite letter (byte " + std::to_string(p[4]) + ")";
      return false;
    }
    r.sca_id = static_cast<std::int8_t>(p[5]);
    static const char* names[5] = {"quatangle", "quaticoeff", "quatjcoeff", "quatkcoeff", "qual_rss"};
    double v[5];
    for (int i = 0; i < 5; ++i) {
      v[i] = detail::be::f64(p + 6 + 8 * i);
      if (!detail::be::finite(v[i], names[i], reason)) return false;
    }
    for (int i = 0; i < 4; ++i) r.q[i] = v[i];
    r.qual_rss = v[4];
    r.qualflg = Bits{p[46], 8};
    return true;
  }
  static void encode(unsigned char* p, const Record& r) {
    detail::be::putI32(p, detail::be::secondsForBinary(r.t));
    p[4] = static_cast<unsigned char>(r.satellite);
    p[5] = static_cast<unsigned char>(static_cast<std::int8_t>(r.sca_id));
    for (int i = 0; i < 4; ++i) detail::be::putF64(p + 6 + 8 * i, r.q[i]);
    detail::be::putF64(p + 38, r.qual_rss);
    p[46] = static_cast<unsigned char>(r.qualflg.value & 0xffu);
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::Sca1bCodec)

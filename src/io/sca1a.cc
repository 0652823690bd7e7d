// SCA1A: star camera Level-1A, one line per head and epoch.
// rcvtime_intg rcvtime_frac GRACEFO_id sca_id sca_desig q0 qi qj qk nlocks nstars sca_confid null1 null2
// sca_mode qualflg
#include "product_io.h"

namespace boresight::io {

bool operator==(const Sca1aRecord& a, const Sca1aRecord& b) {
  return a.t == b.t && a.satellite == b.satellite && a.head == b.head && a.desig == b.desig &&
         a.q[0] == b.q[0] && a.q[1] == b.q[1] && a.q[2] == b.q[2] && a.q[3] == b.q[3] && a.nlocks == b.nlocks &&
         a.nstars == b.nstars && a.confid == b.confid && a.null1 == b.null1 && a.null2 == b.null2 &&
         a.mode == b.mode && a.qualflg == b.qualflg;
}

namespace {
struct Sca1aCodec {
  using Record = Sca1aRecord;
  static bool accepts(Product p) { return p == Product::SCA1A; }
  static Product defaultProduct() { return Product::SCA1A; }
  static bool plausible(const Record& r, Product, const RecordGate& g, std::string* reason) {
    return detail::quaternionPlausible(r.q, g.quat_norm_tolerance, "quaternion", reason);
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    int head = 0;
    return detail::scanTimeIntgFrac(s, r.t) && s.ch(r.satellite, "GRACEFO_id") &&
           s.integerIn(head, 1, 9, "sca_id") && (r.head = static_cast<std::uint8_t>(head), true) &&
           s.ch(r.desig, "sca_desig") && s.f64(r.q[0], "quatangle") && s.f64(r.q[1], "quaticoeff") &&
           s.f64(r.q[2], "quatjcoeff") && s.f64(r.q[3], "quatkcoeff") && s.integer(r.nlocks, "nlocks") &&
           s.integer(r.nstars, "nstars") && s.integer(r.confid, "sca_confid") && s.integer(r.null1, "sca_null1") &&
           s.integer(r.null2, "sca_null2") && s.bits(r.mode, "sca_mode") && s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.satellite).integer(static_cast<int>(r.head)).ch(r.desig);
    w.f64(r.q[0]).f64(r.q[1]).f64(r.q[2]).f64(r.q[3]);
    w.integer(r.nlocks).integer(r.nstars).integer(r.confid).integer(r.null1).integer(r.null2);
    w.bits(r.mode).bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"rcvtime_intg", "rcvtime_frac", "GRACEFO_id", "sca_id", "sca_desig", "quatangle",
            "quaticoeff", "quatjcoeff", "quatkcoeff", "nlocks", "nstars", "sca_confid",
            "sca_null1", "sca_null2", "sca_mode", "qualflg"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::Sca1aCodec)

// QSA1B (star camera head to SRF alignment) and QKS1B (KBR to SRF alignment), static products with
// the fixed header:  time id sca_id q0 qi qj qk 0 qualflg
#include "product_io.h"

namespace boresight::io {

bool operator==(const QsaRecord& a, const QsaRecord& b) {
  return a.t == b.t && a.satellite == b.satellite && a.sensor == b.sensor && a.q[0] == b.q[0] &&
         a.q[1] == b.q[1] && a.q[2] == b.q[2] && a.q[3] == b.q[3] && a.zero == b.zero && a.qualflg == b.qualflg;
}

namespace {
struct QsaCodec {
  using Record = QsaRecord;
  static bool accepts(Product p) { return p == Product::QSA1B || p == Product::QKS1B; }
  static Product defaultProduct() { return Product::QSA1B; }
  static bool plausible(const Record& r, Product, const RecordGate&, std::string* reason) {
    return detail::quaternionPlausible(r.q, plausibility::kAlignmentNormTolerance, "alignment quaternion", reason);
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    return detail::scanTimeSeconds(s, r.t) && s.ch(r.satellite, "id") && s.integerIn(r.sensor, 0, 99, "sca_id") &&
           s.f64(r.q[0], "q0") && s.f64(r.q[1], "qi") && s.f64(r.q[2], "qj") && s.f64(r.q[3], "qk") &&
           s.f64(r.zero, "zero") && s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeSeconds(w, r.t);
    w.ch(r.satellite).integer(r.sensor).f64(r.q[0]).f64(r.q[1]).f64(r.q[2]).f64(r.q[3]).f64(r.zero).bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    return {"time", "id", "sca_id", "q0", "qi", "qj", "qk", "zero", "qualflg"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::QsaCodec)

namespace boresight::io {

ProductFile<QsaRecord> mountingsQsa1b(char satellite, TimeUs t, const std::vector<std::pair<std::int32_t, Quat>>& heads) {
  auto f = makeProduct<QsaRecord>(Product::QSA1B, satellite);
  f.header.style = HeaderStyle::Fixed;
  for (const auto& [id, q] : heads) {
    QsaRecord r;
    r.t = (t / kUsPerSecond) * kUsPerSecond;
    r.satellite = satellite;
    r.sensor = id;
    quatToScalarFirst(q, r.q);
    r.zero = 0;
    r.qualflg = Bits{0, 8};
    f.records.push_back(r);
  }
  return f;
}

}  // namespace boresight::io

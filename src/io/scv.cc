// SCV1A: the simulator's star vectors (one star of one head per line), see ScvRecord in level1.h:
//   rcvtime_intg rcvtime_frac GRACEFO_id sca_id star_id s_x s_y s_z r_x r_y r_z magnitude
#include "product_io.h"

#include <cmath>

namespace boresight::io {

bool operator==(const ScvRecord& a, const ScvRecord& b) {
  for (int k = 0; k < 3; ++k)
    if (a.s[k] != b.s[k] || a.r[k] != b.r[k]) return false;
  return a.t == b.t && a.satellite == b.satellite && a.head == b.head && a.star == b.star && a.mag == b.mag;
}

namespace {
/// A unit vector: finite components, norm within 1e-6 of one (the writer prints 17 digits).
bool unitVector(FieldScanner& s, double (&v)[3], const char* x, const char* y, const char* z, const char* name) {
  if (!s.f64(v[0], x) || !s.f64(v[1], y) || !s.f64(v[2], z)) return false;
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(std::abs(n - 1.0) <= 1e-6)) return s.reject(name, "is not a unit vector (norm differs from 1 by more than 1e-6)");
  return true;
}

struct ScvCodec {
  using Record = ScvRecord;
  static bool accepts(Product p) { return p == Product::SCV1A; }
  static Product defaultProduct() { return Product::SCV1A; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    int head = 0;
    return detail::scanTimeIntgFrac(s, r.t) && s.ch(r.satellite, "GRACEFO_id") && s.integerIn(head, 1, 9, "sca_id") &&
           (r.head = static_cast<std::uint8_t>(head), true) &&
           s.integerIn(r.star, 0, 999999999, "star_id") && unitVector(s, r.s, "s_x", "s_y", "s_z", "s") &&
           unitVector(s, r.r, "r_x", "r_y", "r_z", "r") && s.f64(r.mag, "magnitude");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.satellite).integer(static_cast<int>(r.head)).integer(r.star);
    w.f64(r.s[0]).f64(r.s[1]).f64(r.s[2]).f64(r.r[0]).f64(r.r[1]).f64(r.r[2]).f64(r.mag);
  }
  static std::vector<std::string> columns(Product) {
    return {"rcvtime_intg", "rcvtime_frac", "GRACEFO_id", "sca_id", "star_id", "s_x", "s_y",
            "s_z", "r_x", "r_y", "r_z", "magnitude"};
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::ScvCodec)

#include <boresight/io/scv.h>

namespace boresight::io {

std::size_t nextStarEpoch(const std::vector<ScvRecord>& recs, std::size_t begin, core::StarEpoch& out,
                          std::size_t* dropped) {
  out.n = 0;
  if (begin >= recs.size()) return begin;
  out.t = recs[begin].t;
  std::size_t i = begin;
  for (; i < recs.size() && recs[i].t == out.t; ++i) {
    if (out.n >= core::kMaxStarInputs) {
      if (dropped) ++*dropped;
      continue;
    }
    core::StarObservation& o = out.star[static_cast<std::size_t>(out.n++)];
    o.head_id = recs[i].head;
    o.s_Sk = Vec3(recs[i].s[0], recs[i].s[1], recs[i].s[2]);
    o.r_I = Vec3(recs[i].r[0], recs[i].r[1], recs[i].r[2]);
    o.sigma_rad = 0;
  }
  return i;
}

}  // namespace boresight::io

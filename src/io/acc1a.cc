// ACC1A / ACT1A read into the compact Acc1aRecord (science layout: prod_flag bits 0-5 and 26-28).
// Same text layout as flagged.cc: time_intg time_frac time_ref id qualflg prod_flag values...
#include "product_io.h"

namespace boresight::io {

bool operator==(const Acc1aRecord& a, const Acc1aRecord& b) {
  if (!(a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.qualflg == b.qualflg &&
        a.prod_flag == b.prod_flag))
    return false;
  for (int i = 0; i < 3; ++i) {
    if (a.has(i) && a.lin[i] != b.lin[i]) return false;
    if (a.has(3 + i) && a.ang[i] != b.ang[i]) return false;
    if (a.has(26 + i) && a.counters[i] != b.counters[i]) return false;
  }
  return true;
}

namespace {

constexpr const char* kNames[32] = {"lin_accl_x", "lin_accl_y", "lin_accl_z", "ang_accl_x", "ang_accl_y",
                                    "ang_accl_z", nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
                                    nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
                                    nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, "icu_blk_nr",
                                    "Tenhz_count", "Mhz_count", nullptr, nullptr, nullptr};

double* slot(Acc1aRecord& r, int bit) {
  if (bit < 3) return &r.lin[bit];
  if (bit < 6) return &r.ang[bit - 3];
  return &r.counters[bit - 26];
}
const double* slot(const Acc1aRecord& r, int bit) { return slot(const_cast<Acc1aRecord&>(r), bit); }

struct Acc1aCodec {
  using Record = Acc1aRecord;
  static bool accepts(Product p) { return p == Product::ACC1A || p == Product::ACT1A; }
  static Product defaultProduct() { return Product::ACC1A; }
  static bool plausible(const Record& r, Product, const RecordGate&, std::string* reason) {
    if (r.has(acc_bits::kLinX) && r.has(acc_bits::kLinY) && r.has(acc_bits::kLinZ) &&
        !detail::axesPlausible(r.lin, plausibility::kMaxLinearAccelMS2, "linear acceleration", "m/s^2", reason))
      return false;
    if (r.has(acc_bits::kAngX) && r.has(acc_bits::kAngY) && r.has(acc_bits::kAngZ) &&
        !detail::axesPlausible(r.ang, plausibility::kMaxAngularAccelRadS2, "angular acceleration", "rad/s^2", reason))
      return false;
    return true;
  }
  static bool parse(FieldScanner& s, Record& r, Product) {
    if (!(detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACEFO_id") &&
          s.bits(r.qualflg, "qualflg") && s.bits(r.prod_flag, "prod_flag")))
      return false;
    if (std::uint32_t extra = r.prod_flag.value & ~kAcc1aRecordBits) {
      const std::string why = "bit " + std::to_string(__builtin_ctz(extra)) +
                              " is outside the ACC1A science layout (bits 0-5, 26-28): read as FlaggedRecord";
      return s.reject("prod_flag", why.c_str());
    }
    for (std::uint32_t m = r.prod_flag.value; m != 0; m &= m - 1) {
      const int b = __builtin_ctz(m);
      if (!s.f64(*slot(r, b), kNames[b])) return false;
    }
    return true;
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite).bits(r.qualflg).bits(r.prod_flag);
    for (std::uint32_t m = r.prod_flag.value & kAcc1aRecordBits; m != 0; m &= m - 1) w.f64(*slot(r, __builtin_ctz(m)));
  }
  static std::vector<std::string> columns(Product) {
    return {"rcvtime_intg", "rcvtime_frac", "time_ref", "GRACEFO_id", "qualflg", "prod_flag", "lin_accl_x",
            "lin_accl_y", "lin_accl_z", "ang_accl_x", "ang_accl_y", "ang_accl_z", "icu_blk_nr", "Tenhz_count",
            "Mhz_count"};
  }
};

}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::Acc1aCodec)

// ACC1A, ACT1A, AHK1A, AHK1B: time_intg time_frac time_ref id qualflg prod_flag, then one value for
// each set prod_flag bit, lowest bit first. AHK's bit 29 (status flag) is a 32-character bit string.
#include "product_io.h"

#include <cmath>

namespace boresight::io {

bool operator==(const FlaggedRecord& a, const FlaggedRecord& b) {
  if (!(a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.qualflg == b.qualflg &&
        a.prod_flag == b.prod_flag && a.status_flag == b.status_flag))
    return false;
  for (int i = 0; i < 32; ++i)
    if (a.has(i) && i != kAhkStatusFlagBit && a.value[static_cast<std::size_t>(i)] != b.value[static_cast<std::size_t>(i)])
      return false;
  return true;
}

namespace {

bool isAhk(Product p) { return p == Product::AHK1A || p == Product::AHK1B; }

const char* bitName(Product p, int bit) {
  static const char* acc[32] = {"lin_accl_x", "lin_accl_y", "lin_accl_z", "ang_accl_x", "ang_accl_y",
                                "ang_accl_z", "bias_vol", "Vd", "x1_out", "x2_out", "x3_out", "y1_out",
                                "y2_out", "z1_out", "tesu", "taicu", "tisu", "v15picu", "v15micu",
                                "vr5picu", "tcicu", "v15psu", "v15msu", "v48psu", "v48msu", "undefined_25",
                                "icu_blk_nr", "Tenhz_count", "Mhz_count", "undefined_29", "undefined_30",
                                "undefined_31"};
  static const char* ahk[32] = {"TFEEU_IF", "TFEEU_REF", "TFEEU_X", "TFEEU_YZ", "analog_GND", "+3.3V", "Vp",
                                "MES_Vd", "MES_DET_X1", "MES_DET_X2", "MES_DET_X3", "MES_DET_Y1",
                                "MES_DET_Y2", "MES_DET_Z1", "TSU_Y+", "TICUN", "TSU_Y-", "TSU_Z+", "TSU_Z-",
                                "+5V", "TICUR", "+15V", "-15V", "+48V", "-48V", "undefined_25", "icu_blk_nr",
                                "PPS_source", "Sync_Qual", "statusflag", "undefined_30", "undefined_31"};
  return (isAhk(p) ? ahk : acc)[bit];
}

struct FlaggedCodec {
  using Record = FlaggedRecord;
  static bool accepts(Product p) {
    return p == Product::ACC1A || p == Product::ACT1A || isAhk(p);
  }
  static Product defaultProduct() { return Product::ACC1A; }
  static bool plausible(const Record& r, Product p, const RecordGate&, std::string* reason) {
    if (isAhk(p)) return true;
    for (int group = 0; group < 2; ++group) {  // linear (bits 0-2), angular (bits 3-5)
      const int b0 = group == 0 ? acc_bits::kLinX : acc_bits::kAngX;
      if (!(r.has(b0) && r.has(b0 + 1) && r.has(b0 + 2))) continue;
      const double* v = &r.value[static_cast<std::size_t>(b0)];
      if (!detail::axesPlausible(v, group == 0 ? plausibility::kMaxLinearAccelMS2 : plausibility::kMaxAngularAccelRadS2,
                                 group == 0 ? "linear acceleration" : "angular acceleration",
                                 group == 0 ? "m/s^2" : "rad/s^2", reason))
        return false;
    }
    return true;
  }
  static bool parse(FieldScanner& s, Record& r, Product p) {
    if (!(detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACEFO_id") &&
          s.bits(r.qualflg, "qualflg") && s.bits(r.prod_flag, "prod_flag")))
      return false;
    const bool ahk = isAhk(p);
    // Only the set bits, lowest first.
    for (std::uint32_t m = r.prod_flag.value; m != 0; m &= m - 1) {
      const int b = __builtin_ctz(m);
      if (ahk && b == kAhkStatusFlagBit) {
        if (!s.bits(r.status_flag, bitName(p, b))) return false;
        continue;
      }
      if (!s.f64(r.value[static_cast<std::size_t>(b)], bitName(p, b))) return false;
    }
    return true;
  }
  static void format(LineWriter& w, const Record& r, Product p) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite).bits(r.qualflg).bits(r.prod_flag);
    const bool ahk = isAhk(p);
    for (int b = 0; b < 32; ++b) {
      if (!r.has(b)) continue;
      if (ahk && b == kAhkStatusFlagBit)
        w.bits(r.status_flag);
      else
        w.f64(r.value[static_cast<std::size_t>(b)]);
    }
  }
  static std::vector<std::string> columns(Product p) {
    std::vector<std::string> c = {"rcvtime_intg", "rcvtime_frac", "time_ref", "GRACEFO_id", "qualflg", "prod_flag"};
    for (int b = 0; b < 32; ++b)
      if (std::string(bitName(p, b)).rfind("undefined", 0) != 0) c.emplace_back(bitName(p, b));
    return c;
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::FlaggedCodec)

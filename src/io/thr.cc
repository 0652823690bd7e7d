// THR1A / THR1B: thruster firing counters.
// time_intg time_frac time_ref id, 14 thrust_count, 14 on_time [ms], 14 accum_dur [ms], qualflg
#include "product_io.h"

namespace boresight::io {

bool operator==(const ThrRecord& a, const ThrRecord& b) {
  for (int i = 0; i < kThrusters; ++i)
    if (a.thrust_count[i] != b.thrust_count[i] || a.on_time[i] != b.on_time[i] || a.accum_dur[i] != b.accum_dur[i])
      return false;
  return a.t == b.t && a.time_ref == b.time_ref && a.satellite == b.satellite && a.qualflg == b.qualflg;
}

namespace {
const char* const kThrNames[kThrusters] = {"att_ctrl_1_1", "att_ctrl_1_2", "att_ctrl_1_3", "att_ctrl_1_4",
                                           "att_ctrl_1_5", "att_ctrl_1_6", "att_ctrl_2_1", "att_ctrl_2_2",
                                           "att_ctrl_2_3", "att_ctrl_2_4", "att_ctrl_2_5", "att_ctrl_2_6",
                                           "undef_1",      "undef_2"};

struct ThrCodec {
  using Record = ThrRecord;
  static bool accepts(Product p) { return p == Product::THR1A || p == Product::THR1B; }
  static Product defaultProduct() { return Product::THR1B; }
  static bool parse(FieldScanner& s, Record& r, Product) {
    if (!(detail::scanTimeIntgFrac(s, r.t) && s.ch(r.time_ref, "time_ref") && s.ch(r.satellite, "GRACEFO_id")))
      return false;
    for (auto& v : r.thrust_count)
      if (!s.integer(v, "thrust_count")) return false;
    for (auto& v : r.on_time)
      if (!s.integer(v, "on_time")) return false;
    for (auto& v : r.accum_dur)
      if (!s.integer(v, "accum_dur")) return false;
    return s.bits(r.qualflg, "qualflg");
  }
  static void format(LineWriter& w, const Record& r, Product) {
    detail::writeTimeIntgFrac(w, r.t);
    w.ch(r.time_ref).ch(r.satellite);
    for (auto v : r.thrust_count) w.integer(v);
    for (auto v : r.on_time) w.integer(v);
    for (auto v : r.accum_dur) w.integer(v);
    w.bits(r.qualflg);
  }
  static std::vector<std::string> columns(Product) {
    std::vector<std::string> c = {"time_intg", "time_frac", "time_ref", "GRACEFO_id"};
    for (const char* n : kThrNames) c.push_back(std::string("thrust_count_") + n);
    for (const char* n : kThrNames) c.push_back(std::string("on_time_") + n);
    for (const char* n : kThrNames) c.push_back(std::string("accum_dur_") + n);
    c.emplace_back("qualflg");
    return c;
  }
};
}  // namespace
}  // namespace boresight::io

BORESIGHT_IO_INSTANTIATE(boresight::io::ThrCodec)

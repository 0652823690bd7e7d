// The model overlay (model/overlay.h): names, checks, the noise table, comparison.
#include <boresight/model/overlay.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

namespace boresight::model {
namespace {

/// Equal, NaN equal to NaN (a sigma that is "not determined").
bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }
bool same(const Vec3& a, const Vec3& b) { return same(a.x(), b.x()) && same(a.y(), b.y()) && same(a.z(), b.z()); }

std::string fmtNum(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

std::string fmtTime(const std::optional<TimeUs>& t) { return t ? std::to_string(*t) : std::string("open"); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Names

std::string noiseTermName(const NoiseModel& m, std::size_t index) {
  if (index >= m.terms.size()) return {};
  const NoiseKind k = m.terms[index].kind;
  int n = 0;
  for (std::size_t i = 0; i <= index; ++i) n += m.terms[i].kind == k ? 1 : 0;
  switch (k) {
    case NoiseKind::White: return n == 1 ? "white" : "white" + std::to_string(n);
    case NoiseKind::GaussMarkov: return "gm" + std::to_string(n);
    case NoiseKind::PowerLaw: return n == 1 ? "pl" : "pl" + std::to_string(n);
  }
  return {};
}

std::vector<std::string> noiseTermParameters(NoiseKind k) {
  switch (k) {
    case NoiseKind::White: return {"sigma"};
    case NoiseKind::GaussMarkov: return {"sigma", "tau_s"};
    case NoiseKind::PowerLaw: return {"sigma", "alpha", "f_lo_hz", "f_hi_hz"};
  }
  return {};
}

double noiseTermValue(const NoiseTerm& t, const std::string& p) {
  const auto names = noiseTermParameters(t.kind);
  if (std::find(names.begin(), names.end(), p) == names.end()) return std::numeric_limits<double>::quiet_NaN();
  if (p == "sigma") return t.sigma;
  if (p == "tau_s") return t.tau_s;
  if (p == "alpha") return t.alpha;
  if (p == "f_lo_hz") return t.f_lo_hz;
  return t.f_hi_hz;
}

std::string validateAxisNoise(const AxisNoise& a) {
  if (a.model.empty()) return "no terms";
  if (std::string e = a.model.validate(); !e.empty()) return e;
  if (!(a.model.variance() > 0)) return "the model's variance is 0 (a sensor axis without noise cannot be weighted)";
  std::set<std::string> seen;
  for (const NoiseParam& p : a.params) {
    const auto dot = p.name.find('.');
    bool found = false;
    for (std::size_t i = 0; dot != std::string::npos && i < a.model.terms.size() && !found; ++i)
      found = noiseTermName(a.model, i) == p.name.substr(0, dot) &&
              std::isfinite(noiseTermValue(a.model.terms[i], p.name.substr(dot + 1)));
    if (!found) return "parameter '" + p.name + "': no such term parameter in the model";
    if (!seen.insert(p.name).second) return "parameter '" + p.name + "' given twice";
    if (std::isnan(p.sigma) ? p.determined : !(std::isfinite(p.sigma) && p.sigma >= 0))
      return "parameter '" + p.name + "': its sigma must be finite and >= 0 (or the parameter not determined)";
  }
  return {};
}

const char* headAxisKey(HeadAxis a) {
  switch (a) {
    case HeadAxis::CrossX: return "cross_x";
    case HeadAxis::CrossY: return "cross_y";
    case HeadAxis::AboutBoresight: return "about_boresight";
    case HeadAxis::StarDirection: return "star_direction";
  }
  return "?";
}

const char* accAxisKey(int axis) {
  static const char* k[] = {"x", "y", "z"};
  return axis >= 0 && axis < 3 ? k[axis] : "?";
}

const char* mountingDatumKey(MountingDatum d) {
  switch (d) {
    case MountingDatum::Accelerometer: return "accelerometer";
    case MountingDatum::Ground: return "ground";
    case MountingDatum::StarCameras: return "star_cameras";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// The noise in use

void NoiseInUse::reset(const std::vector<int>& ids) {
  *this = NoiseInUse{};
  n_heads = static_cast<int>(std::min<std::size_t>(ids.size(), core::kMaxHeads));
  for (int s = 0; s < n_heads; ++s) head_id[static_cast<std::size_t>(s)] = ids[static_cast<std::size_t>(s)];
}

void NoiseInUse::layer(const NoiseSection& sec, const std::string& source, std::vector<std::string>* unused) {
  auto put = [](Axis& dst, const std::optional<AxisNoise>& src, const std::string& from) {
    if (!src) return;
    dst.set = true;
    dst.noise = *src;
    dst.source = from;
  };
  if (sec.head_defaults)
    for (int s = 0; s < n_heads; ++s)
      for (int a = 0; a < kHeadAxes; ++a)
        put(head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)], sec.head_defaults->axis[static_cast<std::size_t>(a)],
            source + " noise.head_defaults");
  for (const HeadNoise& h : sec.heads) {
    int slot = -1;
    for (int s = 0; s < n_heads; ++s)
      if (head_id[static_cast<std::size_t>(s)] == h.id) slot = s;
    const std::string where = "noise.heads[id " + std::to_string(h.id) + "]";
    if (slot < 0) {
      if (unused) unused->push_back(where);
      continue;
    }
    for (int a = 0; a < kHeadAxes; ++a)
      put(head[static_cast<std::size_t>(slot)][static_cast<std::size_t>(a)], h.axis[static_cast<std::size_t>(a)],
          source + " " + where);
  }
  if (sec.accelerometer)
    for (int a = 0; a < 3; ++a)
      put(acc[static_cast<std::size_t>(a)], sec.accelerometer->axis[static_cast<std::size_t>(a)], source + " noise.accelerometer");
}

std::string NoiseInUse::missing() const {
  for (int s = 0; s < n_heads; ++s)
    for (int a = 0; a < kHeadAxes; ++a)
      if (!head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].set)
        return "head " + std::to_string(head_id[static_cast<std::size_t>(s)]) + " " + headAxisKey(HeadAxis(a));
  for (int a = 0; a < 3; ++a)
    if (!acc[static_cast<std::size_t>(a)].set) return std::string("accelerometer ") + accAxisKey(a);
  return {};
}

double NoiseInUse::crossSigmaRad(int slot) const {
  const auto& h = head[static_cast<std::size_t>(slot)];
  return std::sqrt(0.5 * (h[0].noise.model.variance() + h[1].noise.model.variance()));
}
double NoiseInUse::aboutSigmaRad(int slot) const {
  return std::sqrt(head[static_cast<std::size_t>(slot)][2].noise.model.variance());
}
double NoiseInUse::starSigmaRad(int slot) const {
  return std::sqrt(head[static_cast<std::size_t>(slot)][3].noise.model.variance());
}
double NoiseInUse::accWhiteSigma(int axis) const { return std::sqrt(acc[static_cast<std::size_t>(axis)].noise.model.whiteVariance()); }

std::vector<std::string> NoiseInUse::describe() const {
  std::vector<std::string> out;
  auto join = [](const std::vector<std::pair<std::string, std::string>>& items) {
    // items: (text, source); each run of items with one source, then that source once
    std::string s;
    for (std::size_t i = 0; i < items.size(); ++i) {
      const bool first_of_run = i == 0 || items[i].second != items[i - 1].second;
      s += i == 0 ? "" : first_of_run ? "; " : ", ";
      s += items[i].first;
      if (i + 1 == items.size() || items[i + 1].second != items[i].second) s += " (" + items[i].second + ")";
    }
    return s;
  };
  for (int s = 0; s < n_heads; ++s) {
    std::vector<std::pair<std::string, std::string>> items;
    for (int a = 0; a < kHeadAxes; ++a) {
      const Axis& x = head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)];
      items.emplace_back(std::string(headAxisKey(HeadAxis(a))) + " " + (x.set ? x.noise.model.describe(kArcsecPerRad, "\"") : "none"),
                         x.set ? x.source : "not configured");
    }
    out.push_back("head " + std::to_string(head_id[static_cast<std::size_t>(s)]) + ": " + join(items));
  }
  std::vector<std::pair<std::string, std::string>> items;
  for (int a = 0; a < 3; ++a) {
    const Axis& x = acc[static_cast<std::size_t>(a)];
    items.emplace_back(std::string(accAxisKey(a)) + " " + (x.set ? x.noise.model.describe(1.0, " rad/s^2") : "none"),
                       x.set ? x.source : "not configured");
  }
  out.push_back("accelerometer: " + join(items));
  return out;
}

// ---------------------------------------------------------------------------------------------
// Equality

bool Uncertain3::operator==(const Uncertain3& o) const { return same(value, o.value) && same(sigma, o.sigma); }
bool MountingEntry::operator==(const MountingEntry& o) const {
  return head == o.head && q_Si_B.coeffs() == o.q_Si_B.coeffs() && datum == o.datum && epoch == o.epoch &&
         same(sigma_rad, o.sigma_rad) && valid == o.valid;
}
bool PublishedFrame::operator==(const PublishedFrame& o) const {
  return q_B_Bpub.coeffs() == o.q_B_Bpub.coeffs() && epoch == o.epoch && calibration == o.calibration;
}
bool ThermalHarmonicEntry::operator==(const ThermalHarmonicEntry& o) const {
  return harmonic == o.harmonic && cos_rad == o.cos_rad && sin_rad == o.sin_rad;
}
bool ThermalHeadEntry::operator==(const ThermalHeadEntry& o) const {
  return head == o.head && constant_rad == o.constant_rad && harmonics == o.harmonics && beta_harmonics == o.beta_harmonics;
}
bool ThermalTerms::operator==(const ThermalTerms& o) const {
  return datum_head == o.datum_head && beta_ref_rad == o.beta_ref_rad && heads == o.heads && valid == o.valid;
}
bool AccelerometerTerms::operator==(const AccelerometerTerms& o) const {
  return bias_rad_s2 == o.bias_rad_s2 && scale == o.scale && misalignment_rad == o.misalignment_rad &&
         nonorthogonality_rad == o.nonorthogonality_rad && valid == o.valid;
}
bool TimeOffsetEntry::operator==(const TimeOffsetEntry& o) const {
  return sensor == o.sensor && relative_to == o.relative_to && same(offset_s, o.offset_s) && same(sigma_s, o.sigma_s) &&
         valid == o.valid;
}

std::vector<std::string> Overlay::parts() const {
  std::vector<std::string> p;
  if (!mountings.empty()) p.push_back("mountings");
  if (!noise.empty()) p.push_back("noise");
  if (thermal) p.push_back("thermal");
  if (accelerometer) p.push_back("accelerometer");
  if (!time_offsets.empty()) p.push_back("time_offsets");
  if (published_frame) p.push_back("published_frame");
  if (data_events) p.push_back("data_events");
  return p;
}

// ---------------------------------------------------------------------------------------------
// Checks

namespace {

std::string checkValidity(const Validity& v) {
  if (v.from && v.to && *v.to < *v.from) return "valid_to is before valid_from";
  return {};
}

std::string checkU3(const Uncertain3& u) {
  if (!u.value.allFinite()) return "values must be finite";
  for (int i = 0; i < 3; ++i)
    if (!std::isnan(u.sigma[i]) && !(std::isfinite(u.sigma[i]) && u.sigma[i] >= 0)) return "sigmas must be >= 0 (or not determined)";
  return {};
}

std::string checkHeadNoise(const HeadNoise& h, const std::string& key) {
  for (int a = 0; a < kHeadAxes; ++a)
    if (h.axis[static_cast<std::size_t>(a)])
      if (std::string e = validateAxisNoise(*h.axis[static_cast<std::size_t>(a)]); !e.empty())
        return key + "." + headAxisKey(HeadAxis(a)) + ": " + e;
  if (std::string e = checkValidity(h.valid); !e.empty()) return key + ": " + e;
  return {};
}

}  // namespace

std::string validate(const Overlay& o) {
  if (o.version != kOverlayVersion) return "boresight_overlay: version " + std::to_string(o.version) + " (this code writes " +
                                           std::to_string(kOverlayVersion) + ")";
  std::set<int> ids;
  for (std::size_t i = 0; i < o.mountings.size(); ++i) {
    const MountingEntry& m = o.mountings[i];
    const std::string k = "mountings[" + std::to_string(i) + "]";
    if (m.head <= 0) return k + ".head: must be > 0";
    if (!ids.insert(m.head).second) return k + ".head: head " + std::to_string(m.head) + " twice";
    if (!m.q_Si_B.coeffs().allFinite() || std::abs(m.q_Si_B.norm() - 1) > 1e-9) return k + ".q_Si_B: not a unit quaternion";
    for (int a = 0; a < 3; ++a)
      if (!std::isnan(m.sigma_rad[a]) && !(std::isfinite(m.sigma_rad[a]) && m.sigma_rad[a] >= 0)) return k + ".sigma: must be >= 0";
    if (std::string e = checkValidity(m.valid); !e.empty()) return k + ": " + e;
  }
  if (o.noise.head_defaults)
    if (std::string e = checkHeadNoise(*o.noise.head_defaults, "noise.head_defaults"); !e.empty()) return e;
  ids.clear();
  for (std::size_t i = 0; i < o.noise.heads.size(); ++i) {
    const std::string k = "noise.heads[" + std::to_string(i) + "]";
    if (o.noise.heads[i].id <= 0) return k + ".id: must be > 0";
    if (!ids.insert(o.noise.heads[i].id).second) return k + ".id: head " + std::to_string(o.noise.heads[i].id) + " twice";
    if (std::string e = checkHeadNoise(o.noise.heads[i], k); !e.empty()) return e;
  }
  if (o.noise.accelerometer) {
    for (int a = 0; a < 3; ++a)
      if (o.noise.accelerometer->axis[static_cast<std::size_t>(a)])
        if (std::string e = validateAxisNoise(*o.noise.accelerometer->axis[static_cast<std::size_t>(a)]); !e.empty())
          return std::string("noise.accelerometer.") + accAxisKey(a) + ": " + e;
    if (std::string e = checkValidity(o.noise.accelerometer->valid); !e.empty()) return "noise.accelerometer: " + e;
  }
  if (o.thermal) {
    const ThermalTerms& t = *o.thermal;
    if (t.datum_head <= 0) return "thermal.datum_head: must be > 0";
    if (t.beta_ref_rad && !std::isfinite(*t.beta_ref_rad)) return "thermal.beta_ref: not finite";
    ids.clear();
    for (std::size_t i = 0; i < t.heads.size(); ++i) {
      const ThermalHeadEntry& h = t.heads[i];
      const std::string k = "thermal.heads[" + std::to_string(i) + "]";
      if (h.head <= 0 || h.head == t.datum_head) return k + ".id: must be > 0 and not the datum head";
      if (!ids.insert(h.head).second) return k + ".id: head " + std::to_string(h.head) + " twice";
      if (std::string e = checkU3(h.constant_rad); !e.empty()) return k + ".constant: " + e;
      if (!h.beta_harmonics.empty() && !t.beta_ref_rad) return k + ".beta_harmonics: need thermal.beta_ref_deg";
      for (const auto* list : {&h.harmonics, &h.beta_harmonics}) {
        std::set<int> orders;
        for (const auto& x : *list) {
          if (x.harmonic < 1) return k + ": harmonic must be >= 1";
          if (!orders.insert(x.harmonic).second) return k + ": harmonic " + std::to_string(x.harmonic) + " twice";
          if (std::string e = checkU3(x.cos_rad); !e.empty()) return k + ": " + e;
          if (std::string e = checkU3(x.sin_rad); !e.empty()) return k + ": " + e;
        }
      }
    }
    if (std::string e = checkValidity(t.valid); !e.empty()) return "thermal: " + e;
  }
  if (o.accelerometer) {
    const AccelerometerTerms& a = *o.accelerometer;
    const std::pair<const char*, const std::optional<Uncertain3>*> items[] = {
        {"bias", &a.bias_rad_s2}, {"scale", &a.scale}, {"misalignment", &a.misalignment_rad},
        {"nonorthogonality", &a.nonorthogonality_rad}};
    for (const auto& [name, v] : items)
      if (*v)
        if (std::string e = checkU3(**v); !e.empty()) return std::string("accelerometer.") + name + ": " + e;
    if (std::string e = checkValidity(a.valid); !e.empty()) return "accelerometer: " + e;
  }
  for (std::size_t i = 0; i < o.time_offsets.size(); ++i) {
    const TimeOffsetEntry& t = o.time_offsets[i];
    const std::string k = "time_offsets[" + std::to_string(i) + "]";
    if (t.sensor.empty() || t.relative_to.empty() || t.sensor == t.relative_to) return k + ": sensor and relative_to must differ";
    if (!std::isfinite(t.offset_s)) return k + ".offset_s: not finite";
    if (!std::isnan(t.sigma_s) && !(std::isfinite(t.sigma_s) && t.sigma_s >= 0)) return k + ".offset_sigma_s: must be >= 0";
    if (std::string e = checkValidity(t.valid); !e.empty()) return k + ": " + e;
  }
  if (o.published_frame) {
    const PublishedFrame& f = *o.published_frame;
    if (!f.q_B_Bpub.coeffs().allFinite() || std::abs(f.q_B_Bpub.norm() - 1.0) > 1e-6) return "published_frame.q_B_Bpub: not a unit quaternion";
    if (f.calibration < 0) return "published_frame.calibration: must be >= 0";
  }
  if (o.data_events) {
    const DataEventRates& r = *o.data_events;
    const auto bad = [](double v) { return !(std::isfinite(v) && v >= 0); };
    if (bad(r.head_dropouts_per_day)) return "data_events.head_dropouts_per_day: must be a finite rate >= 0";
    if (bad(r.epoch_gaps_per_day)) return "data_events.epoch_gaps_per_day: must be a finite rate >= 0";
    if (bad(r.acc_gaps_per_day)) return "data_events.acc_gaps_per_day: must be a finite rate >= 0";
    for (const auto& [v, key] : {std::pair<double, const char*>{r.head_dropout_max_s, "head_dropout_max_s"},
                                 {r.epoch_gap_max_s, "epoch_gap_max_s"}, {r.acc_gap_max_s, "acc_gap_max_s"}})
      if (!std::isnan(v) && !(std::isfinite(v) && v > 0)) return std::string("data_events.") + key + ": must be > 0 (NaN: no limit)";
    for (std::size_t i = 0; i < r.head_dropouts_by_id.size(); ++i) {
      const std::string k = "data_events.heads[" + std::to_string(i) + "]";
      if (r.head_dropouts_by_id[i].first <= 0) return k + ".id: must be > 0";
      if (bad(r.head_dropouts_by_id[i].second)) return k + ".dropouts_per_day: must be a finite rate >= 0";
      for (std::size_t j = 0; j < i; ++j)
        if (r.head_dropouts_by_id[j].first == r.head_dropouts_by_id[i].first) return k + ".id: head given twice";
    }
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Comparison

namespace {

struct Cmp {
  double tol;
  std::vector<std::string> out;
  void num(const std::string& k, double a, double b) {
    if (same(a, b)) return;
    if (std::isfinite(a) && std::isfinite(b) && std::abs(a - b) <= tol * std::max(std::abs(a), std::abs(b))) return;
    out.push_back(k + ": " + fmtNum(a) + " vs " + fmtNum(b));
  }
  void v3(const std::string& k, const Vec3& a, const Vec3& b) {
    for (int i = 0; i < 3; ++i) num(k + "[" + std::to_string(i) + "]", a[i], b[i]);
  }
  void u3(const std::string& k, const Uncertain3& a, const Uncertain3& b) {
    v3(k + ".value", a.value, b.value);
    v3(k + ".sigma", a.sigma, b.sigma);
  }
  void ou3(const std::string& k, const std::optional<Uncertain3>& a, const std::optional<Uncertain3>& b) {
    if (a.has_value() != b.has_value()) return out.push_back(k + ": present in one only");
    if (a) u3(k, *a, *b);
  }
  template <typename T>
  void exact(const std::string& k, const T& a, const T& b) {
    if (!(a == b)) out.push_back(k + ": differs");
  }
  void valid(const std::string& k, const Validity& a, const Validity& b) {
    if (!(a == b)) out.push_back(k + ".valid: " + fmtTime(a.from) + ".." + fmtTime(a.to) + " vs " + fmtTime(b.from) + ".." + fmtTime(b.to));
  }
  void axis(const std::string& k, const std::optional<AxisNoise>& a, const std::optional<AxisNoise>& b) {
    if (a.has_value() != b.has_value()) return out.push_back(k + ": present in one only");
    if (!a) return;
    if (a->model.terms.size() != b->model.terms.size()) return out.push_back(k + ": number of terms differs");
    for (std::size_t i = 0; i < a->model.terms.size(); ++i) {
      const NoiseTerm &x = a->model.terms[i], &y = b->model.terms[i];
      const std::string t = k + "[" + std::to_string(i) + "]";
      if (x.kind != y.kind) {
        out.push_back(t + ": kind differs");
        continue;
      }
      for (const auto& p : noiseTermParameters(x.kind)) num(t + "." + p, noiseTermValue(x, p), noiseTermValue(y, p));
    }
    if (a->params.size() != b->params.size()) return out.push_back(k + ": number of parameter uncertainties differs");
    for (std::size_t i = 0; i < a->params.size(); ++i) {
      const NoiseParam &x = a->params[i], &y = b->params[i];
      const std::string t = k + ".params[" + std::to_string(i) + "]";
      if (x.name != y.name || x.determined != y.determined || x.note != y.note || x.log_scale != y.log_scale)
        out.push_back(t + ": name, determined, note or scale differs");
      num(t + ".value", x.value, y.value);
      num(t + ".sigma", x.sigma, y.sigma);
      num(t + ".log_sigma", x.log_sigma, y.log_sigma);
    }
  }
  void headNoise(const std::string& k, const HeadNoise& a, const HeadNoise& b) {
    exact(k + ".id", a.id, b.id);
    for (int x = 0; x < kHeadAxes; ++x)
      axis(k + "." + headAxisKey(HeadAxis(x)), a.axis[static_cast<std::size_t>(x)], b.axis[static_cast<std::size_t>(x)]);
    valid(k, a.valid, b.valid);
  }
  void harmonics(const std::string& k, const std::vector<ThermalHarmonicEntry>& a, const std::vector<ThermalHarmonicEntry>& b) {
    if (a.size() != b.size()) return out.push_back(k + ": count differs");
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::string t = k + "[" + std::to_string(i) + "]";
      exact(t + ".harmonic", a[i].harmonic, b[i].harmonic);
      u3(t + ".cos", a[i].cos_rad, b[i].cos_rad);
      u3(t + ".sin", a[i].sin_rad, b[i].sin_rad);
    }
  }
};

}  // namespace

std::vector<std::string> compareOverlays(const Overlay& a, const Overlay& b, double rel_tol) {
  Cmp c{rel_tol, {}};
  c.exact("boresight_overlay", a.version, b.version);
  c.exact("written_by", a.written_by, b.written_by);
  c.exact("platform", a.platform, b.platform);
  c.exact("note", a.note, b.note);
  if (a.mountings.size() != b.mountings.size()) c.out.push_back("mountings: count differs");
  for (std::size_t i = 0; i < std::min(a.mountings.size(), b.mountings.size()); ++i) {
    const MountingEntry &x = a.mountings[i], &y = b.mountings[i];
    const std::string k = "mountings[" + std::to_string(i) + "]";
    c.exact(k + ".head", x.head, y.head);
    for (int j = 0; j < 4; ++j) c.num(k + ".q_Si_B[" + std::to_string(j) + "]", x.q_Si_B.coeffs()[j], y.q_Si_B.coeffs()[j]);
    c.exact(k + ".datum", x.datum, y.datum);
    c.exact(k + ".epoch", x.epoch, y.epoch);
    c.v3(k + ".sigma", x.sigma_rad, y.sigma_rad);
    c.valid(k, x.valid, y.valid);
  }
  if (a.noise.head_defaults.has_value() != b.noise.head_defaults.has_value())
    c.out.push_back("noise.head_defaults: present in one only");
  else if (a.noise.head_defaults)
    c.headNoise("noise.head_defaults", *a.noise.head_defaults, *b.noise.head_defaults);
  if (a.noise.heads.size() != b.noise.heads.size()) c.out.push_back("noise.heads: count differs");
  for (std::size_t i = 0; i < std::min(a.noise.heads.size(), b.noise.heads.size()); ++i)
    c.headNoise("noise.heads[" + std::to_string(i) + "]", a.noise.heads[i], b.noise.heads[i]);
  if (a.noise.accelerometer.has_value() != b.noise.accelerometer.has_value()) {
    c.out.push_back("noise.accelerometer: present in one only");
  } else if (a.noise.accelerometer) {
    for (int x = 0; x < 3; ++x)
      c.axis(std::string("noise.accelerometer.") + accAxisKey(x), a.noise.accelerometer->axis[static_cast<std::size_t>(x)],
             b.noise.accelerometer->axis[static_cast<std::size_t>(x)]);
    c.valid("noise.accelerometer", a.noise.accelerometer->valid, b.noise.accelerometer->valid);
  }
  if (a.thermal.has_value() != b.thermal.has_value()) {
    c.out.push_back("thermal: present in one only");
  } else if (a.thermal) {
    const ThermalTerms &x = *a.thermal, &y = *b.thermal;
    c.exact("thermal.datum_head", x.datum_head, y.datum_head);
    if (x.beta_ref_rad.has_value() != y.beta_ref_rad.has_value()) c.out.push_back("thermal.beta_ref: present in one only");
    else if (x.beta_ref_rad) c.num("thermal.beta_ref", *x.beta_ref_rad, *y.beta_ref_rad);
    c.valid("thermal", x.valid, y.valid);
    if (x.heads.size() != y.heads.size()) c.out.push_back("thermal.heads: count differs");
    for (std::size_t i = 0; i < std::min(x.heads.size(), y.heads.size()); ++i) {
      const std::string k = "thermal.heads[" + std::to_string(i) + "]";
      c.exact(k + ".id", x.heads[i].head, y.heads[i].head);
      c.u3(k + ".constant", x.heads[i].constant_rad, y.heads[i].constant_rad);
      c.harmonics(k + ".harmonics", x.heads[i].harmonics, y.heads[i].harmonics);
      c.harmonics(k + ".beta_harmonics", x.heads[i].beta_harmonics, y.heads[i].beta_harmonics);
    }
  }
  if (a.accelerometer.has_value() != b.accelerometer.has_value()) {
    c.out.push_back("accelerometer: present in one only");
  } else if (a.accelerometer) {
    c.ou3("accelerometer.bias", a.accelerometer->bias_rad_s2, b.accelerometer->bias_rad_s2);
    c.ou3("accelerometer.scale", a.accelerometer->scale, b.accelerometer->scale);
    c.ou3("accelerometer.misalignment", a.accelerometer->misalignment_rad, b.accelerometer->misalignment_rad);
    c.ou3("accelerometer.nonorthogonality", a.accelerometer->nonorthogonality_rad, b.accelerometer->nonorthogonality_rad);
    c.valid("accelerometer", a.accelerometer->valid, b.accelerometer->valid);
  }
  if (a.time_offsets.size() != b.time_offsets.size()) c.out.push_back("time_offsets: count differs");
  for (std::size_t i = 0; i < std::min(a.time_offsets.size(), b.time_offsets.size()); ++i) {
    const TimeOffsetEntry &x = a.time_offsets[i], &y = b.time_offsets[i];
    const std::string k = "time_offsets[" + std::to_string(i) + "]";
    c.exact(k + ".sensor", x.sensor, y.sensor);
    c.exact(k + ".relative_to", x.relative_to, y.relative_to);
    c.num(k + ".offset_s", x.offset_s, y.offset_s);
    c.num(k + ".offset_sigma_s", x.sigma_s, y.sigma_s);
    c.valid(k, x.valid, y.valid);
  }
  if (a.published_frame.has_value() != b.published_frame.has_value()) {
    c.out.push_back("published_frame: present in one only");
  } else if (a.published_frame) {
    const PublishedFrame &x = *a.published_frame, &y = *b.published_frame;
    for (int j = 0; j < 4; ++j) c.num("published_frame.q_B_Bpub[" + std::to_string(j) + "]", x.q_B_Bpub.coeffs()[j], y.q_B_Bpub.coeffs()[j]);
    c.exact("published_frame.epoch", x.epoch, y.epoch);
    c.exact("published_frame.calibration", x.calibration, y.calibration);
  }
  if (a.data_events.has_value() != b.data_events.has_value()) {
    c.out.push_back("data_events: present in one only");
  } else if (a.data_events) {
    const DataEventRates &x = *a.data_events, &y = *b.data_events;
    c.num("data_events.head_dropouts_per_day", x.head_dropouts_per_day, y.head_dropouts_per_day);
    c.num("data_events.epoch_gaps_per_day", x.epoch_gaps_per_day, y.epoch_gaps_per_day);
    c.num("data_events.acc_gaps_per_day", x.acc_gaps_per_day, y.acc_gaps_per_day);
    c.num("data_events.head_dropout_max_s", x.head_dropout_max_s, y.head_dropout_max_s);
    c.num("data_events.epoch_gap_max_s", x.epoch_gap_max_s, y.epoch_gap_max_s);
    c.num("data_events.acc_gap_max_s", x.acc_gap_max_s, y.acc_gap_max_s);
    if (x.head_dropouts_by_id.size() != y.head_dropouts_by_id.size()) c.out.push_back("data_events.heads: count differs");
    for (std::size_t i = 0; i < std::min(x.head_dropouts_by_id.size(), y.head_dropouts_by_id.size()); ++i) {
      const std::string k = "data_events.heads[" + std::to_string(i) + "]";
      c.exact(k + ".id", x.head_dropouts_by_id[i].first, y.head_dropouts_by_id[i].first);
      c.num(k + ".dropouts_per_day", x.head_dropouts_by_id[i].second, y.head_dropouts_by_id[i].second);
    }
  }
  return c.out;
}

}  // namespace boresight::model

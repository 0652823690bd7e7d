// The model overlay's YAML reader and writer, and the one YAML form of a noise model
// (io/overlay_yaml.h).
#include "noise_yaml.h"

#include <boresight/io/overlay_yaml.h>
#include <boresight/io/yaml_file.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace boresight::io {

using namespace yamlcheck;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Ranges the reader accepts (beyond them a value is a mistake, not a sensor).
constexpr double kMaxArcsec = 36000;        // 10 deg: angles, sigmas, thermal amplitudes
constexpr double kMaxNoiseArcsec = 3600;    // a head's per-sample noise
constexpr double kMaxAccRadS2 = 1.0;        // angular acceleration levels, biases
constexpr double kMaxScale = 0.5;           // accelerometer scale factors
constexpr double kMaxTimeOffsetS = 3600;
constexpr double kMaxTauS = 1e9;
constexpr double kMaxHz = 1e3;

const char* kindKey(model::NoiseKind k) { return model::noiseKindName(k); }

/// YAML key of a term parameter in the file (the level carries the unit).
std::string paramKey(const std::string& p, bool head_axis) {
  if (p == "sigma") return head_axis ? "sigma_arcsec" : "sigma_rad_s2";
  return p;
}
double paramScale(const std::string& p, bool head_axis) { return p == "sigma" && head_axis ? kRadPerArcsec : 1.0; }

std::vector<std::string> validityKeys(bool with_validity) {
  return with_validity ? std::vector<std::string>{"valid_from", "valid_to"} : std::vector<std::string>{};
}

model::Validity readValidity(const YAML::Node& n, const std::string& prefix) {
  model::Validity v;
  if (n["valid_from"]) v.from = gpsTime(n["valid_from"], join(prefix, "valid_from"));
  if (n["valid_to"]) v.to = gpsTime(n["valid_to"], join(prefix, "valid_to"));
  if (v.from && v.to && *v.to < *v.from) fail(join(prefix, "valid_to"), "before valid_from", n["valid_to"]);
  return v;
}

/// The platform file's sections have no validity: say so rather than "unknown key".
void refuseValidity(const YAML::Node& n, const std::string& prefix) {
  for (const char* k : {"valid_from", "valid_to"})
    if (n[k]) fail(join(prefix, k), "validity spans belong in a model overlay (--overlay), not in the platform file", n[k]);
}

/// One term of an axis's list: appended to `so_far`, its uncertainties to `params`.
void readTerm(const YAML::Node& t, const std::string& key, bool head_axis, std::vector<model::NoiseParam>& params,
              model::NoiseModel& so_far) {
  if (!t.IsMap()) fail(key, "expected a term {kind: white|gauss_markov|power_law, ...}", t);
  const std::string kind = text(t["kind"], key + ".kind");
  model::NoiseTerm term;
  const std::vector<std::string> kinds = {"white", "gauss_markov", "power_law"};
  if (kind == "white") term.kind = model::NoiseKind::White;
  else if (kind == "gauss_markov") term.kind = model::NoiseKind::GaussMarkov;
  else if (kind == "power_law") term.kind = model::NoiseKind::PowerLaw;
  else {
    const std::string near = nearestKey(kind, kinds);
    fail(key + ".kind", "unknown kind '" + kind + "'" + (near.empty() ? " (white, gauss_markov or power_law)" : "; did you mean '" + near + "'?"),
         t["kind"]);
  }
  const auto names = model::noiseTermParameters(term.kind);
  const std::string other = paramKey("sigma", !head_axis);
  if (t[other])
    fail(key + "." + other, "unknown key; did you mean '" + paramKey("sigma", head_axis) +
                                "'? (head axes take levels in arcsec, accelerometer axes in rad/s^2)",
         t[other]);
  std::vector<std::string> known = {"kind", "uncertainty", "not_determined"};
  for (const auto& p : names) known.push_back(paramKey(p, head_axis));
  checkKeys(t, key, known);
  const double max_sigma = head_axis ? kMaxNoiseArcsec : kMaxAccRadS2;
  const std::string sk = paramKey("sigma", head_axis);
  const double sigma = numberIn(t[sk], key + "." + sk, 0, max_sigma);
  if (!(sigma > 0)) fail(key + "." + sk, "must be > 0 (leave a term of zero level out)", t[sk]);
  term.sigma = sigma * paramScale("sigma", head_axis);
  if (term.kind == model::NoiseKind::GaussMarkov) {
    term.tau_s = numberIn(t["tau_s"], key + ".tau_s", 0, kMaxTauS);
    if (!(term.tau_s > 0)) fail(key + ".tau_s", "must be > 0", t["tau_s"]);
  }
  if (term.kind == model::NoiseKind::PowerLaw) {
    term.alpha = numberIn(t["alpha"], key + ".alpha", 0, 2);
    if (!(term.alpha < 2)) fail(key + ".alpha", "must be below 2", t["alpha"]);
    term.f_lo_hz = numberIn(t["f_lo_hz"], key + ".f_lo_hz", 0, kMaxHz);
    if (!(term.f_lo_hz > 0)) fail(key + ".f_lo_hz", "must be > 0", t["f_lo_hz"]);
    term.f_hi_hz = numberIn(t["f_hi_hz"], key + ".f_hi_hz", 0, kMaxHz);
    if (!(term.f_hi_hz > term.f_lo_hz)) fail(key + ".f_hi_hz", "must be above f_lo_hz", t["f_hi_hz"]);
    if (term.f_hi_hz / term.f_lo_hz > 1e8) fail(key + ".f_hi_hz", "f_hi_hz / f_lo_hz must be at most 1e8", t["f_hi_hz"]);
  }
  so_far.terms.push_back(term);
  const std::string tname = model::noiseTermName(so_far, so_far.terms.size() - 1);
  // Uncertainties and undetermined parameters, in parameter order.
  const YAML::Node u = t["uncertainty"], nd = t["not_determined"];
  std::vector<std::string> pkeys;
  for (const auto& p : names) pkeys.push_back(paramKey(p, head_axis));
  for (const auto& [node, what] : {std::make_pair(u, std::string("uncertainty")), std::make_pair(nd, std::string("not_determined"))}) {
    if (!node) continue;
    if (!node.IsMap() || node.size() == 0)
      fail(key + "." + what, "expected a mapping of the term's parameters (" + pkeys.front() + ", ...)", node);
    checkKeys(node, key + "." + what, pkeys);
  }
  for (const auto& p : names) {
    const std::string pk = paramKey(p, head_axis);
    const bool has_u = u && u[pk], has_nd = nd && nd[pk];
    if (!has_u && !has_nd) continue;
    model::NoiseParam np;
    np.name = tname + "." + p;
    np.value = model::noiseTermValue(term, p);
    np.log_scale = p != "alpha";
    np.sigma = kNaN;
    np.log_sigma = kNaN;
    if (has_u) {
      const double hi = p == "sigma" ? max_sigma : p == "tau_s" ? kMaxTauS : p == "alpha" ? 2.0 : kMaxHz;
      np.sigma = numberIn(u[pk], key + ".uncertainty." + pk, 0, hi) * paramScale(p, head_axis);
      np.log_sigma = np.log_scale ? np.sigma / np.value : 0.0;
    }
    if (has_nd) {
      np.determined = false;
      const YAML::Node r = nd[pk];
      if (!r.IsScalar()) fail(key + ".not_determined." + pk, "expected a reason (text)", r);
      np.note = r.Scalar();
    }
    params.push_back(np);
  }
}

}  // namespace

namespace yamlcheck {

model::AxisNoise readAxisNoise(const YAML::Node& n, const std::string& key, bool head_axis) {
  const std::string unit = head_axis ? "sigma_arcsec" : "sigma_rad_s2";
  if (!n || n.IsNull()) fail(key, "missing (a list of noise terms, e.g. [{kind: white, " + unit + ": ...}])", n);
  if (!n.IsSequence()) fail(key, "expected a list of noise terms, e.g. [{kind: white, " + unit + ": ...}]", n);
  if (n.size() == 0) fail(key, "empty (give at least one term)", n);
  model::AxisNoise a;
  for (std::size_t i = 0; i < n.size(); ++i)
    readTerm(n[i], key + "[" + std::to_string(i) + "]", head_axis, a.params, a.model);
  if (std::string e = model::validateAxisNoise(a); !e.empty()) fail(key, e, n);
  return a;
}

model::NoiseSection readNoiseSection(const YAML::Node& n, const std::string& prefix, bool with_validity) {
  model::NoiseSection s;
  if (!n.IsMap()) fail(prefix, "expected a mapping (head_defaults, heads, accelerometer)", n);
  checkKeys(n, prefix, {"head_defaults", "heads", "accelerometer"});
  std::vector<std::string> head_keys;
  for (int a = 0; a < model::kHeadAxes; ++a) head_keys.push_back(model::headAxisKey(model::HeadAxis(a)));
  auto readHead = [&](const YAML::Node& h, const std::string& key, bool with_id) {
    model::HeadNoise hn;
    if (!h.IsMap()) fail(key, "expected a mapping of head axes (" + head_keys.front() + ", ...)", h);
    std::vector<std::string> known = head_keys;
    if (with_id) known.insert(known.begin(), "id");
    for (const auto& k : validityKeys(with_validity)) known.push_back(k);
    if (!with_validity) refuseValidity(h, key);
    checkKeys(h, key, known);
    if (with_id) hn.id = static_cast<int>(integerIn(h["id"], key + ".id", 1, 255));
    for (int a = 0; a < model::kHeadAxes; ++a)
      if (h[head_keys[static_cast<std::size_t>(a)]])
        hn.axis[static_cast<std::size_t>(a)] = readAxisNoise(h[head_keys[static_cast<std::size_t>(a)]], key + "." + head_keys[static_cast<std::size_t>(a)], true);
    if (with_validity) hn.valid = readValidity(h, key);
    return hn;
  };
  if (const YAML::Node d = n["head_defaults"]) s.head_defaults = readHead(d, prefix + ".head_defaults", false);
  if (const YAML::Node hs = n["heads"]) {
    if (!hs.IsSequence()) fail(prefix + ".heads", "expected a list of {id, axes...} (may be empty: [])", hs);
    std::set<int> ids;
    for (std::size_t i = 0; i < hs.size(); ++i) {
      const std::string k = prefix + ".heads[" + std::to_string(i) + "]";
      model::HeadNoise h = readHead(hs[i], k, true);
      if (!ids.insert(h.id).second) fail(k + ".id", "head " + std::to_string(h.id) + " is given twice", hs[i]["id"]);
      s.heads.push_back(std::move(h));
    }
  }
  if (const YAML::Node a = n["accelerometer"]) {
    const std::string k = prefix + ".accelerometer";
    if (!a.IsMap()) fail(k, "expected a mapping of A axes (x, y, z)", a);
    std::vector<std::string> known = {"x", "y", "z"};
    for (const auto& v : validityKeys(with_validity)) known.push_back(v);
    if (!with_validity) refuseValidity(a, k);
    checkKeys(a, k, known);
    model::AccNoise an;
    for (int i = 0; i < 3; ++i)
      if (a[model::accAxisKey(i)]) an.axis[static_cast<std::size_t>(i)] = readAxisNoise(a[model::accAxisKey(i)], k + "." + model::accAxisKey(i), false);
    if (with_validity) an.valid = readValidity(a, k);
    s.accelerometer = an;
  }
  return s;
}

model::DataEventRates readDataEvents(const YAML::Node& n, const std::string& prefix, model::DataEventRates r) {
  constexpr double kMaxRate = 1e6;  // runs per day (a 2 Hz head has 172 800 samples a day)
  if (!n.IsMap()) fail(prefix, "expected a mapping (head_dropouts_per_day, epoch_gaps_per_day, acc_gaps_per_day, heads)", n);
  checkKeys(n, prefix, {"head_dropouts_per_day", "epoch_gaps_per_day", "acc_gaps_per_day", "heads", "head_dropout_max_s",
                        "epoch_gap_max_s", "acc_gap_max_s"});
  const auto rate = [&](const YAML::Node& v, const std::string& key, double def) {
    return v && !v.IsNull() ? numberIn(v, key, 0, kMaxRate) : def;
  };
  r.head_dropouts_per_day = rate(n["head_dropouts_per_day"], prefix + ".head_dropouts_per_day", r.head_dropouts_per_day);
  r.epoch_gaps_per_day = rate(n["epoch_gaps_per_day"], prefix + ".epoch_gaps_per_day", r.epoch_gaps_per_day);
  r.acc_gaps_per_day = rate(n["acc_gaps_per_day"], prefix + ".acc_gaps_per_day", r.acc_gaps_per_day);
  // the longest runs, s (> 0; a null: no limit)
  const auto longest = [&](const YAML::Node& v, const std::string& key, double def) {
    if (!v) return def;
    if (v.IsNull()) return kNaN;
    const double x = numberIn(v, key, 0, 1e9);
    if (!(x > 0)) fail(key, "must be > 0 (seconds; null: no limit)", v);
    return x;
  };
  r.head_dropout_max_s = longest(n["head_dropout_max_s"], prefix + ".head_dropout_max_s", r.head_dropout_max_s);
  r.epoch_gap_max_s = longest(n["epoch_gap_max_s"], prefix + ".epoch_gap_max_s", r.epoch_gap_max_s);
  r.acc_gap_max_s = longest(n["acc_gap_max_s"], prefix + ".acc_gap_max_s", r.acc_gap_max_s);
  if (const YAML::Node hl = n["heads"]) {  // a list given replaces the one before
    if (!hl.IsSequence()) fail(prefix + ".heads", "expected a list of {id, dropouts_per_day}", hl);
    r.head_dropouts_by_id.clear();
    for (std::size_t i = 0; i < hl.size(); ++i) {
      const std::string k = prefix + ".heads[" + std::to_string(i) + "]";
      if (!hl[i].IsMap()) fail(k, "expected a mapping {id, dropouts_per_day}", hl[i]);
      checkKeys(hl[i], k, {"id", "dropouts_per_day"});
      if (!hl[i]["id"]) fail(k + ".id", "missing", hl[i]);
      if (!hl[i]["dropouts_per_day"]) fail(k + ".dropouts_per_day", "missing", hl[i]);
      const int id = static_cast<int>(integerIn(hl[i]["id"], k + ".id", 1, 255));
      for (const auto& e : r.head_dropouts_by_id)
        if (e.first == id) fail(k + ".id", "head " + std::to_string(id) + " given twice", hl[i]["id"]);
      r.head_dropouts_by_id.emplace_back(id, rate(hl[i]["dropouts_per_day"], k + ".dropouts_per_day", 0));
    }
  }
  return r;
}

}  // namespace yamlcheck

// ---------------------------------------------------------------------------------------------
// Reading an overlay

namespace {

model::Uncertain3 readU3(const YAML::Node& n, const std::string& prefix, const std::string& value_key,
                         const std::string& sigma_key, double hi, double scale) {
  model::Uncertain3 u;
  u.value = vec3(n[value_key], join(prefix, value_key), -hi, hi, scale);
  u.sigma = sigma3(n[sigma_key], join(prefix, sigma_key), hi, scale);
  return u;
}

/// "head<id>" or a fixed name among `fixed`.
std::string sensorName(const YAML::Node& n, const std::string& key, const std::vector<std::string>& fixed) {
  const std::string s = text(n, key);
  if (std::find(fixed.begin(), fixed.end(), s) != fixed.end()) return s;
  if (s.size() > 4 && s.rfind("head", 0) == 0 && s.find_first_not_of("0123456789", 4) == std::string::npos) {
    const int id = std::atoi(s.c_str() + 4);
    if (id >= 1 && id <= 255) return s;
  }
  std::string list;
  for (const auto& f : fixed) list += f + ", ";
  fail(key, "expected " + list + "or head<id> (head1, head2, ...), not '" + s + "'", n);
}

std::vector<model::ThermalHarmonicEntry> readHarmonics(const YAML::Node& n, const std::string& key) {
  std::vector<model::ThermalHarmonicEntry> out;
  if (!n) return out;
  if (!n.IsSequence()) fail(key, "expected a list of {harmonic, cos_arcsec, cos_sigma_arcsec, sin_arcsec, sin_sigma_arcsec}", n);
  std::set<int> seen;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string k = key + "[" + std::to_string(i) + "]";
    const YAML::Node h = n[i];
    if (!h.IsMap()) fail(k, "expected a mapping", h);
    checkKeys(h, k, {"harmonic", "cos_arcsec", "cos_sigma_arcsec", "sin_arcsec", "sin_sigma_arcsec"});
    model::ThermalHarmonicEntry e;
    e.harmonic = static_cast<int>(integerIn(h["harmonic"], k + ".harmonic", 1, 100));
    if (!seen.insert(e.harmonic).second) fail(k + ".harmonic", "harmonic " + std::to_string(e.harmonic) + " is given twice", h["harmonic"]);
    e.cos_rad = readU3(h, k, "cos_arcsec", "cos_sigma_arcsec", kMaxArcsec, kRadPerArcsec);
    e.sin_rad = readU3(h, k, "sin_arcsec", "sin_sigma_arcsec", kMaxArcsec, kRadPerArcsec);
    out.push_back(e);
  }
  return out;
}

void readOverlayRoot(const YAML::Node& root, model::Overlay& o) {
  if (!root.IsMap()) fail("(top level)", "expected a mapping that starts with boresight_overlay: " + std::to_string(model::kOverlayVersion), root);
  // The version first: a file of another version may well have keys this one does not know.
  const YAML::Node v = root["boresight_overlay"];
  if (!v)
    fail("boresight_overlay", "missing: not a boresight model overlay (its first key names the schema and the version, boresight_overlay: " +
                                  std::to_string(model::kOverlayVersion) + ")",
         root);
  std::set<std::string> tops;
  for (const auto& kv : root)
    if (!tops.insert(kv.first.Scalar()).second) fail(kv.first.Scalar(), "given twice in this mapping", kv.first);
  const long long version = integerIn(v, "boresight_overlay", 0, 1000000);
  if (version != model::kOverlayVersion)
    fail("boresight_overlay", "unsupported version " + std::to_string(version) + " (this program reads version " +
                                  std::to_string(model::kOverlayVersion) + ")",
         v);
  o.version = static_cast<int>(version);
  checkKeys(root, "", {"boresight_overlay", "written_by", "platform", "note", "mountings", "noise", "thermal", "accelerometer", "time_offsets",
                       "published_frame", "data_events"});
  o.written_by = text(root["written_by"], "written_by");
  if (root["platform"]) o.platform = text(root["platform"], "platform");
  if (root["note"]) o.note = text(root["note"], "note");

  if (const YAML::Node ms = root["mountings"]) {
    if (!ms.IsSequence()) fail("mountings", "expected a list of {head, q_Si_B, datum, epoch, sigma_arcsec}", ms);
    std::set<int> ids;
    for (std::size_t i = 0; i < ms.size(); ++i) {
      const std::string k = "mountings[" + std::to_string(i) + "]";
      const YAML::Node m = ms[i];
      if (!m.IsMap()) fail(k, "expected a mapping {head, q_Si_B, datum, epoch, sigma_arcsec}", m);
      checkKeys(m, k, {"head", "q_Si_B", "datum", "epoch", "sigma_arcsec", "valid_from", "valid_to"});
      model::MountingEntry e;
      e.head = static_cast<int>(integerIn(m["head"], k + ".head", 1, 255));
      if (!ids.insert(e.head).second) fail(k + ".head", "head " + std::to_string(e.head) + " is given twice", m["head"]);
      const YAML::Node q = m["q_Si_B"];
      if (!q || !q.IsSequence() || q.size() != 4) fail(k + ".q_Si_B", "expected [q0, q1, q2, q3] (scalar first)", q ? q : m);
      double qv[4];
      for (std::size_t j = 0; j < 4; ++j) qv[j] = numberIn(q[j], k + ".q_Si_B[" + std::to_string(j) + "]", -1, 1);
      const Quat qq = quatFromScalarFirst(qv);
      if (std::abs(qq.norm() - 1.0) > 1e-6) fail(k + ".q_Si_B", "not a unit quaternion (norm " + std::to_string(qq.norm()) + ")", q);
      e.q_Si_B = qq.normalized();
      const std::string d = text(m["datum"], k + ".datum");
      const std::vector<std::string> datums = {"accelerometer", "ground", "star_cameras"};
      if (d == "accelerometer") e.datum = model::MountingDatum::Accelerometer;
      else if (d == "ground") e.datum = model::MountingDatum::Ground;
      else if (d == "star_cameras") e.datum = model::MountingDatum::StarCameras;
      else {
        const std::string near = nearestKey(d, datums);
        fail(k + ".datum", "unknown datum '" + d + "'" + (near.empty() ? " (accelerometer, ground or star_cameras)" : "; did you mean '" + near + "'?"),
             m["datum"]);
      }
      e.epoch = gpsTime(m["epoch"], k + ".epoch");
      e.sigma_rad = sigma3(m["sigma_arcsec"], k + ".sigma_arcsec", kMaxArcsec, kRadPerArcsec);
      e.valid = readValidity(m, k);
      o.mountings.push_back(e);
    }
  }
  if (const YAML::Node n = root["noise"]) o.noise = readNoiseSection(n, "noise", true);

  if (const YAML::Node t = root["thermal"]) {
    if (!t.IsMap()) fail("thermal", "expected a mapping {datum_head, heads, ...}", t);
    checkKeys(t, "thermal", {"datum_head", "beta_ref_deg", "heads", "valid_from", "valid_to"});
    model::ThermalTerms th;
    th.datum_head = static_cast<int>(integerIn(t["datum_head"], "thermal.datum_head", 1, 255));
    if (t["beta_ref_deg"]) th.beta_ref_rad = numberIn(t["beta_ref_deg"], "thermal.beta_ref_deg", -90, 90) * kRadPerDeg;
    th.valid = readValidity(t, "thermal");
    const YAML::Node hs = t["heads"];
    if (!hs || !hs.IsSequence()) fail("thermal.heads", "expected a list of {id, constant_arcsec, constant_sigma_arcsec, harmonics}", hs ? hs : t);
    std::set<int> ids;
    for (std::size_t i = 0; i < hs.size(); ++i) {
      const std::string k = "thermal.heads[" + std::to_string(i) + "]";
      const YAML::Node h = hs[i];
      if (!h.IsMap()) fail(k, "expected a mapping", h);
      checkKeys(h, k, {"id", "constant_arcsec", "constant_sigma_arcsec", "harmonics", "beta_harmonics"});
      model::ThermalHeadEntry e;
      e.head = static_cast<int>(integerIn(h["id"], k + ".id", 1, 255));
      if (e.head == th.datum_head) fail(k + ".id", "the datum head has no terms (it is the reference)", h["id"]);
      if (!ids.insert(e.head).second) fail(k + ".id", "head " + std::to_string(e.head) + " is given twice", h["id"]);
      e.constant_rad = readU3(h, k, "constant_arcsec", "constant_sigma_arcsec", kMaxArcsec, kRadPerArcsec);
      e.harmonics = readHarmonics(h["harmonics"], k + ".harmonics");
      e.beta_harmonics = readHarmonics(h["beta_harmonics"], k + ".beta_harmonics");
      if (!e.beta_harmonics.empty() && !th.beta_ref_rad)
        fail(k + ".beta_harmonics", "need thermal.beta_ref_deg (the beta modulation is per unit of cos(beta) - cos(beta_ref))", h["beta_harmonics"]);
      th.heads.push_back(e);
    }
    o.thermal = th;
  }

  if (const YAML::Node a = root["accelerometer"]) {
    if (!a.IsMap()) fail("accelerometer", "expected a mapping (bias_rad_s2, scale, misalignment_arcsec, nonorthogonality_arcsec with their sigmas)", a);
    struct Item {
      const char *value, *sigma;
      double hi, scale;
      std::optional<model::Uncertain3> model::AccelerometerTerms::*field;
    };
    const Item items[] = {
        {"bias_rad_s2", "bias_sigma_rad_s2", kMaxAccRadS2, 1.0, &model::AccelerometerTerms::bias_rad_s2},
        {"scale", "scale_sigma", kMaxScale, 1.0, &model::AccelerometerTerms::scale},
        {"misalignment_arcsec", "misalignment_sigma_arcsec", kMaxArcsec, kRadPerArcsec, &model::AccelerometerTerms::misalignment_rad},
        {"nonorthogonality_arcsec", "nonorthogonality_sigma_arcsec", kMaxArcsec, kRadPerArcsec,
         &model::AccelerometerTerms::nonorthogonality_rad}};
    std::vector<std::string> known = {"valid_from", "valid_to"};
    for (const auto& it : items) {
      known.push_back(it.value);
      known.push_back(it.sigma);
    }
    checkKeys(a, "accelerometer", known);
    model::AccelerometerTerms at;
    bool any = false;
    for (const auto& it : items) {
      if (!a[it.value] && !a[it.sigma]) continue;
      if (!a[it.value]) fail(std::string("accelerometer.") + it.value, std::string("missing (") + it.sigma + " is given)", a[it.sigma]);
      if (!a[it.sigma]) fail(std::string("accelerometer.") + it.sigma, std::string("missing (each value carries its 1-sigma; null where not determined)"), a[it.value]);
      at.*(it.field) = readU3(a, "accelerometer", it.value, it.sigma, it.hi, it.scale);
      any = true;
    }
    if (!any) fail("accelerometer", "no terms (bias_rad_s2, scale, misalignment_arcsec, nonorthogonality_arcsec)", a);
    at.valid = readValidity(a, "accelerometer");
    o.accelerometer = at;
  }

  if (const YAML::Node ts = root["time_offsets"]) {
    if (!ts.IsSequence()) fail("time_offsets", "expected a list of {sensor, relative_to, offset_s, offset_sigma_s}", ts);
    for (std::size_t i = 0; i < ts.size(); ++i) {
      const std::string k = "time_offsets[" + std::to_string(i) + "]";
      const YAML::Node t = ts[i];
      if (!t.IsMap()) fail(k, "expected a mapping {sensor, relative_to, offset_s, offset_sigma_s}", t);
      checkKeys(t, k, {"sensor", "relative_to", "offset_s", "offset_sigma_s", "valid_from", "valid_to"});
      model::TimeOffsetEntry e;
      e.sensor = sensorName(t["sensor"], k + ".sensor", {"accelerometer"});
      e.relative_to = sensorName(t["relative_to"], k + ".relative_to", {"heads", "accelerometer", "gps"});
      if (e.sensor == e.relative_to) fail(k + ".relative_to", "the same as sensor", t["relative_to"]);
      e.offset_s = numberIn(t["offset_s"], k + ".offset_s", -kMaxTimeOffsetS, kMaxTimeOffsetS);
      e.sigma_s = t["offset_sigma_s"] && t["offset_sigma_s"].IsNull() ? kNaN
                                                                      : numberIn(t["offset_sigma_s"], k + ".offset_sigma_s", 0, kMaxTimeOffsetS);
      e.valid = readValidity(t, k);
      o.time_offsets.push_back(e);
    }
  }
  if (const YAML::Node ev = root["data_events"]) o.data_events = readDataEvents(ev, "data_events", model::DataEventRates{});
  if (const YAML::Node f = root["published_frame"]) {
    if (!f.IsMap()) fail("published_frame", "expected a mapping {q_B_Bpub, epoch, calibration}", f);
    checkKeys(f, "published_frame", {"q_B_Bpub", "epoch", "calibration"});
    model::PublishedFrame pf;
    const YAML::Node q = f["q_B_Bpub"];
    if (!q || !q.IsSequence() || q.size() != 4) fail("published_frame.q_B_Bpub", "expected [q0, q1, q2, q3] (scalar first)", q ? q : f);
    double qv[4];
    for (std::size_t j = 0; j < 4; ++j) qv[j] = numberIn(q[j], "published_frame.q_B_Bpub[" + std::to_string(j) + "]", -1, 1);
    const Quat qq = quatFromScalarFirst(qv);
    if (std::abs(qq.norm() - 1.0) > 1e-6) fail("published_frame.q_B_Bpub", "not a unit quaternion (norm " + std::to_string(qq.norm()) + ")", q);
    pf.q_B_Bpub = qq.normalized();
    pf.epoch = gpsTime(f["epoch"], "published_frame.epoch");
    pf.calibration = integerIn(f["calibration"], "published_frame.calibration", 0, 1LL << 53);
    o.published_frame = pf;
  }
  if (o.parts().empty())
    fail("(top level)", "the overlay has no content (mountings, noise, thermal, accelerometer, time_offsets, published_frame or data_events)", root);
}

}  // namespace

bool parseOverlay(const std::string& text, const std::string& file, model::Overlay& out, std::string* error) {
  out = model::Overlay{};
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    if (error) *error = file + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) + ": YAML syntax: " + e.msg;
    return false;
  }
  if (!checkDuplicateKeys(root, file, error)) return false;
  try {
    readOverlayRoot(root, out);
  } catch (const Error& e) {
    if (error) *error = located(file, e);
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = file + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  }
  if (std::string e = model::validate(out); !e.empty()) {  // ranges the reader checks already: a backstop
    if (error) *error = file + ": " + e;
    return false;
  }
  return true;
}

bool readOverlay(const std::string& path, model::Overlay& out, std::string* error) {
  std::string text;
  if (!readBounded(path, kMaxConfigBytes, "model overlay", text, error)) return false;
  return parseOverlay(text, path, out, error);
}

// ---------------------------------------------------------------------------------------------
// Writing

std::string yamlNumber(double v) {
  if (!std::isfinite(v)) return "null";
  if (v == 0) return "0";
  // The fewest significant digits (at most 15) that read back as v; 15 when none does (a value that
  // went through the arcsec scaling carries noise in its 16th and 17th digits: 0.05000000000000001).
  char b[64];
  int p = 1;
  for (; p < 15; ++p) {
    std::snprintf(b, sizeof b, "%.*g", p, v);
    if (std::strtod(b, nullptr) == v) break;
  }
  std::snprintf(b, sizeof b, "%.*g", p, v);
  const double a = std::abs(v);
  if (std::strchr(b, 'e') && a >= 1e-4 && a < 1e15) {  // 600, not 6e+02
    const int decimals = std::max(0, p - 1 - static_cast<int>(std::floor(std::log10(a))));
    std::snprintf(b, sizeof b, "%.*f", decimals, v);
  }
  return b;
}

namespace {

std::string quoted(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

std::string timeText(TimeUs t) { return quoted(formatTime(t)); }

std::string vec(const Vec3& v, double scale) {
  return "[" + yamlNumber(v.x() * scale) + ", " + yamlNumber(v.y() * scale) + ", " + yamlNumber(v.z() * scale) + "]";
}

std::string validityText(const model::Validity& v) {
  std::string s;
  if (v.from) s += ", valid_from: " + timeText(*v.from);
  if (v.to) s += ", valid_to: " + timeText(*v.to);
  return s;
}

/// Validity as block lines at `pad`.
std::string validityLines(const model::Validity& v, const std::string& pad) {
  std::string s;
  if (v.from) s += pad + "valid_from: " + timeText(*v.from) + "\n";
  if (v.to) s += pad + "valid_to: " + timeText(*v.to) + "\n";
  return s;
}

}  // namespace

std::string axisNoiseYaml(const model::AxisNoise& a, bool head_axis) {
  std::string s = "[";
  for (std::size_t i = 0; i < a.model.terms.size(); ++i) {
    const model::NoiseTerm& t = a.model.terms[i];
    const std::string tname = model::noiseTermName(a.model, i);
    s += (i ? ", " : "") + std::string("{kind: ") + kindKey(t.kind);
    std::string unc, nd;
    for (const auto& p : model::noiseTermParameters(t.kind)) {
      const std::string pk = paramKey(p, head_axis);
      const double scale = 1.0 / paramScale(p, head_axis);
      s += ", " + pk + ": " + yamlNumber(model::noiseTermValue(t, p) * scale);
      for (const model::NoiseParam& np : a.params) {
        if (np.name != tname + "." + p) continue;
        if (std::isfinite(np.sigma)) unc += (unc.empty() ? "" : ", ") + pk + ": " + yamlNumber(np.sigma * scale);
        if (!np.determined) nd += (nd.empty() ? "" : ", ") + pk + ": " + quoted(np.note);
      }
    }
    if (!unc.empty()) s += ", uncertainty: {" + unc + "}";
    if (!nd.empty()) s += ", not_determined: {" + nd + "}";
    s += "}";
  }
  return s + "]";
}

namespace {

/// "KEY: [{...}]" for one term, else "KEY:" and one "- {...}" line per term.
std::string axisLines(const std::string& pad, const std::string& key, const model::AxisNoise& a, bool head_axis) {
  const std::string flow = axisNoiseYaml(a, head_axis);
  if (a.model.terms.size() <= 1) return pad + key + ": " + flow + "\n";
  std::string s = pad + key + ":\n";
  for (std::size_t i = 0; i < a.model.terms.size(); ++i) {
    model::AxisNoise one;
    one.model.terms.push_back(a.model.terms[i]);
    const std::string name = model::noiseTermName(a.model, i);
    for (const auto& p : a.params)  // renamed to the one-term model's name of the term
      if (p.name.rfind(name + ".", 0) == 0) {
        model::NoiseParam q = p;
        q.name = model::noiseTermName(one.model, 0) + p.name.substr(name.size());
        one.params.push_back(q);
      }
    const std::string t = axisNoiseYaml(one, head_axis);
    s += pad + "  - " + t.substr(1, t.size() - 2) + "\n";
  }
  return s;
}

}  // namespace

std::string noiseSectionYaml(const model::NoiseSection& sec, int indent, bool with_validity) {
  const std::string pad(static_cast<std::size_t>(indent), ' ');
  std::string s;
  auto headAxes = [&](const model::HeadNoise& h, const std::string& p) {
    std::string o;
    for (int a = 0; a < model::kHeadAxes; ++a)
      if (h.axis[static_cast<std::size_t>(a)])
        o += axisLines(p, model::headAxisKey(model::HeadAxis(a)), *h.axis[static_cast<std::size_t>(a)], true);
    if (with_validity) o += validityLines(h.valid, p);
    return o;
  };
  if (sec.head_defaults) s += pad + "head_defaults:\n" + headAxes(*sec.head_defaults, pad + "  ");
  if (!sec.heads.empty()) {
    s += pad + "heads:\n";
    for (const auto& h : sec.heads) {
      s += pad + "  - id: " + std::to_string(h.id) + "\n";
      s += headAxes(h, pad + "    ");
    }
  }
  if (sec.accelerometer) {
    s += pad + "accelerometer:\n";
    for (int a = 0; a < 3; ++a)
      if (sec.accelerometer->axis[static_cast<std::size_t>(a)])
        s += axisLines(pad + "  ", model::accAxisKey(a), *sec.accelerometer->axis[static_cast<std::size_t>(a)], false);
    if (with_validity) s += validityLines(sec.accelerometer->valid, pad + "  ");
  }
  return s;
}

std::string overlayYaml(const model::Overlay& o) {
  std::string s =
      "# boresight model overlay (README: \"The model overlay\"). Angles of heads in arcsec, accelerometer\n"
      "# angular accelerations in rad/s^2, times as GPS calendar \"YYYY-MM-DD HH:MM:SS.ffffff\"; 1-sigmas\n"
      "# are null where not determined; q_Si_B scalar first, R(q_Si_B) = C_Si_B.\n";
  s += "boresight_overlay: " + std::to_string(o.version) + "\n";
  s += "written_by: " + quoted(o.written_by) + "\n";
  if (!o.platform.empty()) s += "platform: " + quoted(o.platform) + "\n";
  if (!o.note.empty()) s += "note: " + quoted(o.note) + "\n";
  if (!o.mountings.empty()) {
    s += "mountings:  # datum: accelerometer (B as the configured C_B_A puts A into it), ground, star_cameras\n";
    for (const auto& m : o.mountings) {
      const Quat& q = m.q_Si_B;
      s += "  - head: " + std::to_string(m.head) + "\n";
      s += "    q_Si_B: [" + yamlNumber(q.w()) + ", " + yamlNumber(q.x()) + ", " + yamlNumber(q.y()) + ", " + yamlNumber(q.z()) + "]\n";
      s += std::string("    datum: ") + model::mountingDatumKey(m.datum) + "\n";
      s += "    epoch: " + timeText(m.epoch) + "\n";
      s += "    sigma_arcsec: " + vec(m.sigma_rad, kArcsecPerRad) + "  # about the head's x, y, z\n";
      s += validityLines(m.valid, "    ");
    }
  }
  if (!o.noise.empty()) s += "noise:\n" + noiseSectionYaml(o.noise, 2, true);
  if (o.thermal) {
    const model::ThermalTerms& t = *o.thermal;
    s += "thermal:  # each head's deformation relative to the datum head, in its frame, harmonics of the argument of latitude\n";
    s += "  datum_head: " + std::to_string(t.datum_head) + "\n";
    if (t.beta_ref_rad) s += "  beta_ref_deg: " + yamlNumber(*t.beta_ref_rad / kRadPerDeg) + "\n";
    s += validityLines(t.valid, "  ");
    s += "  heads:\n";
    for (const auto& h : t.heads) {
      s += "    - id: " + std::to_string(h.head) + "\n";
      s += "      constant_arcsec: " + vec(h.constant_rad.value, kArcsecPerRad) + "\n";
      s += "      constant_sigma_arcsec: " + vec(h.constant_rad.sigma, kArcsecPerRad) + "\n";
      for (const auto& [key, list] : {std::make_pair("harmonics", &h.harmonics), std::make_pair("beta_harmonics", &h.beta_harmonics)}) {
        if (list->empty()) continue;
        s += std::string("      ") + key + ":\n";
        for (const auto& x : *list)
          s += "        - {harmonic: " + std::to_string(x.harmonic) + ", cos_arcsec: " + vec(x.cos_rad.value, kArcsecPerRad) +
               ", cos_sigma_arcsec: " + vec(x.cos_rad.sigma, kArcsecPerRad) + ",\n           sin_arcsec: " +
               vec(x.sin_rad.value, kArcsecPerRad) + ", sin_sigma_arcsec: " + vec(x.sin_rad.sigma, kArcsecPerRad) + "}\n";
      }
    }
  }
  if (o.accelerometer) {
    const model::AccelerometerTerms& a = *o.accelerometer;
    s += "accelerometer:  # in the accelerometer frame A\n";
    auto item = [&](const std::optional<model::Uncertain3>& u, const char* vk, const char* sk, double scale) {
      if (!u) return;
      s += std::string("  ") + vk + ": " + vec(u->value, scale) + "\n";
      s += std::string("  ") + sk + ": " + vec(u->sigma, scale) + "\n";
    };
    item(a.bias_rad_s2, "bias_rad_s2", "bias_sigma_rad_s2", 1.0);
    item(a.scale, "scale", "scale_sigma", 1.0);
    item(a.misalignment_rad, "misalignment_arcsec", "misalignment_sigma_arcsec", kArcsecPerRad);
    item(a.nonorthogonality_rad, "nonorthogonality_arcsec", "nonorthogonality_sigma_arcsec", kArcsecPerRad);
    s += validityLines(a.valid, "  ");
  }
  if (!o.time_offsets.empty()) {
    s += "time_offsets:  # positive: the sensor's tags are late against relative_to\n";
    for (const auto& t : o.time_offsets)
      s += "  - {sensor: " + t.sensor + ", relative_to: " + t.relative_to + ", offset_s: " + yamlNumber(t.offset_s) +
           ", offset_sigma_s: " + yamlNumber(t.sigma_s) + validityText(t.valid) + "}\n";
  }
  if (o.published_frame) {
    const model::PublishedFrame& f = *o.published_frame;
    const Quat& q = f.q_B_Bpub;
    s += "published_frame:  # boresightd: its published attitude's frame from the heads' datum, and the calibration in use\n";
    s += "  q_B_Bpub: [" + yamlNumber(q.w()) + ", " + yamlNumber(q.x()) + ", " + yamlNumber(q.y()) + ", " + yamlNumber(q.z()) + "]\n";
    s += "  epoch: " + timeText(f.epoch) + "  # the last frame change\n";
    s += "  calibration: " + std::to_string(f.calibration) + "\n";
  }
  if (o.data_events) {
    const model::DataEventRates& r = *o.data_events;
    s += "data_events:  # missing-sample runs per day the audit expects (its null for the data events)\n";
    s += "  head_dropouts_per_day: " + yamlNumber(r.head_dropouts_per_day) + "\n";
    s += "  epoch_gaps_per_day: " + yamlNumber(r.epoch_gaps_per_day) + "\n";
    s += "  acc_gaps_per_day: " + yamlNumber(r.acc_gaps_per_day) + "\n";
    s += "  head_dropout_max_s: " + yamlNumber(r.head_dropout_max_s) + "  # the longest run expected, s (null: no limit)\n";
    s += "  epoch_gap_max_s: " + yamlNumber(r.epoch_gap_max_s) + "\n";
    s += "  acc_gap_max_s: " + yamlNumber(r.acc_gap_max_s) + "\n";
    s += "  heads: [";
    for (std::size_t i = 0; i < r.head_dropouts_by_id.size(); ++i)
      s += std::string(i ? ", " : "") + "{id: " + std::to_string(r.head_dropouts_by_id[i].first) +
           ", dropouts_per_day: " + yamlNumber(r.head_dropouts_by_id[i].second) + "}";
    s += "]\n";
  }
  return s;
}

bool writeOverlay(const std::string& path, const model::Overlay& o, std::string* error) {
  return writeFileAtomic(path, overlayYaml(o), error);  // whole or not at all
}

}  // namespace boresight::io

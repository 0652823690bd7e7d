#include <boresight/io/config_keys.h>
#include <boresight/io/yaml_file.h>
#include <boresight/io/time_format.h>
#include <boresight/sim/scenario.h>

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace boresight::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Ctx {
  std::string file;
  std::string* error;
  bool ok = true;
  bool fail(const YAML::Node& n, const std::string& key, const std::string& reason) {
    if (ok && error) {
      const int line = n.IsDefined() ? n.Mark().line + 1 : 0;
      *error = file + ":" + std::to_string(line < 0 ? 0 : line) + ": key '" + key + "': " + reason;
    }
    ok = false;
    return false;
  }
};

bool toDouble(const YAML::Node& n, double& v) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  std::istringstream is(s);
  is.imbue(std::locale::classic());
  is >> v;
  return !is.fail() && is.eof() && std::isfinite(v);
}

/// Reads the keys of one YAML map, remembering which were used so that unknown keys are errors.
class MapReader {
 public:
  MapReader(const YAML::Node& n, std::string prefix, Ctx& c) : n_(n), prefix_(std::move(prefix)), c_(c) {
    if (n_.IsDefined() && !n_.IsNull() && !n_.IsMap()) c_.fail(n_, prefix_.empty() ? "(top)" : prefix_, "must be a map");
  }
  std::string key(const char* k) const { return prefix_.empty() ? k : prefix_ + "." + k; }
  bool has(const char* k) const { return n_.IsMap() && n_[k].IsDefined() && !n_[k].IsNull(); }
  YAML::Node node(const char* k) {
    used_.insert(k);
    return n_.IsMap() ? n_[k] : YAML::Node();
  }
  void num(const char* k, double& v, double lo = -kInf, double hi = kInf, double scale = 1.0) {
    if (!has(k)) {
      used_.insert(k);
      return;
    }
    const YAML::Node x = node(k);
    double d;
    if (!toDouble(x, d)) {
      c_.fail(x, key(k), "expected a number");
      return;
    }
    if (d < lo || d > hi) {
      std::ostringstream o;
      o << "value " << d << " outside [" << lo << ", " << hi << "]";
      c_.fail(x, key(k), o.str());
      return;
    }
    v = d * scale;
  }
  void integer(const char* k, std::int64_t& v, std::int64_t lo, std::int64_t hi) {
    double d = static_cast<double>(v);
    num(k, d, static_cast<double>(lo), static_cast<double>(hi));
    if (d != std::floor(d)) {
      c_.fail(node(k), key(k), "expected an integer");
      return;
    }
    v = static_cast<std::int64_t>(d);
  }
  void vec(const char* k, double* out, int n, double lo = -kInf, double hi = kInf, double scale = 1.0) {
    if (!has(k)) {
      used_.insert(k);
      return;
    }
    const YAML::Node x = node(k);
    if (!x.IsSequence() || static_cast<int>(x.size()) != n) {
      c_.fail(x, key(k), "expected a list of " + std::to_string(n) + " numbers");
      return;
    }
    for (int i = 0; i < n; ++i) {
      double d;
      if (!toDouble(x[static_cast<std::size_t>(i)], d)) {
        c_.fail(x[static_cast<std::size_t>(i)], key(k) + "[" + std::to_string(i) + "]", "expected a number");
        return;
      }
      if (d < lo || d > hi) {
        std::ostringstream o;
        o << "value " << d << " outside [" << lo << ", " << hi << "]";
        c_.fail(x[static_cast<std::size_t>(i)], key(k) + "[" + std::to_string(i) + "]", o.str());
        return;
      }
      out[i] = d * scale;
    }
  }
  void vec3(const char* k, Vec3& v, double lo = -kInf, double hi = kInf, double scale = 1.0) {
    double d[3] = {v.x() / scale, v.y() / scale, v.z() / scale};
    const bool present = has(k);
    vec(k, d, 3, lo, hi, 1.0);
    if (present && c_.ok) v = Vec3(d[0], d[1], d[2]) * scale;
  }
  void str(const char* k, std::string& s) {
    if (!has(k)) {
      used_.insert(k);
      return;
    }
    const YAML::Node x = node(k);
    if (!x.IsScalar()) {
      c_.fail(x, key(k), "expected a string");
      return;
    }
    s = x.Scalar();
  }
  void boolean(const char* k, bool& b) {
    if (!has(k)) {
      used_.insert(k);
      return;
    }
    const YAML::Node x = node(k);
    try {
      b = x.as<bool>();
    } catch (const YAML::Exception&) {
      c_.fail(x, key(k), "expected true or false");
    }
  }
  /// Unknown keys are errors (typos must not silently fall back to defaults).
  void finish(const std::set<std::string>& also_allowed = {}) {
    if (!n_.IsMap() || !c_.ok) return;
    for (const auto& kv : n_) {
      const std::string k = kv.first.Scalar();
      if (!used_.count(k) && !also_allowed.count(k)) {
        std::vector<std::string> known(used_.begin(), used_.end());
        known.insert(known.end(), also_allowed.begin(), also_allowed.end());
        c_.fail(kv.first, key(k.c_str()), io::unknownKeyMessage(k, known));
        return;
      }
    }
  }

 private:
  YAML::Node n_;
  std::string prefix_;
  Ctx& c_;
  std::set<std::string> used_;
};

void readHead(MapReader& r, model::HeadConfig& h) {
  double q[4] = {h.q_Si_B.w(), h.q_Si_B.x(), h.q_Si_B.y(), h.q_Si_B.z()};
  r.vec("q_Si_B", q, 4, -1.0, 1.0);
  const double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  h.q_Si_B = quatFromScalarFirst(q[0] / qn, q[1] / qn, q[2] / qn, q[3] / qn);
  r.vec3("mounting_error_arcsec", h.mounting_error_rad, -36000, 36000, kRadPerArcsec);
  r.vec3("boresight", h.boresight_Si, -1, 1);
  r.num("rate_hz", h.rate_hz, 0.01, 100);
  std::int64_t off = h.tag_offset_us;
  r.integer("time_tag_offset_us", off, 0, 999999);
  h.tag_offset_us = off;
  r.num("time_tag_jitter_us", h.tag_jitter_us, 0, 1000);
  r.num("time_tag_drift_ppm", h.tag_drift_ppm, -1000, 1000);
  r.num("noise_cross_arcsec", h.sigma_cross_rad, 0, 3600, kRadPerArcsec);
  r.num("noise_about_arcsec", h.sigma_roll_rad, 0, 3600, kRadPerArcsec);
  r.num("star_noise_arcsec", h.sigma_star_rad, 0, 3600, kRadPerArcsec);
  r.num("fov_half_angle_deg", h.fov_half_angle_rad, 0.5, 45, kRadPerDeg);
  r.num("limiting_magnitude", h.limiting_mag, -2, 12);
  r.num("sun_exclusion_deg", h.sun_exclusion_rad, 0, 180, kRadPerDeg);
  r.num("earth_exclusion_deg", h.earth_exclusion_rad, -90, 90, kRadPerDeg);
  r.num("moon_exclusion_deg", h.moon_exclusion_rad, 0, 180, kRadPerDeg);
  std::string desig(1, h.desig);
  r.str("designation", desig);
  if (!desig.empty()) h.desig = desig[0];
}

}  // namespace

namespace {
bool parseScenarioAt(const std::string& text, const std::string& file, const std::string& dir, Scenario& out,
                     std::string* error, int depth);
bool loadScenarioAt(const std::string& path, Scenario& out, std::string* error, int depth);
bool applyKeys(const YAML::Node& root, Ctx& c, const std::string& dir, Scenario& s, bool overlay);
bool readText(const std::string& path, std::string& text, std::string& dir, std::string* error);

std::string resolve(const std::string& dir, const std::string& p) { return (!p.empty() && p[0] == '/') ? p : dir + "/" + p; }

/// A layer of a base list: the keys of `path` applied on top of s (its own `base` is an error).
bool applyLayer(const std::string& path, Scenario& s, std::string* error) {
  std::string text, dir;
  if (!readText(path, text, dir, error)) return false;
  Ctx c{path, error};
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    if (error) *error = path + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax: " + e.msg;
    return false;
  }
  if (!root.IsMap()) {
    if (error) *error = path + ":1: a scenario layer must be a YAML map";
    return false;
  }
  if (!io::checkDuplicateKeys(root, path, error)) return false;
  if (root["base"].IsDefined())
    return c.fail(root["base"], "base", "a layer after the first file of a base list cannot have a base of its own");
  const std::string file = s.file;
  if (!applyKeys(root, c, dir, s, true)) return false;
  s.file = file;  // the scenario is still named after the file that lists the layers
  return true;
}
}  // namespace

bool parseScenario(const std::string& text, const std::string& file, const std::string& dir, Scenario& out,
                   std::string* error) {
  return parseScenarioAt(text, file, dir, out, error, 0);
}

namespace {
bool parseScenarioAt(const std::string& text, const std::string& file, const std::string& dir, Scenario& out,
                     std::string* error, int depth) {
  Ctx c{file, error};
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    if (error) *error = file + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax: " + e.msg;
    return false;
  }
  if (!root.IsMap()) {
    if (error) *error = file + ":1: a scenario must be a YAML map";
    return false;
  }
  if (!io::checkDuplicateKeys(root, file, error)) return false;
  Scenario s;
  bool overlay = false;
  const YAML::Node bn = root["base"];
  if (bn.IsDefined() && !bn.IsNull()) {
    // An overlay: start from the base scenario's values. A list: the first file's scenario, then the
    // keys of each further file (a layer, e.g. a noise preset) in order, then this file's keys.
    std::vector<std::string> bases;
    if (bn.IsScalar()) bases.push_back(bn.Scalar());
    for (std::size_t i = 0; bn.IsSequence() && i < bn.size(); ++i) {
      if (!bn[i].IsScalar()) return c.fail(bn[i], "base[" + std::to_string(i) + "]", "expected a file name");
      bases.push_back(bn[i].Scalar());
    }
    if (bases.empty()) return c.fail(bn, "base", "expected a file name or a non-empty list of file names");
    if (depth >= 4) return c.fail(bn, "base", "overlays nested deeper than 4 levels");
    std::string base_err;
    if (!loadScenarioAt(resolve(dir, bases[0]), s, &base_err, depth + 1))
      return c.fail(bn, "base", "the base scenario does not load: " + base_err);
    for (std::size_t i = 1; i < bases.size(); ++i)
      if (!applyLayer(resolve(dir, bases[i]), s, &base_err))
        return c.fail(bn[i], "base[" + std::to_string(i) + "]", "the layer does not apply: " + base_err);
    overlay = true;
  } else {
    s.start = 0;
    (void)io::parseGpsCalendar("2023-06-01T00:00:00", s.start);
    s.star_catalogue = dir + "/stars_bright.csv";
    s.head_defaults.sigma_cross_rad = 6 * kRadPerArcsec;
    s.head_defaults.sigma_roll_rad = 48 * kRadPerArcsec;
  }
  if (!applyKeys(root, c, dir, s, overlay)) return false;
  out = std::move(s);
  return true;
}

/// Applies the keys of one file (not `base`) to s; an overlay keeps what it does not name.
bool applyKeys(const YAML::Node& root, Ctx& c, const std::string& dir, Scenario& s, bool overlay) {
  const std::string& file = c.file;
  std::string* error = c.error;
  MapReader top(root, "", c);
  top.node("base");
  s.file = file;
  std::string sat(1, s.satellite);
  top.str("satellite", sat);
  if (sat.size() != 1 || sat[0] < 'A' || sat[0] > 'Z')
    c.fail(root["satellite"], "satellite", "expected one letter (C, D for GRACE-FO)");
  s.satellite = sat.empty() ? 'C' : sat[0];
  if (top.has("start")) {
    std::string start;
    top.str("start", start);
    if (!io::parseGpsCalendar(start, s.start))
      c.fail(root["start"], "start", "expected a GPS calendar time YYYY-MM-DDTHH:MM:SS");
  } else {
    top.node("start");
  }
  top.num("duration_s", s.duration_s, 1, 366 * 86400.0);
  if (top.has("stars")) {
    std::string stars;
    top.str("stars", stars);
    s.star_catalogue = (!stars.empty() && stars[0] == '/') ? stars : dir + "/" + stars;
  } else {
    top.node("stars");
  }
  top.num("mounting_error_sigma_arcsec", s.mounting_error_sigma_rad, 0, 3600, kRadPerArcsec);

  {  // orbit
    MapReader r(top.node("orbit"), "orbit", c);
    std::string type = s.orbit.type == OrbitConfig::Type::Gnv1b ? "gnv1b" : "circular";
    r.str("type", type);
    if (type == "circular") s.orbit.type = OrbitConfig::Type::Circular;
    else if (type == "gnv1b") s.orbit.type = OrbitConfig::Type::Gnv1b;
    else c.fail(root["orbit"]["type"], "orbit.type", "expected 'circular' or 'gnv1b', got '" + type + "'");
    r.num("altitude_km", s.orbit.altitude_m, 150, 5000, 1e3);
    r.num("inclination_deg", s.orbit.inclination_rad, 0, 180, kRadPerDeg);
    r.num("raan_deg", s.orbit.raan_rad, -360, 360, kRadPerDeg);
    r.num("arg_latitude_deg", s.orbit.arg_lat0_rad, -360, 360, kRadPerDeg);
    r.boolean("j2_nodal_precession", s.orbit.j2_nodal_precession);
    std::string gnv;
    r.str("gnv1b_file", gnv);
    if (!gnv.empty()) s.orbit.gnv1b_file = gnv[0] == '/' ? gnv : dir + "/" + gnv;
    if (s.orbit.type == OrbitConfig::Type::Gnv1b && s.orbit.gnv1b_file.empty())
      c.fail(root["orbit"], "orbit.gnv1b_file", "required when orbit.type is gnv1b");
    r.finish();
  }
  {  // attitude
    auto& a = s.attitude;
    MapReader r(top.node("attitude"), "attitude", c);
    r.num("step_s", a.step_s, 0.001, 1.0);
    double sign = a.along_track_sign;
    r.num("along_track_sign", sign, -1, 1);
    if (sign != 1 && sign != -1) c.fail(root["attitude"]["along_track_sign"], "attitude.along_track_sign", "must be 1 or -1");
    a.along_track_sign = sign > 0 ? 1 : -1;
    r.num("pitch_offset_deg", a.pitch_offset_rad, -90, 90, kRadPerDeg);
    r.vec3("inertia_kg_m2", a.inertia_kg_m2, 1e-3, 1e6);
    r.vec3("deadband_arcsec", a.deadband_rad, 0, 36000, kRadPerArcsec);
    r.vec3("target_rate_rad_s", a.target_rate_rad_s, 0, 1e-2);
    r.vec3("thruster_torque_Nm", a.thruster_torque_Nm, 0, 10);
    r.num("min_on_ms", a.min_on_s, 0, 1000, 1e-3);
    r.num("max_on_ms", a.max_on_s, 0, 1000, 1e-3);
    if (a.max_on_s > a.step_s + 1e-12 || a.min_on_s > a.max_on_s)
      c.fail(root["attitude"], "attitude.max_on_ms", "need min_on_ms <= max_on_ms <= step_s");
    r.num("mtq_kp_s2", a.mtq_kp_s2, 0, 1);
    r.num("mtq_kd_s", a.mtq_kd_s, 0, 10);
    r.vec3("mtq_max_torque_Nm", a.mtq_max_torque_Nm, 0, 1);
    r.vec3("mtq_background_torque_Nm", a.mtq_background_torque_Nm, 0, 1);
    r.vec3("disturbance_torque_Nm", a.disturbance_torque_Nm, 0, 1);
    r.vec3("initial_deviation_arcsec", a.initial_deviation_rad, -36000, 36000, kRadPerArcsec);
    r.vec3("initial_rate_rad_s", a.initial_rate_rad_s, -1e-2, 1e-2);
    const YAML::Node man = r.node("manoeuvres");
    if (man.IsDefined() && !man.IsNull()) {
      if (!man.IsSequence()) c.fail(man, "attitude.manoeuvres", "expected a list");
      a.manoeuvres.clear();  // an overlay's list replaces the base's
      for (std::size_t i = 0; c.ok && man.IsSequence() && i < man.size(); ++i) {
        Manoeuvre m;
        MapReader mr(man[i], "attitude.manoeuvres[" + std::to_string(i) + "]", c);
        mr.vec3("amplitude_deg", m.amplitude_rad, -30, 30, kRadPerDeg);
        mr.num("period_s", m.period_s, 1, 1e5);
        mr.num("start_s", m.start_s, 0, 1e8);
        mr.num("duration_s", m.duration_s, 0, 1e7);
        mr.finish();
        if (m.duration_s < m.period_s) c.fail(man[i], "attitude.manoeuvres[" + std::to_string(i) + "].duration_s", "shorter than one period");
        a.manoeuvres.push_back(m);
      }
    }
    r.finish();
  }
  {  // heads
    model::HeadConfig& def = s.head_defaults;
    if (top.has("head_defaults")) {
      if (overlay && !top.has("heads"))
        c.fail(root["head_defaults"], "head_defaults", "an overlay that changes head_defaults must list its heads too");
      MapReader r(top.node("head_defaults"), "head_defaults", c);
      readHead(r, def);
      r.finish();
    } else {
      top.node("head_defaults");
    }
    const YAML::Node hs = top.node("heads");
    if (overlay && !hs.IsDefined()) {
      // the base's heads stay
    } else if (!hs.IsSequence() || hs.size() == 0) {
      c.fail(hs.IsDefined() ? hs : root, "heads", "expected a non-empty list of heads");
    } else {
      std::set<int> ids;
      s.heads.clear();  // an overlay's list replaces the base's
      for (std::size_t i = 0; c.ok && i < hs.size(); ++i) {
        model::HeadConfig h = def;
        const std::string pre = "heads[" + std::to_string(i) + "]";
        MapReader r(hs[i], pre, c);
        std::int64_t id = static_cast<std::int64_t>(i) + 1;
        r.integer("id", id, 1, 9);
        h.id = static_cast<int>(id);
        if (!ids.insert(h.id).second) c.fail(hs[i]["id"], pre + ".id", "duplicate head id");
        readHead(r, h);
        r.finish();
        if (h.boresight_Si.norm() < 0.5) c.fail(hs[i], pre + ".boresight", "must be a unit vector");
        h.boresight_Si.normalize();
        s.heads.push_back(h);
      }
    }
  }
  {  // head_overrides: keys of existing heads changed in place (a layer's way to set per-head values
     // without replacing the heads, their mountings included)
    const YAML::Node ho = top.node("head_overrides");
    if (ho.IsDefined() && !ho.IsNull()) {
      if (!ho.IsSequence()) c.fail(ho, "head_overrides", "expected a list of {id, keys of a head}");
      for (std::size_t i = 0; c.ok && ho.IsSequence() && i < ho.size(); ++i) {
        const std::string pre = "head_overrides[" + std::to_string(i) + "]";
        MapReader r(ho[i], pre, c);
        if (!r.has("id")) {
          c.fail(ho[i], pre + ".id", "required (the head to change)");
          break;
        }
        std::int64_t id = 0;
        r.integer("id", id, 1, 9);
        model::HeadConfig* h = nullptr;
        for (auto& x : s.heads)
          if (x.id == id) h = &x;
        if (c.ok && !h) {
          c.fail(ho[i]["id"], pre + ".id", "no head " + std::to_string(id) + " in the scenario");
          break;
        }
        if (!c.ok) break;
        readHead(r, *h);
        r.finish();
        if (h->boresight_Si.norm() < 0.5) c.fail(ho[i], pre + ".boresight", "must be a unit vector");
        h->boresight_Si.normalize();
      }
    }
  }
  {  // accelerometer
    auto& a = s.acc;
    MapReader r(top.node("accelerometer"), "accelerometer", c);
    r.num("rate_hz", a.rate_hz, 0.1, 1000);
    std::int64_t off = a.tag_offset_us;
    r.integer("time_tag_offset_us", off, 0, 999999);
    a.tag_offset_us = off;
    r.num("time_tag_jitter_us", a.tag_jitter_us, 0, 1000);
    r.num("time_tag_drift_ppm", a.tag_drift_ppm, -1000, 1000);
    if (r.has("C_B_A")) {  // the one accelerometer rotation of every configuration file: A -> B
      double m[9];
      const YAML::Node x = r.node("C_B_A");
      bool ok = x.IsSequence() && x.size() == 3;
      for (std::size_t i = 0; ok && i < 3; ++i) {
        ok = x[i].IsSequence() && x[i].size() == 3;
        for (std::size_t j = 0; ok && j < 3; ++j) ok = toDouble(x[i][j], m[i * 3 + j]);
      }
      Mat3 C;
      if (ok) C << m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8];
      if (!ok || (C * C.transpose() - Mat3::Identity()).norm() > 1e-6 || C.determinant() < 0)
        c.fail(x, "accelerometer.C_B_A", "expected a 3x3 proper rotation matrix (rows)");
      else a.C_A_B = C.transpose();
    } else {
      r.node("C_B_A");
    }
    r.vec3("white_noise_rad_s2", a.white_rad_s2, 0, 1);
    r.vec3("lowfreq_noise_rad_s2", a.lowfreq_rad_s2, 0, 1);
    r.num("lowfreq_tau_s", a.lowfreq_tau_s, 1, 1e7);
    r.vec3("bias_rad_s2", a.bias_rad_s2, -1, 1);
    r.vec3("lin_bias_m_s2", a.lin_bias_m_s2, -1, 1);
    r.vec3("lin_white_noise_m_s2", a.lin_white_m_s2, 0, 1);
    r.finish();
  }
  {  // output
    MapReader r(top.node("output"), "output", c);
    r.boolean("lcm_log", s.output.lcm_log);
    r.num("gnv1b_interval_s", s.output.gnv1b_interval_s, 1, 3600);
    if (s.output.gnv1b_interval_s != std::floor(s.output.gnv1b_interval_s))
      c.fail(root["output"]["gnv1b_interval_s"], "output.gnv1b_interval_s", "whole seconds only");
    r.num("star_vectors_interval_s", s.output.star_vectors_interval_s, 0, 86400);
    r.str("version", s.output.version);
    r.finish();
  }
  // effects: `effects` replaces the base's list; `add_effects` appends to it (a preset's noise on top
  // of whatever the scenario injects). Origins of added specs name their file.
  const auto slash = file.find_last_of('/');
  const std::string base_name = slash == std::string::npos ? file : file.substr(slash + 1);
  for (const char* list_key : {"effects", "add_effects"}) {
    const bool add = std::string(list_key) == "add_effects";
    const YAML::Node es = top.node(list_key);
    if (es.IsDefined() && !es.IsNull()) {
      if (!es.IsSequence()) c.fail(es, list_key, "expected a list of effects");
      if (!add) s.effects.clear();  // an overlay's list replaces the base's
      for (std::size_t i = 0; c.ok && es.IsSequence() && i < es.size(); ++i) {
        const std::string pre =
            add ? base_name + ": add_effects[" + std::to_string(i) + "]" : "effects[" + std::to_string(i) + "]";
        if (!es[i].IsMap() || !es[i]["name"].IsDefined()) {
          c.fail(es[i], pre, "expected a map with 'name' and the effect's parameters");
          break;
        }
        std::vector<std::pair<std::string, std::string>> kv;
        for (const auto& p : es[i]) {
          if (p.first.Scalar() == "name") continue;
          if (!p.second.IsScalar()) {
            c.fail(p.second, pre + "." + p.first.Scalar(), "expected a scalar");
            break;
          }
          kv.emplace_back(p.first.Scalar(), p.second.Scalar());
        }
        model::EffectSpec spec;
        std::string err;
        if (c.ok && !model::makeEffect(es[i]["name"].Scalar(), kv, pre, spec, &err)) {
          if (error) *error = file + ":" + std::to_string(es[i].Mark().line + 1) + ": " + err;
          c.ok = false;
        }
        if (c.ok) s.effects.push_back(spec);
      }
    }
  }
  top.finish();
  if (c.ok) {
    for (const auto& e : s.effects) {
      if (e.sensor == "all" || e.sensor == "acc") continue;
      bool found = false;
      for (const auto& h : s.heads) found |= std::to_string(h.id) == e.sensor;
      if (!found) {
        if (error) *error = file + ": " + e.origin + ": effect " + e.name + ": key 'sensor': no head " + e.sensor;
        return false;
      }
    }
  }
  return c.ok;
}

}  // namespace

bool addEffectArgs(Scenario& sc, const std::vector<std::string>& args, std::string* error) {
  for (const auto& a : args) {
    model::EffectSpec e;
    if (!model::parseEffectArg(a, e, error)) return false;
    if (e.sensor != "all" && e.sensor != "acc") {
      bool found = false;
      for (const auto& h : sc.heads) found |= std::to_string(h.id) == e.sensor;
      if (!found) {
        if (error) *error = "--effect " + e.name + ": key 'sensor': the scenario has no head " + e.sensor;
        return false;
      }
    }
    sc.effects.push_back(e);
  }
  return true;
}

bool loadScenario(const std::string& path, Scenario& out, std::string* error) {
  return loadScenarioAt(path, out, error, 0);
}

namespace {
bool readText(const std::string& path, std::string& text, std::string& dir, std::string* error) {
  if (!io::readBounded(path, io::kMaxConfigBytes, "scenario file", text, error)) return false;
  const auto slash = path.find_last_of('/');
  dir = slash == std::string::npos ? "." : path.substr(0, slash);
  return true;
}

bool loadScenarioAt(const std::string& path, Scenario& out, std::string* error, int depth) {
  std::string text, dir;
  if (!readText(path, text, dir, error)) return false;
  return parseScenarioAt(text, path, dir, out, error, depth);
}
}  // namespace

}  // namespace boresight::sim

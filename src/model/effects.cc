// The effect catalogue: names, parameters, validation and evaluation.
#include <boresight/model/effects.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace boresight::model {
namespace {

constexpr double kDay = 86400.0;

std::vector<EffectInfo> buildCatalogue() {
  using P = EffectParamInfo;
  std::vector<EffectInfo> c;
  c.push_back({EffectKind::RelativeMisalignment, "relative_misalignment", EffectTarget::Head,
               "constant extra rotation of a head relative to its (true) mounting",
               {P{"x_arcsec", "arcsec", 0, false, "rotation about head x"},
                P{"y_arcsec", "arcsec", 0, false, "rotation about head y"},
                P{"z_arcsec", "arcsec", 0, false, "rotation about head z"}}});
  c.push_back({EffectKind::AnisotropicNoise, "anisotropic_noise", EffectTarget::Head,
               "white attitude noise about the boresight set to about_arcsec (cross-boresight unchanged)",
               {P{"about_arcsec", "arcsec", 0, true, "1-sigma noise about the boresight, per sample"}}});
  c.push_back({EffectKind::ThermalPeriodic, "thermal_periodic", EffectTarget::Head,
               "rotation at harmonic n of the argument of latitude u: amp * cos(n u + phase), amplitude "
               "times 1 + beta_gain (cos(beta) - cos(beta_ref))",
               {P{"harmonic", "cycles/rev", 1, false, "n >= 1"},
                P{"x_arcsec", "arcsec", 0, false, "amplitude about head x"},
                P{"y_arcsec", "arcsec", 0, false, "amplitude about head y"},
                P{"z_arcsec", "arcsec", 0, false, "amplitude about head z"},
                P{"phase_deg", "deg", 0, false, "phase at u = 0"},
                P{"beta_gain", "1", 0, false, "beta-angle modulation gain"},
                P{"beta_ref_deg", "deg", 0, false, "beta angle of unit amplitude"}}});
  c.push_back({EffectKind::Drift, "drift", EffectTarget::Head, "linear rotation with time from start_s",
               {P{"x_arcsec_per_day", "arcsec/day", 0, false, ""}, P{"y_arcsec_per_day", "arcsec/day", 0, false, ""},
                P{"z_arcsec_per_day", "arcsec/day", 0, false, ""},
                P{"start_s", "s since start", 0, false, "drift begins"}}});
  c.push_back({EffectKind::Step, "step", EffectTarget::Head, "sudden rotation at at_s (an event)",
               {P{"x_arcsec", "arcsec", 0, false, ""}, P{"y_arcsec", "arcsec", 0, false, ""},
                P{"z_arcsec", "arcsec", 0, false, ""}, P{"at_s", "s since start", 0, true, "time of the step"}}});
  c.push_back({EffectKind::TimeOffset, "time_offset", EffectTarget::Any,
               "time tags of the sensor run ahead of the truth: t_tag = t_true + offset; 'all' = every head",
               {P{"offset_ms", "ms", 0, true, "|offset| <= 2000 ms"}}});
  c.push_back({EffectKind::AccBias, "acc_bias", EffectTarget::Acc, "constant angular-acceleration bias, frame A",
               {P{"x", "rad/s^2", 0, false, ""}, P{"y", "rad/s^2", 0, false, ""}, P{"z", "rad/s^2", 0, false, ""}}});
  c.push_back({EffectKind::AccScale, "acc_scale", EffectTarget::Acc, "scale error per A axis: a_meas = (1 + s) a",
               {P{"x", "1", 0, false, ""}, P{"y", "1", 0, false, ""}, P{"z", "1", 0, false, ""}}});
  c.push_back({EffectKind::AccMisalignment, "acc_misalignment", EffectTarget::Acc,
               "small rotation of the accelerometer axes: a_A = R(Exp(m)) C_A_B a_B",
               {P{"x_arcsec", "arcsec", 0, false, ""}, P{"y_arcsec", "arcsec", 0, false, ""},
                P{"z_arcsec", "arcsec", 0, false, ""}}});
  c.push_back({EffectKind::Aberration, "aberration", EffectTarget::Head,
               "uncorrected stellar aberration (about 20.5\" annual, 5.2\" orbital)",
               {P{"annual", "0/1", 1, false, "Earth's motion about the Sun"},
                P{"orbital", "0/1", 1, false, "the satellite's motion about the Earth"}}});
  c.push_back({EffectKind::Outliers, "outliers", EffectTarget::Head, "isolated wrong attitudes",
               {P{"rate", "1/sample", 0, true, "probability per sample, 0..1"},
                P{"arcsec", "arcsec", 300, false, "size of the wrong rotation (random axis)"}}});
  c.push_back({EffectKind::SignFlips, "sign_flips", EffectTarget::Head,
               "quaternion delivered as -q (same attitude, discontinuous components)",
               {P{"rate", "1/sample", 0, true, "probability per sample, 0..1"}}});
  c.push_back({EffectKind::Gaps, "gaps", EffectTarget::Any,
               "missing samples: random (per_day, mean_s) and/or one explicit gap (at_s, duration_s)",
               {P{"per_day", "1/day", 0, false, "expected number of random gaps per day"},
                P{"mean_s", "s", 60, false, "mean random gap length (exponential)"},
                P{"at_s", "s since start", 0, false, "explicit gap start"},
                P{"duration_s", "s", 0, false, "explicit gap length (0: none)"}}});
  c.push_back({EffectKind::HeadDropout, "head_dropout", EffectTarget::Head, "a head delivers nothing for a while",
               {P{"at_s", "s since start", 0, true, ""}, P{"duration_s", "s", 0, true, ""}}});
  // Appended (the order above is stable; the audit indexes by name).
  c.push_back({EffectKind::CrossNoise, "cross_noise", EffectTarget::Head,
               "white attitude noise per cross-boresight axis set to cross_arcsec (about-boresight unchanged)",
               {P{"cross_arcsec", "arcsec", 0, true, "1-sigma noise per cross-boresight axis, per sample"}}});
  c.push_back({EffectKind::ClockDrift, "clock_drift", EffectTarget::Any,
               "tag clock rate error: t_tag = t_true + offset + rate_ppm 1e-6 (t_true - start_s); 'all' = every head",
               {P{"rate_ppm", "ppm", 0, true, "|rate| <= 1000 ppm"},
                P{"offset_ms", "ms", 0, false, "clock error at start_s, |offset| <= 2000 ms"},
                P{"start_s", "s since start", 0, false, "reference epoch of the offset"}}});
  // Appended: coloured noise, field-of-view error, thermal wander, accelerometer coloured noise and bias
  // wander. Forms of a coloured term: Gauss-Markov (tau_s > 0) or power law (f_lo_hz, f_hi_hz, alpha).
  const auto form = [](std::vector<P> levels) {
    levels.push_back(P{"tau_s", "s", 0, false, "Gauss-Markov correlation time (> 0: this form)"});
    levels.push_back(P{"alpha", "1", 1, false, "power law: PSD ~ f^-alpha inside [f_lo_hz, f_hi_hz], 0 <= alpha < 2"});
    levels.push_back(P{"f_lo_hz", "Hz", 0, false, "power law: lower corner (> 0 with f_hi_hz: this form)"});
    levels.push_back(P{"f_hi_hz", "Hz", 0, false, "power law: upper corner"});
    return levels;
  };
  c.push_back({EffectKind::ColouredNoise, "coloured_noise", EffectTarget::Head,
               "coloured attitude measurement error of a head: stationary 1-sigma cross_arcsec per cross-boresight "
               "axis (each its own process) and about_arcsec about the boresight, Gauss-Markov or power law (noise.h); "
               "each spec adds an independent term",
               form({P{"cross_arcsec", "arcsec", 0, false, "stationary 1-sigma per cross-boresight axis"},
                     P{"about_arcsec", "arcsec", 0, false, "stationary 1-sigma about the boresight"}})});
  c.push_back({EffectKind::FovError, "fov_error", EffectTarget::Head,
               "field-of-view error: every tracked star displaced by a smooth random field of its focal-plane "
               "position (2-D Legendre terms of degree 1..order, coefficients drawn per head from the seed); the "
               "attitude error is the least-squares rotation of the displacements of the stars in the FOV",
               {P{"arcsec", "arcsec", 0, true, "RMS star displacement per focal-plane axis over the square detector"},
                P{"order", "1", 3, false, "highest total degree of the field, 1..6"}}});
  c.push_back({EffectKind::ThermalWander, "thermal_wander", EffectTarget::Head,
               "random thermal rotation of a head's mounting (moves its boresight and star vectors): stationary "
               "1-sigma cross_arcsec per cross-boresight axis and about_arcsec about the boresight, Gauss-Markov or "
               "power law (noise.h); each spec adds an independent term",
               form({P{"cross_arcsec", "arcsec", 0, false, "stationary 1-sigma per cross-boresight axis"},
                     P{"about_arcsec", "arcsec", 0, false, "stationary 1-sigma about the boresight"}})});
  c.push_back({EffectKind::AccColouredNoise, "acc_coloured_noise", EffectTarget::Acc,
               "coloured angular-acceleration noise per A axis (stationary 1-sigma x, y, z), Gauss-Markov or power "
               "law (noise.h), on top of the configured white and Gauss-Markov noise; each spec adds a term",
               form({P{"x", "rad/s^2", 0, false, "stationary 1-sigma, A x"}, P{"y", "rad/s^2", 0, false, "A y"},
                     P{"z", "rad/s^2", 0, false, "A z"}})});
  c.push_back({EffectKind::AccBiasWander, "acc_bias_wander", EffectTarget::Acc,
               "slowly varying angular-acceleration bias per A axis: a Gauss-Markov process of stationary 1-sigma "
               "x, y, z and correlation time tau_s (over spans << tau_s a random walk of density sigma sqrt(2/tau_s))",
               {P{"x", "rad/s^2", 0, false, "stationary 1-sigma, A x"}, P{"y", "rad/s^2", 0, false, "A y"},
                P{"z", "rad/s^2", 0, false, "A z"},
                P{"tau_s", "s", 864000, false, "correlation time (default 10 days)"}}});
  return c;
}

bool parseDouble(const std::string& s, double& v) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  v = std::strtod(s.c_str(), &end);
  return errno == 0 && end == s.c_str() + s.size() && std::isfinite(v);
}

bool fail(std::string* error, const std::string& origin, std::string_view name, const std::string& key,
          const std::string& reason) {
  if (error) {
    *error = origin + ": effect " + std::string(name);
    if (!key.empty()) *error += ": key '" + key + "'";
    *error += ": " + reason;
  }
  return false;
}

Vec3 arcsecVec(const EffectSpec& s, const char* x, const char* y, const char* z) {
  return Vec3(s.get(x), s.get(y), s.get(z)) * kRadPerArcsec;
}

void addGaps(const EffectSpec& s, std::vector<RandomGaps>& rg, std::vector<Interval>& gaps) {
  if (s.get("per_day") > 0) rg.push_back({s.get("per_day") / kDay, s.get("mean_s")});
  if (s.get("duration_s") > 0) gaps.push_back({s.get("at_s"), s.get("at_s") + s.get("duration_s")});
}

/// Independent white sources: variances add. One source gives its sigma exactly.
void addSigma(double& sigma, double add) { sigma = sigma < 0 ? add : std::hypot(sigma, add); }

ClockDriftTerm clockTerm(const EffectSpec& s) {
  return {s.get("offset_ms") * 1e-3, s.get("rate_ppm"), s.get("start_s")};
}

/// One more term of an axis model (levels of 0 add nothing).
void addTerm(NoiseModel& m, const EffectSpec& s, double sigma) {
  if (sigma > 0) m.add(effectNoiseTerm(s, sigma));
}

}  // namespace

NoiseTerm effectNoiseTerm(const EffectSpec& s, double sigma) {
  if (s.get("tau_s") > 0) return NoiseTerm::gaussMarkov(sigma, s.get("tau_s"));
  return NoiseTerm::powerLaw(sigma, s.get("alpha"), s.get("f_lo_hz"), s.get("f_hi_hz"));
}

const std::vector<EffectInfo>& effectCatalogue() {
  static const std::vector<EffectInfo> c = buildCatalogue();
  return c;
}

const EffectInfo* findEffect(std::string_view name) {
  for (const auto& e : effectCatalogue())
    if (name == e.name) return &e;
  return nullptr;
}

const char* effectName(EffectKind k) {
  for (const auto& e : effectCatalogue())
    if (e.kind == k) return e.name;
  return "?";
}

double EffectSpec::get(const std::string& key) const {
  auto it = values.find(key);
  return it == values.end() ? 0.0 : it->second;
}

bool EffectSpec::appliesToHead(int head_id) const {
  return sensor == "all" || sensor == std::to_string(head_id);
}

bool makeEffect(std::string_view name, const std::vector<std::pair<std::string, std::string>>& kv,
                const std::string& origin, EffectSpec& out, std::string* error) {
  const EffectInfo* info = findEffect(name);
  if (!info) {
    std::string known;
    for (const auto& e : effectCatalogue()) known += std::string(known.empty() ? "" : ", ") + e.name;
    return fail(error, origin, name, "", "unknown effect (known: " + known + ")");
  }
  EffectSpec s;
  s.kind = info->kind;
  s.name = info->name;
  s.origin = origin;
  s.sensor = info->target == EffectTarget::Acc ? "acc" : "all";
  for (const auto& p : info->params) s.values[p.key] = p.def;
  std::map<std::string, bool> seen;
  for (const auto& [k, v] : kv) {
    if (seen[k]) return fail(error, origin, name, k, "given twice");
    seen[k] = true;
    if (k == "sensor" || k == "head") {
      bool is_head = !v.empty() && v.find_first_not_of("0123456789") == std::string::npos && std::atoi(v.c_str()) >= 1;
      if (v == "acc") {
        if (info->target == EffectTarget::Head) return fail(error, origin, name, k, "applies to heads, not 'acc'");
      } else if (v == "all") {
      } else if (is_head) {
        if (info->target == EffectTarget::Acc) return fail(error, origin, name, k, "applies to the accelerometer only");
      } else {
        return fail(error, origin, name, k, "'" + v + "' is not a head id (1, 2, ...), 'all' or 'acc'");
      }
      s.sensor = v;
      continue;
    }
    bool known = false;
    for (const auto& p : info->params) known |= (k == p.key);
    if (!known) {
      std::string keys = "sensor";
      for (const auto& p : info->params) keys += std::string(", ") + p.key;
      return fail(error, origin, name, k, "unknown parameter (parameters: " + keys + ")");
    }
    double d;
    if (!parseDouble(v, d)) return fail(error, origin, name, k, "'" + v + "' is not a finite number");
    s.values[k] = d;
  }
  for (const auto& p : info->params)
    if (p.required && !seen[p.key]) return fail(error, origin, name, p.key, std::string("required (") + p.doc + ")");
  // Ranges.
  auto need = [&](const char* k, bool ok, const char* why) { return ok || fail(error, origin, name, k, why); };
  switch (s.kind) {
    case EffectKind::AnisotropicNoise:
      if (!need("about_arcsec", s.get("about_arcsec") >= 0, "must be >= 0")) return false;
      break;
    case EffectKind::ThermalPeriodic: {
      const double n = s.get("harmonic");
      if (!need("harmonic", n >= 1 && n <= 50 && n == std::floor(n), "must be an integer 1..50")) return false;
      break;
    }
    case EffectKind::TimeOffset:
      if (!need("offset_ms", std::abs(s.get("offset_ms")) <= 2000, "must be within +-2000 ms")) return false;
      break;
    case EffectKind::ClockDrift:
      if (!need("offset_ms", std::abs(s.get("offset_ms")) <= 2000, "must be within +-2000 ms") ||
          !need("rate_ppm", std::abs(s.get("rate_ppm")) <= 1000, "must be within +-1000 ppm"))
        return false;
      break;
    case EffectKind::CrossNoise:
      if (!need("cross_arcsec", s.get("cross_arcsec") >= 0, "must be >= 0")) return false;
      break;
    case EffectKind::Outliers:
    case EffectKind::SignFlips:
      if (!need("rate", s.get("rate") >= 0 && s.get("rate") <= 1, "must be a probability 0..1")) return false;
      break;
    case EffectKind::Gaps:
      if (!need("per_day", s.get("per_day") >= 0, "must be >= 0") ||
          !need("mean_s", s.get("mean_s") > 0, "must be > 0") ||
          !need("duration_s", s.get("duration_s") >= 0, "must be >= 0"))
        return false;
      break;
    case EffectKind::HeadDropout:
      if (!need("duration_s", s.get("duration_s") > 0, "must be > 0")) return false;
      break;
    case EffectKind::AccScale:
      for (const char* k : {"x", "y", "z"})
        if (!need(k, std::abs(s.get(k)) < 0.5, "a scale error must be within +-0.5")) return false;
      break;
    case EffectKind::ColouredNoise:
    case EffectKind::ThermalWander:
    case EffectKind::AccColouredNoise: {
      const bool acc = s.kind == EffectKind::AccColouredNoise;
      const std::vector<const char*> levels = acc ? std::vector<const char*>{"x", "y", "z"}
                                                  : std::vector<const char*>{"cross_arcsec", "about_arcsec"};
      for (const char* k : levels)
        if (!need(k, s.get(k) >= 0, "must be >= 0")) return false;
      // The form follows from the values (truth.yaml gives every key back, defaults included).
      const bool gm = s.get("tau_s") != 0, pl = s.get("f_lo_hz") != 0 || s.get("f_hi_hz") != 0;
      if (gm && pl) return fail(error, origin, name, "tau_s", "give tau_s (Gauss-Markov) or f_lo_hz and f_hi_hz (power law), not both");
      if (!gm && !pl) return fail(error, origin, name, "tau_s", "required: tau_s (Gauss-Markov) or f_lo_hz and f_hi_hz (power law)");
      NoiseModel m;
      m.add(effectNoiseTerm(s, 1.0));
      const std::string why = m.validate();
      if (!why.empty()) return fail(error, origin, name, gm ? "tau_s" : "f_lo_hz", why);
      break;
    }
    case EffectKind::AccBiasWander:
      for (const char* k : {"x", "y", "z"})
        if (!need(k, s.get(k) >= 0, "must be >= 0")) return false;
      if (!need("tau_s", s.get("tau_s") > 0, "must be > 0")) return false;
      break;
    case EffectKind::FovError: {
      const double o = s.get("order");
      if (!need("arcsec", s.get("arcsec") >= 0, "must be >= 0") ||
          !need("order", o >= 1 && o <= 6 && o == std::floor(o), "must be an integer 1..6"))
        return false;
      break;
    }
    default:
      break;
  }
  out = std::move(s);
  return true;
}

bool parseEffectArg(std::string_view arg, EffectSpec& out, std::string* error) {
  const auto colon = arg.find(':');
  const std::string name(arg.substr(0, colon));
  std::vector<std::pair<std::string, std::string>> kv;
  if (colon != std::string_view::npos) {
    std::string_view rest = arg.substr(colon + 1);
    while (!rest.empty()) {
      const auto comma = rest.find(',');
      std::string_view item = rest.substr(0, comma);
      const auto eq = item.find('=');
      if (eq == std::string_view::npos || eq == 0) {
        if (error) *error = "--effect " + name + ": '" + std::string(item) + "' is not key=value";
        return false;
      }
      kv.emplace_back(std::string(item.substr(0, eq)), std::string(item.substr(eq + 1)));
      if (comma == std::string_view::npos) break;
      rest = rest.substr(comma + 1);
    }
  }
  return makeEffect(name, kv, "--effect", out, error);
}

std::string effectCatalogueText() {
  std::ostringstream o;
  for (const auto& e : effectCatalogue()) {
    const char* tgt = e.target == EffectTarget::Head ? "heads" : e.target == EffectTarget::Acc ? "acc" : "heads|acc";
    o << "  " << e.name << " [" << tgt << "]: " << e.doc << "\n      sensor="
      << (e.target == EffectTarget::Acc ? "acc" : e.target == EffectTarget::Any ? "1|2|..|all|acc" : "1|2|..|all");
    for (const auto& p : e.params) {
      o << ", " << p.key << "[" << p.unit << "]";
      if (p.required) o << " (required)";
      else if (p.def != 0) o << "=" << p.def;
    }
    o << "\n";
  }
  return o.str();
}

HeadEffects headEffectsFor(const std::vector<EffectSpec>& specs, int head_id) {
  HeadEffects h;
  for (const auto& s : specs) {
    if (!s.appliesToHead(head_id)) continue;
    switch (s.kind) {
      case EffectKind::RelativeMisalignment: h.misalignment_rad += arcsecVec(s, "x_arcsec", "y_arcsec", "z_arcsec"); break;
      case EffectKind::AnisotropicNoise: addSigma(h.about_sigma_rad, s.get("about_arcsec") * kRadPerArcsec); break;
      case EffectKind::CrossNoise: addSigma(h.cross_sigma_rad, s.get("cross_arcsec") * kRadPerArcsec); break;
      case EffectKind::ClockDrift: h.clock_drifts.push_back(clockTerm(s)); break;
      case EffectKind::ThermalPeriodic: {
        ThermalHarmonic t;
        t.n = static_cast<int>(s.get("harmonic"));
        t.amp_rad = arcsecVec(s, "x_arcsec", "y_arcsec", "z_arcsec");
        t.phase_rad = s.get("phase_deg") * kRadPerDeg;
        t.beta_gain = s.get("beta_gain");
        t.beta_ref_rad = s.get("beta_ref_deg") * kRadPerDeg;
        h.thermal.push_back(t);
        break;
      }
      case EffectKind::Drift:
        h.drifts.push_back({arcsecVec(s, "x_arcsec_per_day", "y_arcsec_per_day", "z_arcsec_per_day") / kDay, s.get("start_s")});
        break;
      case EffectKind::Step: h.steps.emplace_back(s.get("at_s"), arcsecVec(s, "x_arcsec", "y_arcsec", "z_arcsec")); break;
      case EffectKind::TimeOffset: h.time_offset_s += s.get("offset_ms") * 1e-3; break;
      case EffectKind::Aberration:
        h.aberration_annual |= s.get("annual") != 0;
        h.aberration_orbital |= s.get("orbital") != 0;
        break;
      case EffectKind::Outliers: h.outliers.push_back({s.get("rate"), s.get("arcsec") * kRadPerArcsec}); break;
      case EffectKind::SignFlips: h.sign_flip_probs.push_back(s.get("rate")); break;
      case EffectKind::Gaps: addGaps(s, h.random_gaps, h.gaps); break;
      case EffectKind::HeadDropout: h.dropouts.push_back({s.get("at_s"), s.get("at_s") + s.get("duration_s")}); break;
      case EffectKind::ColouredNoise:
        addTerm(h.coloured_cross, s, s.get("cross_arcsec") * kRadPerArcsec);
        addTerm(h.coloured_about, s, s.get("about_arcsec") * kRadPerArcsec);
        break;
      case EffectKind::ThermalWander:
        addTerm(h.wander_cross, s, s.get("cross_arcsec") * kRadPerArcsec);
        addTerm(h.wander_about, s, s.get("about_arcsec") * kRadPerArcsec);
        break;
      case EffectKind::FovError:
        if (s.get("arcsec") > 0) h.fov.push_back({static_cast<int>(s.get("order")), s.get("arcsec") * kRadPerArcsec});
        break;
      default: break;  // accelerometer effects
    }
  }
  return h;
}

AccEffects accEffectsFor(const std::vector<EffectSpec>& specs) {
  AccEffects a;
  for (const auto& s : specs) {
    if (!s.appliesToAcc()) continue;
    switch (s.kind) {
      case EffectKind::AccBias: a.bias_rad_s2 += Vec3(s.get("x"), s.get("y"), s.get("z")); break;
      case EffectKind::AccScale: a.scale += Vec3(s.get("x"), s.get("y"), s.get("z")); break;
      case EffectKind::AccMisalignment: a.misalignment_rad += arcsecVec(s, "x_arcsec", "y_arcsec", "z_arcsec"); break;
      case EffectKind::TimeOffset:
        if (s.sensor == "acc") a.time_offset_s += s.get("offset_ms") * 1e-3;
        break;
      case EffectKind::ClockDrift:
        if (s.sensor == "acc") a.clock_drifts.push_back(clockTerm(s));
        break;
      case EffectKind::Gaps: addGaps(s, a.random_gaps, a.gaps); break;
      case EffectKind::AccColouredNoise:
        for (int k = 0; k < 3; ++k) addTerm(a.coloured[static_cast<std::size_t>(k)], s, s.get(k == 0 ? "x" : k == 1 ? "y" : "z"));
        break;
      case EffectKind::AccBiasWander:
        for (int k = 0; k < 3; ++k) {
          const double sigma = s.get(k == 0 ? "x" : k == 1 ? "y" : "z");
          if (sigma > 0) a.bias_wander[static_cast<std::size_t>(k)].add(NoiseTerm::gaussMarkov(sigma, s.get("tau_s")));
        }
        break;
      default: break;
    }
  }
  return a;
}

Vec3 headSystematicRotVec(const HeadEffects& e, const OrbitContext& ctx) {
  Vec3 phi = e.misalignment_rad;
  for (const auto& h : e.thermal) {
    const double m = 1.0 + h.beta_gain * (std::cos(ctx.beta_rad) - std::cos(h.beta_ref_rad));
    phi += h.amp_rad * (m * std::cos(h.n * ctx.arg_lat_rad + h.phase_rad));
  }
  for (const auto& d : e.drifts)
    if (ctx.t_s > d.start_s) phi += d.rate_rad_s * (ctx.t_s - d.start_s);
  if (ctx.t_s > e.drift_start_s && !e.drift_rad_s.isZero()) phi += e.drift_rad_s * (ctx.t_s - e.drift_start_s);
  for (const auto& [at, rot] : e.steps)
    if (ctx.t_s >= at) phi += rot;
  return phi;
}

Vec3 aberrationRotVec(const HeadEffects& e, const Vec3& b_I, const Mat3& C_Si_I, const OrbitContext& ctx) {
  Vec3 v = Vec3::Zero();
  if (e.aberration_annual) v += ctx.v_earth_I;
  if (e.aberration_orbital) v += ctx.v_sat_I;
  if (v.isZero()) return Vec3::Zero();
  return C_Si_I * (b_I.cross(v) / kSpeedOfLight);
}

double tagMinusTrue(double time_offset_s, const std::vector<ClockDriftTerm>& clock, double t_true_s) {
  double d = time_offset_s;
  for (const auto& c : clock) d += c.offset_s + c.rate_ppm * 1e-6 * (t_true_s - c.start_s);
  return d;
}

double trueTimeOfTag(double time_offset_s, const std::vector<ClockDriftTerm>& clock, double t_tag_s) {
  if (clock.empty()) return t_tag_s - time_offset_s;
  // t_tag = t + off + sum r_j (t - s_j)  =>  t (1 + sum r_j) = t_tag - off + sum r_j s_j
  double off = time_offset_s, r = 0, rs = 0;
  for (const auto& c : clock) {
    off += c.offset_s;
    r += c.rate_ppm * 1e-6;
    rs += c.rate_ppm * 1e-6 * c.start_s;
  }
  return (t_tag_s - off + rs) / (1.0 + r);
}

HeadParamLayout headParamLayout(const HeadEffects& e) {
  HeadParamLayout L;
  for (const auto& h : e.thermal) L.harmonics.push_back({h.n, h.beta_gain, h.beta_ref_rad});
  for (const auto& d : e.drifts) L.drift_starts_s.push_back(d.start_s);
  if (!e.drift_rad_s.isZero()) L.drift_starts_s.push_back(e.drift_start_s);
  for (const auto& st : e.steps) L.step_times_s.push_back(st.first);
  return L;
}

std::vector<double> headParams(const HeadEffects& e) {
  std::vector<double> p;
  p.reserve(headParamLayout(e).size());
  auto put = [&](const Vec3& v) {
    for (int k = 0; k < 3; ++k) p.push_back(v[k]);
  };
  put(e.misalignment_rad);
  for (const auto& h : e.thermal) {
    put(h.amp_rad * std::cos(h.phase_rad));
    put(-h.amp_rad * std::sin(h.phase_rad));
  }
  for (const auto& d : e.drifts) put(d.rate_rad_s);
  if (!e.drift_rad_s.isZero()) put(e.drift_rad_s);
  for (const auto& st : e.steps) put(st.second);
  return p;
}

}  // namespace boresight::model

// The audit's extended model as a model overlay: see include/boresight/audit/extension.h.
#include <boresight/audit/extension.h>
#include <boresight/core/rotation.h>
#include <boresight/io/time_format.h>
#include <boresight/model/stats.h>
#include <boresight/report/text.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cstdlib>
#include <cctype>
#include <cmath>
#include <cstdio>

namespace boresight::audit {
namespace {

std::string num(double v, const char* f = "%.3g") { return report::fmt(v, f); }

/// The estimate of a named cause: its entry in the extended model (every named effect re-estimated
/// together), else the test's own.
const EffectTest& estimateOf(const AuditResult& r, const EffectTest& named) {
  // the same candidate: name, sensor, family and its fixed parameters (a harmonic's order, a step's time)
  auto fixedOf = [](const EffectTest& e, const char* key) {
    for (const auto& p : e.params)
      if (p.key == key) return p.value;
    return kNaN;
  };
  auto same = [&](const EffectTest& a, const EffectTest& b) {
    for (const char* key : {"harmonic", "at_s", "start_s"}) {
      const double x = fixedOf(a, key), y = fixedOf(b, key);
      if (std::isfinite(x) != std::isfinite(y) || (std::isfinite(x) && x != y)) return false;
    }
    return true;
  };
  for (const auto& e : r.extended)
    if (e.name == named.name && e.sensor == named.sensor && e.family == named.family && !e.params.empty() && same(e, named)) return e;
  return named;
}

const ParamValue* param(const EffectTest& e, const std::string& key) {
  for (const auto& p : e.params)
    if (p.key == key) return &p;
  return nullptr;
}

/// Three parameters "x<suffix>", "y<suffix>", "z<suffix>" times `scale`: value and sigma (NaN: none).
bool vec3(const EffectTest& e, const std::string& suffix, double scale, model::Uncertain3& out) {
  const char* ax[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    const ParamValue* p = param(e, ax[a] + suffix);
    if (!p || !std::isfinite(p->value)) return false;
    out.value[a] = p->value * scale;
    out.sigma[a] = std::isfinite(p->sigma) ? p->sigma * scale : std::numeric_limits<double>::quiet_NaN();
  }
  return true;
}

std::string label(const EffectTest& e) { return e.name + "[" + e.sensor + "]"; }

/// Adds `add` to an optional term (first order: small terms of one accelerometer compose by addition).
void addTo(std::optional<model::Uncertain3>& term, const model::Uncertain3& add) {
  if (!term) {
    term = add;
    return;
  }
  term->value += add.value;
  term->sigma = add.sigma;  // the new estimate's uncertainty (it was made with the old terms applied)
}

/// The head-noise entry of `id` in the overlay's section (made when missing).
model::HeadNoise& headEntry(model::NoiseSection& s, int id) {
  for (auto& h : s.heads)
    if (h.id == id) return h;
  s.heads.push_back(model::HeadNoise{});
  s.heads.back().id = id;
  return s.heads.back();
}

/// The model of one head axis in use, with its white term set to `white` (rad; < 0: kept) and a
/// Gauss-Markov term (gm_sigma rad, gm_tau s; gm_sigma <= 0: none) appended.
model::AxisNoise axisWith(const model::NoiseModel& in_use, double white, double gm_sigma, double gm_tau) {
  model::AxisNoise a;
  bool white_set = false;
  for (const auto& t : in_use.terms) {
    if (t.kind == model::NoiseKind::White && white >= 0) {
      if (!white_set) a.model.add(model::NoiseTerm::white(white));
      white_set = true;
      continue;
    }
    a.model.add(t);
  }
  if (white >= 0 && !white_set) a.model.add(model::NoiseTerm::white(white));
  if (gm_sigma > 0 && gm_tau > 0) a.model.add(model::NoiseTerm::gaussMarkov(gm_sigma, gm_tau));
  return a;
}

}  // namespace

Extension extensionOverlay(const AuditResult& r, const io::PlatformConfig& pc, const io::OverlayUse& base,
                           const ExtensionContext& ctx) {
  Extension x;
  model::Overlay& o = x.overlay;
  if (!base.file.empty()) o = base.overlay;  // the model the audit ran with, extended
  o.version = model::kOverlayVersion;
  o.written_by = ctx.written_by;
  o.platform = pc.platform;
  o.note = ctx.note;
  model::Validity span;
  span.from = ctx.t0;
  span.to = ctx.t1;
  const core::HeadSetConfig& heads = pc.pipeline.heads;
  auto slotOf = [&](const std::string& sensor) {
    for (int s = 0; s < heads.n_heads; ++s)
      if (std::to_string(heads.head[static_cast<std::size_t>(s)].id) == sensor) return s;
    return -1;
  };
  // Head noise: per slot the white level per kind (cross, about; < 0 none) and the Gauss-Markov levels.
  std::vector<double> white_cross(static_cast<std::size_t>(heads.n_heads), -1), white_about = white_cross,
                                                                                 gm_cross(white_cross.size(), 0),
                                                                                 gm_about(white_cross.size(), 0);
  double gm_tau = 0;
  bool noise_named = false;
  struct HeadHarmonic {
    int slot, n;
    model::Uncertain3 cos_rad, sin_rad;  ///< the head's own mounting rotation, head axes
  };
  std::vector<HeadHarmonic> thermal;
  // Relative misalignments per slot (head axes) as estimated: their datum is the heads without one.
  std::vector<model::Uncertain3> misalignment(static_cast<std::size_t>(heads.n_heads));
  std::vector<bool> named_mis(static_cast<std::size_t>(heads.n_heads), false);

  for (const EffectTest& named : r.named) {
    const EffectTest& e = estimateOf(r, named);
    const std::string what = label(named) + " (" + named.family + ")";
    if (named.name == "relative_misalignment" && named.family == "relative") {
      const int s = slotOf(named.sensor);
      model::Uncertain3 rv;
      if (s < 0 || !vec3(e, "_arcsec", kRadPerArcsec, rv)) {
        x.not_carried.push_back(what + ": no estimate for a configured head");
        continue;
      }
      misalignment[static_cast<std::size_t>(s)] = rv;
      named_mis[static_cast<std::size_t>(s)] = true;
      x.carried.push_back(what + " -> mountings: head " + named.sensor + " rotated by (" + num(rv.value.x() * kArcsecPerRad) + ", " +
                          num(rv.value.y() * kArcsecPerRad) + ", " + num(rv.value.z() * kArcsecPerRad) +
                          ")\" about its axes, before the datum (below)");
    } else if (named.name == "acc_bias" || named.name == "acc_scale" || named.name == "acc_misalignment") {
      model::Uncertain3 v;
      const bool mis = named.name == "acc_misalignment";
      if (!vec3(e, mis ? "_arcsec" : "", mis ? kRadPerArcsec : 1.0, v)) {
        x.not_carried.push_back(what + ": no estimate");
        continue;
      }
      if (!o.accelerometer) o.accelerometer = model::AccelerometerTerms{};
      model::AccelerometerTerms& a = *o.accelerometer;
      addTo(named.name == "acc_bias" ? a.bias_rad_s2 : named.name == "acc_scale" ? a.scale : a.misalignment_rad, v);
      a.valid = span;
      x.carried.push_back(what + " -> accelerometer: " + (named.name == "acc_bias" ? "bias" : named.name == "acc_scale" ? "scale" : "misalignment") +
                          (base.overlay.accelerometer ? " (added to the overlay's)" : ""));
    } else if ((named.name == "cross_noise" || named.name == "anisotropic_noise") && named.family == "noise") {
      const bool cross = named.name == "cross_noise";
      const ParamValue* p = param(e, cross ? "cross_arcsec" : "about_arcsec");
      if (!p || !(p->value > 0)) {
        x.not_carried.push_back(what + ": no level");
        continue;
      }
      for (int s = 0; s < heads.n_heads; ++s)
        if (named.sensor == "all" || slotOf(named.sensor) == s)
          (cross ? white_cross : white_about)[static_cast<std::size_t>(s)] = p->value * kRadPerArcsec;
      noise_named = true;
      x.carried.push_back(what + " -> noise: the white " + (cross ? "cross-boresight" : "about-boresight") + " level " + num(p->value) +
                          "\" of head" + (named.sensor == "all" ? "s all" : " " + named.sensor));
    } else if (named.name == "coloured_noise" && named.family == "relative") {
      const ParamValue* tau = param(e, "tau_s");
      if (!tau || !(tau->value > 0)) {
        x.not_carried.push_back(what + ": no correlation time");
        continue;
      }
      gm_tau = tau->value;
      std::string levels;
      for (int s = 0; s < heads.n_heads; ++s) {
        const std::string id = std::to_string(heads.head[static_cast<std::size_t>(s)].id);
        const ParamValue* c = param(e, "head" + id + "_cross_arcsec");
        const ParamValue* b = param(e, "head" + id + "_about_arcsec");
        gm_cross[static_cast<std::size_t>(s)] = c && c->value > 0 ? c->value * kRadPerArcsec : 0;
        gm_about[static_cast<std::size_t>(s)] = b && b->value > 0 ? b->value * kRadPerArcsec : 0;
        levels += (levels.empty() ? "" : "; ") + std::string("head ") + id + " " + num(c ? c->value : 0) + "\"/" + num(b ? b->value : 0) + "\"";
      }
      noise_named = true;
      x.carried.push_back(what + " -> noise: a Gauss-Markov term of " + num(gm_tau, "%.0f") + " s on every head axis (cross/about: " + levels + ")");
    } else if (named.name == "time_offset" && (named.family == "angular_acceleration" || named.family == "relative")) {
      const ParamValue* p = param(e, "offset_ms");
      if (!p || !std::isfinite(p->value)) {
        x.not_carried.push_back(what + ": no estimate");
        continue;
      }
      model::TimeOffsetEntry t;
      t.sensor = named.sensor == "acc" ? "accelerometer" : "head" + named.sensor;
      t.relative_to = "heads";
      t.offset_s = p->value * 1e-3;
      t.sigma_s = std::isfinite(p->sigma) ? p->sigma * 1e-3 : std::numeric_limits<double>::quiet_NaN();
      t.valid = span;
      o.time_offsets.push_back(t);
      x.carried.push_back(what + " -> time_offsets: " + t.sensor + " against the heads, " + num(p->value) + " ms");
    } else if (named.name == "thermal_periodic" && named.family == "relative") {
      const int s = slotOf(named.sensor);
      const ParamValue* n = param(e, "harmonic");
      model::Uncertain3 cs, sn;
      if (s < 0 || !n || !(n->value >= 1) || !vec3(e, "_cos_arcsec", kRadPerArcsec, cs) || !vec3(e, "_sin_arcsec", kRadPerArcsec, sn)) {
        x.not_carried.push_back(what + ": no cos/sin estimates");
        continue;
      }
      thermal.push_back({s, static_cast<int>(std::lround(n->value)), cs, sn});
      x.carried.push_back(what + " -> thermal: harmonic " + std::to_string(static_cast<int>(std::lround(n->value))) + " of head " +
                          named.sensor + " (as a deformation relative to the datum head)");
    } else if (named.name == "gaps" && named.family == "data") {
      // a process of missing-sample runs: its observed rate becomes the expected one (the data events'
      // null), the other rates as in use
      const ParamValue* p = param(e, "per_day");
      if (!p || !std::isfinite(p->value)) {
        x.not_carried.push_back(what + ": no rate");
        continue;
      }
      if (!o.data_events) o.data_events = pc.events;
      model::DataEventRates& ev = *o.data_events;
      // a longest run that was exceeded becomes the longest seen (no limit stays no limit)
      const ParamValue* lg = param(e, "longest_s");
      const auto raise = [&](double& max_s) {
        if (lg && std::isfinite(max_s) && lg->value > max_s) max_s = lg->value;
      };
      std::string where;
      if (named.sensor == "all") {
        ev.epoch_gaps_per_day = p->value;
        raise(ev.epoch_gap_max_s);
        where = "every head at once";
      } else if (named.sensor == "acc") {
        ev.acc_gaps_per_day = p->value;
        raise(ev.acc_gap_max_s);
        where = "the accelerometer";
      } else {
        raise(ev.head_dropout_max_s);
        const int id = std::atoi(named.sensor.c_str());
        bool found = false;
        for (auto& hr : ev.head_dropouts_by_id)
          if (hr.first == id) hr.second = p->value, found = true;
        if (!found) ev.head_dropouts_by_id.emplace_back(id, p->value);
        where = "head " + named.sensor;
      }
      x.carried.push_back(what + " -> data_events: " + num(p->value) + " missing-sample runs a day expected of " + where);
    } else {
      std::string why;
      if (named.name == "head_dropout")
        why = "one run, an event: one run does not determine a rate (data_events takes one when it is expected)";
      else if (named.name == "step" || named.name == "drift")
        why = "the overlay has no " + named.name + "s (a mounting per validity span would carry a step; not written yet)";
      else if (named.family == "reference")
        why = "a finding against the outside reference (SCA1B), not a property of the instruments";
      else if (named.family == "data")
        why = "an event of the data, not a model term";
      else
        why = "the overlay has no item for it";
      x.not_carried.push_back(what + ": " + why);
    }
  }

  if (std::find(named_mis.begin(), named_mis.end(), true) != named_mis.end()) {
    // Datum: the body frame the heads define together. The fused attitude is (to first order) the
    // information-weighted mean of the heads' attitudes, so rotating the mountings by corrections of
    // zero weighted mean leaves it where it was - and with it what the accelerometer's terms (estimated
    // against the fused attitude with the mountings in use) refer to. Every head gets a mounting.
    Mat3 W_sum = Mat3::Zero();
    Vec3 Wr_sum = Vec3::Zero();
    std::vector<Mat3> C_B_S(static_cast<std::size_t>(heads.n_heads));
    for (int k = 0; k < heads.n_heads; ++k) {
      const auto& h = heads.head[static_cast<std::size_t>(k)];
      C_B_S[static_cast<std::size_t>(k)] = h.q_Si_B.toRotationMatrix().transpose();
      const Vec3 b = h.boresight_Si.normalized();
      const double ic = 1.0 / std::max(h.sigma_cross_rad * h.sigma_cross_rad, 1e-30), ia = 1.0 / std::max(h.sigma_roll_rad * h.sigma_roll_rad, 1e-30);
      const Mat3 W_S = ic * (Mat3::Identity() - b * b.transpose()) + ia * b * b.transpose();
      const Mat3 W_B = C_B_S[static_cast<std::size_t>(k)] * W_S * C_B_S[static_cast<std::size_t>(k)].transpose();
      W_sum += W_B;
      Wr_sum += W_B * (C_B_S[static_cast<std::size_t>(k)] * misalignment[static_cast<std::size_t>(k)].value);
    }
    const Vec3 rho_B = W_sum.ldlt().solve(Wr_sum);
    for (int k = 0; k < heads.n_heads; ++k) {
      const auto ks = static_cast<std::size_t>(k);
      const auto& h = heads.head[ks];
      model::MountingEntry m;
      m.head = h.id;
      const Vec3 r_k = misalignment[ks].value - C_B_S[ks].transpose() * rho_B;
      m.q_Si_B = (core::quatExp(r_k) * h.q_Si_B).normalized();
      m.datum = model::MountingDatum::StarCameras;
      m.epoch = ctx.t0 + (ctx.t1 - ctx.t0) / 2;
      m.sigma_rad = named_mis[ks] ? misalignment[ks].sigma : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      m.valid = span;
      bool replaced = false;
      for (auto& old : o.mountings)
        if (old.head == m.head) old = m, replaced = true;
      if (!replaced) o.mountings.push_back(m);
    }
    x.carried.push_back("datum of the mountings: the body frame the heads define together (information-weighted mean "
                        "correction zero: the fused attitude stays); common rotation removed (" + num(rho_B.x() * kArcsecPerRad) + ", " +
                        num(rho_B.y() * kArcsecPerRad) + ", " + num(rho_B.z() * kArcsecPerRad) + ")\" about the body axes");
  }

  if (!thermal.empty()) {
    // The overlay's form (core/thermal_harmonics.h): per head k the deformation relative to the datum
    // head d in S_d, C_Sd_Sk = Exp(delta_k) C0_dk. A rotation phi of each head's own mounting
    // (C_Si_B = Exp(phi_i) C0_Si_B) gives, to first order, delta_k = phi_d - C0_dk phi_k.
    if (!o.thermal) {
      o.thermal = model::ThermalTerms{};
      o.thermal->datum_head = heads.head[0].id;
    }
    model::ThermalTerms& th = *o.thermal;
    th.valid = span;
    int d = -1;
    for (int s = 0; s < heads.n_heads; ++s)
      if (heads.head[static_cast<std::size_t>(s)].id == th.datum_head) d = s;
    const Mat3 C_Sd_B = heads.head[static_cast<std::size_t>(std::max(d, 0))].q_Si_B.toRotationMatrix();
    auto term = [&](int k, const HeadHarmonic& h, bool cos) -> std::pair<Vec3, Vec3> {  // contribution to head k, value and variance
      const model::Uncertain3& u = cos ? h.cos_rad : h.sin_rad;
      Vec3 var;
      for (int a = 0; a < 3; ++a) var[a] = std::isfinite(u.sigma[a]) ? u.sigma[a] * u.sigma[a] : 0.0;
      if (h.slot == d) return {u.value, var};  // phi_d enters every other head's delta
      if (h.slot != k) return {Vec3::Zero(), Vec3::Zero()};
      const Mat3 C0 = C_Sd_B * heads.head[static_cast<std::size_t>(k)].q_Si_B.toRotationMatrix().transpose();
      return {-C0 * u.value, Vec3((C0 * var.asDiagonal() * C0.transpose()).diagonal())};
    };
    for (int k = 0; k < heads.n_heads && d >= 0; ++k) {
      if (k == d) continue;
      const int id = heads.head[static_cast<std::size_t>(k)].id;
      for (const HeadHarmonic& h : thermal) {
        if (h.slot != d && h.slot != k) continue;
        model::ThermalHeadEntry* entry = nullptr;
        for (auto& he : th.heads)
          if (he.head == id) entry = &he;
        if (!entry) {
          th.heads.push_back(model::ThermalHeadEntry{});
          th.heads.back().head = id;
          th.heads.back().constant_rad.sigma = Vec3::Zero();
          entry = &th.heads.back();
        }
        model::ThermalHarmonicEntry* he = nullptr;
        for (auto& x2 : entry->harmonics)
          if (x2.harmonic == h.n) he = &x2;
        if (!he) {
          entry->harmonics.push_back(model::ThermalHarmonicEntry{});
          entry->harmonics.back().harmonic = h.n;
          entry->harmonics.back().cos_rad.sigma = entry->harmonics.back().sin_rad.sigma = Vec3::Zero();
          he = &entry->harmonics.back();
        }
        for (const bool cos : {true, false}) {
          const auto [v, var] = term(k, h, cos);
          model::Uncertain3& u = cos ? he->cos_rad : he->sin_rad;
          Vec3 var0 = u.sigma.array().isFinite().select(u.sigma.cwiseProduct(u.sigma), Vec3::Zero());
          u.value += v;
          u.sigma = (var0 + var).cwiseSqrt();
        }
      }
    }
    if (d < 0) x.not_carried.push_back("thermal: the overlay's datum head " + std::to_string(th.datum_head) + " is not configured");
  }

  if (noise_named) {
    for (int s = 0; s < heads.n_heads; ++s) {
      const auto k = static_cast<std::size_t>(s);
      if (white_cross[k] < 0 && white_about[k] < 0 && gm_cross[k] <= 0 && gm_about[k] <= 0) continue;
      const int id = heads.head[k].id;
      model::HeadNoise& hn = headEntry(o.noise, id);
      hn.valid = span;
      for (int a = 0; a < 3; ++a) {  // cross_x, cross_y, about_boresight (the star direction keeps its model)
        const bool cross = a < 2;
        const auto& in_use = pc.noise_in_use.head[k][static_cast<std::size_t>(a)];
        const bool changed = cross ? (white_cross[k] >= 0 || gm_cross[k] > 0) : (white_about[k] >= 0 || gm_about[k] > 0);
        if (!in_use.set || !changed) continue;
        hn.axis[static_cast<std::size_t>(a)] =
            axisWith(in_use.noise.model, cross ? white_cross[k] : white_about[k], cross ? gm_cross[k] : gm_about[k], gm_tau);
      }
    }
  }
  return x;
}

AppliedExtension compareApplied(const AuditResult& first, const AuditResult& second) {
  AppliedExtension a;
  for (const Gain& g : first.gains) {
    AppliedFamily f;
    f.family = g.family;
    f.unit = g.unit;
    f.heldout_rms_configured = g.heldout_rms_before;
    f.heldout_rms_fitted = g.heldout_rms_after;
    for (const Gain& h : second.gains)
      if (h.family == g.family) f.heldout_rms_applied = h.heldout_rms_before;
    a.families.push_back(f);
  }
  for (const EffectTest& e : second.named) {
    const std::string l = label(e) + " (" + e.family + ")";
    a.still_named.push_back(l);
    bool before = false;
    for (const EffectTest& f : first.named) before = before || (f.name == e.name && f.sensor == e.sensor && f.family == e.family);
    if (!before) a.newly_named.push_back(l);
  }
  return a;
}

std::vector<std::string> AppliedExtension::lines() const {
  std::vector<std::string> out;
  for (const auto& f : families) {
    if (f.unit.rfind("1 (normalised", 0) == 0) {  // a ratio to the model's level: 1 is right, not 0
      out.push_back(f.family + ": held-out scatter over the model's " + num(f.heldout_rms_configured, "%.4g") +
                    " with the configured model, " + num(f.heldout_rms_applied, "%.4g") +
                    " with the extension applied (1: the data at the model's level; the first pass's fit: " +
                    num(f.heldout_rms_fitted, "%.4g") + ")");
      continue;
    }
    out.push_back(f.family + ": held-out RMS " + num(f.heldout_rms_configured, "%.4g") + " with the configured model, " +
                  num(f.heldout_rms_applied, "%.4g") + " with the extension applied (" +
                  (f.heldout_rms_configured > 0 && std::isfinite(f.heldout_rms_applied)
                       ? num(100.0 * (f.heldout_rms_applied / f.heldout_rms_configured - 1.0), "%+.1f") + " %"
                       : std::string("-")) +
                  "; the first pass's fit: " + num(f.heldout_rms_fitted, "%.4g") + ") " + f.unit.substr(0, f.unit.find(" (")));
  }
  std::string s;
  for (const auto& n : still_named) s += (s.empty() ? "" : ", ") + n;
  out.push_back("named on the second pass: " + (s.empty() ? std::string("none") : s));
  if (!newly_named.empty()) {
    std::string t;
    for (const auto& n : newly_named) t += (t.empty() ? "" : ", ") + n;
    out.push_back("named on the second pass only: " + t);
  }
  return out;
}

namespace {

std::string namedLabel(const EffectTest& e) { return label(e) + " (" + e.family + ")"; }

struct Band {
  std::string name;
  double lo, hi;
};

std::vector<Band> bandsFor(const Spectrum& s) {
  if (s.unit == "cycles/rev")
    return {{"<0.8/rev", 0, 0.8},  {"1/rev", 0.8, 1.2}, {"1.2-1.8/rev", 1.2, 1.8}, {"2/rev", 1.8, 2.2},
            {"2.2-5/rev", 2.2, 5}, {"5-20/rev", 5, 20}, {">20/rev", 20, 1e300}};
  std::vector<Band> b;
  if (s.freq.empty()) return b;
  double lo = std::pow(10.0, std::floor(std::log10(s.freq.front())));
  while (lo <= s.freq.back()) {
    b.push_back({num(lo, "%g") + "-" + num(10 * lo, "%g") + " " + s.unit, lo, 10 * lo});
    lo *= 10;
  }
  return b;
}

}  // namespace

SimulatedCheck compareWithSimulation(const AuditResult& data, const AuditResult& simulation) {
  SimulatedCheck c;
  for (const Gain& g : data.gains)
    for (const Gain& h : simulation.gains) {
      if (h.family != g.family) continue;
      SimulatedFamily f;
      f.family = g.family;
      f.unit = g.unit;
      f.heldout_rms_data = g.heldout_rms_before;
      f.heldout_rms_sim = h.heldout_rms_before;
      f.ratio = f.heldout_rms_sim > 0 ? f.heldout_rms_data / f.heldout_rms_sim : kNaN;
      // an RMS of n rows has a relative sigma of about sqrt((kurtosis - 1) / 4n) (1/sqrt(2n) for Gaussian
      // rows; more where a few rows carry much of the power, as at the edges of gaps); rows are not
      // independent (bin means of coloured noise), so the tolerance is not smaller than 5 %
      const double n = std::max(1.0, std::min(g.heldout_rows, h.heldout_rows));
      double kurt = 3.0;
      for (double k : {g.heldout_kurtosis_before, h.heldout_kurtosis_before})
        if (std::isfinite(k)) kurt = std::max(kurt, k);
      f.kurtosis = kurt;
      f.tolerance = std::max(0.05, 3.0 * std::sqrt((kurt - 1.0) / (4.0 * n)));
      f.agrees = !std::isfinite(f.ratio) || std::abs(f.ratio - 1.0) <= f.tolerance;
      c.families.push_back(f);
    }
  for (const Spectrum& a : data.spectra)
    for (const Spectrum& b : simulation.spectra) {
      if (a.family != b.family || a.label != b.label || a.unit != b.unit || a.freq.empty() || b.freq.empty()) continue;
      c.data_spectra.push_back(a);
      c.sim_spectra.push_back(b);
      std::string amplitude_unit;
      for (const Series& se : data.series)
        if (se.family == a.family && se.label == a.label && !se.unit.empty()) amplitude_unit = se.unit;
      c.amplitude_units.push_back(amplitude_unit);
      const double df = std::max(a.freq.front(), b.freq.front());  // 1 / span: the independent spacing
      // base bands, then merged from low to high until each has kMinK independent frequencies
      struct Acc {
        double lo, hi, sa = 0, sb = 0;
        int pa = 0, pb = 0;
        std::string name, first;
      };
      std::vector<Acc> base;
      for (const Band& band : bandsFor(a)) {
        Acc x{band.lo, std::min(band.hi, std::min(a.freq.back(), b.freq.back())), 0, 0, 0, 0, band.name, band.name};
        for (std::size_t i = 0; i < a.freq.size() && i < a.before.size(); ++i)
          if (a.freq[i] >= band.lo && a.freq[i] < band.hi && std::isfinite(a.before[i])) x.sa += a.before[i] * a.before[i], ++x.pa;
        for (std::size_t i = 0; i < b.freq.size() && i < b.before.size(); ++i)
          if (b.freq[i] >= band.lo && b.freq[i] < band.hi && std::isfinite(b.before[i])) x.sb += b.before[i] * b.before[i], ++x.pb;
        if (x.pa > 0 && x.pb > 0) base.push_back(x);
      }
      auto kOf = [&](const Acc& x) {
        const double width = std::max(0.0, x.hi - std::max(x.lo, df));
        return std::max(1, std::min(std::min(x.pa, x.pb), static_cast<int>(std::floor(width / df))));
      };
      constexpr int kMinK = 5;
      std::vector<Acc> merged;
      for (const Acc& x : base) {
        if (!merged.empty() && kOf(merged.back()) < kMinK) {
          Acc& m = merged.back();
          m.hi = x.hi, m.sa += x.sa, m.sb += x.sb, m.pa += x.pa, m.pb += x.pb;
          m.name = m.first + " .. " + x.name;
        } else {
          merged.push_back(x);
        }
      }
      if (merged.size() > 1 && kOf(merged.back()) < kMinK) {  // a short last band joins the one before
        Acc last = merged.back();
        merged.pop_back();
        Acc& m = merged.back();
        m.hi = last.hi, m.sa += last.sa, m.sb += last.sb, m.pa += last.pa, m.pb += last.pb;
        m.name = m.first + " .. " + last.name;
      }
      for (const Acc& x : merged) {
        SimulatedBand sb;
        sb.family = a.family;
        sb.label = a.label;
        sb.band = x.name;
        sb.lo = x.lo;
        sb.hi = x.hi;
        sb.k = kOf(x);
        sb.power_data = x.sa / x.pa;
        sb.power_sim = x.sb / x.pb;
        sb.ratio = sb.power_sim > 0 ? sb.power_data / sb.power_sim : kNaN;
        c.bands.push_back(sb);
      }
    }
  // Under the null the ratio of two means of k exponential ordinates is F(2k, 2k): two-sided, at a
  // family-wise 1 % over the bands; plus ln 1.28 for what is not noise (the data's and the simulation's
  // excitation - thruster pulses, attitude - are different draws; the spectra are of bin means).
  for (SimulatedBand& b : c.bands) {
    const double p = 0.01 / (2.0 * static_cast<double>(c.bands.size()));
    b.tolerance = std::log(model::stats::fQuantile(p, 2.0 * b.k, 2.0 * b.k)) + 0.25;
    b.agrees = std::isfinite(b.ratio) && std::abs(std::log(b.ratio)) <= b.tolerance;
  }
  for (const EffectTest& e : data.named) c.named_data.push_back(namedLabel(e));
  for (const EffectTest& e : simulation.named) c.named_sim.push_back(namedLabel(e));
  return c;
}

std::vector<std::string> SimulatedCheck::namedOnDataOnly() const {
  std::vector<std::string> v;
  for (const auto& n : named_data)
    if (std::find(named_sim.begin(), named_sim.end(), n) == named_sim.end()) v.push_back(n);
  return v;
}

bool SimulatedCheck::agrees() const {
  if (!namedOnDataOnly().empty()) return false;
  for (const auto& f : families)
    if (!f.agrees) return false;
  for (const auto& b : bands)
    if (!b.agrees) return false;
  return true;
}

std::vector<std::string> SimulatedCheck::lines() const {
  std::vector<std::string> out;
  for (const auto& f : families)
    out.push_back(f.family + ": held-out RMS with the extended model " + num(f.heldout_rms_data, "%.4g") + " (data), " +
                  num(f.heldout_rms_sim, "%.4g") + " (its simulation): ratio " + num(f.ratio, "%.3f") +
                  (f.agrees ? " - agrees" : " - DIFFERS") + " (tolerance " + num(100 * f.tolerance, "%.0f") + " %" +
                  (f.kurtosis > 4 ? ", residual kurtosis " + num(f.kurtosis, "%.1f") : std::string()) + ")");
  int n_bands = 0, n_differ = 0;
  for (const auto& b : bands) {
    ++n_bands;
    if (b.agrees) continue;
    ++n_differ;
    out.push_back(b.family + " " + b.label + ", band " + b.band + ": residual power data/simulation " + num(b.ratio, "%.3g") +
                  " - DIFFERS (|ln ratio| " + num(std::abs(std::log(b.ratio)), "%.2f") + " > " + num(b.tolerance, "%.2f") + ", " +
                  std::to_string(b.k) + " independent frequencies)");
  }
  out.push_back("spectra: " + std::to_string(n_bands - n_differ) + " of " + std::to_string(n_bands) +
                " bands agree between the data's and the simulation's residuals");
  auto list = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s.empty() ? std::string("none") : s;
  };
  out.push_back("named with the extended model: data " + list(named_data) + "; its simulation " + list(named_sim));
  if (!namedOnDataOnly().empty())
    out.push_back("named on the data and not on the simulation of the model - the model lacks it: " + list(namedOnDataOnly()));
  out.push_back(agrees() ? "the simulation of the extended model reproduces the data's residual statistics"
                         : "the simulation of the extended model does NOT reproduce the data's residual statistics (above)");
  return out;
}

std::vector<std::pair<std::string, report::Plot>> SimulatedCheck::plots() const {
  std::vector<std::pair<std::string, report::Plot>> out;
  std::vector<std::string> fams;
  for (const auto& s : data_spectra)
    if (std::find(fams.begin(), fams.end(), s.family) == fams.end()) fams.push_back(s.family);
  for (const auto& fam : fams) {
    report::Plot p;
    p.title = fam + " residual spectra with the extended model: the data and its simulation";
    p.width = 1100;
    p.logx = p.logy = true;
    p.ylabel = "amplitude";
    double ylo = 1e300, yhi = 0, fhi = 0;
    bool per_rev = false;
    for (std::size_t i = 0; i < data_spectra.size(); ++i) {
      if (data_spectra[i].family != fam) continue;
      p.xlabel = "frequency [" + data_spectra[i].unit + "]";
      if (i < amplitude_units.size() && !amplitude_units[i].empty()) p.ylabel = "amplitude [" + amplitude_units[i] + "]";
      p.series.push_back({data_spectra[i].label + " data", data_spectra[i].freq, data_spectra[i].before, {}, report::Series::Style::kLine, 0.0, {}});
      p.series.push_back({data_spectra[i].label + " simulation", sim_spectra[i].freq, sim_spectra[i].before, {}, report::Series::Style::kLine, 0.0, {}});
      for (const auto* s : {&data_spectra[i], &sim_spectra[i]}) {
        for (double y : s->before)
          if (std::isfinite(y) && y > 0) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
        for (double fq : s->freq) fhi = std::max(fhi, fq);
      }
      per_rev |= data_spectra[i].unit == "cycles/rev";
    }
    if (per_rev && yhi > ylo) {  // the orbit harmonics, where thermal terms and the field-of-view error sit
      std::vector<double> orders;
      for (int n = 1; n <= 10 && n <= fhi; ++n) orders.push_back(n);
      if (!orders.empty()) p.series.push_back(report::verticalMarkers("orbit harmonics", orders, ylo, yhi));
    }
    std::string slug = fam;
    for (char& ch : slug)
      if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    out.emplace_back("model_simulation_spectrum_" + slug + ".svg", std::move(p));
  }
  return out;
}

}  // namespace boresight::audit

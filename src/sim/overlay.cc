#include <boresight/sim/overlay.h>

#include <boresight/io/time_format.h>
#include <boresight/model/rotation.h>
#include <boresight/report/text.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

namespace boresight::sim {
namespace {

std::string num(double v, const char* f = "%.4g") { return report::fmt(v, f); }
/// A value for makeEffect, every digit kept (a non-finite value becomes "-", which makeEffect refuses).
std::string exact(double v) { return report::fmt(v, "%.17g"); }

using KV = std::vector<std::pair<std::string, std::string>>;

class Layer {
 public:
  Layer(const std::string& source, Scenario& sc, ScenarioOverlayUse& use) : src_(source), sc_(sc), use_(use) {}

  bool add(const char* name, const std::string& sensor, KV kv, const std::string& item, std::string* error) {
    kv.emplace_back("sensor", sensor);
    model::EffectSpec s;
    if (!model::makeEffect(name, kv, "overlay " + src_ + ": " + item, s, error)) return false;
    sc_.effects.push_back(std::move(s));
    return true;
  }

  /// A spec on 'all' that is taken off head id: one copy per other head, so those keep it.
  void splitAll(const model::EffectSpec& e, int id, std::vector<model::EffectSpec>& out) const {
    if (id == 0 || e.sensor != "all") return;
    for (const auto& h : sc_.heads)
      if (h.id != id) {
        model::EffectSpec c = e;
        c.sensor = std::to_string(h.id);
        out.push_back(std::move(c));
      }
  }

  /// Drops the scenario's specs of `kind` that act on head `id` (or on the accelerometer with id 0); a
  /// spec on 'all' is split into one per other head first. Each dropped spec is listed once.
  void drop(model::EffectKind kind, int id, const char* what = nullptr) {
    std::vector<model::EffectSpec> out;
    for (auto& e : sc_.effects) {
      if (e.kind != kind || isOurs(e) || !hits(e, id)) {
        out.push_back(e);
        continue;
      }
      splitAll(e, id, out);
      use_.replaced.push_back(e.name + (what ? std::string(" (") + what + ")" : "") + " on " +
                              (id == 0 ? std::string("the accelerometer") : "head " + std::to_string(id)) + " (" + e.origin + ")");
    }
    sc_.effects = std::move(out);
  }

  /// Sets parameter `key` of the scenario's specs of `kind` on head id (0: accelerometer) to zero (a
  /// spec on 'all' split first); a spec left with nothing is dropped. For the coloured specs whose
  /// levels are per axis.
  void zeroAxis(model::EffectKind kind, int id, const char* key, const std::vector<const char*>& all_keys) {
    std::vector<model::EffectSpec> out;
    for (auto& e : sc_.effects) {
      if (e.kind != kind || isOurs(e) || !hits(e, id) || e.get(key) == 0) {
        out.push_back(e);
        continue;
      }
      splitAll(e, id, out);
      model::EffectSpec c = e;
      if (id != 0) c.sensor = std::to_string(id);
      c.values[key] = 0;
      use_.replaced.push_back(e.name + " " + key + " on " + (id == 0 ? std::string("the accelerometer") : "head " + std::to_string(id)) +
                              " (" + e.origin + ")");
      bool left = false;
      for (const char* k : all_keys) left = left || c.get(k) != 0;
      if (left) out.push_back(std::move(c));
    }
    sc_.effects = std::move(out);
  }

  /// Whether a spec acts on head id, or (id 0) on the accelerometer: 'all' of an effect that may target
  /// either (time_offset, gaps, clock_drift) means every head.
  static bool hits(const model::EffectSpec& e, int id) {
    if (id != 0) return e.appliesToHead(id);
    const model::EffectInfo* info = model::findEffect(e.name);
    return e.sensor == "acc" || (e.sensor == "all" && info && info->target == model::EffectTarget::Acc);
  }

  bool isOurs(const model::EffectSpec& e) const { return e.origin.rfind("overlay " + src_ + ":", 0) == 0; }

  model::HeadConfig* head(int id) {
    for (auto& h : sc_.heads)
      if (h.id == id) return &h;
    return nullptr;
  }

 private:
  const std::string& src_;
  Scenario& sc_;
  ScenarioOverlayUse& use_;
};

/// The coloured terms of a model as one spec's keys each: Gauss-Markov {tau_s} or power law {alpha,
/// f_lo_hz, f_hi_hz}, with the level under `level_key` in `scale` units.
std::vector<KV> colouredSpecs(const model::NoiseModel& m, const std::string& level_key, double scale, std::vector<std::string>* notes,
                              const std::string& what) {
  std::vector<KV> out;
  for (const auto& t : m.terms) {
    if (t.kind == model::NoiseKind::White) continue;
    KV kv{{level_key, exact(t.sigma * scale)}};
    if (t.kind == model::NoiseKind::GaussMarkov) {
      kv.emplace_back("tau_s", exact(t.tau_s));
    } else {
      kv.emplace_back("alpha", exact(t.alpha));
      kv.emplace_back("f_lo_hz", exact(t.f_lo_hz));
      kv.emplace_back("f_hi_hz", exact(t.f_hi_hz));
      if (t.pl_terms != 0 && notes)
        notes->push_back(what + ": a power law of " + std::to_string(t.pl_terms) +
                         " Gauss-Markov terms simulated with the simulator's three per decade");
    }
    out.push_back(std::move(kv));
  }
  return out;
}

/// The cross-boresight model the simulator draws both axes with: x and y term by term with the RMS
/// level when their forms agree, else x's form with the RMS of the two axes' coloured variances.
model::NoiseModel crossModel(const model::AxisNoise* x, const model::AxisNoise* y, std::vector<std::string>& notes, int id) {
  if (!x || !y) return (x ? x : y)->model;
  if (x->model == y->model) return x->model;
  model::NoiseModel m;
  const double white = std::sqrt(0.5 * (x->model.whiteVariance() + y->model.whiteVariance()));
  if (white > 0) m.add(model::NoiseTerm::white(white));
  const auto coloured = [](const model::NoiseModel& a) {
    std::vector<model::NoiseTerm> c;
    for (const auto& t : a.terms)
      if (t.kind != model::NoiseKind::White) c.push_back(t);
    return c;
  };
  const auto cx = coloured(x->model), cy = coloured(y->model);
  bool same_forms = cx.size() == cy.size();
  for (std::size_t i = 0; same_forms && i < cx.size(); ++i) {
    model::NoiseTerm a = cx[i], b = cy[i];
    a.sigma = b.sigma = 0;
    same_forms = a == b;
  }
  if (same_forms) {
    for (std::size_t i = 0; i < cx.size(); ++i) {
      model::NoiseTerm t = cx[i];
      t.sigma = std::sqrt(0.5 * (cx[i].sigma * cx[i].sigma + cy[i].sigma * cy[i].sigma));
      m.add(t);
    }
  } else {
    double vx = 0, vy = 0;
    for (const auto& t : cx) vx += t.sigma * t.sigma;
    for (const auto& t : cy) vy += t.sigma * t.sigma;
    const double f = vx > 0 ? std::sqrt(0.5 * (vx + vy) / vx) : 0;
    for (model::NoiseTerm t : cx) {
      t.sigma *= f;
      m.add(t);
    }
    if (vx == 0 && vy > 0)
      for (const auto& t : cy) {
        model::NoiseTerm u = t;
        u.sigma *= std::sqrt(0.5);
        m.add(u);
      }
    if (!cx.empty() || !cy.empty())
      notes.push_back("noise: head " + std::to_string(id) + " cross_x and cross_y have different coloured forms; both axes "
                      "simulated with cross_x's form at the RMS level of the two");
  }
  if (x->model.whiteVariance() != y->model.whiteVariance())
    notes.push_back("noise: head " + std::to_string(id) + " cross_x and cross_y differ; the simulator draws both cross-boresight "
                    "axes alike, with their RMS (" + num(white * kArcsecPerRad) + "\" white)");
  return m;
}

std::size_t colouredTerms(const model::NoiseModel& m) {
  return static_cast<std::size_t>(std::count_if(m.terms.begin(), m.terms.end(), [](const model::NoiseTerm& t) { return t.kind != model::NoiseKind::White; }));
}

std::string validityText(const model::Validity& v) {
  return std::string("valid") + (v.from ? " from " + io::formatTime(*v.from) : "") + (v.to ? " to " + io::formatTime(*v.to) : "");
}

}  // namespace

bool applyOverlay(const model::Overlay& ov, const std::string& source, double duration_s, Scenario& sc,
                  ScenarioOverlayUse& use, std::string* error) {
  Layer L(source, sc, use);
  const TimeUs t0 = sc.start, t1 = sc.start + static_cast<TimeUs>(std::llround(duration_s * 1e6));
  // A model written from data ends at its last epoch; a simulation of the data's span in whole seconds
  // runs a little past it: a minute either side is not worth a note.
  const TimeUs slack = std::min<TimeUs>(60'000'000, (t1 - t0) / 4);
  auto validity = [&](const model::Validity& v, const std::string& item) {
    if (!v.covers(t0 + slack, t1 - slack))
      use.notes.push_back(item + ": " + validityText(v) + ", simulated over the whole span " + io::formatTime(t0) + " to " +
                          io::formatTime(t1));
  };
  const auto fail = [&](const std::string& m) {
    if (error) *error = "overlay " + source + ": " + m;
    return false;
  };

  // Mountings.
  bool any_mounting = false;
  for (const auto& m : ov.mountings) {
    model::HeadConfig* h = L.head(m.head);
    const std::string item = "mountings: head " + std::to_string(m.head);
    if (!h) {
      use.not_applied.push_back(item + ": the scenario has no such head");
      continue;
    }
    h->mounting_error_rad = model::quatLog((m.q_Si_B * h->q_Si_B.conjugate()).normalized());
    L.drop(model::EffectKind::RelativeMisalignment, m.head);
    any_mounting = true;
    use.applied.push_back(item + " (" + model::mountingDatumKey(m.datum) + " datum): " + num(h->mounting_error_rad.norm() * kArcsecPerRad) +
                          "\" from the scenario's nominal mounting");
    validity(m.valid, item);
  }
  if (any_mounting && sc.mounting_error_sigma_rad > 0) {
    use.replaced.push_back("the random mounting error of every head (mounting_error_sigma " +
                           num(sc.mounting_error_sigma_rad * kArcsecPerRad) + "\")");
    sc.mounting_error_sigma_rad = 0;
  }

  // Noise.
  if (!ov.noise.empty()) {
    for (auto& h : sc.heads) {
      std::array<const model::AxisNoise*, model::kHeadAxes> ax{};
      const model::HeadNoise* own = nullptr;
      for (const auto& hn : ov.noise.heads)
        if (hn.id == h.id) own = &hn;
      for (int a = 0; a < model::kHeadAxes; ++a) {
        const auto k = static_cast<std::size_t>(a);
        if (own && own->axis[k]) ax[k] = &*own->axis[k];
        else if (ov.noise.head_defaults && ov.noise.head_defaults->axis[k]) ax[k] = &*ov.noise.head_defaults->axis[k];
      }
      const std::string id = std::to_string(h.id);
      const std::string item = "noise: head " + id;
      const auto* cx = ax[static_cast<std::size_t>(model::HeadAxis::CrossX)];
      const auto* cy = ax[static_cast<std::size_t>(model::HeadAxis::CrossY)];
      const auto* ab = ax[static_cast<std::size_t>(model::HeadAxis::AboutBoresight)];
      const auto* st = ax[static_cast<std::size_t>(model::HeadAxis::StarDirection)];
      if (cx || cy) {
        const model::NoiseModel m = crossModel(cx, cy, use.notes, h.id);
        h.sigma_cross_rad = std::sqrt(m.whiteVariance());
        L.drop(model::EffectKind::CrossNoise, h.id);
        L.zeroAxis(model::EffectKind::ColouredNoise, h.id, "cross_arcsec", {"cross_arcsec", "about_arcsec"});
        for (auto& kv : colouredSpecs(m, "cross_arcsec", kArcsecPerRad, &use.notes, item + " cross"))
          if (!L.add("coloured_noise", id, std::move(kv), item + " cross", error)) return false;
        use.applied.push_back(item + " cross-boresight: white " + num(h.sigma_cross_rad * kArcsecPerRad) + "\", " +
                              std::to_string(colouredTerms(m)) + " coloured term(s)");
      }
      if (own) validity(own->valid, item);
      else if (cx || cy || ab || st) validity(ov.noise.head_defaults->valid, item);
      if (ab) {
        h.sigma_roll_rad = std::sqrt(ab->model.whiteVariance());
        L.drop(model::EffectKind::AnisotropicNoise, h.id);
        L.zeroAxis(model::EffectKind::ColouredNoise, h.id, "about_arcsec", {"cross_arcsec", "about_arcsec"});
        for (auto& kv : colouredSpecs(ab->model, "about_arcsec", kArcsecPerRad, &use.notes, item + " about"))
          if (!L.add("coloured_noise", id, std::move(kv), item + " about the boresight", error)) return false;
        use.applied.push_back(item + " about the boresight: white " + num(h.sigma_roll_rad * kArcsecPerRad) + "\"");
      }
      if ((cx || cy) && ab) {
        L.drop(model::EffectKind::FovError, h.id, "the overlay's noise is the head's whole random error");
        L.drop(model::EffectKind::ThermalWander, h.id, "the overlay's noise is the head's whole random error");
      }
      if (st) {
        h.sigma_star_rad = std::sqrt(st->model.whiteVariance());
        use.applied.push_back(item + " star directions: white " + num(h.sigma_star_rad * kArcsecPerRad) + "\"");
        if (st->model.markovTerms().size() > 0)
          use.not_applied.push_back(item + " star_direction coloured terms: the simulator draws star directions white");
      }
    }
    for (const auto& hn : ov.noise.heads)
      if (!L.head(hn.id)) use.not_applied.push_back("noise: head " + std::to_string(hn.id) + ": the scenario has no such head");
    if (ov.noise.accelerometer) {
      const auto& an = *ov.noise.accelerometer;
      const char* keys[3] = {"x", "y", "z"};
      for (int a = 0; a < 3; ++a) {
        if (!an.axis[static_cast<std::size_t>(a)]) continue;
        const auto& m = an.axis[static_cast<std::size_t>(a)]->model;
        const std::string item = std::string("noise: accelerometer ") + keys[a];
        sc.acc.white_rad_s2[a] = std::sqrt(m.whiteVariance());
        if (sc.acc.lowfreq_rad_s2[a] != 0) {
          use.replaced.push_back(std::string("the accelerometer's low-frequency noise on ") + keys[a] + " (" + num(sc.acc.lowfreq_rad_s2[a]) +
                                 " rad/s^2, tau " + num(sc.acc.lowfreq_tau_s) + " s)");
          sc.acc.lowfreq_rad_s2[a] = 0;
        }
        L.zeroAxis(model::EffectKind::AccColouredNoise, 0, keys[a], {"x", "y", "z"});
        L.zeroAxis(model::EffectKind::AccBiasWander, 0, keys[a], {"x", "y", "z"});
        for (auto& kv : colouredSpecs(m, keys[a], 1.0, &use.notes, item))
          if (!L.add("acc_coloured_noise", "acc", std::move(kv), item, error)) return false;
        use.applied.push_back(item + ": white " + num(sc.acc.white_rad_s2[a]) + " rad/s^2, " +
                              std::to_string(colouredTerms(m)) + " coloured term(s)");
      }
      validity(an.valid, "noise: accelerometer");
    }
  }

  // Thermal terms.
  if (ov.thermal) {
    const auto& th = *ov.thermal;
    const model::HeadConfig* d = L.head(th.datum_head);
    if (!d) return fail("thermal: the datum head " + std::to_string(th.datum_head) + " is not in the scenario");
    for (const auto& h : sc.heads) L.drop(model::EffectKind::ThermalPeriodic, h.id);
    const Mat3 C_Sd_B = d->q_Si_B.toRotationMatrix();
    for (const auto& e : th.heads) {
      const model::HeadConfig* h = L.head(e.head);
      const std::string item = "thermal: head " + std::to_string(e.head);
      if (!h) {
        use.not_applied.push_back(item + ": the scenario has no such head");
        continue;
      }
      const std::string id = std::to_string(e.head);
      // phi_k = -C0_kd delta_k: the head's own rotation that makes the deformation relative to the datum.
      const Mat3 C_k_d = h->q_Si_B.toRotationMatrix() * C_Sd_B.transpose();
      const Vec3 c = -C_k_d * e.constant_rad.value;
      if (c.norm() > 0) {
        L.drop(model::EffectKind::RelativeMisalignment, e.head);
        if (!L.add("relative_misalignment", id,
                   {{"x_arcsec", exact(c.x() * kArcsecPerRad)}, {"y_arcsec", exact(c.y() * kArcsecPerRad)}, {"z_arcsec", exact(c.z() * kArcsecPerRad)}},
                   item + " constant", error))
          return false;
      }
      const char* axis_key[3] = {"x_arcsec", "y_arcsec", "z_arcsec"};
      auto harmonic = [&](const model::ThermalHarmonicEntry& hh, bool beta) -> bool {
        const Vec3 cs = -C_k_d * hh.cos_rad.value, sn = -C_k_d * hh.sin_rad.value;
        const std::string what = item + (beta ? " beta harmonic " : " harmonic ") + std::to_string(hh.harmonic);
        for (int a = 0; a < 3; ++a) {
          // c cos(n u) + s sin(n u) = A cos(n u + phase), A = hypot(c, s), phase = atan2(-s, c).
          const double A = std::hypot(cs[a], sn[a]);
          if (A == 0) continue;
          const double phase_deg = std::atan2(-sn[a], cs[a]) / kRadPerDeg;
          KV kv{{"harmonic", std::to_string(hh.harmonic)}, {axis_key[a], exact(A * kArcsecPerRad)}, {"phase_deg", exact(phase_deg)}};
          if (!beta) {
            if (!L.add("thermal_periodic", id, kv, what, error)) return false;
            continue;
          }
          // A (cos beta - cos beta_ref) cos(n u + phase): A (1 + g) - A with g the modulation.
          KV mod = kv;
          mod.emplace_back("beta_gain", "1");
          mod.emplace_back("beta_ref_deg", exact(*th.beta_ref_rad / kRadPerDeg));
          KV neg{{"harmonic", std::to_string(hh.harmonic)}, {axis_key[a], exact(-A * kArcsecPerRad)}, {"phase_deg", exact(phase_deg)}};
          if (!L.add("thermal_periodic", id, mod, what, error) || !L.add("thermal_periodic", id, neg, what, error)) return false;
        }
        return true;
      };
      for (const auto& hh : e.harmonics)
        if (!harmonic(hh, false)) return false;
      if (!e.beta_harmonics.empty() && !th.beta_ref_rad) return fail(item + ": beta harmonics without beta_ref");
      for (const auto& hh : e.beta_harmonics)
        if (!harmonic(hh, true)) return false;
      use.applied.push_back(item + " relative to head " + std::to_string(th.datum_head) + ": " + std::to_string(e.harmonics.size()) +
                            " harmonic(s)" + (e.beta_harmonics.empty() ? "" : ", " + std::to_string(e.beta_harmonics.size()) + " beta harmonic(s)") +
                            (c.norm() > 0 ? ", a constant of " + num(c.norm() * kArcsecPerRad) + "\"" : ""));
    }
    validity(th.valid, "thermal");
  }

  // Accelerometer terms.
  if (ov.accelerometer) {
    const auto& a = *ov.accelerometer;
    auto vec = [&](const char* name, model::EffectKind kind, const model::Uncertain3& u, double scale, const char* k0, const char* k1,
                   const char* k2) -> bool {
      L.drop(kind, 0);
      const Vec3 v = u.value * scale;
      if (!L.add(name, "acc", {{k0, exact(v.x())}, {k1, exact(v.y())}, {k2, exact(v.z())}}, std::string("accelerometer ") + name, error))
        return false;
      use.applied.push_back(std::string("accelerometer: ") + name + " (" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + ")");
      return true;
    };
    if (a.bias_rad_s2 && sc.acc.bias_rad_s2.norm() > 0) {
      // the overlay's bias is the whole bias of the measurement (what a program subtracts from it)
      use.replaced.push_back("the accelerometer's nominal bias (" + num(sc.acc.bias_rad_s2.x()) + ", " + num(sc.acc.bias_rad_s2.y()) + ", " +
                             num(sc.acc.bias_rad_s2.z()) + ") rad/s^2");
      sc.acc.bias_rad_s2 = Vec3::Zero();
    }
    if (a.bias_rad_s2 && !vec("acc_bias", model::EffectKind::AccBias, *a.bias_rad_s2, 1.0, "x", "y", "z")) return false;
    if (a.scale && !vec("acc_scale", model::EffectKind::AccScale, *a.scale, 1.0, "x", "y", "z")) return false;
    if (a.misalignment_rad &&
        !vec("acc_misalignment", model::EffectKind::AccMisalignment, *a.misalignment_rad, kArcsecPerRad, "x_arcsec", "y_arcsec", "z_arcsec"))
      return false;
    if (a.nonorthogonality_rad && a.nonorthogonality_rad->value.norm() > 0)
      use.not_applied.push_back("accelerometer: non-orthogonality (" + num(a.nonorthogonality_rad->value.norm() * kArcsecPerRad) +
                                "\"): the simulator has no such term");
    validity(a.valid, "accelerometer");
  }

  // Time offsets.
  for (const auto& t : ov.time_offsets) {
    const std::string item = "time_offsets: " + t.sensor + " against " + t.relative_to;
    std::string sensor;
    int id = 0;
    if (t.sensor == "accelerometer") sensor = "acc";
    else if (t.sensor.rfind("head", 0) == 0 && L.head(std::atoi(t.sensor.c_str() + 4))) sensor = t.sensor.substr(4), id = std::atoi(sensor.c_str());
    if (sensor.empty()) {
      use.not_applied.push_back(item + ": the scenario has no such sensor");
      continue;
    }
    if (t.relative_to != "heads" && t.relative_to != "gps") {
      use.not_applied.push_back(item + ": the simulator takes offsets against the heads or GPS only");
      continue;
    }
    double base_ms = 0;
    if (t.relative_to == "heads")
      for (const auto& e : sc.effects)
        if (e.kind == model::EffectKind::TimeOffset && e.sensor == "all" && !L.isOurs(e)) base_ms += e.get("offset_ms");
    if (sensor == "acc") L.drop(model::EffectKind::TimeOffset, 0);
    else L.drop(model::EffectKind::TimeOffset, id);
    const double ms = t.offset_s * 1e3 + base_ms;
    if (!L.add("time_offset", sensor, {{"offset_ms", exact(ms)}}, item, error)) return false;
    use.applied.push_back(item + ": " + num(ms) + " ms against the simulated truth");
    validity(t.valid, item);
  }

  if (ov.published_frame) use.not_applied.push_back("published_frame: the node's state, not a model of the instruments");
  if (ov.data_events)
    use.not_applied.push_back("data_events: the audit's expected rates of missing-sample runs carry no run lengths; the simulator "
                              "draws gaps from the scenario's gaps and head_dropout effects");
  return true;
}

}  // namespace boresight::sim

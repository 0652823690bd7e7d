// A model overlay laid over a platform configuration (io/overlay_apply.h).
#include <boresight/core/rotation.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/io/overlay_yaml.h>
#include <boresight/io/time_format.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace boresight::io {
namespace {

std::string ids(const std::vector<int>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s;
}

std::string arcsec3(const Vec3& v) {
  char b[96];
  std::string s = "[";
  for (int i = 0; i < 3; ++i) {
    if (std::isnan(v[i])) std::snprintf(b, sizeof b, "%snot determined", i ? ", " : "");
    else std::snprintf(b, sizeof b, "%s%.3g", i ? ", " : "", v[i] * kArcsecPerRad);
    s += b;
  }
  return s + "]\"";
}

std::string validityText(const model::Validity& v) {
  if (v.open()) return "";
  return ", valid " + (v.from ? formatTime(*v.from) : std::string("(open)")) + " to " +
         (v.to ? formatTime(*v.to) : std::string("(open)"));
}

int slotOf(const PlatformConfig& pc, int id) {
  for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
    if (pc.pipeline.heads.head[static_cast<std::size_t>(s)].id == id) return s;
  return -1;
}

}  // namespace

bool applyOverlay(const std::string& path, const std::string& program, const OverlayUses& uses, PlatformConfig& pc,
                  OverlayUse& use, std::string* error) {
  model::Overlay ov;
  if (!readOverlay(path, ov, error)) return false;
  return applyOverlay(ov, path, program, uses, pc, use, error);
}

bool applyOverlay(const model::Overlay& ov, const std::string& path, const std::string& program, const OverlayUses& uses,
                  PlatformConfig& pc, OverlayUse& use, std::string* error) {
  use = OverlayUse{};
  use.file = path;
  use.overlay = ov;
  if (!ov.platform.empty() && !pc.platform.empty() && ov.platform != pc.platform) {
    if (error)
      *error = path + ": platform '" + ov.platform + "' is not the platform file's ('" + pc.platform + "', " + pc.file +
               "): an overlay describes one instrument set";
    return false;
  }
  const std::string src = "overlay " + path;

  // Noise.
  if (!ov.noise.empty()) {
    if (uses.noise) {
      std::vector<std::string> unused;
      const model::NoiseInUse before = pc.noise_in_use;
      pc.noise_in_use.layer(ov.noise, src, &unused);
      std::vector<std::string> axes;
      for (int s = 0; s < pc.noise_in_use.n_heads; ++s)
        for (int a = 0; a < model::kHeadAxes; ++a)
          if (pc.noise_in_use.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].source !=
              before.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)].source)
            axes.push_back("head " + std::to_string(pc.noise_in_use.head_id[static_cast<std::size_t>(s)]) + " " +
                           model::headAxisKey(model::HeadAxis(a)));
      for (int a = 0; a < 3; ++a)
        if (pc.noise_in_use.acc[static_cast<std::size_t>(a)].source != before.acc[static_cast<std::size_t>(a)].source)
          axes.push_back(std::string("accelerometer ") + model::accAxisKey(a));
      std::string list;
      for (std::size_t i = 0; i < axes.size(); ++i) list += (i ? ", " : "") + axes[i];
      use.applied.push_back("noise: " + (axes.empty() ? std::string("no configured axis") : list) + " (over the platform file's)");
      for (const auto& u : unused)
        use.not_applied.push_back("noise " + u + ": no such head in the platform file (" + pc.file + ")");
      deriveHeadSigmas(pc);
    } else {
      use.not_applied.push_back("noise: " + program + " does not use noise models");
    }
  }

  // Mountings.
  if (!ov.mountings.empty()) {
    if (uses.mountings) {
      std::vector<int> applied;
      for (const model::MountingEntry& m : ov.mountings) {
        const int s = slotOf(pc, m.head);
        if (s < 0) {
          use.not_applied.push_back("mountings of head " + std::to_string(m.head) + ": no such head in the platform file (" +
                                    pc.file + ")");
          continue;
        }
        pc.pipeline.heads.head[static_cast<std::size_t>(s)].q_Si_B = m.q_Si_B;
        pc.mounting_source[static_cast<std::size_t>(s)] = src + " (datum " + model::mountingDatumKey(m.datum) + ", epoch " +
                                                          formatTime(m.epoch) + ", sigma " + arcsec3(m.sigma_rad) +
                                                          validityText(m.valid) + ")";
        applied.push_back(m.head);
      }
      if (!applied.empty()) {
        bool every = static_cast<int>(applied.size()) == pc.pipeline.heads.n_heads;
        use.applied.push_back("mountings: head" + std::string(applied.size() > 1 ? "s " : " ") + ids(applied) +
                              (every && pc.mounting_from_qsa1b ? " (every head: QSA1B not needed)" : ""));
        if (every) pc.mounting_from_qsa1b = false;
      }
    } else {
      use.not_applied.push_back("mountings: " + program + " does not use mountings");
    }
  }

  // Thermal terms.
  if (ov.thermal) {
    std::vector<int> h;
    for (const auto& x : ov.thermal->heads) h.push_back(x.head);
    const std::string which =
        "head" + std::string(h.size() == 1 ? " " : "s ") + ids(h) + " relative to head " + std::to_string(ov.thermal->datum_head);
    if (uses.thermal) {
      core::ThermalHarmonicModel m;
      std::string why;
      if (!thermalModelFromOverlay(*ov.thermal, pc.pipeline.heads, m, &why)) {
        if (error) *error = path + ": thermal: " + why;
        return false;
      }
      std::string orders;
      for (int n = 0; n < m.n_harmonics; ++n) orders += (n ? ", " : "") + std::to_string(m.order[static_cast<std::size_t>(n)]);
      use.applied.push_back("thermal: " + which + " (harmonics " + (orders.empty() ? std::string("none") : orders) + " per revolution" +
                            (m.beta_terms ? ", beta modulation" : "") +
                            "): functions of the argument of latitude from the orbit (GNI1B / GNV1B files, ORBIT messages)");
      use.thermal_model = m;
    } else {
      use.not_applied.push_back("thermal: " + program + " does not apply thermal terms (" + which + ")");
    }
  }

  // Accelerometer terms.
  if (ov.accelerometer) {
    const model::AccelerometerTerms& a = *ov.accelerometer;
    std::string which;
    auto part = [&](const std::optional<model::Uncertain3>& u, const char* name) {
      if (u) which += std::string(which.empty() ? "" : ", ") + name;
    };
    part(a.bias_rad_s2, "bias");
    part(a.scale, "scale");
    part(a.misalignment_rad, "misalignment");
    part(a.nonorthogonality_rad, "non-orthogonality");
    if (uses.accelerometer) {
      core::AccCorrection c;
      std::string why;
      if (!accCorrectionFromOverlay(a, c, &why)) {
        if (error) *error = path + ": accelerometer: " + why;
        return false;
      }
      pc.pipeline.acc_correction = c;
      use.applied.push_back("accelerometer: " + (which.empty() ? std::string("no term") : which) +
                            " (every accelerometer sample corrected before the core)");
    } else {
      use.not_applied.push_back("accelerometer: " + program + " does not apply accelerometer terms (" + which + ")");
    }
  }

  // The data events' expected rates (the audit's null).
  if (ov.data_events) {
    if (uses.data_events) {
      for (const auto& [id, r] : ov.data_events->head_dropouts_by_id)
        if (slotOf(pc, id) < 0) {
          if (error) *error = path + ": data_events.heads: head " + std::to_string(id) + " is not a head of the platform";
          return false;
        }
      pc.events = *ov.data_events;
      use.applied.push_back("data_events: the expected missing-sample runs (the data events' null)");
    } else {
      use.not_applied.push_back("data_events: " + program + " does not test data events");
    }
  }

  // What no program applies yet.
  for (const auto& t : ov.time_offsets)
    use.not_applied.push_back("time_offsets: " + program + " does not apply time offsets (" + t.sensor + " against " +
                              t.relative_to + ")");
  if (ov.published_frame)
    use.not_applied.push_back("published_frame: boresightd's state (its state_file); " + program + " does not read it");
  return true;
}

bool accCorrectionFromOverlay(const model::AccelerometerTerms& t, core::AccCorrection& out, std::string* error) {
  auto value = [](const std::optional<model::Uncertain3>& u) { return u ? u->value : Vec3(Vec3::Zero()); };
  const Vec3 b = value(t.bias_rad_s2), s = value(t.scale), m = value(t.misalignment_rad), n = value(t.nonorthogonality_rad);
  if (!(b.allFinite() && s.allFinite() && m.allFinite() && n.allFinite())) {
    if (error) *error = "a term that is not a number";
    return false;
  }
  Mat3 K = Mat3::Identity();
  K.diagonal() += s;
  K(0, 1) = K(1, 0) = n[2];
  K(0, 2) = K(2, 0) = n[1];
  K(1, 2) = K(2, 1) = n[0];
  const Eigen::FullPivLU<Mat3> lu(K);
  if (!lu.isInvertible() || std::abs(lu.determinant()) < 1e-6) {
    if (error) *error = "the scale and non-orthogonality make a singular matrix (scale near -1?)";
    return false;
  }
  const Mat3 R = core::quatExp(m).toRotationMatrix();  // as model::AccelModel turns A
  out = core::AccCorrection{};
  out.on = true;
  out.bias_A = b;
  out.M = R.transpose() * lu.inverse();
  return true;
}

bool thermalModelFromOverlay(const model::ThermalTerms& t, const core::HeadSetConfig& heads,
                             core::ThermalHarmonicModel& out, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  auto slot = [&](int id) {
    for (int s = 0; s < heads.n_heads; ++s)
      if (heads.head[static_cast<std::size_t>(s)].id == id) return s;
    return -1;
  };
  core::ThermalHarmonicModel m;
  m.datum_slot = slot(t.datum_head);
  if (m.datum_slot < 0) return fail("the datum head " + std::to_string(t.datum_head) + " is not in the platform file");
  // The model's orders: every harmonic any head names, ascending.
  std::vector<int> orders;
  for (const auto& h : t.heads)
    for (const auto* list : {&h.harmonics, &h.beta_harmonics})
      for (const auto& e : *list)
        if (std::find(orders.begin(), orders.end(), e.harmonic) == orders.end()) orders.push_back(e.harmonic);
  std::sort(orders.begin(), orders.end());
  if (static_cast<int>(orders.size()) > core::kMaxThermalHarmonics)
    return fail(std::to_string(orders.size()) + " distinct harmonics; the core takes at most " +
                std::to_string(core::kMaxThermalHarmonics));
  m.n_harmonics = static_cast<int>(orders.size());
  for (std::size_t n = 0; n < orders.size(); ++n) m.order[n] = orders[n];
  auto var = [](const Vec3& sigma) {
    Vec3 v;
    for (int a = 0; a < 3; ++a) v[a] = std::isfinite(sigma[a]) ? sigma[a] * sigma[a] : 0.0;
    return v;
  };
  for (const auto& h : t.heads) {
    const int s = slot(h.head);
    if (s < 0) return fail("head " + std::to_string(h.head) + " is not in the platform file");
    if (s == m.datum_slot) return fail("head " + std::to_string(h.head) + " is the datum and cannot have terms");
    core::ThermalHeadModel& hm = m.head[static_cast<std::size_t>(s)];
    hm.valid = true;
    hm.constant_rad = h.constant_rad.value;
    Vec3 v = var(h.constant_rad.sigma);
    for (const auto& e : h.harmonics) {
      const auto n = static_cast<std::size_t>(std::find(orders.begin(), orders.end(), e.harmonic) - orders.begin());
      hm.cos_rad[n] = e.cos_rad.value;
      hm.sin_rad[n] = e.sin_rad.value;
      v += 0.5 * (var(e.cos_rad.sigma) + var(e.sin_rad.sigma));
    }
    for (const auto& e : h.beta_harmonics) {
      const auto n = static_cast<std::size_t>(std::find(orders.begin(), orders.end(), e.harmonic) - orders.begin());
      hm.beta_cos_rad[n] = e.cos_rad.value;
      hm.beta_sin_rad[n] = e.sin_rad.value;
      m.beta_terms = true;
    }
    hm.cov_rad2 = v.asDiagonal();
  }
  if (m.beta_terms) {
    if (!t.beta_ref_rad) return fail("beta harmonics without beta_ref");
    m.cos_beta_ref = std::cos(*t.beta_ref_rad);
  }
  const core::Status st = core::validate(m, heads);
  if (st != core::Status::kOk) return fail(std::string("the core refuses the model: ") + core::statusName(st));
  out = m;
  return true;
}

std::vector<std::string> validityWarnings(const OverlayUse& use, TimeUs t0, TimeUs t1) {
  std::vector<std::string> w;
  if (use.file.empty()) return w;
  auto check = [&](const model::Validity& v, const std::string& what, bool applied) {
    if (!applied || v.covers(t0, t1)) return;
    w.push_back("overlay " + use.file + ": " + what + " valid " + (v.from ? formatTime(*v.from) : std::string("(open)")) +
                " to " + (v.to ? formatTime(*v.to) : std::string("(open)")) + ", but the data run from " + formatTime(t0) +
                " to " + formatTime(t1));
  };
  bool noise_applied = false, mountings_applied = false;
  for (const auto& a : use.applied) {
    noise_applied = noise_applied || a.rfind("noise:", 0) == 0;
    mountings_applied = mountings_applied || a.rfind("mountings:", 0) == 0;
  }
  const model::Overlay& o = use.overlay;
  for (const auto& m : o.mountings) {
    bool not_applied = false;
    for (const auto& n : use.not_applied) not_applied = not_applied || n.rfind("mountings of head " + std::to_string(m.head) + ":", 0) == 0;
    check(m.valid, "the mounting of head " + std::to_string(m.head), mountings_applied && !not_applied);
  }
  if (o.noise.head_defaults) check(o.noise.head_defaults->valid, "noise.head_defaults", noise_applied);
  for (const auto& h : o.noise.heads) check(h.valid, "noise.heads[id " + std::to_string(h.id) + "]", noise_applied);
  if (o.noise.accelerometer) check(o.noise.accelerometer->valid, "noise.accelerometer", noise_applied);
  if (o.thermal) check(o.thermal->valid, "the thermal terms", use.thermal_model.has_value());
  return w;
}

std::vector<std::string> modelInUseLines(const PlatformConfig& pc, const OverlayUse& use) {
  std::vector<std::string> out;
  out.push_back("noise in use (per-sample 1-sigma; the core weights the heads with the total, cross-boresight the RMS of x and y):");
  for (const auto& l : pc.noise_in_use.describe()) out.push_back("  " + l);
  out.push_back("mountings in use:");
  for (int s = 0; s < pc.pipeline.heads.n_heads; ++s) {
    const auto& src = pc.mounting_source[static_cast<std::size_t>(s)];
    out.push_back("  head " + std::to_string(pc.pipeline.heads.head[static_cast<std::size_t>(s)].id) + ": " +
                  (src.empty() ? std::string("not set") : src));
  }
  if (!use.file.empty()) {
    out.push_back("overlay " + use.file + " (written by " + use.overlay.written_by + "):");
    for (const auto& a : use.applied) out.push_back("  applied: " + a);
    for (const auto& n : use.not_applied) out.push_back("  not applied: " + n);
  }
  return out;
}

}  // namespace boresight::io

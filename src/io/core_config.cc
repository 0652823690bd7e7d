// YAML platform configuration -> core::PipelineConfig, with file/key/reason errors.
#include "noise_yaml.h"
#include "yaml_check.h"

#include <boresight/core/pipeline.h>
#include <boresight/core/plausibility.h>
#include <boresight/io/core_config.h>
#include <boresight/io/yaml_file.h>
#include <boresight/io/sca_geometry.h>
#include <boresight/io/time_format.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

namespace boresight::io {
namespace {

using yamlcheck::checkKeys;
using yamlcheck::fail;
using ConfigError = yamlcheck::Error;

double num(const YAML::Node& n, const std::string& key, double def, bool required = false) {
  if (!n || n.IsNull()) {
    if (required) fail(key, "missing", n);
    return def;
  }
  return yamlcheck::number(n, key);
}

double positive(const YAML::Node& n, const std::string& key, double def, bool required = false) {
  double v = num(n, key, def, required);
  if (!(v > 0)) fail(key, "must be > 0", n);
  return v;
}

int integer(const YAML::Node& n, const std::string& key, int def) {
  if (!n || n.IsNull()) return def;
  try {
    return n.as<int>();
  } catch (const YAML::Exception&) {
    fail(key, "expected an integer", n);
  }
}

Vec3 vec3(const YAML::Node& n, const std::string& key, const Vec3& def) {
  if (!n || n.IsNull()) return def;
  if (!n.IsSequence() || n.size() != 3) fail(key, "expected [x, y, z]", n);
  Vec3 v;
  for (int i = 0; i < 3; ++i) v[i] = num(n[static_cast<std::size_t>(i)], key + "[" + std::to_string(i) + "]", 0, true);
  return v;
}

/// A head's blinding cones {sun, earth, moon}, radians.
using Cones = std::array<double, 3>;
Cones conesOf(const core::HeadConfig& h) { return {h.sun_exclusion_rad, h.earth_exclusion_rad, h.moon_exclusion_rad}; }
void setCones(core::HeadConfig& h, const Cones& c) {
  h.sun_exclusion_rad = c[0];
  h.earth_exclusion_rad = c[1];
  h.moon_exclusion_rad = c[2];
}

/// Blinding cones {sun, earth, moon} in degrees (each optional over `def`, radians) -> radians.
std::array<double, 3> blindingCones(const YAML::Node& n, const std::string& key, std::array<double, 3> def) {
  if (!n.IsMap()) fail(key, "expected a mapping {sun: deg, earth: deg, moon: deg}", n);
  checkKeys(n, key, {"sun", "earth", "moon"});
  const char* names[3] = {"sun", "earth", "moon"};
  const double lo[3] = {0, -90, 0}, hi[3] = {180, 90, 180};
  for (int i = 0; i < 3; ++i) {
    const YAML::Node v = n[names[i]];
    if (!v) continue;
    const double d = num(v, key + "." + names[i], 0, true);
    if (!(d >= lo[i] && d <= hi[i]))
      fail(key + "." + names[i], "must be within " + std::to_string(static_cast<int>(lo[i])) + ".." +
                                     std::to_string(static_cast<int>(hi[i])) + " deg",
           v);
    def[static_cast<std::size_t>(i)] = d * kRadPerDeg;
  }
  return def;
}

void crn(const YAML::Node& n, const std::string& key, core::CrnConfig& c) {
  if (!n) return;
  if (!n.IsMap()) fail(key, "expected a mapping", n);
  checkKeys(n, key, {"fs_hz", "nc", "bandwidth_hz", "length_s", "output_period_s", "gap_policy", "max_bridge_samples", "bridge_fit"});
  c.fs_hz = positive(n["fs_hz"], key + ".fs_hz", c.fs_hz);
  c.nc = integer(n["nc"], key + ".nc", c.nc);
  if (c.nc < 1 || c.nc > 20) fail(key + ".nc", "must be 1..20", n["nc"]);
  c.bandwidth_hz = positive(n["bandwidth_hz"], key + ".bandwidth_hz", c.bandwidth_hz);
  c.length_s = positive(n["length_s"], key + ".length_s", c.length_s);
  if (n["output_period_s"]) {
    double p = positive(n["output_period_s"], key + ".output_period_s", 1.0);
    if (p < (1.0 - 1e-9) / c.fs_hz || p > 86400.0)
      fail(key + ".output_period_s", "must be from one sampling interval (1/fs_hz = " + std::to_string(1.0 / c.fs_hz) +
                                         " s) to 86400 s", n["output_period_s"]);
    c.output_period_us = static_cast<TimeUs>(std::llround(p * 1e6));
  }
  if (n["gap_policy"]) {
    std::string g = n["gap_policy"].as<std::string>();
    if (g == "bridge") c.gap_policy = core::GapPolicy::kBridge;
    else if (g == "restart") c.gap_policy = core::GapPolicy::kRestart;
    else fail(key + ".gap_policy", "expected bridge or restart, not '" + g + "'", n["gap_policy"]);
  }
  if (n["bridge_fit"]) {
    std::string b = n["bridge_fit"].as<std::string>();
    if (b == "local_fit") c.bridge_fit = core::BridgeFit::kLocalFit;
    else if (b == "linear") c.bridge_fit = core::BridgeFit::kLinear;
    else fail(key + ".bridge_fit", "expected local_fit or linear, not '" + b + "'", n["bridge_fit"]);
  }
  c.max_bridge_samples = integer(n["max_bridge_samples"], key + ".max_bridge_samples", c.max_bridge_samples);
  if (c.max_bridge_samples < 0 || c.max_bridge_samples > core::kMaxBridgeSamples)
    fail(key + ".max_bridge_samples", "must be 0.." + std::to_string(core::kMaxBridgeSamples), n["max_bridge_samples"]);
  core::CrnKernel k;
  if (core::designCrn(c, k) != core::Status::kOk)
    fail(key, "the CRN parameters give no valid filter (taps = fs*Tf must be <= " +
                  std::to_string(core::kMaxCrnTaps) + ", B below Nyquist)", n);
}

/// Which file gave each part of the merged noise section (for NoiseInUse's sources).
struct NoiseSources {
  std::array<std::string, model::kHeadAxes> head_defaults{};
  std::string heads;
  std::array<std::string, 3> acc{};
};

/// The keys that were per-head noise levels before the noise section, and where each went.
const char* movedSigmaKey(const std::string& k) {
  if (k == "sigma_cross_arcsec") return "noise.head_defaults.cross_x and .cross_y";
  if (k == "sigma_roll_arcsec") return "noise.head_defaults.about_boresight";
  if (k == "sigma_star_arcsec") return "noise.head_defaults.star_direction";
  return nullptr;
}

std::string dirOf(const std::string& p) {
  const auto k = p.find_last_of('/');
  return k == std::string::npos ? std::string(".") : p.substr(0, k);
}

bool loadAt(const std::string& path, PlatformConfig& out, NoiseSources& src, std::string* error, int depth);

/// Reads one file's keys over `out` (its base already loaded into it when `overlay`).
void readPlatform(const YAML::Node& root, const std::string& path, bool overlay, PlatformConfig& out, NoiseSources& src) {
  out.platform = root["platform"] ? root["platform"].as<std::string>() : (overlay ? out.platform : "unnamed");
  auto& p = out.pipeline;
  const YAML::Node heads = root["heads"];
  if (!overlay && (!heads || !heads.IsMap())) fail("heads", "missing (a mapping with 'list')", heads ? heads : root);
  if (heads && !heads.IsMap()) fail("heads", "expected a mapping (mounting, list, ...)", heads);
  if (heads) {
    checkKeys(heads, "heads", {"mounting", "unit_norm_tolerance", "list", "fusion_alignment",
                               "relative_time_constant_s", "relative_min_epochs", "alignment_update_epochs",
                               "mounting_uncertainty_arcsec", "blinding_deg"});
    if (heads["mounting_uncertainty_arcsec"])
      out.mounting_uncertainty_arcsec = positive(heads["mounting_uncertainty_arcsec"], "heads.mounting_uncertainty_arcsec", 0.0);
    std::string mounting = out.mounting_from_qsa1b ? "qsa1b" : "explicit";
    if (heads["mounting"]) mounting = heads["mounting"].as<std::string>();
    if (mounting != "qsa1b" && mounting != "explicit") fail("heads.mounting", "expected qsa1b or explicit", heads["mounting"]);
    out.mounting_from_qsa1b = mounting == "qsa1b";
    p.heads.unit_norm_tolerance = positive(heads["unit_norm_tolerance"], "heads.unit_norm_tolerance", overlay ? p.heads.unit_norm_tolerance : 1e-5);
    if (p.heads.unit_norm_tolerance > plausibility::kMaxQuatNormTolerance)
      fail("heads.unit_norm_tolerance", "must be at most 0.01 (a larger tolerance lets through quaternions that are "
                                        "not rotations)", heads["unit_norm_tolerance"]);
    if (const YAML::Node fa = heads["fusion_alignment"]) {
      const std::string v = fa.as<std::string>();
      if (v == "nominal") p.fusion_alignment = core::FusionAlignment::kNominal;
      else if (v == "running_means") p.fusion_alignment = core::FusionAlignment::kRunningMeans;
      else fail("heads.fusion_alignment", "expected nominal or running_means, not '" + v + "'", fa);
    }
    p.heads.relative_time_constant_s =
        positive(heads["relative_time_constant_s"], "heads.relative_time_constant_s", p.heads.relative_time_constant_s);
    p.heads.relative_min_epochs = integer(heads["relative_min_epochs"], "heads.relative_min_epochs", p.heads.relative_min_epochs);
    if (p.heads.relative_min_epochs < 1) fail("heads.relative_min_epochs", "must be >= 1", heads["relative_min_epochs"]);
    p.alignment_update_epochs = integer(heads["alignment_update_epochs"], "heads.alignment_update_epochs", p.alignment_update_epochs);
    if (p.alignment_update_epochs < 1)
      fail("heads.alignment_update_epochs", "must be >= 1", heads["alignment_update_epochs"]);
  }
  // blinding cones: heads.blinding_deg for every head, a head's own blinding_deg over it
  // (an overlay starts from the base's first head, a platform file from the defaults)
  Cones cones = conesOf(overlay ? p.heads.head[0] : core::HeadConfig{});
  const bool cones_given = heads && heads["blinding_deg"];
  if (cones_given) cones = blindingCones(heads["blinding_deg"], "heads.blinding_deg", cones);
  const bool list_given = heads && heads["list"];
  const YAML::Node list = list_given ? heads["list"] : root["heads"];
  if (list_given || !overlay) {  // a list given replaces the base's
    if (!list_given || !list.IsSequence() || list.size() == 0) fail("heads.list", "missing or empty", list_given ? list : heads);
    if (list.size() > static_cast<std::size_t>(core::kMaxHeads))
      fail("heads.list", "more than " + std::to_string(core::kMaxHeads) + " heads (kMaxHeads)", list);
    p.heads.n_heads = static_cast<int>(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string k = "heads.list[" + std::to_string(i) + "]";
      const YAML::Node h = list[i];
      if (!h.IsMap()) fail(k, "expected a mapping (id, boresight, q_Si_B)", h);
      for (const auto& kv : h)
        if (const char* moved = movedSigmaKey(kv.first.Scalar()))
          fail(k + "." + kv.first.Scalar(),
               std::string("the head noise levels moved to the noise section: ") + moved +
                   " (a noise model per axis, e.g. [{kind: white, sigma_arcsec: 6.0}]; per head: noise.heads[{id: N, ...}])",
               kv.first);
      checkKeys(h, k, {"id", "boresight", "q_Si_B", "blinding_deg"});
      auto& hc = p.heads.head[i];
      hc = core::HeadConfig{};
      setCones(hc, h["blinding_deg"] ? blindingCones(h["blinding_deg"], k + ".blinding_deg", cones) : cones);
      out.mounting_source[i].clear();
      hc.id = integer(h["id"], k + ".id", 0);
      if (hc.id <= 0) fail(k + ".id", "missing or not > 0", h["id"] ? h["id"] : h);
      for (std::size_t o = 0; o < i; ++o)
        if (p.heads.head[o].id == hc.id) fail(k + ".id", "duplicate head id " + std::to_string(hc.id), h["id"]);
      Vec3 b = vec3(h["boresight"], k + ".boresight", Vec3::UnitZ());
      if (std::abs(b.norm() - 1.0) > 1e-6) fail(k + ".boresight", "must be a unit vector", h["boresight"]);
      hc.boresight_Si = b;
      if (h["q_Si_B"]) {
        const YAML::Node q = h["q_Si_B"];
        if (!q.IsSequence() || q.size() != 4) fail(k + ".q_Si_B", "expected [q0, q1, q2, q3]", q);
        double v[4];
        for (int j = 0; j < 4; ++j) v[j] = num(q[static_cast<std::size_t>(j)], k + ".q_Si_B", 0, true);
        Quat qq = quatFromScalarFirst(v);
        if (std::abs(qq.norm() - 1.0) > 1e-6) fail(k + ".q_Si_B", "not a unit quaternion", q);
        hc.q_Si_B = qq;
        out.mounting_source[i] = path + " " + k + ".q_Si_B";
      } else if (!out.mounting_from_qsa1b) {
        fail(k + ".q_Si_B", "missing (or set heads.mounting: qsa1b)", h);
      }
    }
  }
  if (cones_given && !list_given)  // an overlay's cones for the base's heads
    for (int s = 0; s < p.heads.n_heads; ++s) setCones(p.heads.head[static_cast<std::size_t>(s)], cones);
  if (!out.mounting_from_qsa1b)
    for (int s = 0; s < p.heads.n_heads; ++s)
      if (out.mounting_source[static_cast<std::size_t>(s)].empty())
        fail("heads.list[" + std::to_string(s) + "].q_Si_B", "missing (heads.mounting: explicit; or set heads.mounting: qsa1b)",
             heads ? heads : root);
  if (const YAML::Node n = root["noise"]) {
    const model::NoiseSection sec = yamlcheck::readNoiseSection(n, "noise", false);
    model::NoiseSection& ns = out.noise;
    if (sec.head_defaults) {
      if (!ns.head_defaults) ns.head_defaults = model::HeadNoise{};
      for (int a = 0; a < model::kHeadAxes; ++a)
        if (sec.head_defaults->axis[static_cast<std::size_t>(a)]) {
          ns.head_defaults->axis[static_cast<std::size_t>(a)] = sec.head_defaults->axis[static_cast<std::size_t>(a)];
          src.head_defaults[static_cast<std::size_t>(a)] = path;
        }
    }
    if (n["heads"]) {
      ns.heads = sec.heads;
      src.heads = path;
    }
    if (sec.accelerometer) {
      if (!ns.accelerometer) ns.accelerometer = model::AccNoise{};
      for (int a = 0; a < 3; ++a)
        if (sec.accelerometer->axis[static_cast<std::size_t>(a)]) {
          ns.accelerometer->axis[static_cast<std::size_t>(a)] = sec.accelerometer->axis[static_cast<std::size_t>(a)];
          src.acc[static_cast<std::size_t>(a)] = path;
        }
    }
  }
  // Per-head noise names configured heads only.
  for (std::size_t i = 0; i < out.noise.heads.size(); ++i) {
    bool found = false;
    for (int s = 0; s < p.heads.n_heads; ++s) found = found || p.heads.head[static_cast<std::size_t>(s)].id == out.noise.heads[i].id;
    if (!found)
      fail("noise.heads[" + std::to_string(i) + "].id", "head " + std::to_string(out.noise.heads[i].id) + " is not in heads.list",
           root["noise"] && root["noise"]["heads"] ? root["noise"]["heads"][i]["id"] : (heads ? heads["list"] : root));
  }
  crn(root["crn_attitude"], "crn_attitude", p.crn_attitude);
  crn(root["crn_acc"], "crn_acc", p.crn_acc);
  if (const YAML::Node acc = root["accelerometer"]) {
    if (!acc.IsMap()) fail("accelerometer", "expected a mapping", acc);
    checkKeys(acc, "accelerometer", {"C_B_A", "use"});
    if (const YAML::Node m = acc["C_B_A"]) {
      if (!m.IsSequence() || m.size() != 3) fail("accelerometer.C_B_A", "expected three rows", m);
      Mat3 C;
      for (int r = 0; r < 3; ++r) C.row(r) = vec3(m[static_cast<std::size_t>(r)], "accelerometer.C_B_A", Vec3::Zero()).transpose();
      if ((C * C.transpose() - Mat3::Identity()).norm() > 1e-6 || C.determinant() < 0)
        fail("accelerometer.C_B_A", "not a rotation matrix", m);
      p.C_B_A = C;
    }
    if (acc["use"]) p.use_accelerometer = acc["use"].as<bool>();
  }
  if (const YAML::Node ev = root["data_events"]) {
    out.events = yamlcheck::readDataEvents(ev, "data_events", out.events);
    const YAML::Node hl = ev["heads"];
    for (std::size_t i = 0; i < out.events.head_dropouts_by_id.size(); ++i) {
      const int id = out.events.head_dropouts_by_id[i].first;
      if (core::slotOf(p.heads, id) < 0)
        fail("data_events.heads[" + std::to_string(i) + "].id", "head " + std::to_string(id) + " is not in heads.list",
             hl ? hl[i]["id"] : ev);
    }
  }
  if (const YAML::Node th = root["thermal"]) {
    if (!th.IsMap()) fail("thermal", "expected a mapping", th);
    checkKeys(th, "thermal", {"wahba_correction", "deformation_model", "tau_s", "hold_drift_arcsec_per_s"});
    if (const YAML::Node w = th["wahba_correction"]) {
      const std::string v = w.as<std::string>();
      if (v == "none") p.wahba_correction = core::RelativeCorrection::kNone;
      else if (v == "iba_one_axis") p.wahba_correction = core::RelativeCorrection::kIbaOneAxis;
      else if (v == "filtered_three_axis") p.wahba_correction = core::RelativeCorrection::kFilteredThreeAxis;
      else fail("thermal.wahba_correction", "expected none, iba_one_axis or filtered_three_axis, not '" + v + "'", w);
    }
    if (const YAML::Node m = th["deformation_model"]) {
      const std::string v = m.as<std::string>();
      if (v == "level") p.deformation.model = core::DeformationModel::kLevel;
      else if (v == "linear") p.deformation.model = core::DeformationModel::kLinear;
      else fail("thermal.deformation_model", "expected level or linear, not '" + v + "'", m);
    }
    p.deformation.tau_s = positive(th["tau_s"], "thermal.tau_s", p.deformation.tau_s);
    p.deformation.hold_drift_rad_per_s =
        num(th["hold_drift_arcsec_per_s"], "thermal.hold_drift_arcsec_per_s",
            p.deformation.hold_drift_rad_per_s * kArcsecPerRad) * kRadPerArcsec;
    if (p.deformation.hold_drift_rad_per_s < 0)
      fail("thermal.hold_drift_arcsec_per_s", "must be >= 0", th["hold_drift_arcsec_per_s"]);
  }
}

/// The noise table from the merged section, each axis with the file that gave it; "" or what is missing.
std::string resolveNoise(PlatformConfig& out, const NoiseSources& src) {
  std::vector<int> ids;
  for (int s = 0; s < out.pipeline.heads.n_heads; ++s) ids.push_back(out.pipeline.heads.head[static_cast<std::size_t>(s)].id);
  model::NoiseInUse& u = out.noise_in_use;
  u.reset(ids);
  const model::NoiseSection& ns = out.noise;
  for (int s = 0; s < u.n_heads; ++s)
    for (int a = 0; a < model::kHeadAxes; ++a) {
      auto& ax = u.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)];
      for (const auto& h : ns.heads)
        if (h.id == ids[static_cast<std::size_t>(s)] && h.axis[static_cast<std::size_t>(a)]) {
          ax.set = true;
          ax.noise = *h.axis[static_cast<std::size_t>(a)];
          ax.source = src.heads + " noise.heads[id " + std::to_string(h.id) + "]";
        }
      if (!ax.set && ns.head_defaults && ns.head_defaults->axis[static_cast<std::size_t>(a)]) {
        ax.set = true;
        ax.noise = *ns.head_defaults->axis[static_cast<std::size_t>(a)];
        ax.source = src.head_defaults[static_cast<std::size_t>(a)] + " noise.head_defaults";
      }
    }
  for (int a = 0; a < 3; ++a)
    if (ns.accelerometer && ns.accelerometer->axis[static_cast<std::size_t>(a)]) {
      auto& ax = u.acc[static_cast<std::size_t>(a)];
      ax.set = true;
      ax.noise = *ns.accelerometer->axis[static_cast<std::size_t>(a)];
      ax.source = src.acc[static_cast<std::size_t>(a)] + " noise.accelerometer";
    }
  return u.missing();
}

bool loadAt(const std::string& path, PlatformConfig& out, NoiseSources& src, std::string* error, int depth) {
  YAML::Node root;
  if (!loadYamlFile(path, root, error, "platform configuration file")) return false;
  try {
    if (!root.IsMap()) fail("(top level)", "expected a mapping", root);
    checkKeys(root, "", {"base", "platform", "heads", "noise", "crn_attitude", "crn_acc", "accelerometer", "thermal", "data_events"});
    bool overlay = false;
    if (const YAML::Node b = root["base"]) {
      const std::string base = yamlcheck::text(b, "base");
      if (depth >= 4) fail("base", "platform files nested deeper than 4 levels (a loop?)", b);
      const std::string base_path = base[0] == '/' ? base : dirOf(path) + "/" + base;
      std::string berr;
      if (!loadAt(base_path, out, src, &berr, depth + 1)) fail("base", "the base platform file does not load: " + berr, b);
      overlay = true;
    }
    out.file = path;
    readPlatform(root, path, overlay, out, src);
    if (depth == 0) {
      const std::string missing = resolveNoise(out, src);
      if (!missing.empty())
        fail("noise", "no noise model for " + missing +
                          " (noise.head_defaults gives every head's cross_x, cross_y, about_boresight and star_direction; "
                          "noise.accelerometer its x, y and z)",
             root["noise"] ? root["noise"] : root);
      deriveHeadSigmas(out);
      // What the checks above let through and the core still refuses: said with the place of the heads.
      // (With heads.mounting: qsa1b the mountings are not known yet: the check waits for them.)
      auto core = std::make_unique<core::Pipeline>();
      if (!out.mounting_from_qsa1b && core->configure(out.pipeline) != core::Status::kOk)
        fail("heads", "the real-time core refuses this configuration (heads, CRN filters, C_B_A together)",
             root["heads"] ? root["heads"] : root);
    }
  } catch (const ConfigError& e) {
    if (error) *error = yamlcheck::located(path, e);
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  }
  return true;
}

}  // namespace

bool loadPlatformConfig(const std::string& path, PlatformConfig& out, std::string* error) {
  out = PlatformConfig{};
  NoiseSources src;
  return loadAt(path, out, src, error, 0);
}

void deriveHeadSigmas(PlatformConfig& cfg) {
  const model::NoiseInUse& u = cfg.noise_in_use;
  for (int s = 0; s < cfg.pipeline.heads.n_heads && s < u.n_heads; ++s) {
    core::HeadConfig& h = cfg.pipeline.heads.head[static_cast<std::size_t>(s)];
    h.sigma_cross_rad = u.crossSigmaRad(s);
    h.sigma_roll_rad = u.aboutSigmaRad(s);
    h.sigma_star_rad = u.starSigmaRad(s);
  }
}

bool applyQsa1bMounting(PlatformConfig& cfg, const std::vector<QsaRecord>& qsa, TimeUs t_ref, std::string* error) {
  auto& hs = cfg.pipeline.heads;
  for (int s = 0; s < hs.n_heads; ++s) {
    auto& h = hs.head[static_cast<std::size_t>(s)];
    if (cfg.mounting_source[static_cast<std::size_t>(s)].rfind("overlay", 0) == 0) continue;  // the overlay's
    const QsaRecord* best = alignmentAt(qsa, h.id, t_ref);
    if (!best) {
      if (error) *error = "QSA1B has no alignment for head " + std::to_string(h.id);
      return false;
    }
    h.q_Si_B = quatFromScalarFirst(best->q).normalized();
    cfg.mounting_source[static_cast<std::size_t>(s)] = "QSA1B (latest record at or before " + formatTime(t_ref) + ")";
  }
  return true;
}

}  // namespace boresight::io

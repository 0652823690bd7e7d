// YAML platform configuration -> core::PipelineConfig, with file/key/reason errors.
#include <boresight/io/config_keys.h>
#include <boresight/io/core_config.h>
#include <boresight/io/yaml_file.h>
#include <boresight/io/sca_geometry.h>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <memory>
#include <cmath>
#include <stdexcept>

namespace boresight::io {
namespace {

struct ConfigError : std::runtime_error {
  ConfigError(const std::string& what, int line_) : std::runtime_error(what), line(line_) {}
  int line = 0;  ///< 1-based line of the offending node, 0 when unknown
};

int lineOf(const YAML::Node& n) { return n && n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }

/// The error names the key; `at` (when defined) gives the line.
[[noreturn]] void fail(const std::string& key, const std::string& why, const YAML::Node& at = YAML::Node()) {
  throw ConfigError("key '" + key + "': " + why, lineOf(at));
}

/// Every key of the mapping n must be one of `known`; a misspelt key names the nearest known one.
void checkKeys(const YAML::Node& n, const std::string& prefix, const std::vector<std::string>& known) {
  if (!n || !n.IsMap()) return;
  for (const auto& kv : n) {
    const std::string k = kv.first.Scalar();
    if (std::find(known.begin(), known.end(), k) == known.end())
      fail(prefix.empty() ? k : prefix + "." + k, unknownKeyMessage(k, known), kv.first);
  }
}

double num(const YAML::Node& n, const std::string& key, double def, bool required = false) {
  if (!n || n.IsNull()) {
    if (required) fail(key, "missing", n);
    return def;
  }
  try {
    double v = n.as<double>();
    if (!std::isfinite(v)) fail(key, "not a finite number", n);
    return v;
  } catch (const YAML::Exception&) {
    fail(key, "expected a number", n);
  }
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

void crn(const YAML::Node& n, const std::string& key, core::CrnConfig& c) {
  if (!n) return;
  if (!n.IsMap()) fail(key, "expected a mapping", n);
  checkKeys(n, key, {"fs_hz", "nc", "bandwidth_hz", "length_s", "output_period_s", "gap_policy", "max_bridge_samples"});
  c.fs_hz = positive(n["fs_hz"], key + ".fs_hz", c.fs_hz);
  c.nc = integer(n["nc"], key + ".nc", c.nc);
  if (c.nc < 1 || c.nc > 20) fail(key + ".nc", "must be 1..20", n["nc"]);
  c.bandwidth_hz = positive(n["bandwidth_hz"], key + ".bandwidth_hz", c.bandwidth_hz);
  c.length_s = positive(n["length_s"], key + ".length_s", c.length_s);
  if (n["output_period_s"]) {
    double p = positive(n["output_period_s"], key + ".output_period_s", 1.0);
    if (false)
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
  c.max_bridge_samples = integer(n["max_bridge_samples"], key + ".max_bridge_samples", c.max_bridge_samples);
  if (c.max_bridge_samples < 0 || c.max_bridge_samples > core::kMaxBridgeSamples)
    fail(key + ".max_bridge_samples", "must be 0.." + std::to_string(core::kMaxBridgeSamples), n["max_bridge_samples"]);
  core::CrnKernel k;
  if (core::designCrn(c, k) != core::Status::kOk)
    fail(key, "the CRN parameters give no valid filter (taps = fs*Tf must be <= " +
                  std::to_string(core::kMaxCrnTaps) + ", B below Nyquist)", n);
}

}  // namespace

bool loadPlatformConfig(const std::string& path, PlatformConfig& out, std::string* error) {
  out = PlatformConfig{};
  YAML::Node root;
  if (!loadYamlFile(path, root, error, "platform configuration file")) return false;
  try {
    if (!root.IsMap()) fail("(top level)", "expected a mapping", root);
    checkKeys(root, "", {"platform", "heads", "crn_attitude", "crn_acc", "accelerometer", "thermal"});
    out.platform = root["platform"] ? root["platform"].as<std::string>() : "unnamed";
    auto& p = out.pipeline;
    const YAML::Node heads = root["heads"];
    if (!heads || !heads.IsMap()) fail("heads", "missing (a mapping with 'list')", heads ? heads : root);
    checkKeys(heads, "heads", {"mounting", "unit_norm_tolerance", "list", "fusion_alignment",
                               "relative_time_constant_s", "relative_min_epochs", "alignment_update_epochs"});
    std::string mounting = heads["mounting"] ? heads["mounting"].as<std::string>() : "explicit";
    if (mounting != "qsa1b" && mounting != "explicit") fail("heads.mounting", "expected qsa1b or explicit", heads["mounting"]);
    out.mounting_from_qsa1b = mounting == "qsa1b";
    p.heads.unit_norm_tolerance = positive(heads["unit_norm_tolerance"], "heads.unit_norm_tolerance", 1e-5);
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
    const YAML::Node list = heads["list"];
    if (!list || !list.IsSequence() || list.size() == 0) fail("heads.list", "missing or empty", list ? list : heads);
    if (list.size() > static_cast<std::size_t>(core::kMaxHeads))
      fail("heads.list", "more than " + std::to_string(core::kMaxHeads) + " heads (kMaxHeads)", list);
    p.heads.n_heads = static_cast<int>(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string k = "heads.list[" + std::to_string(i) + "]";
      const YAML::Node h = list[i];
      if (!h.IsMap()) fail(k, "expected a mapping (id, boresight, sigmas, q_Si_B)", h);
      checkKeys(h, k, {"id", "boresight", "sigma_cross_arcsec", "sigma_roll_arcsec", "sigma_star_arcsec", "q_Si_B"});
      auto& hc = p.heads.head[i];
      hc.id = integer(h["id"], k + ".id", 0);
      if (hc.id <= 0) fail(k + ".id", "missing or not > 0", h["id"] ? h["id"] : h);
      for (std::size_t o = 0; o < i; ++o)
        if (p.heads.head[o].id == hc.id) fail(k + ".id", "duplicate head id " + std::to_string(hc.id), h["id"]);
      Vec3 b = vec3(h["boresight"], k + ".boresight", Vec3::UnitZ());
      if (std::abs(b.norm() - 1.0) > 1e-6) fail(k + ".boresight", "must be a unit vector", h["boresight"]);
      hc.boresight_Si = b;
      hc.sigma_cross_rad = positive(h["sigma_cross_arcsec"], k + ".sigma_cross_arcsec", 6.0) * kRadPerArcsec;
      hc.sigma_roll_rad = positive(h["sigma_roll_arcsec"], k + ".sigma_roll_arcsec", 48.0) * kRadPerArcsec;
      hc.sigma_star_rad = positive(h["sigma_star_arcsec"], k + ".sigma_star_arcsec", 5.0) * kRadPerArcsec;
      for (const char* s : {"sigma_cross_arcsec", "sigma_roll_arcsec", "sigma_star_arcsec"}) {
        const double v = (s[6] == 'c' ? hc.sigma_cross_rad : s[6] == 'r' ? hc.sigma_roll_rad : hc.sigma_star_rad) / kRadPerArcsec;
        if (v < 1e-3 || v > 1e5)  // the fusion inverts the heads' covariances: keep them numbers it can
          fail(k + "." + s, "must be from 0.001 to 100000 arcsec", h[s]);
      }
      if (h["q_Si_B"]) {
        const YAML::Node q = h["q_Si_B"];
        if (!q.IsSequence() || q.size() != 4) fail(k + ".q_Si_B", "expected [q0, q1, q2, q3]", q);
        double v[4];
        for (int j = 0; j < 4; ++j) v[j] = num(q[static_cast<std::size_t>(j)], k + ".q_Si_B", 0, true);
        Quat qq = quatFromScalarFirst(v);
        if (std::abs(qq.norm() - 1.0) > 1e-6) fail(k + ".q_Si_B", "not a unit quaternion", q);
        hc.q_Si_B = qq;
      } else if (!out.mounting_from_qsa1b) {
        fail(k + ".q_Si_B", "missing (or set heads.mounting: qsa1b)", h);
      }
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
    // What the checks above let through and the core still refuses: said with the place of the heads.
    // (With heads.mounting: qsa1b the mountings are not known yet: the check waits for them.)
    auto core = std::make_unique<core::Pipeline>();
    if (!out.mounting_from_qsa1b && core->configure(out.pipeline) != core::Status::kOk)
      fail("heads", "the real-time core refuses this configuration (heads, CRN filters, C_B_A together)", heads);
  } catch (const ConfigError& e) {
    if (error) *error = path + ":" + (e.line > 0 ? std::to_string(e.line) + ":" : std::string()) + " " + e.what();
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
    return false;
  }
  return true;
}

bool applyQsa1bMounting(PlatformConfig& cfg, const std::vector<QsaRecord>& qsa, TimeUs t_ref, std::string* error) {
  auto& hs = cfg.pipeline.heads;
  for (int s = 0; s < hs.n_heads; ++s) {
    auto& h = hs.head[static_cast<std::size_t>(s)];
    const QsaRecord* best = alignmentAt(qsa, h.id, t_ref);
    if (!best) {
      if (error) *error = "QSA1B has no alignment for head " + std::to_string(h.id);
      return false;
    }
    h.q_Si_B = quatFromScalarFirst(best->q).normalized();
  }
  return true;
}

}  // namespace boresight::io

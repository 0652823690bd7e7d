// The node's configuration file: the platform file it names plus the node's own keys, validated at
// start-up with "FILE: KEY: reason" errors. Unknown keys are errors (a typo never passes silently).
#include <boresight/io/core_config.h>
#include <boresight/io/config_keys.h>
#include <boresight/io/yaml_file.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/node/node.h>

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <vector>
#include <set>
#include <sstream>

namespace boresight::node {
namespace {

struct Reader {
  std::string file;
  std::string err;
  /// "FILE:LINE: key 'KEY': reason" (the line of `at` when it has one).
  bool fail(const std::string& key, const std::string& why, const YAML::Node& at = YAML::Node()) {
    if (err.empty()) err = io::yamlPlace(file, io::yamlLine(at)) + "key '" + key + "': " + why;
    return false;
  }
  bool keys(const YAML::Node& n, const std::string& where, const std::set<std::string>& allowed) {
    if (!n.IsMap()) return fail(where.empty() ? "(top)" : where, "expected a map", n);
    for (const auto& kv : n) {
      const std::string k = kv.first.as<std::string>();
      if (!allowed.count(k))
        return fail(where.empty() ? k : where + "." + k,
                    io::unknownKeyMessage(k, std::vector<std::string>(allowed.begin(), allowed.end())), kv.first);
    }
    return true;
  }
  bool num(const YAML::Node& n, const std::string& key, const std::string& path, double& v, double lo, double hi) {
    if (!n[key]) return true;
    double x = 0;
    try {
      x = n[key].as<double>();
    } catch (const YAML::Exception&) {
      return fail(path, "expected a number", n[key]);
    }
    if (!std::isfinite(x) || x < lo || x > hi) {
      std::ostringstream s;
      s << "must be within " << lo << " .. " << hi << " (not " << n[key].Scalar() << ")";
      return fail(path, s.str(), n[key]);
    }
    v = x;
    return true;
  }
  bool str(const YAML::Node& n, const std::string& key, const std::string& path, std::string& v) {
    if (!n[key]) return true;
    if (!n[key].IsScalar() || n[key].as<std::string>().empty()) return fail(path, "expected a non-empty string", n[key]);
    v = n[key].as<std::string>();
    return true;
  }
  bool boolean(const YAML::Node& n, const std::string& key, const std::string& path, bool& v) {
    if (!n[key]) return true;
    try {
      v = n[key].as<bool>();
    } catch (const YAML::Exception&) {
      return fail(path, "expected true or false", n[key]);
    }
    return true;
  }
};

std::string dirOf(const std::string& p) {
  const auto k = p.find_last_of('/');
  return k == std::string::npos ? std::string(".") : p.substr(0, k);
}

bool loadTop(const YAML::Node& top, const std::string& path, Reader& r, NodeConfig& out);

}  // namespace

bool loadNodeConfig(const std::string& path, NodeConfig& out, std::string* error) {
  out = NodeConfig{};
  out.file = path;
  Reader r{path, {}};
  YAML::Node top;
  if (!io::loadYamlFile(path, top, error, "node configuration file")) return false;
  auto done = [&](bool ok) {
    if (!ok && error) *error = r.err;
    return ok;
  };
  try {
    return done(loadTop(top, path, r, out));
  } catch (const YAML::Exception& e) {  // a value of the wrong shape (a map where a string goes)
    if (error) *error = io::yamlPlace(path, e.mark.line + 1) + e.msg;
    return false;
  }
}

namespace {
bool loadTop(const YAML::Node& top, const std::string& path, Reader& r, NodeConfig& out) {
  auto done = [](bool ok) { return ok; };
  if (!r.keys(top, "", {"platform", "overlay", "state_file", "mountings", "lcm_url", "channels", "lookahead_s", "health_period_s",
                        "max_time_jump_s", "time_jump_confirm", "max_rate_hz", "ring_capacity", "calibration"}))
    return done(false);
  if (!top["platform"]) return done(r.fail("platform", "required (the platform configuration file)", top));
  std::string platform;
  if (!r.str(top, "platform", "platform", platform)) return done(false);
  if (platform[0] != '/') platform = dirOf(path) + "/" + platform;
  out.platform_file = platform;
  io::PlatformConfig pc;
  std::string perr;
  if (!io::loadPlatformConfig(platform, pc, &perr)) return done(r.fail("platform", perr, top["platform"]));
  std::string m = pc.mounting_from_qsa1b ? "log" : "config";
  if (!r.str(top, "mountings", "mountings", m)) return done(false);
  if (m != "log" && m != "config")
    return done(r.fail("mountings", "expected 'log' (NOMINAL_MOUNTINGS message) or 'config'", top["mountings"]));
  if (m == "config" && pc.mounting_from_qsa1b)
    return done(r.fail("mountings", "the platform file takes its mountings from QSA1B: use 'log'", top["mountings"]));
  out.mountings_from_log = m == "log";
  if (out.mountings_from_log)
    for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
      pc.mounting_source[static_cast<std::size_t>(s)] = "the first NOMINAL_MOUNTINGS message (mountings: log)";
  io::OverlayUse ovu;
  if (top["state_file"]) {
    if (!r.str(top, "state_file", "state_file", out.state_file)) return done(false);
    if (!out.state_file.empty() && out.state_file[0] != '/') out.state_file = dirOf(path) + "/" + out.state_file;
  }
  if (top["overlay"]) {
    if (!r.str(top, "overlay", "overlay", out.overlay)) return done(false);
    if (out.overlay[0] != '/') out.overlay = dirOf(path) + "/" + out.overlay;
    io::OverlayUses uses;
    uses.thermal = true;
    // The accelerometer terms correct every sample before the core's CRN (the published alpha_acc_B), as
    // in process and the audit; the worker still gets the samples as measured, as calibrate's feed does
    // (method A estimates its own accelerometer terms from them).
    uses.accelerometer = true;
    if (!io::applyOverlay(out.overlay, "boresightd", uses, pc, ovu, &perr)) return done(r.fail("overlay", perr, top["overlay"]));
    out.thermal_model = ovu.thermal_model;
    for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
      if (pc.mounting_source[static_cast<std::size_t>(s)].rfind("overlay", 0) == 0) out.overlay_mounting_mask |= 1u << s;
    // Every head's mounting from the overlay: nothing to wait for (later NOMINAL_MOUNTINGS messages are
    // counted, not applied).
    if (out.overlay_mounting_mask == (1u << pc.pipeline.heads.n_heads) - 1) out.mountings_from_log = false;
  }
  out.pipeline = pc.pipeline;
  for (int a = 0; a < 3; ++a) out.acc_white_noise_radps2[a] = pc.noise_in_use.accWhiteSigma(a);
  out.model_in_use = io::modelInUseLines(pc, ovu);
  if (!r.str(top, "lcm_url", "lcm_url", out.lcm_url)) return done(false);
  if (top["channels"]) {
    const YAML::Node c = top["channels"];
    if (!r.keys(c, "channels", {"star_head", "accel", "star_vectors", "mountings", "orbit", "attitude", "monitor",
                                 "calibration", "health", "command"}))
      return done(false);
    Channels& ch = out.channels;
    for (auto p : {std::make_pair("star_head", &ch.star_head), std::make_pair("accel", &ch.accel),
                   std::make_pair("star_vectors", &ch.star_vectors), std::make_pair("mountings", &ch.mountings),
                   std::make_pair("orbit", &ch.orbit), std::make_pair("attitude", &ch.attitude),
                   std::make_pair("monitor", &ch.monitor), std::make_pair("calibration", &ch.calibration),
                   std::make_pair("health", &ch.health), std::make_pair("command", &ch.command)})
      if (!r.str(c, p.first, std::string("channels.") + p.first, *p.second)) return done(false);
    std::set<std::string> names{ch.star_head, ch.accel, ch.star_vectors, ch.mountings, ch.orbit,
                                ch.attitude, ch.monitor, ch.calibration, ch.health, ch.command};
    if (names.size() != 10) return done(r.fail("channels", "every channel needs its own name", c));
  }
  double v = 0;
  if (!r.num(top, "lookahead_s", "lookahead_s", out.lookahead_s, 0.001, 600)) return done(false);
  if (!r.num(top, "health_period_s", "health_period_s", out.health_period_s, 0.01, 86400)) return done(false);
  if (top["max_time_jump_s"])
    return done(r.fail("max_time_jump_s",
                       "no longer read: every tag further than lookahead_s from the data time needs time_jump_confirm "
                       "messages in a row to agree; remove the key",
                       top["max_time_jump_s"]));
  v = out.time_jump_confirm;
  if (!r.num(top, "time_jump_confirm", "time_jump_confirm", v, 1, 16)) return done(false);
  if (v != std::floor(v)) return done(r.fail("time_jump_confirm", "expected a whole number", top["time_jump_confirm"]));
  out.time_jump_confirm = static_cast<int>(v);
  if (top["max_rate_hz"]) {
    const YAML::Node c = top["max_rate_hz"];
    if (!r.keys(c, "max_rate_hz", {"star_head", "accel", "star_vectors"})) return done(false);
    if (!r.num(c, "star_head", "max_rate_hz.star_head", out.max_head_rate_hz, 0.1, 1e5) ||
        !r.num(c, "accel", "max_rate_hz.accel", out.max_accel_rate_hz, 0.1, 1e5) ||
        !r.num(c, "star_vectors", "max_rate_hz.star_vectors", out.max_star_rate_hz, 0.1, 1e5))
      return done(false);
  }
  v = static_cast<double>(out.ring_capacity);
  if (!r.num(top, "ring_capacity", "ring_capacity", v, 16, 1 << 24)) return done(false);
  out.ring_capacity = static_cast<std::size_t>(v);
  if ((out.ring_capacity & (out.ring_capacity - 1)) != 0 || static_cast<double>(out.ring_capacity) != v)
    return done(r.fail("ring_capacity", "must be a power of two", top["ring_capacity"]));
  if (top["calibration"]) {
    const YAML::Node c = top["calibration"];
    CalibrationConfig& k = out.calibration;
    if (!r.keys(c, "calibration", {"enabled", "cadence_s", "min_span_s", "apply_lag_epochs", "decimation_s",
                                    "max_observations", "apply", "apply_common_rotation",
                                    "frame_change_min_interval_s", "frame_change_max_chi2_per_dof", "hold_for_command",
                                    "method", "raw_passes", "time_offset", "acc_scale", "harmonics"}))
      return done(false);
    std::string method = "crn";
    if (!r.str(c, "method", "calibration.method", method)) return done(false);
    if (method != "crn" && method != "attitude")
      return done(r.fail("calibration.method", "expected 'crn' (the CRN-domain solver) or 'attitude' (the attitude-domain estimate)",
                         c["method"]));
    k.method = method == "attitude" ? CalibrationConfig::Method::kAttitude : CalibrationConfig::Method::kCrn;
    v = k.raw_passes;
    if (!r.num(c, "raw_passes", "calibration.raw_passes", v, 1, 10)) return done(false);
    if (v != std::floor(v)) return done(r.fail("calibration.raw_passes", "expected a whole number", c["raw_passes"]));
    k.raw_passes = static_cast<int>(v);
    v = k.raw_harmonics;
    if (!r.num(c, "harmonics", "calibration.harmonics", v, 0, 8)) return done(false);
    if (v != std::floor(v)) return done(r.fail("calibration.harmonics", "expected a whole number", c["harmonics"]));
    k.raw_harmonics = static_cast<int>(v);
    if (!r.boolean(c, "time_offset", "calibration.time_offset", k.raw_time_offset) ||
        !r.boolean(c, "acc_scale", "calibration.acc_scale", k.raw_acc_scale))
      return done(false);
    if (k.method == CalibrationConfig::Method::kAttitude) {
      // As `boresight calibrate --method attitude`: the noise in use (platform file, overlay), the bias and
      // (time_offset, acc_scale) the accelerometer's time offset and scale estimated, the noise models
      // fitted to the data; not determined above the platform's mounting uncertainty.
      if (const std::string e = pc.noise_in_use.missing(); !e.empty())
        return done(r.fail("calibration.method", "attitude needs a noise model for " + e + " (the platform file's noise section)", c["method"]));
      calib::RawBoundOptions ro;
      ro.fit_noise = true;
      ro.time_offset = k.raw_time_offset;
      ro.scale = k.raw_acc_scale;
      const double unobs = pc.mounting_uncertainty_arcsec > 0 ? std::min(pc.mounting_uncertainty_arcsec, 3600.0) : 3600.0;
      ro.unobservable_sigma_rad = unobs * kRadPerArcsec;
      out.raw_not_determined_rad = ro.unobservable_sigma_rad;
      out.raw_config = calib::rawBoundConfig(pc.pipeline, pc.noise_in_use, ro);
      if (const std::string e = out.raw_config->validate(); !e.empty()) return done(r.fail("calibration.method", e, c["method"]));
    }
    if (!r.boolean(c, "enabled", "calibration.enabled", k.enabled) || !r.boolean(c, "apply", "calibration.apply", k.apply) ||
        !r.boolean(c, "apply_common_rotation", "calibration.apply_common_rotation", k.apply_common_rotation) ||
        !r.boolean(c, "hold_for_command", "calibration.hold_for_command", k.hold_for_command) ||
        !r.num(c, "cadence_s", "calibration.cadence_s", k.cadence_s, 60, 1e8) ||
        !r.num(c, "min_span_s", "calibration.min_span_s", k.min_span_s, 60, 1e8) ||
        !r.num(c, "decimation_s", "calibration.decimation_s", k.decimation_s, 0.5, 3600) ||
        !r.num(c, "frame_change_min_interval_s", "calibration.frame_change_min_interval_s", k.frame_change_min_interval_s, 0, 1e8) ||
        !r.num(c, "frame_change_max_chi2_per_dof", "calibration.frame_change_max_chi2_per_dof", k.frame_change_max_chi2_per_dof, 0.01, 1e6))
      return done(false);
    const double head_dt = 1.0 / out.pipeline.crn_attitude.fs_hz;
    if (k.decimation_s < head_dt * (1 - 1e-9))
      return done(r.fail("calibration.decimation_s",
                         "must be at least the head sampling interval (" + std::to_string(head_dt) + " s at crn_attitude.fs_hz)",
                         c["decimation_s"]));
    v = k.apply_lag_epochs;
    if (!r.num(c, "apply_lag_epochs", "calibration.apply_lag_epochs", v, 1, 1e6)) return done(false);
    k.apply_lag_epochs = static_cast<int>(v);
    v = static_cast<double>(k.max_observations);
    if (!r.num(c, "max_observations", "calibration.max_observations", v, 0, 1e8)) return done(false);
    k.max_observations = static_cast<std::size_t>(v);
  }
  return done(true);
}
}  // namespace

}  // namespace boresight::node

// The model a command ran with, as JSON (calibrate's result file, audit.json): every head and
// accelerometer axis's noise model with its source (the platform file or an overlay), the per-sample
// sigmas the core weights the heads with, every head's mounting with its source, and the overlay's
// applied / not applied parts.
#pragma once

#include <boresight/io/core_config.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/io/overlay_yaml.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace boresight::cli {

inline nlohmann::ordered_json modelInUseJson(const io::PlatformConfig& pc, const io::OverlayUse& use) {
  using J = nlohmann::ordered_json;
  J noise = J::array();
  const model::NoiseInUse& u = pc.noise_in_use;
  for (int s = 0; s < u.n_heads; ++s)
    for (int a = 0; a < model::kHeadAxes; ++a) {
      const auto& x = u.head[static_cast<std::size_t>(s)][static_cast<std::size_t>(a)];
      noise.push_back({{"sensor", "head " + std::to_string(u.head_id[static_cast<std::size_t>(s)])},
                       {"axis", model::headAxisKey(model::HeadAxis(a))},
                       {"model", io::axisNoiseYaml(x.noise, true)},
                       {"sigma_arcsec", std::sqrt(x.noise.model.variance()) * kArcsecPerRad},
                       {"source", x.source}});
    }
  for (int a = 0; a < 3; ++a) {
    const auto& x = u.acc[static_cast<std::size_t>(a)];
    noise.push_back({{"sensor", "accelerometer"},
                     {"axis", model::accAxisKey(a)},
                     {"model", io::axisNoiseYaml(x.noise, false)},
                     {"sigma_rad_s2", std::sqrt(x.noise.model.variance())},
                     {"source", x.source}});
  }
  J heads = J::array();
  for (int s = 0; s < pc.pipeline.heads.n_heads; ++s) {
    const core::HeadConfig& h = pc.pipeline.heads.head[static_cast<std::size_t>(s)];
    const Quat& q = h.q_Si_B;
    heads.push_back({{"id", h.id},
                     {"sigma_cross_arcsec", h.sigma_cross_rad * kArcsecPerRad},
                     {"sigma_about_arcsec", h.sigma_roll_rad * kArcsecPerRad},
                     {"sigma_star_arcsec", h.sigma_star_rad * kArcsecPerRad},
                     {"q_Si_B", {q.w(), q.x(), q.y(), q.z()}},
                     {"mounting_source", pc.mounting_source[static_cast<std::size_t>(s)]}});
  }
  J j;
  j["platform_file"] = pc.file;
  j["noise"] = noise;
  j["heads"] = heads;
  if (use.file.empty()) {
    j["overlay"] = nullptr;
  } else {
    j["overlay"] = {{"file", use.file}, {"written_by", use.overlay.written_by}, {"applied", use.applied},
                    {"not_applied", use.not_applied}};
  }
  return j;
}

}  // namespace boresight::cli

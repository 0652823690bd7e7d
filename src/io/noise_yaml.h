// The YAML reader of a noise section (io/overlay_yaml.h describes the form), shared by the platform
// file (core_config.cc) and the overlay (overlay_yaml.cc). Private to src/io.
#pragma once

#include "yaml_check.h"

#include <boresight/model/overlay.h>

namespace boresight::io::yamlcheck {

/// Reads the mapping under `noise:` (`prefix` is its key path, "noise"). Validity spans (valid_from,
/// valid_to) only when `with_validity` (overlays); the platform file refuses them with the reason.
/// Throws Error.
model::NoiseSection readNoiseSection(const YAML::Node& n, const std::string& prefix, bool with_validity);

/// Reads one axis (a list of terms) with the unit of its level: head axes in arcsec, accelerometer
/// axes in rad/s^2. Throws Error.
model::AxisNoise readAxisNoise(const YAML::Node& n, const std::string& key, bool head_axis);

}  // namespace boresight::io::yamlcheck

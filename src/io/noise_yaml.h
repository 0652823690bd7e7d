// The YAML readers of a noise section (io/overlay_yaml.h describes the form) and of a data_events
// section, shared by the platform file (core_config.cc) and the overlay (overlay_yaml.cc). Private to
// src/io.
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

/// Reads the mapping under `data_events:` (`prefix` is its key path) over `base`: rates given replace
/// the base's, a `heads` list replaces its list. Rates in runs per day, 0..1e6; head ids 1..255, each
/// once (whether they are the platform's heads is the caller's check). Throws Error.
model::DataEventRates readDataEvents(const YAML::Node& n, const std::string& prefix, model::DataEventRates base);

}  // namespace boresight::io::yamlcheck

// Simulation scenarios: a YAML file (config/sim_*.yaml) parsed and validated into a plain struct.
//
// Every key is checked: unknown keys, wrong types, out-of-range values and malformed effects give
// one error "FILE:LINE: key 'heads[1].noise_cross_arcsec': reason". Units are in the key names
// (_deg, _arcsec, _s, _us, _km, _Nm, _rad_s2 ...); frames are documented in config/sim_gracefo.yaml.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/model/effects.h>
#include <boresight/model/sensors.h>
#include <boresight/sim/attitude.h>
#include <boresight/sim/orbit.h>

#include <string>
#include <vector>

namespace boresight::sim {

struct OutputConfig {
  bool lcm_log = true;
  double gnv1b_interval_s = 1.0;
  /// Star vectors (SCV1A file, STAR_VECTORS LCM messages): every head's stars at the first sample at
  /// or after each multiple of this interval, s; 0: none. At most star_vectors_per_head (brightest).
  double star_vectors_interval_s = 10.0;
  int star_vectors_per_head = 8;
  std::string version = "04";  ///< the release field of the file names (SCA1A_2023-06-01_C_04.txt)
};

struct Scenario {
  std::string file;                  ///< where it was read from (messages, truth.yaml)
  char satellite = 'C';
  TimeUs start = 0;                  ///< GPS microseconds past 2000-01-01 12:00:00 GPS
  double duration_s = 86400;         ///< default duration (the command line overrides it)
  std::string star_catalogue;        ///< resolved path
  OrbitConfig orbit;
  AttitudeConfig attitude;
  model::HeadConfig head_defaults;    ///< what every head starts from (an overlay's new heads too)
  std::vector<model::HeadConfig> heads;
  double mounting_error_sigma_rad = 0;  ///< random extra mounting error per head axis (drawn from the seed)
  model::AccelConfig acc;
  std::vector<model::EffectSpec> effects;
  OutputConfig output;
};

/// Parses YAML text. `file` names it in messages; relative paths (stars, GNV1B, base) resolve against `dir`.
/// Overlays: a top-level `base: FILE` loads that scenario first and the keys given here replace its
/// values (a list - heads, manoeuvres, effects - replaces the base's list whole); at most 4 levels.
/// `base: [FILE, LAYER...]`: the first file's scenario, then the keys of each layer in order (a layer
/// is an overlay without a base of its own, e.g. a noise preset such as config/preset_realistic.yaml),
/// then this file's keys. Two keys serve layers that must stack on any scenario: `add_effects` (appended
/// to the effects so far; `effects` replaces them) and `head_overrides: [{id, KEY: value...}]` (keys of
/// an existing head changed in place, the others kept; an unknown id is an error).
bool parseScenario(const std::string& yaml_text, const std::string& file, const std::string& dir, Scenario& out,
                   std::string* error);
bool loadScenario(const std::string& path, Scenario& out, std::string* error);

/// Adds effects given as "NAME:key=value,..." (the --effect option), checking their target heads exist.
bool addEffectArgs(Scenario& sc, const std::vector<std::string>& args, std::string* error);

// Calendar dates: io::parseGpsCalendar and io::formatDate (boresight/io/time_format.h).

}  // namespace boresight::sim

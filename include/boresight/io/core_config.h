// Platform configuration files (config/*.yaml) parsed and validated into the real-time core's plain
// config structs. The core never reads files; this is the only place that turns YAML into them.
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/io/level1.h>

#include <string>
#include <vector>

namespace boresight::io {

struct PlatformConfig {
  std::string platform;          ///< name from the file
  core::PipelineConfig pipeline;  ///< ready for Pipeline::configure()
  bool mounting_from_qsa1b = false;  ///< the heads' q_Si_B must come from a QSA1B file
};

/// Parses and validates a platform file. On failure returns false and sets *error to
/// "FILE: KEY: reason" (or "FILE:LINE:COL: reason" for YAML syntax errors).
bool loadPlatformConfig(const std::string& path, PlatformConfig& out, std::string* error);

/// Fills the heads' mountings from QSA1B records (q_Si_B); the latest record of each head at or
/// before `t_ref` wins. False with *error when a configured head has no record.
bool applyQsa1bMounting(PlatformConfig& cfg, const std::vector<QsaRecord>& qsa, TimeUs t_ref, std::string* error);

}  // namespace boresight::io

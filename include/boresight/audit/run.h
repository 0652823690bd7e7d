// The model audit over recorded telemetry: what `boresight audit` runs and what the real-sample test
// runs, in one place.
//
//   files -> stream::classifyInputs / prepareConfig (SCA1A, ACC1A, QSA1B mountings, LCM log)
//         -> stream::Engine (-> Collector as InputObserver and RowSink)
//   GNI1B (else GNV1B) files, an LCM log's ORBIT messages -> the same engine, in time order
//         -> Collector::onOrbit (the orbit context)
//   SCA1B (+ CLK1B) -> ReferenceFeed -> Collector::addReference (interleaved with the head epochs)
//   -> analyse() -> AuditResult
//
// Other Level-1 products among the inputs are listed as ignored (not an error).
#pragma once

#include <boresight/audit/audit.h>
#include <boresight/core/pipeline.h>
#include <boresight/io/core_config.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/stream/source.h>

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace boresight::audit {

struct RunRequest {
  std::string config;               ///< platform file (config/gracefo.yaml)
  /// A model overlay (io/overlay_apply.h): its noise replaces the platform file's (the noise levels the
  /// tests compare with), its mountings the nominal ones; the rest is reported as not applied.
  std::string overlay;
  std::vector<std::string> inputs;  ///< Level-1 files or LCM logs, recognised by content
  AuditOptions options;
  /// The truth to compare the estimates with (a simulation's: audit/simulated.h readTruthFile reads a
  /// truth.yaml); none: no comparison. The audit library does not read the simulator's files.
  std::optional<Truth> truth;
  double lookahead_s = 2.0;         ///< out-of-order tolerance of the inputs
  bool strict = false;              ///< stop at the first malformed input line
  /// Progress while replaying (every `progress_every_s` of data time), e.g. to stderr; may be empty.
  std::function<void(const std::string&)> progress;
  double progress_every_s = 6 * 3600.0;
};

struct RunOutput {
  AuditResult result;
  std::vector<std::string> inputs;   ///< "FILE: role" for every file used
  std::vector<std::string> notes;    ///< ignored files, the reference's time base, ...
  std::string reference_time_base;   ///< empty without SCA1B
  stream::Counters counters;         ///< every input record: used or rejected with its reason
  core::Health health;
  std::uint64_t epochs = 0, rows = 0, orbit_samples = 0, orbit_rejected = 0, reference_samples = 0,
                reference_dropped = 0;
  double span_s = 0;
  TimeUs first_epoch = 0, last_epoch = 0;  ///< the head epochs' span (GPS)
  bool truth_given = false;
  io::PlatformConfig platform;        ///< the configuration the audit ran with (noise and mountings in use)
  io::OverlayUse overlay;             ///< what was taken from --overlay (empty file: none)
  std::vector<std::string> model_in_use;  ///< io::modelInUseLines plus validity warnings, for people
};

/// Runs the audit. False with *error (file:line: reason) on bad input; the analysis' own limits (too
/// short a span for a family, ...) are in the result, not errors.
bool runAudit(const RunRequest& req, RunOutput& out, std::string* error);

}  // namespace boresight::audit

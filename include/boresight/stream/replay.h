// Replaying recorded telemetry through the engine: input files sorted by content, the core
// configuration completed for them, one source per file. Every program that replays files (process,
// calibrate, audit, noise) opens its replay with openReplay() and starts it with startReplay():
//
//   stream::ReplayRequest rq;  rq.program = "boresight process";  rq.config = ...;  rq.inputs = files;
//   stream::Replay r;
//   if (!stream::openReplay(rq, r, &err)) ...;   // platform, overlay, inputs by content, QSA1B, engine
//   ... r.in.ignored: the program says what it ignores; r.engine->addSink / addObserver ...
//   if (!stream::startReplay(r, &err)) ...;      // one source per file (the orbit when wanted)
//   r.engine->run();
//
// The steps below are its parts.
#pragma once

#include <boresight/io/core_config.h>
#include <boresight/io/level1.h>
#include <boresight/io/overlay_apply.h>
#include <boresight/stream/engine.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace boresight::stream {

struct ReplayInputs {
  std::vector<std::string> sca, acc, lcm;  ///< SCA1A, ACC1A/ACT1A files; LCM logs
  std::vector<std::string> scv;            ///< SCV1A star vectors (the simulator's product)
  std::vector<std::string> qsa;            ///< QSA1B files (read up front: mountings)
  std::vector<io::QsaRecord> qsa_records;
  std::vector<std::pair<std::string, std::string>> ignored;  ///< (file, product): not a replay input
  /// GNV1B / GNI1B files (orbit): also listed in `ignored`, since most runs do not read them;
  /// addSources opens them when the engine wants the orbit (Engine::wantsOrbit: a thermal model in the
  /// core, or an observer that takes the orbit); calibrate's thermal fit reads them from here.
  std::vector<std::string> orbit;
};

/// Sorts the files by their content (LCM sync word, Level-1 header). Other Level-1 products (GNV1B,
/// SCA1B, CLK1B, ...) go to `ignored`. False with *error for a file that is neither (file:line:
/// reason), an unreadable QSA1B, or Level-1 star/accelerometer files mixed with LCM logs (the same
/// samples twice).
bool classifyInputs(const std::vector<std::string>& files, ReplayInputs& in, std::string* error);

/// Completes the platform configuration for these inputs: the heads' mountings from QSA1B at the
/// first head tag when the platform asks for them (heads.mounting: qsa1b), and the accelerometer
/// path off when no input carries accelerometer samples. False with *error (no star input, no QSA1B
/// where one is needed, a head without a QSA1B record).
bool prepareConfig(const ReplayInputs& in, const io::ReadOptions& opt, io::PlatformConfig& pc, std::string* error);

/// The heads' and the accelerometer's sampling intervals (median over the first few thousand samples
/// of the inputs) against the platform's crn_attitude.fs_hz and crn_acc.fs_hz
/// (plausibility::rateMatches): a mismatch is an error that gives both rates and the consequence.
/// prepareConfig() calls it; the node's replay too.
bool checkSampleRates(const ReplayInputs& in, const io::ReadOptions& opt, const core::PipelineConfig& cfg,
                      std::string* error);

/// One source per input file, in the order SCA1A files, ACC1A files, SCV1A files, orbit files (only
/// when engine.wantsOrbit(): set the thermal model and add the observers first), LCM logs (that order
/// also breaks ties at equal time tags). `prefetch`: each is read on its own worker thread.
bool addSources(const ReplayInputs& in, const io::ReadOptions& opt, bool prefetch, Engine& engine, std::string* error);

/// What a program replays and how.
struct ReplayRequest {
  std::string program;              ///< "boresight process", ... (in the overlay's applied / not applied lines)
  std::string config;               ///< platform file
  std::string overlay;              ///< model overlay, empty: none
  io::OverlayUses uses;             ///< the overlay's parts the program applies
  std::vector<std::string> inputs;  ///< files, sorted by content
  bool strict = false;              ///< stop at the first malformed input line
  double lookahead_s = 2.0;         ///< the assembler's look-ahead
  /// False: SCV1A star vectors among the inputs are moved to `ignored` (not an input of the program).
  bool star_vectors = true;
  /// True: the overlay's thermal terms are set in the engine's core (the prediction of blind pairs).
  bool thermal_in_core = false;
};

/// An opened replay: the platform with the overlay and the QSA1B mountings, the inputs by content, and
/// the engine configured with them (no source yet: sinks and observers go in before startReplay()).
struct Replay {
  io::PlatformConfig pc;
  io::OverlayUse overlay;
  ReplayInputs in;
  io::ReadOptions opt;
  std::unique_ptr<Engine> engine;
};

/// Loads the platform file, applies the overlay, sorts the inputs, completes the configuration for them
/// (prepareConfig) and configures the engine (and its thermal model with thermal_in_core). False with
/// *error (file:line: reason) at the first step that fails.
bool openReplay(const ReplayRequest& rq, Replay& r, std::string* error);

/// One source per input (addSources, read ahead on worker threads). False with *error.
bool startReplay(Replay& r, std::string* error);

}  // namespace boresight::stream

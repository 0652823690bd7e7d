// The model audit of simulated data (library boresight_audit_sim: the audit library itself does not
// link the simulator), in memory: the simulator's samples go through the same path the
// `boresight audit` command uses for files, without writing any.
//
//   sim::Simulator (its own thread) -> bounded queue -> stream::Source -> stream::Engine -> core::Pipeline
//                                                         |                    |-> InputObserver -> Collector
//                                                         |                    \-> RowSink -------> Collector
//                                                         \-> orbit samples -> Collector::addOrbit
//   Collector -> analyse() -> AuditResult
//
// Head samples become stream::Sample's as Sca1aSource makes them from SCA1A records (a blinded head
// delivers nothing, as in the files), accelerometer samples as Acc1aSource does from ACC1A, orbit
// samples as model::orbitSampleFromInertial does from GNI1B. Star vectors are not audit inputs and are
// dropped. Memory does not depend on the span: the simulator runs on a worker thread and waits while
// the queue holds `queue_batches` batches of `batch_size` samples; the Collector's bins are bounded by
// AuditOptions::max_bins.
//
// The baseline model is what a user of the simulated files would configure (pipelineConfigFor): the
// scenario's NOMINAL mountings (what QSA1B carries, without the mounting errors), the heads' nominal
// noise model (sigma_cross, sigma_roll), the nominal C_B_A; effects are not part of it.
#pragma once

#include <boresight/audit/audit.h>
#include <boresight/sim/scenario.h>
#include <boresight/stream/source.h>

#include <cstdint>
#include <functional>
#include <string>

namespace boresight::sim {
class Simulator;
}

namespace boresight::audit {

/// The core configuration a user of the scenario's files would run: `base` (CRNs, fusion settings;
/// the defaults equal config/gracefo.yaml's) with every scenario head's id, nominal q_Si_B,
/// boresight and noise model, the nominal C_B_A and the CRN input rates of the heads and the
/// accelerometer. False with *error when the scenario has no heads, too many, or heads of different
/// rates.
bool pipelineConfigFor(const sim::Scenario& sc, const core::PipelineConfig& base, core::PipelineConfig& out,
                       std::string* error);

/// The truth of an initialised simulator: the scenario's effects and every head's mounting error
/// (the configured one plus the seed's random draw).
Truth truthOf(const sim::Simulator& s);

/// The same from a simulator's truth.yaml (sim::readTruthYaml): the injected effects (as simulated)
/// and each head's constant mounting error (head frame, the drawn part included), for
/// RunRequest::truth. False with *error ("FILE:LINE: key 'k': reason").
bool readTruthFile(const std::string& path, Truth& out, std::string* error);

struct SimulatedOptions {
  std::uint64_t seed = 1;
  double duration_s = 0;  ///< 0: the scenario's duration_s
  AuditOptions audit;
  core::PipelineConfig base{};  ///< CRNs and fusion settings (pipelineConfigFor replaces heads and C_B_A)
  /// Hand the truth to analyse() for its parameter comparison. Off by default: the audit is not told
  /// what was injected.
  bool compare_truth = false;
  std::size_t batch_size = 1024;   ///< samples per hand-over from the simulator thread
  std::size_t queue_batches = 8;   ///< batches the queue holds at most
};

/// What a simulated run fed into the Collector.
struct SimulatedRun {
  bool ok = false;
  std::string error;               ///< when !ok: what failed (scenario, simulator, core configuration)
  Truth truth;
  core::PipelineConfig config{};   ///< what the core and the Collector ran
  stream::Counters counters;       ///< the engine's input counters
  std::uint64_t epochs = 0, rows = 0, orbit_samples = 0;
  bool simulated_to_end = false;   ///< the simulator ran its whole span (false when the consumer stopped it)
  double collect_wall_s = 0;       ///< simulator + engine + Collector, wall clock
};

/// The feed alone: runs the simulator and a stream::Engine configured with `cfg`, hands the engine's
/// validated inputs to `observer` and its rows to `sink` (either may be null) and every orbit sample
/// to `orbit` (may be empty), on the caller's thread. run.truth and run.config are filled.
SimulatedRun feedSimulated(const sim::Scenario& sc, const SimulatedOptions& opt, const core::PipelineConfig& cfg,
                           stream::InputObserver* observer, stream::RowSink* sink,
                           const std::function<void(const model::OrbitSample&)>& orbit);

/// Configures `c` for the scenario (pipelineConfigFor(sc, opt.base)) and feeds it a simulated span
/// (feedSimulated). The Collector is then ready for analyse().
SimulatedRun collectSimulated(const sim::Scenario& sc, const SimulatedOptions& opt, Collector& c);

struct SimulatedAudit {
  SimulatedRun run;
  AuditResult result;
  double analyse_wall_s = 0;  ///< analyse() alone, wall clock
};

/// collectSimulated + analyse. result is empty when !run.ok.
SimulatedAudit auditSimulated(const sim::Scenario& sc, const SimulatedOptions& opt);

}  // namespace boresight::audit

// The streaming replay engine: sources -> epoch assembler (bounded look-ahead) -> core::Pipeline ->
// sinks. Memory does not depend on the span: the sources read in chunks, the assembler buffers at
// most AssemblerConfig::max_buffered samples, the core is fixed-size and rows go straight to the
// sinks. `boresight process`, `calibrate` and the audit run it over files; `boresightd` runs it on a
// stream::PushSource fed by its message handlers, with a StepHook for its work between core steps.
//
//   stream::Engine e;
//   if (!e.configure(cfg, &err)) ...;
//   e.addSource(std::move(sca_source));  e.addSink(&csv);  e.addObserver(&span);  // optional
//   auto r = e.run();                    // kDone, kPending (live source), kError (e.error())
//   e.counters();                        // read == used + rejected, with reasons
#pragma once

#include <boresight/core/pipeline.h>
#include <boresight/stream/assembler.h>
#include <boresight/model/orbit_context.h>
#include <boresight/stream/sinks.h>
#include <boresight/stream/source.h>

#include <memory>
#include <string>
#include <vector>

namespace boresight::stream {

/// The orbit angles of an orbit sample (model/orbit_context.h: GNV1B rotated by the Earth rotation
/// angle): u, du/dt and beta as the core's thermal prediction takes them. False when the position and
/// velocity span no orbit plane; then the angles are NaN (the core counts that input as non-finite).
/// The engine and the node step Pipeline::stepOrbit with it.
bool orbitAngles(const Sample& s, model::OrbitSample& out);

/// What a driver does between the core's steps, on the engine's thread (the node: new mountings,
/// ground commands and finished calibrations at a head-epoch boundary; its latency figures, the
/// worker's schedule and the health messages after a step). Must not allocate, throw or block when
/// the engine runs on a real-time thread.
class StepHook {
 public:
  virtual ~StepHook() = default;
  /// A head-epoch boundary: the core is about to step the epoch `e` (what the driver changes in the
  /// core now applies from this epoch on).
  virtual void beforeHeads(const core::HeadEpoch& /*e*/) {}
  /// The core stepped an input: kind kHead (a head epoch at t), kAccel, kStar (a star epoch) or kOrbit,
  /// with the core's status and the step's wall time in ns (the core's step alone; 0 for orbit
  /// samples). After the observers saw the input, before the rows it completed go to the sinks.
  virtual void afterStep(Sample::Kind /*kind*/, TimeUs /*t*/, core::Status /*st*/, double /*wall_ns*/) {}
};

class Engine {
 public:
  enum class Result : std::uint8_t { kDone, kPending, kError };

  explicit Engine(const AssemblerConfig& acfg = {});
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  /// Configures the core. False with *error when the core rejects the configuration.
  bool configure(const core::PipelineConfig& cfg, std::string* error);
  /// The thermal model of the heads' relative deformation (Pipeline::setThermalModel), after
  /// configure(): from then on the engine reads the orbit inputs (addSources opens GNI1B / GNV1B files;
  /// an LCM log's ORBIT messages are samples) and steps the core's thermal prediction with them.
  /// False with *error when the core refuses the model.
  bool setThermalModel(const core::ThermalHarmonicModel& m, std::string* error);
  /// The orbit is read: the core has a thermal model, or an observer wants the orbit. Otherwise orbit
  /// samples are counted as rejected (Reject::kNoConsumer) and orbit files are not opened.
  bool wantsOrbit() const;
  /// Orbit samples handed to the core's thermal prediction and the observers that take the orbit.
  std::uint64_t orbitSamples() const { return orbit_samples_; }
  void addSource(std::unique_ptr<Source> s);
  void addSink(RowSink* sink);  ///< not owned; must outlive run()
  /// Sees every head epoch (validated, see InputObserver) and accelerometer sample handed to the core;
  /// not owned.
  void addObserver(InputObserver* o);
  /// The driver's hook (not owned; nullptr: none). With a hook, every core step is timed.
  void setHook(StepHook* h) { hook_ = h; }

  /// Runs until every source is finished (then the core is flushed and the sinks end: kDone), a
  /// source has nothing now (kPending: call run() again later), or a source or sink fails (kError).
  Result run();

  const std::string& error() const { return error_; }
  const Counters& counters() const { return asm_.counters(); }
  const Counters& counters(std::size_t source) const { return asm_.counters(source); }
  const Source& source(std::size_t i) const { return *sources_[i]; }
  std::size_t sourceCount() const { return sources_.size(); }
  std::uint64_t rows() const { return rows_; }
  TimeUs firstEpoch() const { return first_epoch_; }
  TimeUs lastEpoch() const { return last_epoch_; }
  std::uint64_t epochs() const { return epochs_; }
  /// Star epochs handed to the core, and those it solved (the rest are counted in its health).
  std::uint64_t starEpochs() const { return star_epochs_; }
  std::uint64_t starSolutions() const { return star_solutions_; }
  std::size_t maxBuffered() const { return asm_.maxBuffered(); }
  core::Health health() const;
  const core::Pipeline& pipeline() const { return *pipe_; }
  /// The core, for a driver that changes it between steps (hands mountings, restarts it). Re-configure
  /// through configure() (it also keeps the engine's head configuration for the observers' epochs).
  /// Observers get the core's own validated epoch (Pipeline::lastValidHeads): nothing to keep in step.
  core::Pipeline& pipeline() { return *pipe_; }

  // A driver of a live source (stream::PushSource) between pushes and runs:
  /// True when a sample of this kind at t would be rejected as late (EpochAssembler::late): a driver
  /// that counts per message checks it before pushing.
  bool late(TimeUs t, Sample::Kind kind) const { return asm_.late(t, kind); }
  /// The tag of the last input handed to the core since the start or the last restart (false: none).
  bool lastHandedOut(TimeUs& t) const {
    Sample::Kind k{};
    return asm_.lastHandedOut(t, k);
  }
  /// A re-synchronisation (a confirmed clock step back): what the assembler holds goes to the core,
  /// the core's pending rows go to the sinks, then the assembler forgets its time and the core (its
  /// validator, whose epochs the observers get, included) starts again (filters empty; its health counts restart too, so a driver
  /// adds them up before). `before_reset` runs between the flush and the reset (the driver's last look
  /// at the core). kError as run().
  template <typename F>
  Result restart(F&& before_reset) {
    asm_.restart();
    const Result r = run();
    if (r == Result::kError) return r;
    if (!flushCore()) return Result::kError;
    before_reset();
    pipe_->reset();
    return r;
  }
  /// The core's pending rows (Pipeline::flush) to the sinks, at a boundary where the driver changes the
  /// core (new mountings). False when a sink fails (error()).
  bool flushCore();

 private:
  bool drain();
  std::unique_ptr<core::Pipeline> pipe_;
  EpochAssembler asm_;
  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<RowSink*> sinks_;
  std::vector<InputObserver*> observers_;
  StepHook* hook_ = nullptr;
  core::HeadSetConfig heads_cfg_{};
  std::string error_;
  bool configured_ = false, begun_ = false, finished_ = false;
  std::uint64_t rows_ = 0, epochs_ = 0, star_epochs_ = 0, star_solutions_ = 0, orbit_samples_ = 0;
  Sample orbit_{};  ///< the orbit sample the assembler hands out
  std::unique_ptr<core::StarEpoch> stars_;  ///< scratch (a star epoch is ~5 kB)
  TimeUs first_epoch_ = 0, last_epoch_ = 0;
};

}  // namespace boresight::stream

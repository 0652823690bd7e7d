// The streaming replay engine: sources -> epoch assembler (bounded look-ahead) -> core::Pipeline ->
// sinks. Memory does not depend on the span: the sources read in chunks, the assembler buffers at
// most AssemblerConfig::max_buffered samples, the core is fixed-size and rows go straight to the
// sinks. `boresight process` runs it over files; the node and the batch tools will run it too.
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

 private:
  bool drain();
  std::unique_ptr<core::Pipeline> pipe_;
  EpochAssembler asm_;
  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<RowSink*> sinks_;
  std::vector<InputObserver*> observers_;
  std::unique_ptr<core::HeadInputValidator> obs_validator_;  ///< the core's validator, for observers
  core::HeadSetConfig heads_cfg_{};
  std::string error_;
  bool configured_ = false, begun_ = false, finished_ = false;
  std::uint64_t rows_ = 0, epochs_ = 0, star_epochs_ = 0, star_solutions_ = 0, orbit_samples_ = 0;
  Sample orbit_{};  ///< the orbit sample the assembler hands out
  std::unique_ptr<core::StarEpoch> stars_;  ///< scratch (a star epoch is ~5 kB)
  TimeUs first_epoch_ = 0, last_epoch_ = 0;
};

}  // namespace boresight::stream

// Simulator output: real-format Level-1 files (SCA1A, ACC1A, GNV1B streamed in chunks, QSA1B), an
// LCM log of the node's input messages, and truth.yaml.
//
// Streaming: io::ChunkedProductWriter (boresight/io/chunked_writer.h) writes each product as its
// records come, in one chunk of memory whatever the duration.
#pragma once

#include <boresight/io/chunked_writer.h>
#include <boresight/io/level1.h>
#include <boresight/io/files.h>
#include <boresight/sim/simulator.h>
#include <boresight/sim/truth.h>

#include <cstdio>
#include <memory>
#include <functional>
#include <string>
#include <vector>

namespace boresight::sim {


/// "SCA1A_2023-06-01_C_04.txt" for the scenario's start date, satellite and version.
std::string productFileName(const char* product, const Scenario& sc);

/// The Level-1 records the simulator writes for a sample (also used by tests to compare read-backs).
io::Sca1aRecord toSca1a(const HeadSampleOut& s, char satellite);
io::FlaggedRecord toAcc1a(const AccSampleOut& a, char satellite);
io::GnvRecord toGnv1b(const OrbitSampleOut& o, char satellite);
/// SCV1A records (one per star) of a head's star vectors.
void toScv1a(const StarVectorsOut& s, char satellite, std::vector<io::ScvRecord>& out);

/// Writes SCA1A (all heads, blinded samples skipped), ACC1A and GNV1B as the simulation runs, and
/// SCV1A (star vectors, a simulator product) when the scenario's output.star_vectors_interval_s > 0.
/// files(): SCA1A, ACC1A, GNV1B, then SCV1A when written.
class Level1Sink : public SimSink {
 public:
  bool open(const std::string& dir, const Scenario& sc, std::string* error);
  void head(const HeadSampleOut& s) override;
  void accel(const AccSampleOut& a) override;
  void orbit(const OrbitSampleOut& o) override;
  void stars(const StarVectorsOut& s) override;
  bool close(std::string* error);
  std::vector<std::string> files() const { return files_; }

 private:
  char sat_ = 'C';
  bool scv_on_ = false;
  io::ChunkedProductWriter<io::ScvRecord> scv_;
  std::vector<io::ScvRecord> scv_buf_;
  io::ChunkedProductWriter<io::Sca1aRecord> sca_;
  io::ChunkedProductWriter<io::FlaggedRecord> acc_;
  io::ChunkedProductWriter<io::GnvRecord> gnv_;
  std::vector<std::string> files_;
};

/// The node's input messages (io::LcmLogWriter): heads on STAR_HEAD, accelerometer on ACCEL, star
/// vectors on STAR_VECTORS (one message per head epoch, sequence counted over the channel).
class LcmSink : public SimSink {
 public:
  LcmSink();
  ~LcmSink() override;
  bool open(const std::string& path, std::string* error);
  void head(const HeadSampleOut& s) override;
  void accel(const AccSampleOut& a) override;
  void stars(const StarVectorsOut& s) override;
  /// Orbit samples as ORBIT messages (inertial, GNI1B-like).
  void orbit(const OrbitSampleOut& o) override;
  /// The nominal mountings (what the QSA1B says) and C_B_A as one NOMINAL_MOUNTINGS message at the
  /// scenario's start: call once after open(), before run().
  bool writeMountings(const Simulator& sim);
  bool close(std::string* error);
  std::uint64_t written() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Forwards every sample to several sinks.
class TeeSink : public SimSink {
 public:
  void add(SimSink* s) { sinks_.push_back(s); }
  void head(const HeadSampleOut& s) override {
    for (auto* k : sinks_) k->head(s);
  }
  void accel(const AccSampleOut& a) override {
    for (auto* k : sinks_) k->accel(a);
  }
  void orbit(const OrbitSampleOut& o) override {
    for (auto* k : sinks_) k->orbit(o);
  }
  void stars(const StarVectorsOut& s) override {
    for (auto* k : sinks_) k->stars(s);
  }

 private:
  std::vector<SimSink*> sinks_;
};

/// QSA1B with the NOMINAL alignment q_Si_B of every head (what the ground calibration says).
bool writeQsa1b(const std::string& path, const Simulator& sim, std::string* error);

// writeTruthYaml: sim/truth.h.

/// A whole simulation into a folder (which must exist), as `boresight simulate` writes it: the Level-1
/// text products, QSA1B, the LCM log when `lcm` (and the scenario's output.lcm_log), truth.yaml.
/// `simulator` must be initialised; `effect_args` go to truth.yaml; `files` receives every product
/// written but truth.yaml. False with *error naming the file that could not be written.
bool simulateIntoFolder(Simulator& simulator, const std::string& dir, bool lcm, const std::vector<std::string>& effect_args,
                        const std::function<void(double)>& progress, std::vector<std::string>& files, std::string* error);

}  // namespace boresight::sim

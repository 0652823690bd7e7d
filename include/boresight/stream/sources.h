// Sources of the replay engine: Level-1 files read as streams and LCM logs read straight into
// samples; and the recognition of an input file by its content.
#pragma once

#include <boresight/core/ring.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>
#include <boresight/stream/source.h>

#include <memory>
#include <string>

namespace boresight::io {
class LcmLogReader;
}

namespace boresight::stream {

/// What an input file is, from its content: an LCM log by the LCM event sync word at byte 0, a
/// Level-1 product by its header (and file name). Never reads more than the header.
struct FileKind {
  enum class Type : std::uint8_t { kLcmLog, kLevel1, kUnknown };
  Type type = Type::kUnknown;
  io::Product product = io::Product::Unknown;  ///< kLevel1
  std::string product_name;                    ///< kLevel1: "SCA1A", ...
  std::string reason;                          ///< kUnknown: "file:line: reason"
};
FileKind identifyFile(const std::string& path);

/// True when the first four bytes are the LCM log event sync word (0xEDA1DA01, big-endian).
bool hasLcmMagic(const std::string& path);

/// What every Level-1 file source shares: the streaming reader, the file name, the reader's rejected
/// lines reported first (as Reject::kMalformed, or Reject::kImplausible for a well-formed record
/// outside a plausibility gate) and the issues kept for reports. A derived source turns the held record `rec_` into a sample.
template <typename Rec>
class Level1FileSource : public Source {
 public:
  bool open(const std::string& path, const io::ReadOptions& opt, std::string* error) {
    name_ = path;
    io::ReadOptions o = opt;
    o.max_issues_kept = o.max_issues_kept < 20 ? o.max_issues_kept : 20;
    return s_.open(path, o, error);
  }
  const std::string& name() const override { return name_; }
  std::string error() const override { return s_.error(); }
  std::vector<std::string> issues() const override {
    std::vector<std::string> v;
    for (const auto& i : s_.rejected()) v.push_back(i.str());
    return v;
  }
  const io::Header& header() const { return s_.header(); }

 protected:
  /// kSample: `rec_` holds the next record; kRejected: a malformed line (why set); kEnd; kError.
  Next nextRecord(Reject& why) {
    if (!held_ && !done_) {
      held_ = s_.next(rec_);
      done_ = !held_;
    }
    if (reported_implausible_ < s_.implausibleCount()) {
      ++reported_implausible_;
      why = Reject::kImplausible;
      return Next::kRejected;
    }
    if (reported_malformed_ < s_.rejectedCount() - s_.implausibleCount()) {
      ++reported_malformed_;
      why = Reject::kMalformed;
      return Next::kRejected;
    }
    if (held_) {
      held_ = false;
      return Next::kSample;
    }
    return s_.ok() ? Next::kEnd : Next::kError;
  }
  Rec rec_{};

 private:
  io::ProductStream<Rec> s_;
  std::string name_;
  std::size_t reported_malformed_ = 0, reported_implausible_ = 0;
  bool held_ = false, done_ = false;
};

/// SCA1A head samples from one file, in file order (the engine merges by time).
class Sca1aSource final : public Level1FileSource<io::Sca1aRecord> {
 public:
  Next next(Sample& out, Reject& why) override;
};

/// ACC1A (or ACT1A) angular accelerations from one file, in file order. Records without all three
/// angular accelerations are rejected (Reject::kInvalidFlag), unless keepWithoutAngular(true): then
/// they are samples with flags bit 0 clear (for writing messages; never hand those to the core).
class Acc1aSource final : public Level1FileSource<io::FlaggedRecord> {
 public:
  void keepWithoutAngular(bool keep) { keep_without_angular_ = keep; }
  Next next(Sample& out, Reject& why) override;

 private:
  bool keep_without_angular_ = false;
};

/// SCV1A star vectors (the simulator's product, one star of one head per line) from one file, in
/// file order; sigma 0 (the head's configured sigma_star).
class ScvSource final : public Level1FileSource<io::ScvRecord> {
 public:
  Next next(Sample& out, Reject& why) override;
};

/// GNI1B (inertial) or GNV1B (Earth-fixed) orbit records from one file, in file order, as kOrbit samples
/// with the record's frame; a position or velocity outside the plausibility gates is rejected as
/// Reject::kImplausible by the reader (a well-formed record far from any orbit).
class OrbitFileSource final : public Level1FileSource<io::GnvRecord> {
 public:
  Next next(Sample& out, Reject& why) override;
};

/// An LCM log (channels STAR_HEAD, ACCEL, STAR_VECTORS and ORBIT, see io/lcm_log.h) read message by message
/// straight into samples; a STAR_VECTORS message gives one sample per star. Head messages without the
/// valid bit, accelerometer messages without valid angular acceleration and star messages without
/// the valid bit or stars are rejected with their reason; other channels and undecodable messages too;
/// values outside the plausibility gates (a head quaternion, an angular acceleration, a star
/// direction) as Reject::kImplausible.
class LcmLogSource final : public Source {
 public:
  LcmLogSource();
  ~LcmLogSource() override;
  /// Refuses a file that does not start with the LCM sync word (with the file and the reason).
  bool open(const std::string& path, std::string* error);
  /// The head quaternion gate's tolerance (core/plausibility.h; the platform's unit_norm_tolerance).
  void setQuatTolerance(double tol) { quat_tol_ = tol; }
  Next next(Sample& out, Reject& why) override;
  const std::string& name() const override { return name_; }
  std::string error() const override { return error_; }

 private:
  std::unique_ptr<io::LcmLogReader> r_;
  std::string name_, error_;
  double quat_tol_ = plausibility::kQuatNormTolerance;
  int star_n_ = 0, star_next_ = 0;  ///< stars of the current STAR_VECTORS message, next to hand out
};

}  // namespace boresight::stream

namespace boresight::stream {

/// A live source: the driver pushes the samples it received (the node's message handlers, after their
/// checks) and runs the engine; next() hands them out in push order, kPending when it holds none, kEnd
/// once closed and empty. Fixed capacity, allocated once by init(): the engine takes each sample right
/// after its push, so a few slots are enough. Rejects nothing itself (the driver counts what it refuses
/// before pushing).
class PushSource final : public Source {
 public:
  explicit PushSource(std::string name = "live") : name_(std::move(name)) {}
  void init(std::size_t capacity) { buf_.reset(capacity); }
  /// False (nothing pushed) when full.
  bool push(const Sample& s) { return buf_.push(s); }
  void close() { closed_ = true; }
  Next next(Sample& out, Reject& why) override;
  const std::string& name() const override { return name_; }

 private:
  core::Ring<Sample> buf_;
  bool closed_ = false;
  std::string name_;
};

/// Runs another (file) source on its own thread and hands its results over in batches through a
/// bounded queue, so parsing overlaps the core. Memory: at most `queue_batches` batches of
/// `batch_size` results. Do not wrap a live source (kPending ends its batch and is passed on).
class PrefetchSource final : public Source {
 public:
  explicit PrefetchSource(std::unique_ptr<Source> inner, std::size_t batch_size = 2048, std::size_t queue_batches = 4);
  ~PrefetchSource() override;
  Next next(Sample& out, Reject& why) override;
  const std::string& name() const override { return inner_->name(); }
  /// Valid once next() has returned kEnd or kError (the worker has finished then).
  std::string error() const override;
  std::vector<std::string> issues() const override;

 private:
  struct Impl;
  std::unique_ptr<Source> inner_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace boresight::stream

// boresight::io - a Level-1 product written as its records come, in constant memory.
//
// The io writers format whole ProductFile objects. ChunkedProductWriter writes the header of
// formatProduct(empty product) with the fields known only at the end - the record count and, when
// asked, the time coverage - widened to fixed widths, then formats chunks of records, drops each
// chunk's repeated header and appends the records, and at close() overwrites those fields in place
// (left-aligned, blank-padded: the readers trim blanks). Memory is one chunk, whatever the duration.
// The file appears whole at close() or not at all (AtomicFile).
//
// Time coverage, as the official products state it: GRACE-FO's YAML header gets time_coverage_start /
// time_coverage_stop (GPS calendar, "2023-06-01T00:00:00.00") and start_time_epoch_secs /
// stop_time_epoch_secs (whole seconds past the GPS J2000 epoch; the readers' time gate uses them);
// GRACE's fixed header gets "TIME FIRST OBS(SEC PAST EPOCH)" and "TIME LAST OBS(SEC PAST EPOCH)". The
// values are those of the first and last record (records in time order); with no records they stay
// blank (a reader takes no coverage).
#pragma once

#include <boresight/io/files.h>
#include <boresight/io/level1.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace boresight::io {

template <typename Rec>
class ChunkedProductWriter {
 public:
  ChunkedProductWriter() = default;
  ~ChunkedProductWriter();
  ChunkedProductWriter(const ChunkedProductWriter&) = delete;
  ChunkedProductWriter& operator=(const ChunkedProductWriter&) = delete;
  /// `proto` supplies the header (makeProduct(...)); its records are ignored. `coverage`: the header
  /// states the records' time span (see above).
  bool open(const std::string& path, const ProductFile<Rec>& proto, std::string* error, std::size_t chunk_records = 16384,
            bool coverage = false);
  void add(const Rec& r) {
    if (written() == 0) t_first_ = r.t;
    t_last_ = r.t;
    chunk_.records.push_back(r);
    if (chunk_.records.size() >= chunk_size_) flush();
  }
  bool close(std::string* error);
  /// Records flushed to the file so far.
  std::uint64_t count() const { return count_; }
  /// Records added so far (flushed or in the current chunk).
  std::uint64_t written() const { return count_ + chunk_.records.size(); }

 private:
  void flush();
  enum class Field : std::uint8_t { Count, StartIso, StopIso, StartSecs, StopSecs, FirstObs, LastObs };
  struct Slot {
    Field field;
    std::size_t offset, width;
  };
  std::string value(Field f) const;
  std::string path_;
  ProductFile<Rec> chunk_;
  std::size_t chunk_size_ = 16384, header_lines_ = 0;  ///< lines of formatProduct's header (each chunk's)
  std::vector<Slot> slots_;
  AtomicFile file_;
  std::FILE* body_ = nullptr;
  std::uint64_t count_ = 0;
  TimeUs t_first_ = 0, t_last_ = 0;
  bool io_error_ = false;
};

}  // namespace boresight::io

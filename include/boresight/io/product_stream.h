// Level-1 product files read as streams: the header up front, then records one at a time from a
// fixed-size buffer, so memory does not grow with the file (a full-day ACC1A is 183 MB of text).
//
//   io::ProductStream<io::Sca1aRecord> s;
//   if (!s.open(path, {}, &err)) ...;           // err: "file:line: reason"
//   io::Sca1aRecord r;
//   while (s.next(r)) use(r);                   // malformed lines are skipped and counted
//   if (!s.ok()) ...s.error()...;               // OnError::Stop, or a read error
//
// Records come in file order (a stream does not sort). Only ASCII products are streamed; a GRACE
// binary Level-1B file is refused by open() with a reason (read it with readProduct()).
#pragma once

#include <boresight/io/level1.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace boresight::io {

/// The lines of a Level-1 ASCII file after its header, read in chunks (the header is read whole).
class LineStream {
 public:
  static constexpr std::size_t kDefaultChunk = 1u << 20;

  LineStream() = default;
  ~LineStream();
  LineStream(const LineStream&) = delete;
  LineStream& operator=(const LineStream&) = delete;

  /// Opens the file and parses its header (identification as readProduct() does: file name first,
  /// then the header; opt.product forces it). False with *error ("file:line: reason").
  bool open(const std::string& path, const ReadOptions& opt, std::string* error,
            std::size_t chunk_bytes = kDefaultChunk);
  const Header& header() const { return header_; }
  const std::string& file() const { return file_; }
  /// The next non-blank line (without its newline) and its 1-based line number. The view is valid
  /// until the next call. False at the end of the file or on a read error (see error()); also (with
  /// error() set) for a line longer than kMaxLineBytes or a file longer than maxFileBytes() of its
  /// product: an endless or binary input is refused with the limit it crossed.
  bool next(std::string_view& line, std::size_t& line_no);
  /// Empty unless reading failed.
  const std::string& error() const { return error_; }
  /// Byte offset of the first data byte, and the file size (for progress and block splitting).
  std::uint64_t dataOffset() const { return data_offset_; }
  std::uint64_t fileSize() const { return file_size_; }
  /// Most bytes read from the file before it is refused (maxFileBytes of its product).
  std::uint64_t maxBytes() const { return max_bytes_; }

 private:
  bool refill();
  std::FILE* f_ = nullptr;
  std::string file_;
  Header header_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;  ///< unread bytes in buf_
  bool eof_ = false;
  std::size_t line_no_ = 0;
  std::uint64_t data_offset_ = 0, file_size_ = 0, read_ = 0, max_bytes_ = 0;
  std::string error_;
};

/// Records of one Level-1 product file, one at a time.
template <typename Rec>
class ProductStream {
 public:
  bool open(const std::string& path, const ReadOptions& opt, std::string* error,
            std::size_t chunk_bytes = LineStream::kDefaultChunk) {
    opt_ = opt;
    ok_ = true;
    error_.clear();
    rejected_.clear();
    rejected_count_ = implausible_count_ = records_ = 0;
    if (!lines_.open(path, opt, error, chunk_bytes)) return fail(error ? *error : std::string());
    if (lines_.header().binary) {
      std::string e = path + ":" + std::to_string(lines_.header().line_count) + ": binary " +
                      lines_.header().product_name + " (FILE FORMAT 0) is not read as a stream";
      if (error) *error = e;
      return fail(e);
    }
    if (!recordAccepts<Rec>(lines_.header().product)) {
      std::string e = path + ":1: product " + lines_.header().product_name + " is not read by this reader";
      if (error) *error = e;
      return fail(e);
    }
    gate_ = makeRecordGate(lines_.header(), path, opt);
    return true;
  }
  /// The next well-formed record. Malformed lines are counted (and the first
  /// ReadOptions::max_issues_kept kept); with OnError::Stop the first one ends the stream (ok() false).
  bool next(Rec& r) {
    std::string_view line;
    std::size_t no = 0;
    while (ok_ && lines_.next(line, no)) {
      FieldScanner s(line);
      r = Rec{};
      const bool formed = parseRecord<Rec>(s, r, lines_.header().product);
      if (formed && checkRecord<Rec>(r, lines_.header().product, gate_, &gate_reason_)) {
        ++records_;
        line_no_ = no;
        return true;
      }
      ++rejected_count_;
      if (formed) ++implausible_count_;
      const std::string& why = formed ? gate_reason_ : s.reason();
      if (rejected_.size() < opt_.max_issues_kept) rejected_.push_back(ParseIssue{lines_.file(), no, why});
      if (opt_.on_error == OnError::Stop) return fail(lines_.file() + ":" + std::to_string(no) + ": " + why);
    }
    if (ok_ && !lines_.error().empty()) fail(lines_.error());
    return false;
  }
  const Header& header() const { return lines_.header(); }
  const std::string& file() const { return lines_.file(); }
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  std::size_t records() const { return records_; }
  std::size_t rejectedCount() const { return rejected_count_; }
  /// Of the rejected lines: well-formed records outside a plausibility gate (RecordGate).
  std::size_t implausibleCount() const { return implausible_count_; }
  /// The line number of the record next() returned last.
  std::size_t lineNumber() const { return line_no_; }
  const std::vector<ParseIssue>& rejected() const { return rejected_; }

 private:
  bool fail(const std::string& e) {
    ok_ = false;
    error_ = e;
    return false;
  }
  LineStream lines_;
  ReadOptions opt_;
  bool ok_ = true;
  std::string error_;
  std::vector<ParseIssue> rejected_;
  std::size_t rejected_count_ = 0, implausible_count_ = 0, records_ = 0, line_no_ = 0;
  RecordGate gate_;
  std::string gate_reason_;
};

}  // namespace boresight::io

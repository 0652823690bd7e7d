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
  /// until the next call. False at the end of the file or on a read error (see error()).
  bool next(std::string_view& line, std::size_t& line_no);
  /// Empty unless reading failed.
  const std::string& error() const { return error_; }
  /// Byte offset of the first data byte, and the file size (for progress and block splitting).
  std::uint64_t dataOffset() const { return data_offset_; }
  std::uint64_t fileSize() const { return file_size_; }

 private:
  bool refill();
  std::FILE* f_ = nullptr;
  std::string file_;
  Header header_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;  ///< unread bytes in buf_
  bool eof_ = false;
  std::size_t line_no_ = 0;
  std::uint64_t data_offset_ = 0, file_size_ = 0;
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
    rejected_count_ = records_ = 0;
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
      if (parseRecord<Rec>(s, r, lines_.header().product)) {
        ++records_;
        return true;
      }
      ++rejected_count_;
      if (rejected_.size() < opt_.max_issues_kept) rejected_.push_back(ParseIssue{lines_.file(), no, s.reason()});
      if (opt_.on_error == OnError::Stop) return fail(lines_.file() + ":" + std::to_string(no) + ": " + s.reason());
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
  std::size_t rejected_count_ = 0, records_ = 0;
};

}  // namespace boresight::io

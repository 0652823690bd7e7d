// LineStream: a Level-1 ASCII file's header, then its lines from a fixed-size buffer.
#include <boresight/io/product_stream.h>

#include "product_io.h"

#include <cerrno>
#include <cstring>

namespace boresight::io {

LineStream::~LineStream() {
  if (f_) std::fclose(f_);
}

bool LineStream::open(const std::string& path, const ReadOptions& opt, std::string* error, std::size_t chunk_bytes) {
  if (f_) std::fclose(f_);
  f_ = nullptr;
  file_ = path;
  header_ = Header{};
  begin_ = end_ = 0;
  eof_ = false;
  line_no_ = 0;
  read_ = 0;
  error_.clear();
  auto fail = [&](std::size_t line, const std::string& why) {
    if (error) *error = path + ":" + std::to_string(line) + ": " + why;
    if (f_) std::fclose(f_);
    f_ = nullptr;
    return false;
  };
  f_ = std::fopen(path.c_str(), "rb");
  if (!f_) return fail(0, std::string("cannot open: ") + std::strerror(errno));
  file_size_ = 0;
  if (std::fseek(f_, 0, SEEK_END) == 0) {
    long n = std::ftell(f_);
    if (n > 0) file_size_ = static_cast<std::uint64_t>(n);
    std::fseek(f_, 0, SEEK_SET);
  }
  // The header is read from a prefix that grows until the header parses (headers are a few kB).
  constexpr std::size_t kMaxHeader = kMaxHeaderBytes + 4096;
  std::string prefix;
  std::size_t want = 64u << 10;
  std::size_t off = 0;
  std::string err;
  for (;;) {
    const std::size_t have = prefix.size();
    prefix.resize(want);
    const std::size_t got = std::fread(&prefix[have], 1, want - have, f_);
    prefix.resize(have + got);
    const bool whole = got < want - have;
    if (std::ferror(f_)) return fail(0, "read error");
    bool parsed = parseHeader(prefix, header_, &off, &err);
    // A fixed header may be repeated after its END OF HEADER: make sure the prefix reaches past it.
    if (parsed && (whole || off + 4096 < prefix.size())) break;
    if (!parsed && (whole || want >= kMaxHeader)) return fail(header_.line_count + 1, err);
    want *= 2;
  }
  if (!detail::resolveProduct(header_, path, opt, &err)) return fail(1, err);
  max_bytes_ = maxFileBytes(header_.product);
  if (file_size_ > max_bytes_)
    return fail(0, std::to_string(file_size_) + " bytes, more than the limit of " + std::to_string(max_bytes_) +
                       " bytes for a " + header_.product_name + " file");
  data_offset_ = off;
  read_ = prefix.size();
  line_no_ = header_.line_count;
  buf_.resize(std::max<std::size_t>(chunk_bytes, 4096));
  if (header_.binary) return true;  // the caller decides; nothing is read as text
  // Keep the bytes already read after the header.
  const std::size_t rest = prefix.size() - off;
  if (rest > buf_.size()) buf_.resize(rest);
  std::memcpy(buf_.data(), prefix.data() + off, rest);
  begin_ = 0;
  end_ = rest;
  eof_ = std::feof(f_) != 0;
  return true;
}

bool LineStream::refill() {
  if (eof_ || !f_) return false;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buf_.size()) {  // a line longer than the buffer
    if (buf_.size() > kMaxLineBytes) {
      error_ = file_ + ":" + std::to_string(line_no_ + 1) + ": line longer than " + std::to_string(kMaxLineBytes >> 10) +
               " KiB: not a Level-1 record line (binary data or an endless input?): the file is refused";
      eof_ = true;
      return false;
    }
    buf_.resize(buf_.size() * 2);
  }
  const std::size_t got = std::fread(buf_.data() + end_, 1, buf_.size() - end_, f_);
  end_ += got;
  read_ += got;
  if (read_ > max_bytes_) {
    error_ = file_ + ":" + std::to_string(line_no_ + 1) + ": more than " + std::to_string(max_bytes_) +
             " bytes, the limit for a " + header_.product_name + " file: refused (an endless input?)";
    eof_ = true;
    return false;
  }
  if (got == 0) {
    eof_ = true;
    if (std::ferror(f_)) error_ = file_ + ":" + std::to_string(line_no_ + 1) + ": read error";
  }
  return got > 0;
}

bool LineStream::next(std::string_view& line, std::size_t& line_no) {
  if (!f_ || header_.binary) return false;
  for (;;) {
    const char* b = buf_.data() + begin_;
    const void* nl = std::memchr(b, '\n', end_ - begin_);
    if (!nl && !eof_) {
      refill();  // moves the unread bytes to the front (or sets eof_): look again
      if (!error_.empty()) return false;
      continue;
    }
    if (!nl && begin_ == end_) return false;
    const char* e = nl ? static_cast<const char*>(nl) : buf_.data() + end_;
    ++line_no_;
    const std::size_t len = static_cast<std::size_t>(e - b);
    if (len > kMaxLineBytes) {
      error_ = file_ + ":" + std::to_string(line_no_) + ": line longer than " + std::to_string(kMaxLineBytes >> 10) +
               " KiB: not a Level-1 record line (binary data or an endless input?): the file is refused";
      return false;
    }
    begin_ += len + (nl ? 1 : 0);
    // Blank lines (spaces, tabs, CR only) count for the numbering but are not handed out.
    if (FieldScanner(b, e).atEnd()) continue;
    line = std::string_view(b, len);
    line_no = line_no_;
    return true;
  }
}

}  // namespace boresight::io

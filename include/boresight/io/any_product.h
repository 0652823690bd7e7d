// Reading any Level-1 product file without knowing its type in advance (for `boresight inspect`).
#pragma once

#include <boresight/io/level1.h>

#include <optional>
#include <string>
#include <vector>

namespace boresight::io {

struct ProductSummary {
  std::string file;
  std::string product;    ///< five-letter name ("SCA1A"), or "" when unknown
  char satellite = '?';   ///< from the records, else the header
  std::size_t records = 0;  ///< counted, never taken from the header
  std::optional<std::int64_t> declared_records;  ///< what the header claims
  bool has_time = false;
  TimeUs first_time = 0, last_time = 0;  ///< first and last record time tags (file order)
  std::vector<ParseIssue> rejected;
  std::size_t rejected_count = 0;
  bool ok = true;     ///< false: the file could not be read at all (see error)
  std::string error;  ///< "file:line: reason"
  bool binary = false;  ///< GRACE big-endian binary Level-1B
};

/// Identify the product (file name, then header) and read it with its typed reader, or with a generic
/// reader (first field: time) for Level-1 products without one. Never throws.
ProductSummary summarizeProduct(const std::string& path, const ReadOptions& opt = {});

}  // namespace boresight::io

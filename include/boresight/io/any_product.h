// Reading any Level-1 product file without knowing its type in advance (for `boresight inspect`).
#pragma once

#include <boresight/io/level1.h>

#include <cstdint>
#include <optional>
#include <string_view>
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
/// reader (first field: time) for Level-1 products without one. Also recognised:
///  - `.rpt` daily report files (one line; the first token names the product file, e.g.
///    "SCA1A_2023-06-01_C_04.dat"): product "<NAME> report", 1 record, no time;
///  - GRACE binary Level-1B (fixed header with FILE FORMAT 0): binary == true; read for SCA1B,
///    ACC1B, ACT1B, GNV1B and GNI1B, ok == false with a reason for other binary products.
/// Anything else (RINEX, prose, garbage) gives ok == false and error "file:line: reason". Never throws.
ProductSummary summarizeProduct(const std::string& path, const ReadOptions& opt = {});
/// The same on text already in memory; `file` names it (and identifies the product).
ProductSummary summarizeText(std::string_view text, const std::string& file, const ReadOptions& opt = {});

/// One record of a Level-1 product read without its layout: the time tag and how many
/// whitespace-separated tokens the line holds.
struct GenericRecord {
  TimeUs t = 0;  ///< first field (integer seconds), plus the second as microseconds when it is a fraction
  std::uint16_t tokens = 0;  ///< tokens on the line (saturates at 65535)
};

/// Generic reader for Level-1 products without a typed codec (KBR1B, MAG1B, GNV1A, GPS1A, ...).
/// The first field must be an integer time in seconds. The second field is taken as the
/// microseconds of that time when the YAML header names it "*frac*", or, without YAML columns,
/// when the first data line's second field is an integer 0..999999 followed (as third or fourth
/// field) by a one-character time_ref 'R' or 'G'; that choice then holds for the whole file.
/// Any Level-1 product (typed or not) can be read this way; there is no writer.
ProductFile<GenericRecord> parseGeneric(std::string_view text, std::string_view file, const ReadOptions& opt = {});
ProductFile<GenericRecord> readGeneric(const std::string& path, const ReadOptions& opt = {});

}  // namespace boresight::io

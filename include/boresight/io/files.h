// Inputs and outputs of the programs: bounded reads, output paths that never destroy an input, and
// files that appear whole or not at all.
//
// Reading: every input has a size limit for its kind (a configuration file, a ground measurement, a
// Level-1 product, an LCM log). A directory, a missing file or an input larger than its limit (an
// endless one such as /dev/zero included) is refused with the path and the limit crossed; nothing is
// read beyond limit + 1 bytes.
//
// Writing: checkOutputs() refuses, before anything is opened for writing, an output that is also an
// input (after resolving links), two outputs on one path, and an output inside an input directory.
// AtomicFile writes under a temporary name in the destination's folder and renames it over the
// destination on commit(): a failing run leaves the previous file or nothing, never half a file.
// OutputDir removes a folder it created when the run fails before keep().
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace boresight::io {

/// Size limits of the inputs read whole (bytes). A larger input is refused with the limit.
constexpr std::uint64_t kMaxConfigBytes = 4u << 20;          ///< YAML: platform, node, scenario, truth
constexpr std::uint64_t kMaxMeasurementBytes = 256u << 20;   ///< a method C ground measurement file
constexpr std::uint64_t kMaxTableBytes = 256u << 20;         ///< a CSV table (plot) or star catalogue
constexpr std::uint64_t kMaxLcmLogBytes = 64ull << 30;       ///< an LCM log (streamed; about 45 days)

/// "1.5 MiB" and the like, for messages about limits.
std::string formatBytes(std::uint64_t bytes);

/// Checks that `path` can be read as an input of the given kind: it exists, is not a directory, and a
/// regular file is at most max_bytes. False with *error "PATH: reason". `what` names the input in the
/// message ("configuration file", "ground measurement").
bool checkInputFile(const std::string& path, std::uint64_t max_bytes, const char* what, std::string* error);

/// The whole content of `path`, at most max_bytes: a directory, an unreadable path, or an input with
/// more bytes (also one that never ends: a device, a pipe) is refused with the limit crossed, having
/// read at most max_bytes + 1 bytes. False with *error "PATH: reason".
bool readBounded(const std::string& path, std::uint64_t max_bytes, const char* what, std::string& out,
                 std::string* error);

/// The absolute path with symbolic links, "." and ".." resolved; for a path that does not exist (yet),
/// its deepest existing ancestor resolved and the rest appended. Empty for an empty path.
std::string resolvedPath(const std::string& path);

/// One output of a program run: the option that names it ("--out") and its path; `directory` for a
/// folder the program writes into.
struct OutputPath {
  std::string option;
  std::string path;
  bool directory = false;
};

/// Refuses, before anything is written: an output whose path is an input's (links resolved, hard
/// links too); two outputs on one path; an output inside an input directory (a folder that is read).
/// A program that writes named files into an output folder checks those paths again when it knows
/// them. Empty paths are skipped. False with *error ("--out x.csv: is also an input (x.csv): refused,
/// it would be overwritten").
bool checkOutputs(const std::vector<std::string>& inputs, const std::vector<OutputPath>& outputs, std::string* error);

/// A file written under a temporary name next to `path` ("PATH.tmp-XXXXXX") and renamed over it by
/// commit(). Without commit() (an error, an exception, an early return) the temporary file is removed
/// and `path` is untouched.
class AtomicFile {
 public:
  AtomicFile() = default;
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Creates the temporary file. False with *error "PATH: cannot create: reason".
  bool open(const std::string& path, std::string* error);
  bool isOpen() const { return f_ != nullptr; }
  std::FILE* file() const { return f_; }
  /// Appends bytes; false (and the file is not committed later) on a write error.
  bool write(std::string_view bytes);
  /// Flushes, closes and renames the temporary file over the destination. False with *error.
  bool commit(std::string* error);
  /// Removes the temporary file (the destination is untouched).
  void abandon();
  const std::string& path() const { return path_; }

 private:
  std::FILE* f_ = nullptr;
  std::string path_, tmp_;
  bool failed_ = false;
};

/// The whole text to `path` through an AtomicFile. False with *error.
bool writeFileAtomic(const std::string& path, std::string_view text, std::string* error);

/// A folder a program writes into: created (with its parents) when missing. When the run fails (the
/// object is destroyed without keep()), a folder it created is removed again if nothing is left in it.
class OutputDir {
 public:
  OutputDir() = default;
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;
  /// Creates `path` when missing. False with *error ("PATH: cannot create the folder: reason", or
  /// "PATH: exists and is not a folder").
  bool open(const std::string& path, std::string* error);
  /// The run succeeded: the folder stays.
  void keep() { keep_ = true; }

 private:
  std::vector<std::string> created_;  ///< folders this object created, outermost first
  bool keep_ = false;
};

}  // namespace boresight::io

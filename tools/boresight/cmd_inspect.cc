// boresight inspect PATH... [--json FILE]: what is in a set of Level-1 files.
#include <boresight/io/any_product.h>
#include <boresight/io/files.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>
#include <boresight/io/sca_geometry.h>
#include <boresight/io/time_format.h>

#include <boresight/io/lcm_log.h>
#include <boresight/stream/sources.h>

#include <nlohmann/json.hpp>

#include "cli_common.h"
#include "commands.h"

#include <algorithm>
#include <cstdio>
#include <dirent.h>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_inspect {
namespace {

const char* kUsage =
    "usage: boresight inspect PATH... [--json FILE] [--boresight X,Y,Z] [--max-rejected N] [--threads N]\n"
    "\n"
    "For each Level-1 product file (a directory is read recursively): product, satellite, record count\n"
    "(counted, not taken from the header), first and last time tag, and rejected lines with reasons.\n"
    "Files are read in blocks, in constant memory, on several threads. An LCM log (recognised by its\n"
    "content) is summarised too: messages, first and last sensor time, messages not read (other\n"
    "channels, undecodable).\n"
    "Where SCA1A files with two or more heads are given: samples per head and, per head pair, the mean\n"
    "inter-boresight angle (deg) and its standard deviation (arcsec); with a QSA1B file, the angle implied\n"
    "by the QSA1B alignment (deg) and the offset (arcsec).\n"
    "\n"
    "  --json FILE        also write the results as JSON (keys: files[], pairs[])\n"
    "  --boresight X,Y,Z  boresight axis in the head frame (default 0,0,1, GRACE-FO)\n"
    "  --max-rejected N   rejected lines listed per file (default 5; all are counted)\n"
    "  --threads N        parser threads per file (default 0: every hardware thread for large files)\n"
    "\n"
    "Times are GPS seconds past 2000-01-01 12:00:00 (receiver time for Level-1A) and the GPS calendar.\n"
    "Exit status: 0 when every file was read, 1 when a file could not be read, 2 on usage errors.\n";

bool isDir(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

/// The files under `path` (itself when it is no directory), sorted; each directory once (a link that
/// points back up is not followed again) and at most 64 levels deep.
void listFiles(const std::string& path, std::vector<std::string>& out,
               std::vector<std::pair<dev_t, ino_t>>* seen_dirs = nullptr, int depth = 0) {
  if (!isDir(path)) {
    out.push_back(path);
    return;
  }
  std::vector<std::pair<dev_t, ino_t>> own;
  if (!seen_dirs) seen_dirs = &own;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || depth > 64) return;
  const std::pair<dev_t, ino_t> id{st.st_dev, st.st_ino};
  if (std::find(seen_dirs->begin(), seen_dirs->end(), id) != seen_dirs->end()) return;
  seen_dirs->push_back(id);
  DIR* d = ::opendir(path.c_str());
  if (!d) {
    out.push_back(path);
    return;
  }
  std::vector<std::string> names;
  while (dirent* e = ::readdir(d)) {
    std::string n = e->d_name;
    if (n == "." || n == ".." || n[0] == '.') continue;
    names.push_back(n);
  }
  ::closedir(d);
  std::sort(names.begin(), names.end());
  for (const auto& n : names) listFiles(path + "/" + n, out, seen_dirs, depth + 1);
}

double seconds(TimeUs t) { return toSeconds(t); }

/// An LCM log as a summary: events by kind, sensor time span, what was not read.
io::ProductSummary summarizeLcm(const std::string& path) {
  io::ProductSummary s;
  s.file = path;
  s.product = "LCM log";
  io::LcmLogReader r;
  std::string err;
  if (!r.open(path, &err)) {
    s.ok = false;
    s.error = err;
    return s;
  }
  io::HeadSample h;
  io::AccelSample a;
  for (;;) {
    auto k = r.next(h, a);
    if (k == io::LcmLogReader::Kind::End) break;
    if (k == io::LcmLogReader::Kind::Skipped) continue;
    const TimeUs t = k == io::LcmLogReader::Kind::Head    ? h.utime
                     : k == io::LcmLogReader::Kind::Stars ? r.stars().utime
                     : k == io::LcmLogReader::Kind::Orbit ? r.orbit().utime
                                                          : a.utime;
    if (!s.has_time) s.first_time = t;
    s.has_time = true;
    s.last_time = t;
    ++s.records;
  }
  s.rejected_count = static_cast<std::size_t>(r.unknownChannel() + r.decodeFailures());
  if (r.unknownChannel())
    s.rejected.push_back(io::ParseIssue{path, 0, std::to_string(r.unknownChannel()) + " events on other channels"});
  if (r.decodeFailures())
    s.rejected.push_back(io::ParseIssue{path, 0, std::to_string(r.decodeFailures()) + " undecodable messages"});
  return s;
}

}  // namespace

int runInspect(int argc, char** argv) {
  CLI::App app{"boresight inspect"};
  std::vector<std::string> paths;
  std::string json_path, boresight_s;
  int max_rej = 5, threads = 0;
  app.add_option("paths", paths)->required();
  app.add_option("--json", json_path);
  app.add_option("--boresight", boresight_s);
  app.add_option("--max-rejected", max_rej);
  app.add_option("--threads", threads)->check(finiteRange(0, 64));
  if (int st = parseCommandLine(app, argc, argv, "inspect", kUsage); st >= 0) return st;
  if (max_rej < 0) {
    std::fprintf(stderr, "boresight inspect: --max-rejected wants a count >= 0, not %d\n", max_rej);
    return 2;
  }
  Vec3 axis = boresightDefault();
  if (!boresight_s.empty()) {
    double v[3];
    char tail = 0;
    if (std::sscanf(boresight_s.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) != 3 ||
        !Vec3(v[0], v[1], v[2]).allFinite() || Vec3(v[0], v[1], v[2]).norm() < 1e-9) {
      std::fprintf(stderr, "boresight inspect: --boresight wants three numbers X,Y,Z, not '%s'\n", boresight_s.c_str());
      return 2;
    }
    axis = Vec3(v[0], v[1], v[2]).normalized();
  }
  io::ReadOptions ropt;
  ropt.threads = threads;
  {
    std::string err;
    if (!io::checkOutputs(paths, {{"--json", json_path}}, &err)) {
      std::fprintf(stderr, "boresight inspect: %s\n", err.c_str());
      return 1;
    }
  }

  std::vector<std::string> files;
  for (const auto& p : paths) {
    const std::size_t before = files.size();
    listFiles(p, files);
    if (files.size() == before) std::printf("%s: a folder without files: nothing to inspect there (ignored)\n", p.c_str());
  }

  nlohmann::json js_files = nlohmann::json::array();
  int status = 0;
  std::vector<std::string> sca_files;
  std::vector<io::QsaRecord> qsa;
  bool have_qsa = false;
  std::vector<char> sca_sats;

  std::printf("%-44s %-8s %-3s %9s %9s  %-26s %-26s %s\n", "file", "product", "sat", "records", "header",
              "first time (GPS)", "last time (GPS)", "rejected");
  for (const auto& f : files) {
    io::ProductSummary s = stream::hasLcmMagic(f) ? summarizeLcm(f) : io::summarizeProduct(f, ropt);
    std::string shown = f.size() > 44 ? "..." + f.substr(f.size() - 41) : f;
    nlohmann::json j;
    j["file"] = f;
    j["product"] = s.product;
    j["satellite"] = std::string(1, s.satellite);
    j["records"] = s.records;
    j["header_records"] = s.declared_records ? nlohmann::json(*s.declared_records) : nlohmann::json(nullptr);
    j["first_time"] = s.has_time ? nlohmann::json(seconds(s.first_time)) : nlohmann::json(nullptr);
    j["last_time"] = s.has_time ? nlohmann::json(seconds(s.last_time)) : nlohmann::json(nullptr);
    j["ok"] = s.ok;
    if (!s.ok) j["error"] = s.error;
    nlohmann::json rej = nlohmann::json::array();
    for (const auto& r : s.rejected) rej.push_back({{"line", r.line}, {"reason", r.reason}});
    j["rejected"] = std::move(rej);
    j["rejected_count"] = s.rejected_count;
    js_files.push_back(std::move(j));

    if (!s.ok) {
      std::printf("%-44s %-8s  error: %s\n", shown.c_str(), s.product.empty() ? "?" : s.product.c_str(), s.error.c_str());
      status = 1;
      continue;
    }
    std::string hdr = s.declared_records ? std::to_string(*s.declared_records) : "-";
    std::printf("%-44s %-8s %-3c %9zu %9s  %-26s %-26s %zu\n", shown.c_str(), s.product.c_str(), s.satellite,
                s.records, hdr.c_str(), s.has_time ? io::formatTime(s.first_time).c_str() : "-",
                s.has_time ? io::formatTime(s.last_time).c_str() : "-", s.rejected_count);
    int shown_rej = 0;
    for (const auto& r : s.rejected) {
      if (shown_rej++ >= max_rej) break;
      std::printf("    rejected %s\n", r.str().c_str());
    }
    if (s.rejected_count > static_cast<std::size_t>(max_rej))
      std::printf("    ... %zu rejected lines in all\n", s.rejected_count);

    if (s.product == "SCA1A") {
      if (std::find(sca_sats.begin(), sca_sats.end(), s.satellite) == sca_sats.end()) sca_sats.push_back(s.satellite);
      sca_files.push_back(f);
    } else if (s.product == "QSA1B") {
      auto qf = io::readProduct<io::QsaRecord>(f);
      if (qf.ok) {
        qsa.insert(qsa.end(), qf.records.begin(), qf.records.end());
        have_qsa = true;
      }
    }
  }

  nlohmann::json js_pairs = nlohmann::json::array();
  if (sca_sats.size() > 1) {
    std::printf("\nSCA1A files of several satellites were given: inter-boresight angles need one satellite.\n");
  } else if (!sca_files.empty()) {
    // Streamed, in constant memory, when the records are in time order across the files as given;
    // otherwise everything is loaded and sorted by the whole-file function.
    io::IbaAccumulator acc(axis);
    int count[10] = {0};
    bool in_order = true;
    for (const auto& f : sca_files) {
      io::ProductStream<io::Sca1aRecord> st;
      std::string err;
      if (!st.open(f, ropt, &err)) continue;
      io::Sca1aRecord r;
      while (in_order && st.next(r)) {
        in_order = acc.add(r);
        if (in_order) count[r.head < 10 ? r.head : 0]++;
      }
    }
    std::vector<io::PairIba> pairs;
    if (in_order) {
      pairs = acc.finish(have_qsa ? &qsa : nullptr);
    } else {
      std::vector<io::Sca1aRecord> sca;
      for (const auto& f : sca_files) {
        auto sf = io::readProduct<io::Sca1aRecord>(f, ropt);
        if (sf.ok) sca.insert(sca.end(), sf.records.begin(), sf.records.end());
      }
      for (auto& c : count) c = 0;
      for (const auto& r : sca) count[r.head < 10 ? r.head : 0]++;
      pairs = io::interBoresightAngles(sca, have_qsa ? &qsa : nullptr, axis);
    }
    std::printf("\nSCA1A samples per head:");
    for (int h = 1; h < 10; ++h)
      if (count[h]) std::printf("  head %d: %d", h, count[h]);
    std::printf("\n");
    if (!pairs.empty()) {
      std::printf("\n%-6s %7s %16s %16s %18s %18s\n", "heads", "epochs", "iba_mean_deg", "iba_std_arcsec",
                  "iba_nominal_deg", "iba_offset_arcsec");
    }
    for (const auto& p : pairs) {
      char heads[8];
      std::snprintf(heads, sizeof heads, "%d-%d", p.head_a, p.head_b);
      std::printf("%-6s %7zu %16.6f %16.2f", heads, p.epochs, p.mean_deg, p.std_arcsec);
      if (p.nominal_deg) std::printf(" %18.6f", *p.nominal_deg);
      else std::printf(" %18s", "-");
      if (p.offset_arcsec) std::printf(" %18.1f\n", *p.offset_arcsec);
      else std::printf(" %18s\n", "-");
      js_pairs.push_back({{"heads", {p.head_a, p.head_b}},
                          {"epochs", p.epochs},
                          {"iba_mean_deg", p.mean_deg},
                          {"iba_std_arcsec", p.std_arcsec},
                          {"iba_nominal_deg", p.nominal_deg ? nlohmann::json(*p.nominal_deg) : nlohmann::json(nullptr)},
                          {"iba_offset_arcsec", p.offset_arcsec ? nlohmann::json(*p.offset_arcsec) : nlohmann::json(nullptr)}});
    }
    if (!pairs.empty() && !have_qsa) std::printf("(give a QSA1B file to compare with the nominal alignment)\n");
  }

  if (!json_path.empty()) {
    nlohmann::json js = {{"files", std::move(js_files)}, {"pairs", std::move(js_pairs)}};
    const std::string text = js.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    std::string err;
    if (!io::writeFileAtomic(json_path, text, &err)) {
      std::fprintf(stderr, "boresight inspect: %s\n", err.c_str());
      return 1;
    }
    std::printf("\nJSON written to %s\n", json_path.c_str());
  }
  return status;
}

}  // namespace cmd_inspect

int runInspect(int argc, char** argv) { return cmd_inspect::runInspect(argc, argv); }

}  // namespace boresight::cli

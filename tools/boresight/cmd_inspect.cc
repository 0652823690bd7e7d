// boresight inspect PATH... [--json FILE]: what is in a set of Level-1 files.
#include <boresight/io/any_product.h>
#include <boresight/io/level1.h>
#include <boresight/io/sca_geometry.h>
#include <boresight/io/time_format.h>

#include "args.h"
#include "commands.h"
#include "json.h"

#include <algorithm>
#include <cstdio>
#include <dirent.h>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace boresight::cli {
namespace {

const char* kUsage =
    "usage: boresight inspect PATH... [--json FILE] [--boresight X,Y,Z] [--max-rejected N]\n"
    "\n"
    "For each Level-1 product file (a directory is read recursively): product, satellite, record count\n"
    "(counted, not taken from the header), first and last time tag, and rejected lines with reasons.\n"
    "Where SCA1A files with two or more heads are given: samples per head and, per head pair, the mean\n"
    "inter-boresight angle (deg) and its standard deviation (arcsec); with a QSA1B file, the angle implied\n"
    "by the QSA1B alignment (deg) and the offset (arcsec).\n"
    "\n"
    "  --json FILE        also write the results as JSON (keys: files[], pairs[])\n"
    "  --boresight X,Y,Z  boresight axis in the head frame (default 0,0,1, GRACE-FO)\n"
    "  --max-rejected N   rejected lines listed per file (default 5; all are counted)\n"
    "\n"
    "Times are GPS seconds past 2000-01-01 12:00:00 (receiver time for Level-1A) and the GPS calendar.\n"
    "Exit status: 0 when every file was read, 1 when a file could not be read, 2 on usage errors.\n";

bool isDir(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

void listFiles(const std::string& path, std::vector<std::string>& out) {
  if (!isDir(path)) {
    out.push_back(path);
    return;
  }
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
  for (const auto& n : names) listFiles(path + "/" + n, out);
}

double seconds(TimeUs t) { return toSeconds(t); }

}  // namespace

int runInspect(int argc, char** argv) {
  Args a(argc, argv, {"--json", "--boresight", "--max-rejected"}, {"--help", "-h"});
  if (a.help()) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!a.ok() || a.positional().empty()) {
    std::fprintf(stderr, "boresight inspect: %s\n\n%s", a.ok() ? "no PATH given" : a.error().c_str(), kUsage);
    return 2;
  }
  Vec3 axis = boresightDefault();
  if (a.has("--boresight")) {
    double v[3];
    if (std::sscanf(a.get("--boresight").c_str(), "%lf,%lf,%lf", &v[0], &v[1], &v[2]) != 3 ||
        Vec3(v[0], v[1], v[2]).norm() < 1e-9) {
      std::fprintf(stderr, "boresight inspect: --boresight wants three numbers X,Y,Z, not '%s'\n",
                   a.get("--boresight").c_str());
      return 2;
    }
    axis = Vec3(v[0], v[1], v[2]).normalized();
  }
  const int max_rej = std::atoi(a.get("--max-rejected", "5").c_str());

  std::vector<std::string> files;
  for (const auto& p : a.positional()) listFiles(p, files);

  JsonWriter js;
  js.beginObject().key("files").beginArray();
  int status = 0;
  std::vector<io::Sca1aRecord> sca;
  std::vector<io::QsaRecord> qsa;
  bool have_qsa = false;
  std::vector<char> sca_sats;

  std::printf("%-44s %-8s %-3s %9s %9s  %-26s %-26s %s\n", "file", "product", "sat", "records", "header",
              "first time (GPS)", "last time (GPS)", "rejected");
  for (const auto& f : files) {
    io::ProductSummary s = io::summarizeProduct(f);
    std::string shown = f.size() > 44 ? "..." + f.substr(f.size() - 41) : f;
    js.beginObject().key("file").value(f).key("product").value(s.product);
    js.key("satellite").value(std::string(1, s.satellite));
    js.key("records").value(s.records);
    if (s.declared_records) js.key("header_records").value(static_cast<long long>(*s.declared_records));
    else js.key("header_records").null();
    if (s.has_time) {
      js.key("first_time").value(seconds(s.first_time)).key("last_time").value(seconds(s.last_time));
    } else {
      js.key("first_time").null().key("last_time").null();
    }
    js.key("ok").value(s.ok);
    if (!s.ok) js.key("error").value(s.error);
    js.key("rejected").beginArray();
    for (const auto& r : s.rejected) js.beginObject().key("line").value(r.line).key("reason").value(r.reason).endObject();
    js.endArray().key("rejected_count").value(s.rejected_count).endObject();

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
    if (s.rejected_count > static_cast<std::size_t>(std::max(0, max_rej)) && max_rej >= 0)
      std::printf("    ... %zu rejected lines in all\n", s.rejected_count);

    if (s.product == "SCA1A") {
      auto sf = io::readProduct<io::Sca1aRecord>(f);
      if (sf.ok) {
        sca.insert(sca.end(), sf.records.begin(), sf.records.end());
        if (std::find(sca_sats.begin(), sca_sats.end(), s.satellite) == sca_sats.end()) sca_sats.push_back(s.satellite);
      }
    } else if (s.product == "QSA1B") {
      auto qf = io::readProduct<io::QsaRecord>(f);
      if (qf.ok) {
        qsa.insert(qsa.end(), qf.records.begin(), qf.records.end());
        have_qsa = true;
      }
    }
  }
  js.endArray();

  js.key("pairs").beginArray();
  if (sca_sats.size() > 1) {
    std::printf("\nSCA1A files of several satellites were given: inter-boresight angles need one satellite.\n");
  } else if (!sca.empty()) {
    int count[10] = {0};
    for (const auto& r : sca) count[r.head < 10 ? r.head : 0]++;
    std::printf("\nSCA1A samples per head:");
    for (int h = 1; h < 10; ++h)
      if (count[h]) std::printf("  head %d: %d", h, count[h]);
    std::printf("\n");
    auto pairs = io::interBoresightAngles(sca, have_qsa ? &qsa : nullptr, axis);
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
      js.beginObject().key("heads").beginArray().value(p.head_a).value(p.head_b).endArray();
      js.key("epochs").value(p.epochs).key("iba_mean_deg").value(p.mean_deg).key("iba_std_arcsec").value(p.std_arcsec);
      js.key("iba_nominal_deg");
      if (p.nominal_deg) js.value(*p.nominal_deg); else js.null();
      js.key("iba_offset_arcsec");
      if (p.offset_arcsec) js.value(*p.offset_arcsec); else js.null();
      js.endObject();
    }
    if (!pairs.empty() && !have_qsa) std::printf("(give a QSA1B file to compare with the nominal alignment)\n");
  }
  js.endArray().endObject();

  if (a.has("--json")) {
    std::string path = a.get("--json");
    std::FILE* out = std::fopen(path.c_str(), "w");
    if (!out) {
      std::fprintf(stderr, "boresight inspect: cannot write %s\n", path.c_str());
      return 1;
    }
    std::fputs(js.str().c_str(), out);
    std::fputc('\n', out);
    std::fclose(out);
    std::printf("\nJSON written to %s\n", path.c_str());
  }
  return status;
}

}  // namespace boresight::cli

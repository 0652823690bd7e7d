// boresight convert: Level-1 SCA1A / ACC1A files -> LCM log ordered by sensor time, and back.
#include <boresight/io/any_product.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/time_format.h>
#include <boresight/sim/output.h>

#include <boresight/stream/sources.h>

#include "cli_common.h"
#include "commands.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace boresight::cli {
namespace {

const char* kUsage =
    "usage: boresight convert INPUT... --out LOG.lcm [--strict]\n"
    "       boresight convert LOG.lcm --to-level1 DIR [--satellite C]\n"
    "\n"
    "Level-1 to LCM: SCA1A records become star_head_sample_t messages on channel STAR_HEAD and ACC1A\n"
    "records accel_sample_t messages on channel ACCEL, merged in sensor-time order (ties: heads by id,\n"
    "then the accelerometer). Other products are not node inputs: they are listed and skipped.\n"
    "Rejected lines are counted and reported per file; --strict stops at the first one.\n"
    "\n"
    "LCM to Level-1: writes SCA1A_<date>_<sat>_04.txt and ACC1A_<date>_<sat>_04.txt in DIR. The LCM\n"
    "types carry time, head, quaternion, star count and accelerations; the SCA1A fields nlocks,\n"
    "sca_confid, sca_mode and qualflg and the ACC1A ICU block number are not in them and come back as 0.\n"
    "\n"
    "  --out LOG.lcm       LCM log to write\n"
    "  --to-level1 DIR     convert an LCM log back to Level-1 files in DIR (created if missing)\n"
    "  --satellite C       satellite letter for the Level-1 files written back (default C)\n"
    "  --strict            stop at the first malformed line instead of skipping it\n"
    "\n"
    "Inputs are recognised by their content (Level-1 header, LCM log sync word), not their names. A file\n"
    "that is neither, or a log that cannot be read, is an error (exit status 1) naming the file and why.\n";

struct Event {
  TimeUs t;
  int order;  // head id for heads, 100 for the accelerometer: deterministic ties
  bool is_head;
  std::size_t index;
};

struct Options {
  std::vector<std::string> inputs;
  std::string out, to_level1, satellite = "C";
  bool strict = false;
};

int toLcm(const Options& a) {
  std::vector<io::HeadSample> heads;
  std::vector<io::AccelSample> accels;
  io::ReadOptions opt;
  if (a.strict) opt.on_error = io::OnError::Stop;
  int status = 0;
  std::map<int, std::int32_t> head_seq;
  std::int32_t acc_seq = 0;
  for (const auto& f : a.inputs) {
    stream::FileKind kind = stream::identifyFile(f);
    if (kind.type == stream::FileKind::Type::kUnknown) {
      std::fprintf(stderr, "boresight convert: %s\n", kind.reason.c_str());
      return 1;
    }
    if (kind.type == stream::FileKind::Type::kLcmLog) {
      std::fprintf(stderr, "boresight convert: %s is an LCM log: convert it with --to-level1 DIR\n", f.c_str());
      return 1;
    }
    std::string name = kind.product_name;
    if (name == "SCA1A") {
      auto p = io::readProduct<io::Sca1aRecord>(f, opt);
      if (!p.ok) {
        std::fprintf(stderr, "%s\n", p.error.c_str());
        return 1;
      }
      for (const auto& r : p.records) heads.push_back(io::headFromSca1a(r, head_seq[r.head]++));
      std::printf("%s: %zu SCA1A records, %zu rejected\n", f.c_str(), p.records.size(), p.rejected_count);
      for (std::size_t i = 0; i < p.rejected.size() && i < 5; ++i) std::printf("    rejected %s\n", p.rejected[i].str().c_str());
    } else if (name == "ACC1A" || name == "ACT1A") {
      auto p = io::readProduct<io::FlaggedRecord>(f, opt);
      if (!p.ok) {
        std::fprintf(stderr, "%s\n", p.error.c_str());
        return 1;
      }
      std::size_t without_ang = 0;
      for (const auto& r : p.records) {
        accels.push_back(io::accelFromAcc1a(r, acc_seq++));
        without_ang += (accels.back().flags & 1) ? 0 : 1;
      }
      std::printf("%s: %zu ACC1A records (%zu without angular acceleration: flagged invalid), %zu rejected\n",
                  f.c_str(), p.records.size(), without_ang, p.rejected_count);
      for (std::size_t i = 0; i < p.rejected.size() && i < 5; ++i) std::printf("    rejected %s\n", p.rejected[i].str().c_str());
    } else {
      std::printf("%s: %s is not a node input (SCA1A, ACC1A): ignored\n", f.c_str(), name.c_str());
    }
  }
  std::vector<Event> ev;
  ev.reserve(heads.size() + accels.size());
  for (std::size_t i = 0; i < heads.size(); ++i) ev.push_back({heads[i].utime, heads[i].head_id, true, i});
  for (std::size_t i = 0; i < accels.size(); ++i) ev.push_back({accels[i].utime, 100, false, i});
  std::stable_sort(ev.begin(), ev.end(), [](const Event& x, const Event& y) {
    return x.t != y.t ? x.t < y.t : x.order < y.order;
  });
  io::LcmLogWriter w;
  std::string err;
  const std::string out = a.out;
  if (!w.open(out, &err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  for (const auto& e : ev) {
    bool ok = e.is_head ? w.write(heads[e.index]) : w.write(accels[e.index]);
    if (!ok) {
      std::fprintf(stderr, "boresight convert: %s: write failed\n", out.c_str());
      return 1;
    }
  }
  w.close();
  std::printf("%s: %zu star head samples, %zu accelerometer samples", out.c_str(), heads.size(), accels.size());
  if (!ev.empty()) std::printf(", %s .. %s", io::formatTime(ev.front().t).c_str(), io::formatTime(ev.back().t).c_str());
  std::printf("\n");
  return status;
}

int toLevel1(const Options& a) {
  if (a.inputs.size() != 1) {
    std::fprintf(stderr, "boresight convert: --to-level1 takes exactly one LCM log\n");
    return 2;
  }
  const std::string log = a.inputs[0], dir = a.to_level1;
  const std::string& sat_s = a.satellite;
  if (sat_s.size() != 1 || sat_s[0] < 'A' || sat_s[0] > 'Z') {
    std::fprintf(stderr, "boresight convert: --satellite wants one capital letter, not '%s'\n", sat_s.c_str());
    return 2;
  }
  const char sat = sat_s[0];
  // Event by event into chunked writers: memory does not grow with the log.
  io::LcmLogReader reader;
  std::string err;
  if (!reader.open(log, &err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  sim::ChunkedProductWriter<io::Sca1aRecord> sca;
  sim::ChunkedProductWriter<io::FlaggedRecord> acc;
  std::string sca_path, acc_path;
  std::uint64_t invalid_heads = 0, invalid_accel = 0;
  bool dir_made = false;
  auto pathFor = [&](const char* name, TimeUs t) {
    if (!dir_made) ::mkdir(dir.c_str(), 0777);
    dir_made = true;
    return dir + "/" + name + "_" + io::formatDate(t) + "_" + sat + "_04.txt";
  };
  io::HeadSample h;
  io::AccelSample m;
  for (;;) {
    const auto k = reader.next(h, m);
    if (k == io::LcmLogReader::Kind::End) break;
    if (k == io::LcmLogReader::Kind::Head) {
      invalid_heads += (h.flags & 1) ? 0 : 1;
      if (sca_path.empty()) {
        sca_path = pathFor("SCA1A", h.utime);
        if (!sca.open(sca_path, io::makeProduct<io::Sca1aRecord>(io::Product::SCA1A, sat), &err)) {
          std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
          return 1;
        }
      }
      sca.add(io::sca1aFromHead(h, sat));
    } else if (k == io::LcmLogReader::Kind::Accel) {
      invalid_accel += (m.flags & 1) ? 0 : 1;
      if (acc_path.empty()) {
        acc_path = pathFor("ACC1A", m.utime);
        if (!acc.open(acc_path, io::makeProduct<io::FlaggedRecord>(io::Product::ACC1A, sat), &err)) {
          std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
          return 1;
        }
      }
      acc.add(io::acc1aFromAccel(m, sat));
    }
  }
  if (sca_path.empty() && acc_path.empty()) {
    std::fprintf(stderr,
                 "boresight convert: %s: no %s or %s messages in the log (%llu events on other channels, %llu "
                 "undecodable): nothing to write\n",
                 log.c_str(), io::kStarHeadChannel, io::kAccelChannel,
                 static_cast<unsigned long long>(reader.unknownChannel()),
                 static_cast<unsigned long long>(reader.decodeFailures()));
    return 1;
  }
  int status = 0;
  auto finish = [&](auto& w, const std::string& path) {
    if (path.empty()) return;
    std::string e;
    if (!w.close(&e)) {
      std::fprintf(stderr, "boresight convert: %s\n", e.c_str());
      status = 1;
      return;
    }
    std::printf("%s: %llu records\n", path.c_str(), static_cast<unsigned long long>(w.count()));
  };
  finish(sca, sca_path);
  finish(acc, acc_path);
  if (reader.unknownChannel() || reader.decodeFailures())
    std::printf("%s: %llu events on other channels and %llu undecodable messages skipped\n", log.c_str(),
                static_cast<unsigned long long>(reader.unknownChannel()),
                static_cast<unsigned long long>(reader.decodeFailures()));
  if (invalid_accel)
    std::printf("%llu accelerometer samples had no valid angular acceleration\n",
                static_cast<unsigned long long>(invalid_accel));
  if (invalid_heads)
    std::printf("%llu head samples were flagged invalid (kept)\n", static_cast<unsigned long long>(invalid_heads));
  return status;
}

}  // namespace

int runConvert(int argc, char** argv) {
  CLI::App app{"boresight convert"};
  Options o;
  app.add_option("inputs", o.inputs)->required();
  auto* out = app.add_option("--out", o.out);
  auto* back = app.add_option("--to-level1", o.to_level1);
  out->excludes(back);
  app.add_option("--satellite", o.satellite);
  app.add_flag("--strict", o.strict);
  if (int st = parseCommandLine(app, argc, argv, "convert", kUsage); st >= 0) return st;
  if (o.out.empty() == o.to_level1.empty()) {
    std::fprintf(stderr, "boresight convert: give exactly one of --out and --to-level1\n\n%s", kUsage);
    return 2;
  }
  return !o.out.empty() ? toLcm(o) : toLevel1(o);
}

}  // namespace boresight::cli

// boresight convert: Level-1 SCA1A / ACC1A files -> LCM log ordered by sensor time, and back.
#include <boresight/io/any_product.h>
#include <boresight/io/chunked_writer.h>
#include <boresight/io/files.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/time_format.h>
#include <boresight/sim/output.h>

#include <boresight/stream/assembler.h>
#include <boresight/stream/sources.h>

#include "cli_common.h"
#include "commands.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstdio>
#include <limits>
#include <map>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_convert {
namespace {

const char* kUsage =
    "usage: boresight convert INPUT... --out LOG.lcm [--strict]\n"
    "       boresight convert LOG.lcm --to-level1 DIR [--satellite C]\n"
    "\n"
    "Level-1 to LCM: SCA1A records become star_head_sample_t messages on channel STAR_HEAD and ACC1A\n"
    "records accel_sample_t messages on channel ACCEL, merged in sensor-time order (ties: heads by id,\n"
    "then the accelerometer). A QSA1B file becomes one nominal_mountings_t message (NOMINAL_MOUNTINGS)\n"
    "at the start of the log, GNV1B / GNI1B files orbit_sample_t messages (ORBIT) in time order, so a\n"
    "replay through boresightd needs nothing but its configuration and the log. Other products are\n"
    "not node inputs: they are listed and skipped.\n"
    "Rejected lines are counted and reported per file; --strict stops at the first one. The files are\n"
    "streamed and merged with a bounded look-ahead (memory does not grow with the span): a record more\n"
    "than --lookahead seconds out of time order is rejected as late and counted.\n"
    "\n"
    "LCM to Level-1: writes SCA1A_<date>_<sat>_04.txt and ACC1A_<date>_<sat>_04.txt in DIR, and the ORBIT\n"
    "messages as GNI1B (inertial) or GNV1B (Earth-fixed) files by their frame. The LCM\n"
    "types carry time, head, quaternion, star count and accelerations; the SCA1A fields nlocks,\n"
    "sca_confid, sca_mode and qualflg and the ACC1A ICU block number are not in them and come back as 0.\n"
    "\n"
    "  --out LOG.lcm       LCM log to write\n"
    "  --to-level1 DIR     convert an LCM log back to Level-1 files in DIR (created if missing)\n"
    "  --satellite C       satellite letter for the Level-1 files written back (default C)\n"
    "  --strict            stop at the first malformed line instead of skipping it\n"
    "  --lookahead S       how far out of time order a record may be and still be sorted in (default 2)\n"
    "\n"
    "Inputs are recognised by their content (Level-1 header, LCM log sync word), not their names. A file\n"
    "that is neither, or a log that cannot be read, is an error (exit status 1) naming the file and why.\n";

struct Options {
  std::vector<std::string> inputs;
  std::string out, to_level1, satellite = "C";
  bool strict = false;
  double lookahead_s = 2.0;
};

/// Level-1 -> LCM as a stream: one source per file, merged by the engine's assembler with a bounded
/// look-ahead, written sample by sample. Memory does not grow with the span. The order is the one a
/// stable sort of everything by (time tag; heads by id, then the accelerometer) gives: the assembler
/// hands out by tag, heads before the accelerometer, then by file in the order given and in each
/// file's order, and the heads of one tag are put in id order here. Records out of order by more than
/// the look-ahead are rejected as late and counted per file. Message sequence numbers count per head
/// (and for the accelerometer) in the order written.
int toLcm(const Options& a) {
  io::ReadOptions opt;
  if (a.strict) opt.on_error = io::OnError::Stop;
  std::vector<std::unique_ptr<stream::Source>> sources;
  std::vector<std::string> product_of;
  std::vector<io::QsaRecord> qsa;   // QSA1B records (the latest per head is written)
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
    const std::string& name = kind.product_name;
    std::string err;
    if (kind.product == io::Product::SCA1A) {
      auto s = std::make_unique<stream::Sca1aSource>();
      if (!s->open(f, opt, &err)) {
        std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
        return 1;
      }
      sources.push_back(std::make_unique<stream::PrefetchSource>(std::move(s)));
      product_of.push_back(name);
    } else if (kind.product == io::Product::ACC1A || kind.product == io::Product::ACT1A) {
      auto s = std::make_unique<stream::Acc1aSource>();
      if (!s->open(f, opt, &err)) {
        std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
        return 1;
      }
      s->keepWithoutAngular(true);  // written as messages with the angular bit clear
      sources.push_back(std::make_unique<stream::PrefetchSource>(std::move(s)));
      product_of.push_back(name);
    } else if (kind.product == io::Product::QSA1B) {
      auto pf = io::readProduct<io::QsaRecord>(f, opt);
      if (!pf.ok || pf.records.empty()) {
        std::fprintf(stderr, "boresight convert: %s: %s\n", f.c_str(), pf.ok ? "no QSA1B record" : pf.error.c_str());
        return 1;
      }
      if (pf.rejected_count > 0) {  // as process and calibrate: no mountings from a damaged file
        std::fprintf(stderr, "boresight convert: %s (%zu of the QSA1B lines rejected): the mountings cannot be taken from it\n",
                     pf.rejected.empty() ? f.c_str() : pf.rejected.front().str().c_str(), pf.rejected_count);
        return 1;
      }
      for (const auto& r : pf.records) qsa.push_back(r);
    } else if (kind.product == io::Product::GNV1B || kind.product == io::Product::GNI1B) {
      // The orbit is a stream like the others (the engine's source): merged by time, streamed.
      auto s = std::make_unique<stream::OrbitFileSource>();
      if (!s->open(f, opt, &err)) {
        std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
        return 1;
      }
      sources.push_back(std::move(s));
      product_of.push_back(name);
    } else {
      std::printf("%s: %s is not a node input (SCA1A, ACC1A, QSA1B, GNV1B, GNI1B): ignored\n", f.c_str(), name.c_str());
    }
  }
  stream::AssemblerConfig acfg;
  acfg.lookahead_us = static_cast<TimeUs>(std::llround(a.lookahead_s * 1e6));
  stream::EpochAssembler asm_(acfg);
  for (auto& s : sources) asm_.addSource(s.get());

  io::LcmLogWriter w;
  std::string err;
  const std::string out = a.out;
  if (!w.open(out, &err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  // The nominal mountings first (the latest QSA1B record of each head), then the samples merged by time
  // (at one tag heads, then the accelerometer, then the orbit: the assembler's order).
  if (!qsa.empty()) {
    std::map<int, io::QsaRecord> last;
    for (const auto& r : qsa)
      if (!last.count(r.sensor) || last[r.sensor].t <= r.t) last[r.sensor] = r;
    io::NominalMountings m;
    m.source = 1;
    for (const auto& kv : last) {
      if (m.n_heads >= io::NominalMountings::kCapacity) break;
      m.utime = std::max(m.utime, kv.second.t);
      m.head_id[m.n_heads] = kv.first;
      for (int k = 0; k < 4; ++k) m.q_Si_B[m.n_heads][k] = kv.second.q[k];
      ++m.n_heads;
    }
    if (!w.write(m)) {
      std::fprintf(stderr, "boresight convert: %s: write failed\n", out.c_str());
      return 1;
    }
    std::printf("%s: NOMINAL_MOUNTINGS of %d heads from QSA1B\n", out.c_str(), m.n_heads);
  }
  std::int32_t orbit_seq = 0;
  std::map<int, std::int32_t> head_seq;
  std::int32_t acc_seq = 0;
  std::uint64_t n_heads = 0, n_accel = 0, n_orbit = 0, without_ang = 0;
  TimeUs first_t = 0, last_t = 0;
  bool write_failed = false;
  // The samples of one time tag (heads first, as the assembler gives them): heads put in id order.
  std::vector<stream::Sample> group;
  auto flush = [&]() {
    auto heads_end = std::find_if(group.begin(), group.end(),
                                  [](const stream::Sample& x) { return x.kind != stream::Sample::Kind::kHead; });
    std::stable_sort(group.begin(), heads_end,
                     [](const stream::Sample& x, const stream::Sample& y) { return x.head_id < y.head_id; });
    for (const auto& x : group) {
      bool ok;
      if (x.kind == stream::Sample::Kind::kHead) {
        io::HeadSample h;
        h.utime = x.t;
        h.head_id = x.head_id;
        quatToScalarFirst(x.q_I_S, h.q);
        h.star_count = x.star_count;
        h.flags = x.flags;
        h.seq = head_seq[x.head_id]++;
        ok = w.write(h);
        ++n_heads;
      } else if (x.kind == stream::Sample::Kind::kOrbit) {
        io::OrbitSample o;
        o.utime = x.t;
        o.frame = x.orbit_frame == 'I' ? 'I' : 'E';
        for (int k = 0; k < 3; ++k) {
          o.r_m[k] = x.r_orbit[k];
          o.v_m_s[k] = x.v_orbit[k];
        }
        o.seq = orbit_seq++;
        ok = w.write(o);
        ++n_orbit;
      } else {
        io::AccelSample m;
        m.utime = x.t;
        for (int i = 0; i < 3; ++i) {
          m.ang_accel[i] = x.a_A[i];
          m.lin_accel[i] = x.lin_A[i];
        }
        m.flags = x.flags;
        m.seq = acc_seq++;
        without_ang += (m.flags & 1) ? 0 : 1;
        ok = w.write(m);
        ++n_accel;
      }
      if (!ok) write_failed = true;
    }
    group.clear();
  };
  stream::Sample x;
  for (;;) {
    const auto o = asm_.nextSample(x);
    if (o == stream::EpochAssembler::Out::kError) {
      const int i = asm_.errorSource();
      std::fprintf(stderr, "boresight convert: %s\n",
                   i >= 0 ? sources[std::size_t(i)]->error().c_str() : "a source failed");
      return 1;
    }
    if (o != stream::EpochAssembler::Out::kHeads && o != stream::EpochAssembler::Out::kAccel &&
        o != stream::EpochAssembler::Out::kOrbit)
      break;
    if (!group.empty() && group.front().t != x.t) flush();
    if (x.kind != stream::Sample::Kind::kOrbit) {  // the span of the sensors' samples
      if (n_heads + n_accel == 0) first_t = x.t;
      last_t = x.t;
    }
    group.push_back(x);
    if (write_failed) break;
  }
  flush();
  if (!write_failed && n_heads + n_accel == 0) {
    std::fprintf(stderr, "boresight convert: no star head or accelerometer sample in the inputs: nothing to write\n");
    return 1;  // the writer removes its temporary file
  }
  if (!write_failed && !w.close(&err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  if (write_failed) {
    std::fprintf(stderr, "boresight convert: %s: write failed\n", out.c_str());
    return 1;
  }
  // Every record read is written or rejected with its reason, per file.
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const auto& c = asm_.counters(i);
    std::printf("%s: %llu %s records read, %llu written", sources[i]->name().c_str(),
                static_cast<unsigned long long>(c.read), product_of[i].c_str(),
                static_cast<unsigned long long>(c.used()));
    for (int r = 0; r < stream::kRejectCount; ++r)
      if (c.rejected[std::size_t(r)])
        std::printf(", %llu rejected: %s", static_cast<unsigned long long>(c.rejected[std::size_t(r)]),
                    io::rejectText(stream::Reject(r)));
    std::printf("\n");
    auto issues = sources[i]->issues();
    for (std::size_t k = 0; k < issues.size() && k < 5; ++k) std::printf("    rejected %s\n", issues[k].c_str());
  }
  if (without_ang)
    std::printf("%llu accelerometer records without angular acceleration: written flagged invalid\n",
                static_cast<unsigned long long>(without_ang));
  if (asm_.counters().rejected[std::size_t(stream::Reject::kLate)])
    std::printf("%llu records more than the look-ahead (%.3g s) out of time order: rejected as late (--lookahead)\n",
                static_cast<unsigned long long>(asm_.counters().rejected[std::size_t(stream::Reject::kLate)]),
                a.lookahead_s);
  std::printf("%s: %llu star head samples, %llu accelerometer samples", out.c_str(),
              static_cast<unsigned long long>(n_heads), static_cast<unsigned long long>(n_accel));
  if (n_heads + n_accel) std::printf(", %s .. %s", io::formatTime(first_t).c_str(), io::formatTime(last_t).c_str());
  if (n_orbit) std::printf("; %llu orbit samples", static_cast<unsigned long long>(n_orbit));
  std::printf("\n");
  return 0;
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
  io::ChunkedProductWriter<io::Sca1aRecord> sca;
  io::ChunkedProductWriter<io::FlaggedRecord> acc;
  io::ChunkedProductWriter<io::GnvRecord> gni, gnv;  // ORBIT messages by frame: inertial, Earth-fixed
  std::string sca_path, acc_path, gni_path, gnv_path;
  std::uint64_t invalid_heads = 0, invalid_accel = 0;
  io::OutputDir out_dir;  // created when missing, removed again when the conversion fails
  if (!out_dir.open(dir, &err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  auto pathFor = [&](const char* name, TimeUs t) {
    return dir + "/" + name + "_" + io::formatDate(t) + "_" + sat + "_04.txt";
  };
  // The file names are known once the first tag is: none of them may be the log being read.
  auto refuseOverInput = [&](const std::string& path) {
    std::string e;
    if (io::checkOutputs({log}, {{"--to-level1", path}}, &e)) return false;
    std::fprintf(stderr, "boresight convert: %s\n", e.c_str());
    return true;
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
        if (refuseOverInput(sca_path)) return 1;
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
        if (refuseOverInput(acc_path)) return 1;
        if (!acc.open(acc_path, io::makeProduct<io::FlaggedRecord>(io::Product::ACC1A, sat), &err)) {
          std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
          return 1;
        }
      }
      acc.add(io::acc1aFromAccel(m, sat));
    } else if (k == io::LcmLogReader::Kind::Orbit) {
      const io::OrbitSample& o = reader.orbit();
      const bool inertial = o.frame == 'I';
      std::string& path = inertial ? gni_path : gnv_path;
      auto& w = inertial ? gni : gnv;
      if (path.empty()) {
        path = pathFor(inertial ? "GNI1B" : "GNV1B", o.utime);
        if (refuseOverInput(path)) return 1;
        if (!w.open(path, io::makeProduct<io::GnvRecord>(inertial ? io::Product::GNI1B : io::Product::GNV1B, sat), &err)) {
          std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
          return 1;
        }
      }
      io::GnvRecord g;
      g.t = o.utime;
      g.satellite = sat;
      g.coord_ref = o.frame;
      for (int i = 0; i < 3; ++i) {
        g.pos[i] = o.r_m[i];
        g.vel[i] = o.v_m_s[i];
      }
      w.add(g);
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
  finish(gni, gni_path);
  finish(gnv, gnv_path);
  if (status == 0) out_dir.keep();
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
  app.add_option("--lookahead", o.lookahead_s)->check(finiteRange(0.0, 3600.0));
  if (int st = parseCommandLine(app, argc, argv, "convert", kUsage); st >= 0) return st;
  if (o.out.empty() == o.to_level1.empty()) {
    std::fprintf(stderr, "boresight convert: give exactly one of --out and --to-level1\n\n%s", kUsage);
    return 2;
  }
  std::string err;
  if (!io::checkOutputs(o.inputs, {{"--out", o.out}, {"--to-level1", o.to_level1, true}}, &err)) {
    std::fprintf(stderr, "boresight convert: %s\n", err.c_str());
    return 1;
  }
  return !o.out.empty() ? toLcm(o) : toLevel1(o);
}

}  // namespace cmd_convert

int runConvert(int argc, char** argv) { return cmd_convert::runConvert(argc, argv); }

}  // namespace boresight::cli

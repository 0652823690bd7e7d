// `boresight convert` Level-1 -> LCM as a stream (the engine's sources and assembler), against the
// implementation it replaced: every record loaded, stable-sorted by (time; heads by id, then the
// accelerometer), written. Same log bytes on a span split into several files; records out of order
// inside the look-ahead sorted in, beyond it rejected as late, counted and named.
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

using namespace boresight;

namespace {

using testutil::slurp;

std::string tempDir() { return testutil::makeTempDir("boresight_convert"); }

using testutil::CliRun;
CliRun run(const std::string& args) { return testutil::runProgram(BORESIGHT_CLI, args); }

struct Records {
  std::vector<io::Sca1aRecord> sca;
  std::vector<io::FlaggedRecord> acc;
};

/// A 10-minute simulated span (3 heads at 2 Hz, accelerometer at 10 Hz).
const Records& span() {
  static const Records r = [] {
    Records out;
    const std::string dir = tempDir();
    sim::Scenario sc;
    std::string err;
    EXPECT_TRUE(sim::loadScenario(std::string(BORESIGHT_SOURCE_DIR) + "/config/sim_gracefo.yaml", sc, &err)) << err;
    sim::Simulator simulator;
    EXPECT_TRUE(simulator.init(sc, 5, 600.0, &err)) << err;
    sim::Level1Sink l1;
    EXPECT_TRUE(l1.open(dir, sc, &err)) << err;
    simulator.run(l1);
    EXPECT_TRUE(l1.close(&err)) << err;
    auto s = io::readProduct<io::Sca1aRecord>(dir + "/" + sim::productFileName("SCA1A", sc));
    auto a = io::readProduct<io::FlaggedRecord>(dir + "/" + sim::productFileName("ACC1A", sc));
    EXPECT_TRUE(s.ok && a.ok) << s.error << a.error;
    out.sca = s.records;
    out.acc = a.records;
    return out;
  }();
  return r;
}

template <typename Rec>
std::string writeRecords(const std::string& path, io::Product product, const std::vector<Rec>& recs) {
  auto f = io::makeProduct<Rec>(product, 'C');
  f.records = recs;
  std::string err;
  EXPECT_TRUE(io::writeProduct(path, f, &err)) << err;
  return path;
}

/// The replaced implementation: files read whole in the order given, message sequence numbers in
/// read order, a stable sort by (time; heads by id, then the accelerometer), written.
/// `seq_in_time_order`: sequence numbers given after the sort instead (the streaming convert numbers
/// in the order written; the two agree when every file is in time order).
void referenceLog(const std::vector<std::vector<io::Sca1aRecord>>& sca_files,
                  const std::vector<std::vector<io::FlaggedRecord>>& acc_files, const std::string& out,
                  bool seq_in_time_order) {
  std::vector<io::HeadSample> heads;
  std::vector<io::AccelSample> accels;
  std::map<int, std::int32_t> head_seq;
  std::int32_t acc_seq = 0;
  for (const auto& f : sca_files)
    for (const auto& r : f) heads.push_back(io::headFromSca1a(r, head_seq[r.head]++));
  for (const auto& f : acc_files)
    for (const auto& r : f) accels.push_back(io::accelFromAcc1a(r, acc_seq++));
  struct Ev {
    TimeUs t;
    int order;
    bool head;
    std::size_t i;
  };
  std::vector<Ev> ev;
  for (std::size_t i = 0; i < heads.size(); ++i) ev.push_back({heads[i].utime, heads[i].head_id, true, i});
  for (std::size_t i = 0; i < accels.size(); ++i) ev.push_back({accels[i].utime, 100, false, i});
  std::stable_sort(ev.begin(), ev.end(), [](const Ev& x, const Ev& y) { return x.t != y.t ? x.t < y.t : x.order < y.order; });
  io::LcmLogWriter w;
  std::string err;
  ASSERT_TRUE(w.open(out, &err)) << err;
  head_seq.clear();
  acc_seq = 0;
  for (const auto& e : ev) {
    if (e.head) {
      io::HeadSample h = heads[e.i];
      if (seq_in_time_order) h.seq = head_seq[h.head_id]++;
      ASSERT_TRUE(w.write(h));
    } else {
      io::AccelSample a = accels[e.i];
      if (seq_in_time_order) a.seq = acc_seq++;
      ASSERT_TRUE(w.write(a));
    }
  }
  w.close();
}

template <typename Rec>
std::vector<std::vector<Rec>> splitInThree(const std::vector<Rec>& v) {
  const std::size_t a = v.size() / 3, b = 2 * v.size() / 3;
  return {std::vector<Rec>(v.begin(), v.begin() + long(a)), std::vector<Rec>(v.begin() + long(a), v.begin() + long(b)),
          std::vector<Rec>(v.begin() + long(b), v.end())};
}

/// Writes the files (SCA1A_<i>.txt, ACC1A_<i>.txt) and returns them as command-line arguments.
std::string writeFiles(const std::string& d, const std::vector<std::vector<io::Sca1aRecord>>& sca,
                       const std::vector<std::vector<io::FlaggedRecord>>& acc) {
  std::string args;
  for (std::size_t i = 0; i < sca.size(); ++i)
    args += " " + writeRecords(d + "/SCA1A_" + std::to_string(i) + ".txt", io::Product::SCA1A, sca[i]);
  for (std::size_t i = 0; i < acc.size(); ++i)
    args += " " + writeRecords(d + "/ACC1A_" + std::to_string(i) + ".txt", io::Product::ACC1A, acc[i]);
  return args;
}

}  // namespace

TEST(StreamConvert, SeveralFilesGiveTheSameLogBytesAsLoadSortWrite) {
  auto acc = span().acc;
  ASSERT_GT(acc.size(), 5000u);
  // One record without angular accelerations (written flagged invalid, as before), and one without
  // the linear ones.
  acc[1234].prod_flag.value &= ~0x38u;
  acc[2345].prod_flag.value &= ~0x07u;
  const auto sca_files = splitInThree(span().sca);
  const auto acc_files = splitInThree(acc);
  const std::string d = tempDir();
  const std::string args = writeFiles(d, sca_files, acc_files);
  referenceLog(sca_files, acc_files, d + "/ref.lcm", false);
  CliRun r = run("convert" + args + " --out " + d + "/new.lcm");
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string ref = slurp(d + "/ref.lcm"), got = slurp(d + "/new.lcm");
  EXPECT_GT(ref.size(), 100000u);
  EXPECT_TRUE(ref == got) << "log bytes differ (" << ref.size() << " vs " << got.size() << ")\n" << r.out;
  EXPECT_NE(r.out.find("1 accelerometer records without angular acceleration"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("rejected"), std::string::npos) << r.out;
}

TEST(StreamConvert, OutOfOrderInsideTheLookAheadSortedBeyondItRejectedAsLate) {
  auto sca = span().sca;
  auto acc = span().acc;
  // Inside the 2 s look-ahead: neighbouring epochs swapped (0.5-1 s), runs of 10 ACC records reversed.
  auto sca_in = sca;
  for (std::size_t i = 200; i + 3 < 260; i += 6) std::swap(sca_in[i], sca_in[i + 3]);
  auto acc_in = acc;
  for (std::size_t i = 1000; i + 10 < 1200; i += 10) std::reverse(acc_in.begin() + long(i), acc_in.begin() + long(i + 10));
  // The heads of one tag in reverse id order in the file: written in id order (as before).
  ASSERT_TRUE(sca_in[600].t == sca_in[602].t && sca_in[600].head < sca_in[602].head);
  std::reverse(sca_in.begin() + 600, sca_in.begin() + 603);
  const std::string d = tempDir();
  std::string args = writeFiles(d, {sca_in}, {acc_in});
  referenceLog({sca_in}, {acc_in}, d + "/ref.lcm", true);
  CliRun r = run("convert" + args + " --out " + d + "/in.lcm");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(slurp(d + "/ref.lcm") == slurp(d + "/in.lcm")) << r.out;

  // Beyond it: one head record 30 s later in its file, one ACC record 60 s later: rejected as late,
  // counted per file, and the log is that of the data without them.
  const std::string e = tempDir();
  auto sca_late = sca;
  const auto moved_head = sca_late[300];
  sca_late.erase(sca_late.begin() + 300);
  auto sca_without = sca_late;
  sca_late.insert(sca_late.begin() + 300 + 30 * 6, moved_head);
  auto acc_late = acc;
  const auto moved_acc = acc_late[2000];
  acc_late.erase(acc_late.begin() + 2000);
  auto acc_without = acc_late;
  acc_late.insert(acc_late.begin() + 2000 + 600, moved_acc);
  args = writeFiles(e, {sca_late}, {acc_late});
  referenceLog({sca_without}, {acc_without}, e + "/ref.lcm", true);
  CliRun l = run("convert" + args + " --out " + e + "/late.lcm");
  ASSERT_EQ(l.status, 0) << l.out;
  EXPECT_TRUE(slurp(e + "/ref.lcm") == slurp(e + "/late.lcm")) << l.out;
  EXPECT_NE(l.out.find("SCA1A_0.txt: " + std::to_string(sca.size()) + " SCA1A records read, " +
                       std::to_string(sca.size() - 1) + " written, 1 rejected: late"),
            std::string::npos)
      << l.out;
  EXPECT_NE(l.out.find("ACC1A_0.txt: " + std::to_string(acc.size()) + " ACC1A records read, " +
                       std::to_string(acc.size() - 1) + " written, 1 rejected: late"),
            std::string::npos)
      << l.out;
  EXPECT_NE(l.out.find("2 records more than the look-ahead"), std::string::npos) << l.out;

  // A look-ahead longer than the displacements takes them in: the log of the sorted data.
  CliRun w = run("convert" + args + " --out " + e + "/wide.lcm --lookahead 90");
  ASSERT_EQ(w.status, 0) << w.out;
  referenceLog({sca_late}, {acc_late}, e + "/ref_wide.lcm", true);
  EXPECT_TRUE(slurp(e + "/ref_wide.lcm") == slurp(e + "/wide.lcm")) << w.out;
}

TEST(StreamConvert, StrictStopsAtTheFirstMalformedLineWithFileAndLine) {
  const std::string d = tempDir();
  std::vector<io::Sca1aRecord> sca(span().sca.begin(), span().sca.begin() + 60);
  const std::string f = writeRecords(d + "/SCA1A_0.txt", io::Product::SCA1A, sca);
  {
    std::FILE* fp = std::fopen(f.c_str(), "ab");
    ASSERT_NE(fp, nullptr);
    std::fputs("738849600 this is not a record\n", fp);
    std::fclose(fp);
  }
  CliRun lax = run("convert " + f + " --out " + d + "/a.lcm");
  EXPECT_EQ(lax.status, 0) << lax.out;
  EXPECT_NE(lax.out.find("61 SCA1A records read, 60 written, 1 rejected: malformed"), std::string::npos) << lax.out;
  CliRun strict = run("convert " + f + " --out " + d + "/b.lcm --strict");
  EXPECT_EQ(strict.status, 1) << strict.out;
  EXPECT_NE(strict.out.find(f + ":"), std::string::npos) << strict.out;
}

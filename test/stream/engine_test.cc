// The streaming replay engine on simulated spans, against a reference replay that loads everything,
// sorts it and merges it (the replay `boresight process` used before the engine). Rows are compared
// bit for bit; every input record must be used or rejected with a reason.
#include <boresight/core/rotation.h>
#include <boresight/io/core_config.h>
#include <boresight/io/level1.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>
#include <boresight/stream/sources.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

using namespace boresight;

namespace {

using testutil::slurp;

std::string sourceDir() { return BORESIGHT_SOURCE_DIR; }

std::string tempDir() { return testutil::makeTempDir("boresight_stream"); }

/// A simulated span written as `simulate` writes it: SCA1A, ACC1A, QSA1B and the LCM log.
struct Span {
  std::string dir, sca, acc, qsa, lcm, scv;
};

Span simulate(double seconds, std::uint64_t seed = 11) {
  Span s;
  s.dir = tempDir();
  sim::Scenario sc;
  std::string err;
  EXPECT_TRUE(sim::loadScenario(sourceDir() + "/config/sim_gracefo.yaml", sc, &err)) << err;
  sim::Simulator simulator;
  EXPECT_TRUE(simulator.init(sc, seed, seconds, &err)) << err;
  sim::Level1Sink l1;
  sim::LcmSink log;
  s.lcm = s.dir + "/sim.lcmlog";
  EXPECT_TRUE(l1.open(s.dir, sc, &err)) << err;
  EXPECT_TRUE(log.open(s.lcm, &err)) << err;
  sim::TeeSink tee;
  tee.add(&l1);
  tee.add(&log);
  simulator.run(tee);
  EXPECT_TRUE(l1.close(&err)) << err;
  EXPECT_TRUE(log.close(&err)) << err;
  s.sca = s.dir + "/" + sim::productFileName("SCA1A", sc);
  s.acc = s.dir + "/" + sim::productFileName("ACC1A", sc);
  s.qsa = s.dir + "/" + sim::productFileName("QSA1B", sc);
  s.scv = s.dir + "/" + sim::productFileName("SCV1A", sc);
  EXPECT_TRUE(sim::writeQsa1b(s.qsa, simulator, &err)) << err;
  return s;
}

/// One simulated span shared by the tests (10 minutes: rates need ~35 s on each side).
const Span& span() {
  static const Span s = simulate(600.0);
  return s;
}

/// The platform with the ideal noise preset: the spans are simulated from config/sim_gracefo.yaml
/// (white 6"/48" heads).
core::PipelineConfig pipelineConfig(const std::vector<io::Sca1aRecord>& sca, bool with_acc = true) {
  io::PlatformConfig pc;
  std::string err;
  EXPECT_TRUE(io::loadPlatformConfig(sourceDir() + "/config/gracefo_ideal.yaml", pc, &err)) << err;
  auto q = io::readProduct<io::QsaRecord>(span().qsa);
  EXPECT_TRUE(q.ok) << q.error;
  TimeUs t0 = sca.empty() ? 0 : std::min_element(sca.begin(), sca.end(), [](auto& a, auto& b) { return a.t < b.t; })->t;
  EXPECT_TRUE(io::applyQsa1bMounting(pc, q.records, t0, &err)) << err;
  if (!with_acc) pc.pipeline.use_accelerometer = false;
  return pc.pipeline;
}

/// The replay before the engine: everything loaded, stable-sorted by time, merged (heads first).
std::vector<core::PipelineRow> referenceRows(std::vector<io::Sca1aRecord> sca, std::vector<io::FlaggedRecord> acc,
                                             const core::PipelineConfig& cfg) {
  std::stable_sort(sca.begin(), sca.end(), [](const auto& x, const auto& y) { return x.t < y.t; });
  std::stable_sort(acc.begin(), acc.end(), [](const auto& x, const auto& y) { return x.t < y.t; });
  auto pipe = std::make_unique<core::Pipeline>();
  EXPECT_EQ(pipe->configure(cfg), core::Status::kOk);
  std::vector<core::PipelineRow> rows;
  auto drain = [&] {
    core::PipelineRow r;
    while (pipe->popRow(r)) rows.push_back(r);
  };
  std::size_t i = 0, j = 0;
  while (i < sca.size() || j < acc.size()) {
    if (j >= acc.size() || (i < sca.size() && sca[i].t <= acc[j].t)) {
      core::HeadEpoch e;
      e.t = sca[i].t;
      while (i < sca.size() && sca[i].t == e.t) {
        if (e.n < core::kMaxHeads) {
          auto& s = e.sample[static_cast<std::size_t>(e.n++)];
          s.head_id = sca[i].head;
          s.q_I_Si = quatFromScalarFirst(sca[i].q);
        }
        ++i;
      }
      pipe->stepHeads(e);
    } else {
      const auto& r = acc[j++];
      if (!(r.has(io::acc_bits::kAngX) && r.has(io::acc_bits::kAngY) && r.has(io::acc_bits::kAngZ))) continue;
      pipe->stepAcc(r.t, Vec3(r.value[3], r.value[4], r.value[5]));
    }
    drain();
  }
  pipe->flush();
  drain();
  return rows;
}

struct VectorSink final : stream::RowSink {
  std::vector<core::PipelineRow> rows;
  std::vector<stream::StarSolution> stars;
  bool write(const core::PipelineRow& r) override {
    rows.push_back(r);
    return true;
  }
  bool writeStars(const stream::StarSolution& s) override {
    stars.push_back(s);
    return true;
  }
};

bool sameBits(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

/// Rows identical field by field (NaN == NaN). Reports the first difference.
::testing::AssertionResult sameRows(const std::vector<core::PipelineRow>& a, const std::vector<core::PipelineRow>& b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << "row counts " << a.size() << " vs " << b.size();
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto& x = a[i];
    const auto& y = b[i];
    bool same = x.t == y.t && x.heads_used == y.heads_used && x.has_rates == y.has_rates && x.has_acc == y.has_acc &&
                x.q_I_B.coeffs() == y.q_I_B.coeffs();
    for (int k = 0; k < 3 && same; ++k)
      same = sameBits(x.w_B[k], y.w_B[k]) && sameBits(x.a_sc_B[k], y.a_sc_B[k]) && sameBits(x.a_acc_B[k], y.a_acc_B[k]);
    for (std::size_t p = 0; p < x.iba_rad.size() && same; ++p)
      same = sameBits(x.iba_rad[p], y.iba_rad[p]) && sameBits(x.iba_dev_rad[p], y.iba_dev_rad[p]);
    if (!same) return ::testing::AssertionFailure() << "row " << i << " (t " << x.t << " / " << y.t << ") differs";
  }
  return ::testing::AssertionSuccess();
}

struct EngineRun {
  std::vector<core::PipelineRow> rows;
  std::vector<stream::StarSolution> stars;
  std::uint64_t star_epochs = 0;
  stream::Counters total;
  std::vector<stream::Counters> per_source;
  TimeUs first = 0, last = 0;
  stream::Engine::Result result = stream::Engine::Result::kError;
  std::string error;
};

EngineRun runEngine(const std::vector<std::string>& sca, const std::vector<std::string>& acc,
                    const std::vector<std::string>& lcm, const core::PipelineConfig& cfg,
                    stream::AssemblerConfig acfg = {}, bool prefetch = false, const std::vector<std::string>& scv = {}) {
  EngineRun out;
  stream::Engine e(acfg);
  std::string err;
  EXPECT_TRUE(e.configure(cfg, &err)) << err;
  auto add = [&](std::unique_ptr<stream::Source> s) {
    if (prefetch) s = std::make_unique<stream::PrefetchSource>(std::move(s), 64, 2);
    e.addSource(std::move(s));
  };
  for (const auto& f : sca) {
    auto s = std::make_unique<stream::Sca1aSource>();
    EXPECT_TRUE(s->open(f, {}, &err)) << err;
    add(std::move(s));
  }
  for (const auto& f : acc) {
    auto s = std::make_unique<stream::Acc1aSource>();
    EXPECT_TRUE(s->open(f, {}, &err)) << err;
    add(std::move(s));
  }
  for (const auto& f : scv) {
    auto s = std::make_unique<stream::ScvSource>();
    EXPECT_TRUE(s->open(f, {}, &err)) << err;
    add(std::move(s));
  }
  for (const auto& f : lcm) {
    auto s = std::make_unique<stream::LcmLogSource>();
    EXPECT_TRUE(s->open(f, &err)) << err;
    add(std::move(s));
  }
  VectorSink sink;
  e.addSink(&sink);
  out.result = e.run();
  out.error = e.error();
  out.rows = std::move(sink.rows);
  out.stars = std::move(sink.stars);
  out.star_epochs = e.starEpochs();
  out.total = e.counters();
  for (std::size_t i = 0; i < e.sourceCount(); ++i) out.per_source.push_back(e.counters(i));
  out.first = e.firstEpoch();
  out.last = e.lastEpoch();
  return out;
}

std::vector<io::Sca1aRecord> readSca(const std::string& f) {
  auto p = io::readProduct<io::Sca1aRecord>(f);
  EXPECT_TRUE(p.ok) << p.error;
  return p.records;
}
std::vector<io::FlaggedRecord> readAcc(const std::string& f) {
  auto p = io::readProduct<io::FlaggedRecord>(f);
  EXPECT_TRUE(p.ok) << p.error;
  return p.records;
}

template <typename Rec>
std::string writeRecords(const std::string& path, io::Product product, const std::vector<Rec>& recs) {
  auto f = io::makeProduct<Rec>(product, 'C');
  f.records = recs;
  std::string err;
  EXPECT_TRUE(io::writeProduct(path, f, &err)) << err;
  return path;
}

void expectCountersAddUp(const EngineRun& r) {
  EXPECT_EQ(r.total.read, r.total.used() + r.total.rejectedTotal());
  stream::Counters sum;
  for (const auto& c : r.per_source) {
    EXPECT_EQ(c.read, c.used() + c.rejectedTotal());
    sum.read += c.read;
  }
  EXPECT_EQ(sum.read, r.total.read);
}

}  // namespace

TEST(StreamEngine, Level1RowsEqualTheLoadSortMergeReplay) {
  const auto sca = readSca(span().sca);
  const auto acc = readAcc(span().acc);
  ASSERT_GT(sca.size(), 1000u);
  const auto cfg = pipelineConfig(sca);
  const auto ref = referenceRows(sca, acc, cfg);
  ASSERT_GT(ref.size(), 500u);
  ASSERT_TRUE(std::any_of(ref.begin(), ref.end(), [](const auto& r) { return r.has_rates && r.has_acc; }));
  for (bool prefetch : {false, true}) {
    EngineRun r = runEngine({span().sca}, {span().acc}, {}, cfg, {}, prefetch);
    ASSERT_EQ(r.result, stream::Engine::Result::kDone) << r.error;
    EXPECT_TRUE(sameRows(r.rows, ref)) << "prefetch " << prefetch;
    EXPECT_EQ(r.total.read, sca.size() + acc.size());
    EXPECT_EQ(r.total.used_heads, sca.size());
    EXPECT_EQ(r.total.rejectedTotal(), 0u);
    expectCountersAddUp(r);
    // First and last epochs: the first and last head tags, and rows cover them.
    EXPECT_EQ(r.first, sca.front().t);
    EXPECT_EQ(r.last, sca.back().t);
    EXPECT_EQ(r.rows.front().t, sca.front().t);
    // Rows come at the output rate (every other epoch here): the last is within one second of the end.
    EXPECT_LE(r.rows.back().t, sca.back().t);
    EXPECT_GT(r.rows.back().t, sca.back().t - kUsPerSecond);
    EXPECT_EQ(r.rows.back().t, ref.back().t);
  }
}

/// Records what an InputObserver sees.
struct RecordingObserver final : stream::InputObserver {
  std::vector<TimeUs> head_tags, acc_tags;
  std::uint64_t head_samples = 0, heads_ok = 0, acc_ok = 0;
  int ends = 0;
  bool after_end = false;
  void onHeads(const core::HeadEpoch& e, core::Status st) override {
    after_end = after_end || ends > 0;
    head_tags.push_back(e.t);
    head_samples += std::uint64_t(e.n);
    heads_ok += st == core::Status::kOk;
  }
  void onAcc(TimeUs t, const Vec3&, core::Status st) override {
    after_end = after_end || ends > 0;
    acc_tags.push_back(t);
    acc_ok += st == core::Status::kOk;
  }
  void onEnd() override { ++ends; }
};

TEST(StreamEngine, AnObserverSeesEveryEpochAndAccelerometerSampleTheCoreGets) {
  const auto sca = readSca(span().sca);
  const auto acc = readAcc(span().acc);
  const auto cfg = pipelineConfig(sca);
  stream::Engine e;
  std::string err;
  ASSERT_TRUE(e.configure(cfg, &err)) << err;
  auto s1 = std::make_unique<stream::Sca1aSource>();
  ASSERT_TRUE(s1->open(span().sca, {}, &err)) << err;
  auto s2 = std::make_unique<stream::Acc1aSource>();
  ASSERT_TRUE(s2->open(span().acc, {}, &err)) << err;
  e.addSource(std::move(s1));
  e.addSource(std::move(s2));
  RecordingObserver a, b;
  e.addObserver(&a);
  e.addObserver(&b);
  ASSERT_EQ(e.run(), stream::Engine::Result::kDone) << e.error();
  for (const RecordingObserver* o : {&a, &b}) {
    EXPECT_EQ(o->head_tags.size(), e.epochs());
    EXPECT_EQ(o->head_samples, e.counters().used_heads);
    EXPECT_EQ(o->head_samples, sca.size());
    EXPECT_EQ(o->acc_tags.size(), e.counters().used_accel);
    EXPECT_EQ(o->acc_tags.size(), acc.size());
    // First and last epochs, in time order, every status the core gave counted; onEnd once, last.
    ASSERT_FALSE(o->head_tags.empty());
    EXPECT_EQ(o->head_tags.front(), e.firstEpoch());
    EXPECT_EQ(o->head_tags.back(), e.lastEpoch());
    EXPECT_TRUE(std::is_sorted(o->head_tags.begin(), o->head_tags.end()));
    EXPECT_TRUE(std::is_sorted(o->acc_tags.begin(), o->acc_tags.end()));
    EXPECT_EQ(o->heads_ok, e.epochs());  // clean simulated data: the core takes every epoch
    EXPECT_EQ(o->ends, 1);
    EXPECT_FALSE(o->after_end);
  }
  // run() after the end does not call the observer again.
  EXPECT_EQ(e.run(), stream::Engine::Result::kDone);
  EXPECT_EQ(a.ends, 1);
}

/// Hands out a fixed list of samples.
class ListSource final : public stream::Source {
 public:
  explicit ListSource(std::vector<stream::Sample> v) : v_(std::move(v)) {}
  Next next(stream::Sample& out, stream::Reject&) override {
    if (i_ >= v_.size()) return Next::kEnd;
    out = v_[i_++];
    return Next::kSample;
  }
  const std::string& name() const override { return name_; }

 private:
  std::vector<stream::Sample> v_;
  std::size_t i_ = 0;
  std::string name_ = "list";
};

TEST(StreamEngine, AnObserverGetsHeadEpochsAsTheCoreValidatorLeavesThem) {
  const auto sca = readSca(span().sca);
  const auto cfg = pipelineConfig(sca, false);
  ASSERT_EQ(cfg.heads.n_heads, 3);
  const int id0 = cfg.heads.head[0].id, id1 = cfg.heads.head[1].id, id2 = cfg.heads.head[2].id;
  auto head = [](TimeUs t, int id, Quat q) {
    stream::Sample x;
    x.kind = stream::Sample::Kind::kHead;
    x.t = t;
    x.head_id = id;
    x.q_I_S = q;
    return x;
  };
  const Quat q(Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized()));
  const Quat nan(NAN, 0, 0, 0);
  const Quat scaled(q.coeffs() * (1.0 + 2e-6));  // inside the unit-norm tolerance: normalised
  std::vector<stream::Sample> in = {
      head(1000000, id2, q), head(1000000, id0, q), head(1000000, id1, q),  // slot order on output
      head(1500000, id0, q), head(1500000, id1, nan), head(1500000, 99, q),  // NaN and unknown id dropped
      head(2000000, id1, nan),                                                // nothing valid: not passed
      head(2500000, id0, scaled), head(2500000, id0, q),                      // a head twice: second dropped
  };
  stream::Engine e;
  std::string err;
  ASSERT_TRUE(e.configure(cfg, &err)) << err;
  e.addSource(std::make_unique<ListSource>(in));
  struct Obs final : stream::InputObserver {
    std::vector<core::HeadEpoch> got;
    void onHeads(const core::HeadEpoch& x, core::Status) override { got.push_back(x); }
  } obs;
  e.addObserver(&obs);
  ASSERT_EQ(e.run(), stream::Engine::Result::kDone) << e.error();
  EXPECT_EQ(e.epochs(), 4u);
  ASSERT_EQ(obs.got.size(), 3u);
  ASSERT_EQ(obs.got[0].n, 3);
  EXPECT_EQ(obs.got[0].sample[0].head_id, id0);
  EXPECT_EQ(obs.got[0].sample[1].head_id, id1);
  EXPECT_EQ(obs.got[0].sample[2].head_id, id2);
  ASSERT_EQ(obs.got[1].n, 1);
  EXPECT_EQ(obs.got[1].t, 1500000);
  EXPECT_EQ(obs.got[1].sample[0].head_id, id0);
  ASSERT_EQ(obs.got[2].n, 1);
  EXPECT_EQ(obs.got[2].t, 2500000);
  EXPECT_NEAR(obs.got[2].sample[0].q_I_Si.norm(), 1.0, 1e-15);
  EXPECT_NEAR(obs.got[2].sample[0].q_I_Si.angularDistance(q), 0.0, 1e-12);
  for (const auto& x : obs.got)
    for (int k = 0; k < x.n; ++k) EXPECT_TRUE(core::allFinite(x.sample[std::size_t(k)].q_I_Si));
}

/// The span's head and accelerometer records as samples in time order (heads first at equal tags), the
/// order a live link delivers them in.
std::vector<stream::Sample> mergedSamples(const std::vector<io::Sca1aRecord>& sca, const std::vector<io::FlaggedRecord>& acc) {
  std::vector<stream::Sample> v;
  for (const auto& r : sca) {
    stream::Sample x;
    x.kind = stream::Sample::Kind::kHead;
    x.t = r.t;
    x.head_id = r.head;
    x.q_I_S = quatFromScalarFirst(r.q);
    v.push_back(x);
  }
  for (const auto& r : acc) {
    stream::Sample x;
    x.kind = stream::Sample::Kind::kAccel;
    x.t = r.t;
    x.a_A = Vec3(r.value[3], r.value[4], r.value[5]);
    v.push_back(x);
  }
  std::stable_sort(v.begin(), v.end(), [](const stream::Sample& a, const stream::Sample& b) {
    return a.t != b.t ? a.t < b.t : static_cast<int>(a.kind) < static_cast<int>(b.kind);
  });
  return v;
}

/// What a driver's hook sees: every boundary and step, in order.
struct RecordingHook final : stream::StepHook {
  std::vector<TimeUs> before, heads, accs;
  int out_of_order = 0;  ///< a head step without its boundary just before it
  bool open_boundary = false;
  double min_head_ns = 1e300;
  void beforeHeads(const core::HeadEpoch& e) override {
    if (open_boundary) ++out_of_order;
    before.push_back(e.t);
    open_boundary = true;
  }
  void afterStep(stream::Sample::Kind k, TimeUs t, core::Status, double ns) override {
    if (k == stream::Sample::Kind::kHead) {
      if (!open_boundary || before.back() != t) ++out_of_order;
      open_boundary = false;
      heads.push_back(t);
      min_head_ns = std::min(min_head_ns, ns);
    } else if (k == stream::Sample::Kind::kAccel) {
      accs.push_back(t);
    }
  }
};

// The node's data path: a live source pushed sample by sample, the engine run after each push (kPending
// while it holds nothing), a hook at every head-epoch boundary. It must give the rows of the file
// replay bit for bit, call the hook once per boundary and step, and judge lateness by the assembler's
// own rule; a restart (a clock step back) hands out what is held, then the core and the observers'
// validator start again.
TEST(StreamEngine, APushSourceWithAHookGivesTheFileReplaysRowsAndRestarts) {
  const auto sca = readSca(span().sca);
  const auto acc = readAcc(span().acc);
  const auto cfg = pipelineConfig(sca);
  const EngineRun files = runEngine({span().sca}, {span().acc}, {}, cfg);
  ASSERT_EQ(files.result, stream::Engine::Result::kDone) << files.error;
  const std::vector<stream::Sample> in = mergedSamples(sca, acc);
  ASSERT_GT(in.size(), 1000u);

  stream::Engine e;
  std::string err;
  ASSERT_TRUE(e.configure(cfg, &err)) << err;
  auto src = std::make_unique<stream::PushSource>();
  src->init(8);
  stream::PushSource* push = src.get();
  e.addSource(std::move(src));
  VectorSink sink;
  e.addSink(&sink);
  RecordingHook hook;
  e.setHook(&hook);
  struct Obs final : stream::InputObserver {
    std::size_t heads = 0;
    void onHeads(const core::HeadEpoch&, core::Status) override { ++heads; }
  } obs;
  e.addObserver(&obs);
  TimeUs t_dummy = 0;
  EXPECT_FALSE(e.lastHandedOut(t_dummy));  // nothing handed out yet
  for (const auto& x : in) {
    ASSERT_TRUE(push->push(x));
    ASSERT_EQ(e.run(), stream::Engine::Result::kPending);
  }
  push->close();
  ASSERT_EQ(e.run(), stream::Engine::Result::kDone) << e.error();
  EXPECT_TRUE(sameRows(sink.rows, files.rows));
  EXPECT_EQ(hook.out_of_order, 0);
  EXPECT_EQ(hook.heads.size(), e.epochs());
  EXPECT_EQ(hook.before.size(), e.epochs());
  EXPECT_EQ(hook.accs.size(), e.counters().used_accel);
  EXPECT_EQ(hook.heads.front(), e.firstEpoch());
  EXPECT_EQ(hook.heads.back(), e.lastEpoch());
  EXPECT_GT(hook.min_head_ns, 0.0);  // every head step timed
  EXPECT_EQ(obs.heads, e.epochs());
  // The late rule, asked before a push: the last epoch's tag is gone for a head, not for the accelerometer.
  TimeUs last = 0;
  ASSERT_TRUE(e.lastHandedOut(last));
  EXPECT_EQ(last, in.back().t);
  EXPECT_TRUE(e.late(e.lastEpoch(), stream::Sample::Kind::kHead));
  EXPECT_TRUE(e.late(e.firstEpoch(), stream::Sample::Kind::kAccel));
  EXPECT_FALSE(e.late(last + 1, stream::Sample::Kind::kHead));

  // A clock step back: the first half, a restart, then the whole span again from its start.
  stream::Engine r;
  ASSERT_TRUE(r.configure(cfg, &err)) << err;
  src = std::make_unique<stream::PushSource>();
  src->init(8);
  push = src.get();
  r.addSource(std::move(src));
  VectorSink rsink;
  r.addSink(&rsink);
  Obs robs;
  r.addObserver(&robs);
  const std::size_t half = in.size() / 2;
  for (std::size_t i = 0; i < half; ++i) {
    ASSERT_TRUE(push->push(in[i]));
    r.run();
  }
  int before_reset = 0;
  std::uint64_t epochs_before_reset = 0;
  ASSERT_EQ(r.restart([&] {
    ++before_reset;
    epochs_before_reset = r.pipeline().health().count(core::Status::kOk);
  }),
            stream::Engine::Result::kPending);
  EXPECT_EQ(before_reset, 1);
  const std::size_t rows_first = rsink.rows.size();
  const std::size_t heads_first = robs.heads;
  EXPECT_GT(epochs_before_reset, 0u);
  EXPECT_EQ(r.pipeline().health().count(core::Status::kOk), 0u);  // the core started again
  EXPECT_FALSE(r.lastHandedOut(t_dummy));                // the assembler forgot its time
  EXPECT_FALSE(r.late(in.front().t, stream::Sample::Kind::kHead));
  // Everything of the first half went out before the restart: the rows of a replay of that half alone
  // (the records are in time order in the files, so the half's are the first ones of each).
  ASSERT_TRUE(std::is_sorted(sca.begin(), sca.end(), [](const auto& a, const auto& b) { return a.t < b.t; }));
  ASSERT_TRUE(std::is_sorted(acc.begin(), acc.end(), [](const auto& a, const auto& b) { return a.t < b.t; }));
  std::size_t heads_in_half = 0;
  for (std::size_t i = 0; i < half; ++i) heads_in_half += in[i].kind == stream::Sample::Kind::kHead;
  const std::vector<io::Sca1aRecord> sca_half(sca.begin(), sca.begin() + static_cast<long>(heads_in_half));
  const std::vector<io::FlaggedRecord> acc_half(acc.begin(), acc.begin() + static_cast<long>(half - heads_in_half));
  EXPECT_TRUE(sameRows(std::vector<core::PipelineRow>(rsink.rows.begin(), rsink.rows.begin() + static_cast<long>(rows_first)),
                       referenceRows(sca_half, acc_half, cfg)));
  for (const auto& x : in) {
    ASSERT_TRUE(push->push(x));
    r.run();
  }
  push->close();
  ASSERT_EQ(r.run(), stream::Engine::Result::kDone) << r.error();
  // After the restart: the whole span's rows again, and the observers saw every epoch again (their
  // validator restarted with the core: without it, every epoch older than the first half's last fails).
  EXPECT_TRUE(sameRows(std::vector<core::PipelineRow>(rsink.rows.begin() + static_cast<long>(rows_first), rsink.rows.end()),
                       files.rows));
  EXPECT_EQ(robs.heads - heads_first, obs.heads);
  EXPECT_EQ(r.counters().rejectedTotal(), 0u);
}

TEST(StreamEngine, LcmLogGivesTheSameRowsAsLevel1) {
  const auto sca = readSca(span().sca);
  const auto cfg = pipelineConfig(sca);
  EngineRun l1 = runEngine({span().sca}, {span().acc}, {}, cfg);
  EngineRun lcm = runEngine({}, {}, {span().lcm}, cfg);
  ASSERT_EQ(lcm.result, stream::Engine::Result::kDone) << lcm.error;
  EXPECT_TRUE(sameRows(lcm.rows, l1.rows));
  EXPECT_EQ(lcm.total.used_heads, l1.total.used_heads);
  EXPECT_EQ(lcm.total.used_accel, l1.total.used_accel);
  EXPECT_GT(lcm.total.used_stars, 0u);  // the simulator's log carries STAR_VECTORS too
  expectCountersAddUp(lcm);
}

TEST(StreamEngine, StarVectorsFromScv1aAndFromTheLogGiveTheSameJointAttitudes) {
  const auto sca = readSca(span().sca);
  const auto cfg = pipelineConfig(sca);
  EngineRun l1 = runEngine({span().sca}, {span().acc}, {}, cfg, {}, false, {span().scv});
  EngineRun lcm = runEngine({}, {}, {span().lcm}, cfg);
  ASSERT_EQ(l1.result, stream::Engine::Result::kDone) << l1.error;
  ASSERT_EQ(lcm.result, stream::Engine::Result::kDone) << lcm.error;
  // star vectors every 10 s of the 600 s span, at head epochs
  EXPECT_GE(l1.star_epochs, 55u);
  EXPECT_EQ(l1.star_epochs, lcm.star_epochs);
  EXPECT_EQ(l1.total.used_stars, lcm.total.used_stars);
  ASSERT_EQ(l1.stars.size(), lcm.stars.size());
  ASSERT_GT(l1.stars.size(), l1.star_epochs / 2);
  // Star vectors come after the head epoch of their tag: the rows are those of the heads alone.
  EXPECT_TRUE(sameRows(l1.rows, runEngine({span().sca}, {span().acc}, {}, cfg).rows));
  for (std::size_t i = 0; i < l1.stars.size(); ++i) {
    const auto& a = l1.stars[i];
    const auto& b = lcm.stars[i];
    EXPECT_EQ(a.wahba.t, b.wahba.t);
    EXPECT_TRUE(a.has_fused);  // at a head epoch
    EXPECT_EQ(a.wahba.stars_used, b.wahba.stars_used);
    // the log carries the star vectors as written (SCV1A text has 10 decimals): same to ~1e-9 rad
    EXPECT_LT(core::angleBetween(a.wahba.q_I_B, b.wahba.q_I_B), 1e-8) << i;
    // the joint attitude and the fused one describe the same body: within the simulated mounting
    // errors (<= 70") and noise, not degrees apart
    EXPECT_LT(core::angleBetween(a.wahba.q_I_B, a.q_I_B_fused) * kArcsecPerRad, 150.0) << i;
  }
  expectCountersAddUp(l1);
}

TEST(StreamAssembler, StarVectorsWithoutAConsumerAreCountedNotHandedOut) {
  stream::LcmLogSource src;
  std::string err;
  ASSERT_TRUE(src.open(span().lcm, &err)) << err;
  stream::EpochAssembler a;
  a.addSource(&src);
  core::HeadEpoch e;
  TimeUs t = 0;
  Vec3 acc = Vec3::Zero();
  std::uint64_t heads = 0;
  for (;;) {
    const auto o = a.next(e, t, acc);
    ASSERT_NE(o, stream::EpochAssembler::Out::kStars);
    if (o == stream::EpochAssembler::Out::kEnd) break;
    ASSERT_NE(o, stream::EpochAssembler::Out::kError);
    if (o == stream::EpochAssembler::Out::kHeads) heads += static_cast<std::uint64_t>(e.n);
  }
  EXPECT_EQ(a.counters().used_stars, 0u);
  EXPECT_GT(a.counters().rejected[std::size_t(stream::Reject::kNoConsumer)], 0u);
  EXPECT_EQ(a.counters().used_heads, heads);
  EXPECT_EQ(a.counters().read, a.counters().used() + a.counters().rejectedTotal());
}

TEST(StreamEngine, SeveralFilesOfOneProductAreMergedByTime) {
  const auto sca = readSca(span().sca);
  const auto acc = readAcc(span().acc);
  const auto cfg = pipelineConfig(sca);
  const std::string d = tempDir();
  // SCA1A split in two halves given in reverse order; ACC1A split into even and odd records.
  std::vector<io::Sca1aRecord> a(sca.begin(), sca.begin() + long(sca.size() / 2)), b(sca.begin() + long(sca.size() / 2), sca.end());
  std::vector<io::FlaggedRecord> even, odd;
  for (std::size_t i = 0; i < acc.size(); ++i) (i % 2 ? odd : even).push_back(acc[i]);
  const auto fa = writeRecords(d + "/SCA1A_a.txt", io::Product::SCA1A, a);
  const auto fb = writeRecords(d + "/SCA1A_b.txt", io::Product::SCA1A, b);
  const auto fe = writeRecords(d + "/ACC1A_e.txt", io::Product::ACC1A, even);
  const auto fo = writeRecords(d + "/ACC1A_o.txt", io::Product::ACC1A, odd);
  EngineRun whole = runEngine({span().sca}, {span().acc}, {}, cfg);
  EngineRun split = runEngine({fb, fa}, {fo, fe}, {}, cfg);
  ASSERT_EQ(split.result, stream::Engine::Result::kDone) << split.error;
  EXPECT_TRUE(sameRows(split.rows, whole.rows));
  EXPECT_EQ(split.total.rejectedTotal(), 0u);
  expectCountersAddUp(split);
}

TEST(StreamEngine, OutOfOrderInsideTheLookAheadIsSortedBeyondItRejectedAsLate) {
  auto sca = readSca(span().sca);
  auto acc = readAcc(span().acc);
  const auto cfg = pipelineConfig(sca);
  const std::string d = tempDir();
  // Inside: swap neighbouring epochs' records (0.5-1 s apart) and reverse runs of 10 ACC records (1 s).
  auto sca_in = sca;
  for (std::size_t i = 200; i + 3 < 260; i += 6) std::swap(sca_in[i], sca_in[i + 3]);
  auto acc_in = acc;
  for (std::size_t i = 1000; i + 10 < 1200; i += 10) std::reverse(acc_in.begin() + long(i), acc_in.begin() + long(i + 10));
  const auto f1 = writeRecords(d + "/SCA1A_in.txt", io::Product::SCA1A, sca_in);
  const auto f2 = writeRecords(d + "/ACC1A_in.txt", io::Product::ACC1A, acc_in);
  EngineRun in = runEngine({f1}, {f2}, {}, cfg);
  ASSERT_EQ(in.result, stream::Engine::Result::kDone) << in.error;
  EXPECT_TRUE(sameRows(in.rows, referenceRows(sca, acc, cfg)));
  EXPECT_EQ(in.total.rejectedTotal(), 0u);

  // Beyond: one head record moved 30 s later in the file, one ACC record 60 s later. Both arrive when
  // their time is long gone: rejected as late, and the rows are those of the data without them.
  auto sca_late = sca;  // record 300 moved to index 300 + 30 * 6 (the others shift down by one)
  std::rotate(sca_late.begin() + 300, sca_late.begin() + 301, sca_late.begin() + 300 + 30 * 6 + 1);
  ASSERT_EQ(sca_late[300 + 30 * 6].t, sca[300].t);
  auto acc_late = acc;  // record 2000 moved to index 2600
  std::rotate(acc_late.begin() + 2000, acc_late.begin() + 2001, acc_late.begin() + 2000 + 600 + 1);
  ASSERT_EQ(acc_late[2000 + 600].t, acc[2000].t);
  const auto f3 = writeRecords(d + "/SCA1A_late.txt", io::Product::SCA1A, sca_late);
  const auto f4 = writeRecords(d + "/ACC1A_late.txt", io::Product::ACC1A, acc_late);
  EngineRun late = runEngine({f3}, {f4}, {}, cfg);
  ASSERT_EQ(late.result, stream::Engine::Result::kDone) << late.error;
  EXPECT_EQ(late.total.rejected[std::size_t(stream::Reject::kLate)], 2u);
  EXPECT_EQ(late.total.rejectedTotal(), 2u);
  expectCountersAddUp(late);
  auto sca_without = sca;
  sca_without.erase(sca_without.begin() + 300);
  auto acc_without = acc;
  acc_without.erase(acc_without.begin() + 2000);
  EXPECT_TRUE(sameRows(late.rows, referenceRows(sca_without, acc_without, cfg)));

  // A longer look-ahead takes the 30 s and 60 s displacements in: nothing late, rows as sorted data.
  stream::AssemblerConfig wide;
  wide.lookahead_us = 90 * kUsPerSecond;
  EngineRun w = runEngine({f3}, {f4}, {}, cfg, wide);
  EXPECT_EQ(w.total.rejectedTotal(), 0u);
  EXPECT_TRUE(sameRows(w.rows, referenceRows(sca, acc, cfg)));
}

TEST(StreamEngine, GapsAndATruncatedLastLine) {
  auto sca = readSca(span().sca);
  auto acc = readAcc(span().acc);
  const auto cfg = pipelineConfig(sca);
  const std::string d = tempDir();
  // A 20 s gap in all heads and a 7 s gap in the accelerometer.
  auto in_gap = [](TimeUs t, TimeUs t0, double s) { return t >= t0 && t < t0 + static_cast<TimeUs>(s * 1e6); };
  const TimeUs t0 = sca.front().t;
  std::vector<io::Sca1aRecord> sg;
  for (const auto& r : sca)
    if (!in_gap(r.t, t0 + 200 * kUsPerSecond, 20)) sg.push_back(r);
  std::vector<io::FlaggedRecord> ag;
  for (const auto& r : acc)
    if (!in_gap(r.t, t0 + 400 * kUsPerSecond, 7)) ag.push_back(r);
  ASSERT_LT(sg.size(), sca.size());
  ASSERT_LT(ag.size(), acc.size());
  const auto fs = writeRecords(d + "/SCA1A_gap.txt", io::Product::SCA1A, sg);
  std::string fa = writeRecords(d + "/ACC1A_gap.txt", io::Product::ACC1A, ag);
  // Truncate the last ACC1A line in the middle (no newline at the end).
  {
    std::string text = slurp(fa);
    ASSERT_EQ(text.back(), '\n');
    const std::size_t last = text.rfind('\n', text.size() - 2);
    text.resize(last + 1 + (text.size() - last - 1) / 2);
    std::ofstream(fa, std::ios::binary | std::ios::trunc) << text;
  }
  EngineRun r = runEngine({fs}, {fa}, {}, cfg);
  ASSERT_EQ(r.result, stream::Engine::Result::kDone) << r.error;
  EXPECT_EQ(r.total.rejected[std::size_t(stream::Reject::kMalformed)], 1u);
  EXPECT_EQ(r.total.read, sg.size() + ag.size());
  expectCountersAddUp(r);
  ag.pop_back();
  EXPECT_TRUE(sameRows(r.rows, referenceRows(sg, ag, cfg)));
}

TEST(StreamEngine, EmptyInputs) {
  const std::string d = tempDir();
  // An empty file is neither a Level-1 product nor an LCM log: recognised as such, with a reason.
  const std::string empty = d + "/SCA1A_empty.txt";
  std::ofstream(empty).close();
  stream::FileKind k = stream::identifyFile(empty);
  EXPECT_EQ(k.type, stream::FileKind::Type::kUnknown);
  EXPECT_NE(k.reason.find(empty + ":"), std::string::npos) << k.reason;
  // A product with a header and no records: a source that ends at once; no rows, nothing read.
  const auto none = writeRecords(d + "/SCA1A_none.txt", io::Product::SCA1A, std::vector<io::Sca1aRecord>{});
  const auto cfg = pipelineConfig(readSca(span().sca), false);
  EngineRun r = runEngine({none}, {}, {}, cfg);
  EXPECT_EQ(r.result, stream::Engine::Result::kDone);
  EXPECT_TRUE(r.rows.empty());
  EXPECT_EQ(r.total.read, 0u);
}

TEST(StreamEngine, FilesAreRecognisedByContent) {
  const std::string d = tempDir();
  // The simulator's log is "sim.lcmlog"; copy it under a Level-1 looking name and a plain one.
  std::string bytes = slurp(span().lcm);
  std::ofstream(d + "/SCA1A_not_really.txt", std::ios::binary) << bytes;
  EXPECT_EQ(stream::identifyFile(span().lcm).type, stream::FileKind::Type::kLcmLog);
  EXPECT_EQ(stream::identifyFile(d + "/SCA1A_not_really.txt").type, stream::FileKind::Type::kLcmLog);
  auto sca = stream::identifyFile(span().sca);
  EXPECT_EQ(sca.type, stream::FileKind::Type::kLevel1);
  EXPECT_EQ(sca.product, io::Product::SCA1A);
  // Garbage: refused by the LCM source with the file and the reason.
  std::ofstream(d + "/garbage.lcm") << "this is not an LCM log at all\n";
  EXPECT_EQ(stream::identifyFile(d + "/garbage.lcm").type, stream::FileKind::Type::kUnknown);
  stream::LcmLogSource s;
  std::string err;
  EXPECT_FALSE(s.open(d + "/garbage.lcm", &err));
  EXPECT_NE(err.find(d + "/garbage.lcm: not an LCM log"), std::string::npos) << err;
}

TEST(StreamEngine, MemoryIsBoundedByTheLookAheadNotTheSpan) {
  const auto sca = readSca(span().sca);
  const auto cfg = pipelineConfig(sca);
  stream::Engine e;
  std::string err;
  ASSERT_TRUE(e.configure(cfg, &err));
  auto s1 = std::make_unique<stream::Sca1aSource>();
  auto s2 = std::make_unique<stream::Acc1aSource>();
  ASSERT_TRUE(s1->open(span().sca, {}, &err));
  ASSERT_TRUE(s2->open(span().acc, {}, &err));
  e.addSource(std::move(s1));
  e.addSource(std::move(s2));
  stream::BatchBufferSink ring(100);
  e.addSink(&ring);
  ASSERT_EQ(e.run(), stream::Engine::Result::kDone);
  // 2 s look-ahead at 6 head samples and 10 accelerometer samples a second, both ends of the window
  // included, plus the sample of each source that is past it.
  EXPECT_LE(e.maxBuffered(), 2u * (6 + 10) + 8);
  EXPECT_GT(e.maxBuffered(), 10u);
  // The ring keeps the last 100 rows, in order.
  EXPECT_EQ(ring.size(), 100u);
  EXPECT_EQ(ring.written(), e.rows());
  EXPECT_EQ(ring.overwritten(), e.rows() - 100);
  EXPECT_LE(ring.at(99).t, e.lastEpoch());
  EXPECT_GT(ring.at(99).t, e.lastEpoch() - kUsPerSecond);
  for (std::size_t i = 1; i < ring.size(); ++i) EXPECT_LT(ring.at(i - 1).t, ring.at(i).t);
}

TEST(StreamReplay, InputsByContentIgnoredListedMixedRefused) {
  const std::string d = tempDir();
  const std::string gnv = writeRecords(d + "/GNV1B_x.txt", io::Product::GNV1B, std::vector<io::GnvRecord>(3));
  stream::ReplayInputs in;
  std::string err;
  ASSERT_TRUE(stream::classifyInputs({span().sca, span().acc, span().qsa, gnv}, in, &err)) << err;
  EXPECT_EQ(in.sca.size(), 1u);
  EXPECT_EQ(in.acc.size(), 1u);
  EXPECT_EQ(in.qsa_records.size(), 3u);
  ASSERT_EQ(in.ignored.size(), 1u);
  EXPECT_EQ(in.ignored[0].second, "GNV1B");
  ASSERT_EQ(in.orbit.size(), 1u);
  EXPECT_EQ(in.orbit[0], gnv);
  EXPECT_FALSE(stream::classifyInputs({span().lcm, span().sca}, in, &err));
  EXPECT_NE(err.find("is an LCM log and"), std::string::npos) << err;
  // Configuration for the inputs: mountings from QSA1B at the first head tag; no accelerometer
  // input switches its path off.
  io::PlatformConfig pc;
  ASSERT_TRUE(io::loadPlatformConfig(sourceDir() + "/config/gracefo_ideal.yaml", pc, &err)) << err;
  ASSERT_TRUE(stream::classifyInputs({span().sca, span().qsa}, in, &err)) << err;
  ASSERT_TRUE(stream::prepareConfig(in, {}, pc, &err)) << err;
  EXPECT_FALSE(pc.pipeline.use_accelerometer);
  const auto cfg = pipelineConfig(readSca(span().sca));
  for (int s = 0; s < cfg.heads.n_heads; ++s)
    EXPECT_EQ(pc.pipeline.heads.head[std::size_t(s)].q_Si_B.coeffs(), cfg.heads.head[std::size_t(s)].q_Si_B.coeffs());
  ASSERT_TRUE(stream::classifyInputs({span().sca}, in, &err));
  io::PlatformConfig pc2;
  ASSERT_TRUE(io::loadPlatformConfig(sourceDir() + "/config/gracefo_ideal.yaml", pc2, &err)) << err;
  EXPECT_FALSE(stream::prepareConfig(in, {}, pc2, &err));
  EXPECT_NE(err.find("give a QSA1B file"), std::string::npos) << err;
  // An LCM log carries them in its NOMINAL_MOUNTINGS message, as boresightd takes them: no QSA1B file
  // needed, the same mountings as the QSA1B file's (before: refused, "give a QSA1B file").
  const std::string with_m = tempDir() + "/mountings.lcmlog";
  {
    sim::Scenario sc;
    ASSERT_TRUE(sim::loadScenario(sourceDir() + "/config/sim_gracefo.yaml", sc, &err)) << err;
    sim::Simulator simulator;
    ASSERT_TRUE(simulator.init(sc, 11, 60.0, &err)) << err;
    sim::LcmSink log;
    ASSERT_TRUE(log.open(with_m, &err)) << err;
    ASSERT_TRUE(log.writeMountings(simulator));
    simulator.run(log);
    ASSERT_TRUE(log.close(&err)) << err;
  }
  ASSERT_TRUE(stream::classifyInputs({with_m}, in, &err)) << err;
  io::PlatformConfig pc3;
  ASSERT_TRUE(io::loadPlatformConfig(sourceDir() + "/config/gracefo_ideal.yaml", pc3, &err)) << err;
  ASSERT_TRUE(stream::prepareConfig(in, {}, pc3, &err)) << err;
  for (int s = 0; s < pc3.pipeline.heads.n_heads; ++s) {
    EXPECT_LT(pc3.pipeline.heads.head[std::size_t(s)].q_Si_B.angularDistance(pc.pipeline.heads.head[std::size_t(s)].q_Si_B), 1e-9) << s;
    EXPECT_NE(pc3.mounting_source[std::size_t(s)].find("the first NOMINAL_MOUNTINGS message"), std::string::npos)
        << pc3.mounting_source[std::size_t(s)];
  }
}

TEST(StreamReplay, OpenReplayIsTheOneSetUpOfEveryProgram) {
  // openReplay + startReplay: what process, calibrate, audit and noise each did in their own lines.
  const std::string d = tempDir();
  const std::string cfg = sourceDir() + "/config/gracefo_ideal.yaml";
  stream::ReplayRequest rq;
  rq.program = "test";
  rq.config = cfg;
  rq.inputs = {span().sca, span().acc, span().qsa, span().scv};
  stream::Replay r;
  std::string err;
  ASSERT_TRUE(stream::openReplay(rq, r, &err)) << err;
  EXPECT_EQ(r.in.scv.size(), 1u);
  EXPECT_TRUE(r.in.ignored.empty());
  EXPECT_TRUE(r.pc.pipeline.use_accelerometer);
  ASSERT_TRUE(r.engine != nullptr);
  stream::BatchBufferSink rows(100000);
  r.engine->addSink(&rows);
  ASSERT_TRUE(stream::startReplay(r, &err)) << err;
  ASSERT_EQ(r.engine->run(), stream::Engine::Result::kDone) << r.engine->error();
  // the same rows as the steps by hand (the StreamEngine tests' way)
  stream::ReplayInputs in;
  io::PlatformConfig pc;
  ASSERT_TRUE(io::loadPlatformConfig(cfg, pc, &err)) << err;
  ASSERT_TRUE(stream::classifyInputs(rq.inputs, in, &err)) << err;
  ASSERT_TRUE(stream::prepareConfig(in, {}, pc, &err)) << err;
  stream::Engine e;
  ASSERT_TRUE(e.configure(pc.pipeline, &err)) << err;
  stream::BatchBufferSink rows2(100000);
  e.addSink(&rows2);
  ASSERT_TRUE(stream::addSources(in, {}, true, e, &err)) << err;
  ASSERT_EQ(e.run(), stream::Engine::Result::kDone);
  ASSERT_EQ(rows.size(), rows2.size());
  ASSERT_GT(rows.size(), 500u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows.at(i).t, rows2.at(i).t);
    EXPECT_EQ(rows.at(i).q_I_B.coeffs(), rows2.at(i).q_I_B.coeffs());
  }
  // star vectors not wanted: listed as ignored; strict read options; the look-ahead reaches the engine
  rq.star_vectors = false;
  rq.strict = true;
  ASSERT_TRUE(stream::openReplay(rq, r, &err)) << err;
  EXPECT_TRUE(r.in.scv.empty());
  ASSERT_EQ(r.in.ignored.size(), 1u);
  EXPECT_EQ(r.in.ignored[0].second, "SCV1A");
  EXPECT_EQ(r.opt.on_error, io::OnError::Stop);
  // each step's failure with its reason: the platform file, the overlay, the inputs, the configuration
  rq.config = d + "/no_such.yaml";
  EXPECT_FALSE(stream::openReplay(rq, r, &err));
  EXPECT_NE(err.find("no_such.yaml"), std::string::npos) << err;
  rq.config = cfg;
  rq.overlay = d + "/ov.yaml";
  {
    std::ofstream o(rq.overlay);
    o << "boresight_overlay: 1\nwritten_by: test\nno_such_key: 1\n";
  }
  EXPECT_FALSE(stream::openReplay(rq, r, &err));
  EXPECT_NE(err.find("ov.yaml:3: key 'no_such_key'"), std::string::npos) << err;
  rq.overlay.clear();
  rq.inputs = {span().lcm, span().sca};
  EXPECT_FALSE(stream::openReplay(rq, r, &err));
  EXPECT_NE(err.find("is an LCM log and"), std::string::npos) << err;
  rq.inputs = {span().sca};
  EXPECT_FALSE(stream::openReplay(rq, r, &err));
  EXPECT_NE(err.find("give a QSA1B file"), std::string::npos) << err;
  EXPECT_FALSE(stream::startReplay(r, &err)) << "nothing opened";
}

TEST(StreamEngine, DamagedLcmLogCountsWhatItCannotRead) {
  // Junk between events and a cut last event: each damaged stretch is one malformed message, the
  // events around them are read, and read == used + rejected still holds.
  const std::string bytes = slurp(span().lcm);
  ASSERT_GT(bytes.size(), 100000u);
  // Event boundaries: find sync words after a few thousand bytes.
  const std::string sync = "\xED\xA1\xDA\x01";
  const std::size_t e1 = bytes.find(sync, 5000), e2 = bytes.find(sync, 60000);
  ASSERT_NE(e1, std::string::npos);
  ASSERT_NE(e2, std::string::npos);
  std::string damaged = bytes.substr(0, e1) + "some junk that is not an event" + bytes.substr(e1, e2 - e1) +
                        std::string(1000, '\x01') + bytes.substr(e2);
  damaged.resize(damaged.size() - 20);  // cut the last event
  const std::string d = tempDir();
  const std::string path = d + "/damaged.log";
  ASSERT_TRUE(testutil::writeFile(path, damaged)) << path;
  const auto cfg = pipelineConfig(readSca(span().sca));
  EngineRun clean = runEngine({}, {}, {span().lcm}, cfg);
  EngineRun r = runEngine({}, {}, {path}, cfg);
  ASSERT_EQ(r.result, stream::Engine::Result::kDone) << r.error;
  EXPECT_EQ(r.total.rejected[std::size_t(stream::Reject::kMalformed)], 3u);
  EXPECT_EQ(r.total.used(), clean.total.used() - 1);  // only the cut event is lost
  expectCountersAddUp(r);
}

TEST(StreamReplay, Qsa1bReferenceTimeIsTheEarliestFirstHeadTagOverAllInputs) {
  // Two SCA1A files, the later half given first, and a QSA1B history: alignment A valid from long
  // before the span, alignment B from a time between the two files' first tags. The mountings must be
  // those valid at the earliest first head tag over all inputs (A), not at the first file's (B).
  const auto sca = readSca(span().sca);
  const std::string d = tempDir();
  const std::size_t half = sca.size() / 2;
  const auto early = writeRecords(d + "/SCA1A_early.txt", io::Product::SCA1A,
                                  std::vector<io::Sca1aRecord>(sca.begin(), sca.begin() + long(half)));
  const auto late = writeRecords(d + "/SCA1A_late.txt", io::Product::SCA1A,
                                 std::vector<io::Sca1aRecord>(sca.begin() + long(half), sca.end()));
  const TimeUs t_b = sca[half / 2].t;  // after the early file's first tag, before the late file's
  ASSERT_LT(sca.front().t, t_b);
  ASSERT_LT(t_b, sca[half].t);
  std::vector<io::QsaRecord> qsa;
  for (int head = 1; head <= 3; ++head) {
    io::QsaRecord a;
    a.t = 0;
    a.sensor = head;
    a.q[0] = 1, a.q[1] = 0, a.q[2] = 0, a.q[3] = 0;
    io::QsaRecord b = a;
    b.t = t_b;
    b.q[0] = 0, b.q[1] = 1;
    qsa.push_back(a);
    qsa.push_back(b);
  }
  const auto qsa_file = writeRecords(d + "/QSA1B_hist.txt", io::Product::QSA1B, qsa);
  for (const auto& order : {std::vector<std::string>{late, early, qsa_file}, std::vector<std::string>{early, late, qsa_file}}) {
    stream::ReplayInputs in;
    std::string err;
    ASSERT_TRUE(stream::classifyInputs(order, in, &err)) << err;
    io::PlatformConfig pc;
    ASSERT_TRUE(io::loadPlatformConfig(sourceDir() + "/config/gracefo_ideal.yaml", pc, &err)) << err;
    ASSERT_TRUE(stream::prepareConfig(in, {}, pc, &err)) << err;
    for (int s = 0; s < pc.pipeline.heads.n_heads; ++s)
      EXPECT_EQ(pc.pipeline.heads.head[std::size_t(s)].q_Si_B.w(), 1.0) << "head " << s << ", first input " << order[0];
  }
}

TEST(StreamEngine, AnLcmEventWithADamagedLengthCostsOnlyThatEvent) {
  // An event in the middle whose data length claims 48 MB (past the end of the file): the reader
  // resynchronises at the next sync word, so that one event is malformed and the rest are read
  // (before, the claimed length swallowed the rest of the log as one cut event).
  const std::string bytes = slurp(span().lcm);
  const std::string sync = "\xED\xA1\xDA\x01";
  const std::size_t e1 = bytes.find(sync, 5000);
  ASSERT_NE(e1, std::string::npos);
  std::string damaged = bytes;
  damaged[e1 + 24] = '\x03';  // data length (big-endian int32 at byte 24 of the event header)
  const std::string d = tempDir();
  const std::string path = d + "/bad_length.log";
  ASSERT_TRUE(testutil::writeFile(path, damaged)) << path;
  const auto cfg = pipelineConfig(readSca(span().sca));
  EngineRun clean = runEngine({}, {}, {span().lcm}, cfg);
  EngineRun r = runEngine({}, {}, {path}, cfg);
  ASSERT_EQ(r.result, stream::Engine::Result::kDone) << r.error;
  EXPECT_EQ(r.total.rejected[std::size_t(stream::Reject::kMalformed)], 1u);
  EXPECT_EQ(r.total.used(), clean.total.used() - 1);
  expectCountersAddUp(r);
}

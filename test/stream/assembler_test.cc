// Epoch assembler and sinks on hand-made sources: order, ties, grouping, look-ahead, rejects,
// pending and failing sources, and the CSV number format against printf.
#include <boresight/stream/assembler.h>
#include <boresight/stream/sinks.h>
#include <boresight/stream/sources.h>

#include <gtest/gtest.h>

#include "test_files.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace boresight;
using stream::Sample;
using stream::Source;

namespace {

using testutil::slurp;

struct Step {
  Source::Next n;
  Sample s;
  stream::Reject why = stream::Reject::kMalformed;
};

/// A source that replays a script.
class ScriptSource final : public Source {
 public:
  explicit ScriptSource(std::vector<Step> steps, std::string name = "script") : steps_(std::move(steps)), name_(std::move(name)) {}
  Next next(Sample& out, stream::Reject& why) override {
    if (i_ >= steps_.size()) return Next::kEnd;
    const Step& s = steps_[i_++];
    out = s.s;
    why = s.why;
    return s.n;
  }
  const std::string& name() const override { return name_; }
  std::string error() const override { return "script failed"; }

 private:
  std::vector<Step> steps_;
  std::size_t i_ = 0;
  std::string name_;
};

Step head(double t_s, int id) {
  Step s{Source::Next::kSample, {}};
  s.s.kind = Sample::Kind::kHead;
  s.s.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  s.s.head_id = id;
  return s;
}
Step acc(double t_s, double v = 0) {
  Step s{Source::Next::kSample, {}};
  s.s.kind = Sample::Kind::kAccel;
  s.s.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  s.s.a_A = Vec3(v, 0, 0);
  return s;
}

Step orbitAt(double t_s, double x_m = 6.8e6) {
  Step s{Source::Next::kSample, {}};
  s.s.kind = Sample::Kind::kOrbit;
  s.s.t = static_cast<TimeUs>(std::llround(t_s * 1e6));
  s.s.r_orbit = Vec3(x_m, 0, 0);
  s.s.v_orbit = Vec3(0, 7.6e3, 0);
  return s;
}

/// What the assembler handed out, as text: "H<t>:<ids>", "A<t>" or "O<t>" (orbit, when `take_orbit`).
std::string drain(stream::EpochAssembler& a, stream::EpochAssembler::Out* last = nullptr, bool take_orbit = false) {
  std::ostringstream o;
  core::HeadEpoch e;
  TimeUs t;
  Vec3 v;
  Sample orbit;
  for (;;) {
    auto r = a.next(e, t, v, nullptr, take_orbit ? &orbit : nullptr);
    if (r == stream::EpochAssembler::Out::kOrbit) {
      EXPECT_EQ(orbit.t, t);
      o << "O" << t / 1000000.0 << " ";
    } else if (r == stream::EpochAssembler::Out::kHeads) {
      o << "H" << e.t / 1000000.0 << ":";
      for (int k = 0; k < e.n; ++k) o << e.sample[std::size_t(k)].head_id;
      o << " ";
    } else if (r == stream::EpochAssembler::Out::kAccel) {
      o << "A" << t / 1000000.0 << " ";
    } else {
      if (last) *last = r;
      break;
    }
  }
  return o.str();
}

}  // namespace

TEST(Assembler, MergesByTimeHeadsFirstThenSourceOrder) {
  ScriptSource a({head(1, 1), head(1, 2), head(2, 1), head(3, 1)});
  ScriptSource b({acc(0.5), acc(1), acc(2.5), acc(3)});
  ScriptSource c({head(1, 3), head(3, 2)});
  stream::EpochAssembler as;
  as.addSource(&a);
  as.addSource(&b);
  as.addSource(&c);
  EXPECT_EQ(drain(as), "A0.5 H1:123 A1 H2:1 A2.5 H3:12 A3 ");
  EXPECT_EQ(as.counters().read, 10u);
  EXPECT_EQ(as.counters().used_heads, 6u);
  EXPECT_EQ(as.counters().used_accel, 4u);
  EXPECT_EQ(as.counters(2).used_heads, 2u);
}

TEST(Assembler, SortsInsideTheLookAheadAndRejectsLateSamples) {
  // 0.4 s out of order: sorted with a 1 s look-ahead. The head at 0.2 s comes after 3 s: late.
  ScriptSource a({head(1, 1), head(0.6, 1), head(2, 1), head(3, 1), head(0.2, 2), head(3, 2), head(4, 1)});
  stream::AssemblerConfig cfg;
  cfg.lookahead_us = kUsPerSecond;
  stream::EpochAssembler as(cfg);
  as.addSource(&a);
  EXPECT_EQ(drain(as), "H0.6:1 H1:1 H2:1 H3:12 H4:1 ");
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kLate)], 1u);
  EXPECT_EQ(as.counters().read, as.counters().used() + as.counters().rejectedTotal());
}

TEST(Assembler, AHeadAtAnEpochAlreadyHandedOutIsLate) {
  // Look-ahead 1 us: the second head of t=1 arrives after t=1 went (and after a later sample).
  ScriptSource a({head(1, 1), head(2, 1), head(1, 2)});
  stream::AssemblerConfig cfg;
  cfg.lookahead_us = 1;
  stream::EpochAssembler as(cfg);
  as.addSource(&a);
  EXPECT_EQ(drain(as), "H1:1 H2:1 ");
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kLate)], 1u);
}

TEST(Assembler, MoreHeadsThanTheCoreTakesAreCounted) {
  std::vector<Step> s;
  for (int id = 1; id <= core::kMaxHeads + 2; ++id) s.push_back(head(1, id));
  ScriptSource a(s);
  stream::EpochAssembler as;
  as.addSource(&a);
  drain(as);
  EXPECT_EQ(as.counters().used_heads, std::uint64_t(core::kMaxHeads));
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kTooManyHeads)], 2u);
  EXPECT_EQ(as.counters().read, as.counters().used() + as.counters().rejectedTotal());
}

TEST(Assembler, RejectedRecordsPendingAndErrors) {
  Step bad{Source::Next::kRejected, {}, stream::Reject::kInvalidFlag};
  Step pending{Source::Next::kPending, {}};
  ScriptSource a({head(1, 1), bad, pending, head(5, 1)});
  stream::EpochAssembler as;
  as.addSource(&a);
  stream::EpochAssembler::Out last{};
  // Pending before 1 s + look-ahead is reached: nothing can go out yet.
  EXPECT_EQ(drain(as, &last), "");
  EXPECT_EQ(last, stream::EpochAssembler::Out::kPending);
  EXPECT_EQ(drain(as, &last), "H1:1 H5:1 ");
  EXPECT_EQ(last, stream::EpochAssembler::Out::kEnd);
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kInvalidFlag)], 1u);
  EXPECT_EQ(as.counters().read, 3u);

  ScriptSource b({head(1, 1), Step{Source::Next::kError, {}}});
  stream::EpochAssembler as2;
  as2.addSource(&b);
  EXPECT_EQ(drain(as2, &last), "");
  EXPECT_EQ(last, stream::EpochAssembler::Out::kError);
  EXPECT_EQ(as2.errorSource(), 0);
}

TEST(Assembler, OrbitSamplesGoInTimeOrderLastAtTheirTagOrAreCountedWithoutAConsumer) {
  auto run = [](bool take, stream::Counters& c) {
    ScriptSource a({head(1, 1), head(2, 1), head(3, 1), head(4, 1)});
    ScriptSource b({acc(2), acc(3.5)});
    ScriptSource o({orbitAt(0.5), orbitAt(2), orbitAt(3.5)});
    stream::EpochAssembler as;
    as.addSource(&o);  // added first: at an equal tag the orbit still goes after heads and accelerometer
    as.addSource(&a);
    as.addSource(&b);
    const std::string s = drain(as, nullptr, take);
    c = as.counters();
    return s;
  };
  stream::Counters c;
  EXPECT_EQ(run(true, c), "O0.5 H1:1 H2:1 A2 O2 H3:1 A3.5 O3.5 H4:1 ");
  EXPECT_EQ(c.used_orbit, 3u);
  EXPECT_EQ(c.read, c.used() + c.rejectedTotal());
  EXPECT_EQ(run(false, c), "H1:1 H2:1 A2 H3:1 A3.5 H4:1 ");
  EXPECT_EQ(c.used_orbit, 0u);
  EXPECT_EQ(c.rejected[std::size_t(stream::Reject::kNoConsumer)], 3u);
  EXPECT_EQ(c.read, c.used() + c.rejectedTotal());
  // nextSample() (convert) hands orbit samples out as kOrbit and counts them as used.
  ScriptSource o({orbitAt(1), orbitAt(2)});
  stream::EpochAssembler as;
  as.addSource(&o);
  Sample s;
  EXPECT_EQ(as.nextSample(s), stream::EpochAssembler::Out::kOrbit);
  EXPECT_EQ(s.kind, Sample::Kind::kOrbit);
  EXPECT_EQ(as.nextSample(s), stream::EpochAssembler::Out::kOrbit);
  EXPECT_EQ(as.nextSample(s), stream::EpochAssembler::Out::kEnd);
  EXPECT_EQ(as.counters().used_orbit, 2u);
}

TEST(Assembler, PrefetchHandsOverTheSameSequence) {
  std::vector<Step> s;
  for (int k = 0; k < 1000; ++k) {
    s.push_back(head(k * 0.5, 1 + k % 3));
    if (k % 7 == 0) s.push_back(Step{Source::Next::kRejected, {}, stream::Reject::kMalformed});
  }
  ScriptSource direct(s);
  stream::PrefetchSource pre(std::make_unique<ScriptSource>(s), 16, 2);
  stream::EpochAssembler a1, a2;
  a1.addSource(&direct);
  a2.addSource(&pre);
  EXPECT_EQ(drain(a1), drain(a2));
  EXPECT_EQ(a1.counters().rejectedTotal(), a2.counters().rejectedTotal());
  EXPECT_EQ(a2.counters().rejectedTotal(), 143u);
}

TEST(CsvRowSink, NumbersAreFormattedAsPrintf) {
  const std::string dir = testutil::makeTempDir("boresight_csv");
  const std::string path = dir + "/rows.csv";
  core::PipelineConfig cfg;
  cfg.heads.n_heads = 3;
  for (int s = 0; s < 3; ++s) cfg.heads.head[std::size_t(s)].id = s + 1;
  stream::CsvRowSink sink(path);
  ASSERT_TRUE(sink.begin(cfg));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<core::PipelineRow> rows;
  for (int i = 0; i < 300; ++i) {
    core::PipelineRow r;
    r.t = 738849600LL * kUsPerSecond + i * 499999LL - (i == 5 ? 800000000000000LL : 0);
    r.q_I_B = Quat(u(rng), u(rng), u(rng), u(rng)).normalized();
    r.heads_used = i % 4;
    r.has_rates = i % 5 != 0;
    r.has_acc = i % 3 != 0;
    const double scale = std::pow(10.0, -12 + i % 14);
    r.w_B = Vec3(u(rng), u(rng), u(rng)) * scale;
    r.a_sc_B = Vec3(u(rng), u(rng), u(rng)) * scale;
    r.a_acc_B = Vec3(u(rng), 0.0, -0.0) * scale;
    r.rate_bridged = i % 6;
    r.w_sigma_B = Vec3(u(rng) + 1.5, 2.0, i % 4 == 0 ? std::nan("") : 3.0) * 1e-7 * scale;
    r.a_sc_sigma_B = Vec3(1.0, u(rng) + 1.5, 2.5) * 1e-9 * scale;
    r.acc_bridged = i % 3;
    r.a_acc_sigma_bridge = r.acc_bridged > 0 ? (u(rng) + 2.0) * 1e-10 * scale : 0.0;
    for (auto& v : r.iba_rad) v = i % 7 == 0 ? std::nan("") : u(rng) * 3;
    for (auto& v : r.iba_dev_rad) v = u(rng) * 1e-4 * scale;
    const Mat3 L = (Mat3() << 2 + u(rng), 0, 0, u(rng), 3, 0, u(rng), u(rng), 1 + i % 5).finished() * 1e-6;
    r.P_B = L * L.transpose();
    rows.push_back(r);
    ASSERT_TRUE(sink.write(r));
  }
  ASSERT_TRUE(sink.end());
  // The same rows through printf, as process wrote them before the engine.
  std::string expect = "time_s,q0,q1,q2,q3,w_x,w_y,w_z,a_sc_x,a_sc_y,a_sc_z,a_acc_x,a_acc_y,a_acc_z,"
                       "iba_12_deg,iba_12_dev_arcsec,iba_13_deg,iba_13_dev_arcsec,iba_23_deg,iba_23_dev_arcsec,heads_used,"
                       "rate_bridged,w_sigma_x,w_sigma_y,w_sigma_z,a_sc_sigma_x,a_sc_sigma_y,a_sc_sigma_z,acc_bridged,"
                       "a_acc_sigma_bridge,q_sigma_x_arcsec,q_sigma_y_arcsec,q_sigma_z_arcsec,q_corr_xy,q_corr_xz,q_corr_yz\n";
  char b[128];
  auto num = [&](double v, const char* fmt) {
    if (std::isfinite(v)) {
      std::snprintf(b, sizeof b, fmt, v);
      expect += b;
    } else {
      expect += ',';
    }
  };
  for (const auto& r : rows) {
    std::int64_t sec = r.t / kUsPerSecond, us = r.t % kUsPerSecond;
    if (us < 0) us += kUsPerSecond, --sec;
    std::snprintf(b, sizeof b, "%lld.%06lld", static_cast<long long>(sec), static_cast<long long>(us));
    expect += b;
    double q[4];
    quatToScalarFirst(r.q_I_B, q);
    for (double v : q) num(v, ",%.17g");
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.w_B[k] : NAN, ",%.9e");
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.a_sc_B[k] : NAN, ",%.9e");
    for (int k = 0; k < 3; ++k) num(r.has_acc ? r.a_acc_B[k] : NAN, ",%.9e");
    for (int s1 = 0; s1 < 3; ++s1)
      for (int s2 = s1 + 1; s2 < 3; ++s2) {
        const auto p = std::size_t(core::pairIndex(s1, s2));
        num(r.iba_rad[p] / kRadPerDeg, ",%.9f");
        num(r.iba_dev_rad[p] * kArcsecPerRad, ",%.3f");
      }
    std::snprintf(b, sizeof b, ",%d,%d", r.heads_used, r.rate_bridged);
    expect += b;
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.w_sigma_B[k] : NAN, ",%.3e");
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.a_sc_sigma_B[k] : NAN, ",%.3e");
    std::snprintf(b, sizeof b, ",%d", r.acc_bridged);
    expect += b;
    num(r.has_acc ? r.a_acc_sigma_bridge : NAN, ",%.3e");
    for (int k = 0; k < 3; ++k) num(r.heads_used > 0 ? std::sqrt(r.P_B(k, k)) * kArcsecPerRad : NAN, ",%.4f");
    for (const auto& [a, c] : {std::pair<int, int>{0, 1}, {0, 2}, {1, 2}})
      num(r.heads_used > 0 ? r.P_B(a, c) / (std::sqrt(r.P_B(a, a)) * std::sqrt(r.P_B(c, c))) : NAN, ",%.4f");
    expect += '\n';
  }
  std::string got = slurp(path);
  EXPECT_EQ(got, expect);
  EXPECT_EQ(sink.rows(), rows.size());
}

// ---- robust time base and duplicates (bad input costs what it is, not what follows it) -------------

TEST(AssemblerTimeBase, OneTagFarAheadCostsThatSampleNotTheLookAheadOfTheRest) {
  // Three heads at 2 Hz for 60 s; one head-2 tag 1e8 s ahead in the middle (a corrupt tag). Before the
  // robust time base it became the source's time: every later sample went out alone and the other heads
  // of each tag were late (about half the file).
  std::vector<Step> s;
  for (int k = 0; k < 120; ++k)
    for (int id = 1; id <= 3; ++id) {
      Step h = head(1000 + k * 0.5, id);
      if (k == 60 && id == 2) h.s.t += 100000000LL * kUsPerSecond;
      s.push_back(h);
    }
  ScriptSource a(s);
  ScriptSource b({acc(1000), acc(1030), acc(1059.5)});
  stream::EpochAssembler as;
  as.addSource(&a);
  as.addSource(&b);
  const std::string out = drain(as);
  const auto& c = as.counters();
  EXPECT_EQ(c.rejected[std::size_t(stream::Reject::kTimeJump)], 1u);
  EXPECT_EQ(c.rejected[std::size_t(stream::Reject::kLate)], 0u);
  EXPECT_EQ(c.used_heads, 359u);
  EXPECT_EQ(c.read, c.used() + c.rejectedTotal());
  EXPECT_NE(out.find("H1030:13 "), std::string::npos) << out;  // the epoch of the corrupt tag keeps 1 and 3
  EXPECT_NE(out.find("H1030.5:123 "), std::string::npos);
  EXPECT_EQ(out.find("1e+08"), std::string::npos);
}

TEST(AssemblerTimeBase, AWrongFirstTagAndARealGapAreTold) {
  // The first tag is corrupt (a day ahead): dropped, the source's time is the real one.
  ScriptSource a({head(86400 + 10, 1), head(10, 1), head(10.5, 1), head(11, 1)});
  stream::EpochAssembler as;
  as.addSource(&a);
  EXPECT_EQ(drain(as), "H10:1 H10.5:1 H11:1 ");
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kTimeJump)], 1u);
  // A real gap of an hour, confirmed by the next sample: nothing lost.
  ScriptSource b({head(10, 1), head(10.5, 1), head(3610, 1), head(3610.5, 1), head(3611, 1)});
  stream::EpochAssembler as2;
  as2.addSource(&b);
  EXPECT_EQ(drain(as2), "H10:1 H10.5:1 H3610:1 H3610.5:1 H3611:1 ");
  EXPECT_EQ(as2.counters().rejectedTotal(), 0u);
  // A tag far behind the source's time is late even before anything after it went out.
  ScriptSource c({head(100, 1), head(100.5, 1), head(100 - 1e8, 1), head(101, 1)});
  stream::EpochAssembler as3;
  as3.addSource(&c);
  EXPECT_EQ(drain(as3), "H100:1 H100.5:1 H101:1 ");
  EXPECT_EQ(as3.counters().rejected[std::size_t(stream::Reject::kLate)], 1u);
}

TEST(AssemblerTimeBase, TheSameHeadTwiceAtOneTagIsADuplicateNotAFourthHead) {
  // SCA1A given twice (its content, under another name): each epoch has every head twice. Before,
  // the excess went to the core ("more heads than kMaxHeads", all counted as used).
  std::vector<Step> s;
  for (int k = 0; k < 10; ++k)
    for (int id = 1; id <= 3; ++id) s.push_back(head(k * 0.5, id));
  ScriptSource a(s), b(s);
  stream::EpochAssembler as;
  as.addSource(&a);
  as.addSource(&b);
  const std::string out = drain(as);
  EXPECT_EQ(as.counters().used_heads, 30u);
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kDuplicate)], 30u);
  EXPECT_EQ(as.counters().rejected[std::size_t(stream::Reject::kTooManyHeads)], 0u);
  EXPECT_NE(out.find("H0.5:123 "), std::string::npos) << out;
}

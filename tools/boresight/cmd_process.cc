// boresight process --config FILE INPUT... --out FILE.csv: the real-time core over recorded telemetry.
#include <boresight/core/pipeline.h>
#include <boresight/io/core_config.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/time_format.h>

#include "args.h"
#include "commands.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace boresight::cli {
namespace {

const char* kUsage =
    "usage: boresight process --config FILE INPUT... --out FILE.csv [--compare-sca1b FILE] [--clk1b FILE]\n"
    "\n"
    "Runs the real-time core (head fusion, CRN rates and angular acceleration, accelerometer angular\n"
    "acceleration through the same CRN, inter-boresight monitor) over Level-1 files (SCA1A, ACC1A, and\n"
    "QSA1B for the mountings when the config says heads.mounting: qsa1b) or an LCM log (.lcm), in\n"
    "sensor-time order, and writes one CSV row per output epoch:\n"
    "  time_s            GPS seconds past 2000-01-01 12:00:00 (receiver time for Level-1A input)\n"
    "  q0,q1,q2,q3       fused body attitude q_I_B (R(q) = C_I_B), scalar first, through the mountings\n"
    "  w_x,w_y,w_z       angular rate, rad/s, body frame (empty where the CRN has too little data)\n"
    "  a_sc_x..z         star-sensor angular acceleration, rad/s^2, body frame\n"
    "  a_acc_x..z        accelerometer angular acceleration, same CRN low-pass, rad/s^2, body frame\n"
    "  iba_<i><j>_deg, iba_<i><j>_dev_arcsec   per head pair: inter-boresight angle, deviation from ground\n"
    "  heads_used        heads fused at this epoch\n"
    "The CRN output is stamped at the centre tap: rates need Tf/2 (~35 s) of data on each side.\n"
    "\n"
    "  --config FILE         platform file (config/gracefo.yaml)\n"
    "  --out FILE.csv        output table\n"
    "  --compare-sca1b FILE  compare the fused attitude with the official SCA1B product: per-axis mean\n"
    "                        and scatter of the difference (arcsec, body axes)\n"
    "  --clk1b FILE          receiver-to-GPS clock offsets for that comparison (Level-1A tags are\n"
    "                        receiver time; without CLK1B they are compared as if they were GPS time)\n"
    "  --strict              stop at the first malformed input line\n";

struct Input {
  std::vector<io::Sca1aRecord> sca;
  std::vector<io::FlaggedRecord> acc;
  std::vector<io::QsaRecord> qsa;
  std::size_t rejected_lines = 0;
};

bool readInputs(const Args& a, Input& in) {
  io::ReadOptions opt;
  if (a.has("--strict")) opt.on_error = io::OnError::Stop;
  for (const auto& f : a.positional()) {
    if (f.size() > 4 && f.substr(f.size() - 4) == ".lcm") {
      io::LcmAsLevel1 l;
      std::string err;
      if (!io::readLcmAsLevel1(f, 'C', true, l, &err)) {
        std::fprintf(stderr, "boresight process: %s\n", err.c_str());
        return false;
      }
      in.sca.insert(in.sca.end(), l.sca.begin(), l.sca.end());
      in.acc.insert(in.acc.end(), l.acc.begin(), l.acc.end());
      in.rejected_lines += l.invalid_heads + l.invalid_accel + l.decode_failures;
      std::printf("%s: LCM log, %zu head and %zu accelerometer samples; invalid: %llu head, %llu accelerometer; "
                  "%llu on other channels, %llu undecodable\n",
                  f.c_str(), l.sca.size(), l.acc.size(), static_cast<unsigned long long>(l.invalid_heads),
                  static_cast<unsigned long long>(l.invalid_accel), static_cast<unsigned long long>(l.unknown_channel),
                  static_cast<unsigned long long>(l.decode_failures));
      continue;
    }
    std::string name = io::productNameFromPath(f);
    auto report = [&](const auto& p) {
      std::printf("%s: %zu records, %zu rejected\n", f.c_str(), p.records.size(), p.rejected_count);
      for (std::size_t i = 0; i < p.rejected.size() && i < 5; ++i) std::printf("    rejected %s\n", p.rejected[i].str().c_str());
      in.rejected_lines += p.rejected_count;
    };
    if (name == "SCA1A") {
      auto p = io::readProduct<io::Sca1aRecord>(f, opt);
      if (!p.ok) return std::fprintf(stderr, "%s\n", p.error.c_str()), false;
      report(p);
      in.sca.insert(in.sca.end(), p.records.begin(), p.records.end());
    } else if (name == "ACC1A") {
      auto p = io::readProduct<io::FlaggedRecord>(f, opt);
      if (!p.ok) return std::fprintf(stderr, "%s\n", p.error.c_str()), false;
      report(p);
      in.acc.insert(in.acc.end(), p.records.begin(), p.records.end());
    } else if (name == "QSA1B") {
      auto p = io::readProduct<io::QsaRecord>(f, opt);
      if (!p.ok) return std::fprintf(stderr, "%s\n", p.error.c_str()), false;
      report(p);
      in.qsa.insert(in.qsa.end(), p.records.begin(), p.records.end());
    } else {
      std::fprintf(stderr, "boresight process: %s: not an input of process (SCA1A, ACC1A, QSA1B, .lcm)\n", f.c_str());
      return false;
    }
  }
  return true;
}

/// Receiver time -> GPS time from CLK1B (t_gps = t_rcv + eps_time, linear between records).
struct ClockMap {
  std::vector<io::ClkRecord> r;
  double epsAt(TimeUs t) const {
    if (r.empty()) return 0.0;
    if (t <= r.front().t) return r.front().eps_time;
    for (std::size_t i = 1; i < r.size(); ++i)
      if (t <= r[i].t) {
        double f = double(t - r[i - 1].t) / double(std::max<TimeUs>(1, r[i].t - r[i - 1].t));
        return r[i - 1].eps_time + f * (r[i].eps_time - r[i - 1].eps_time);
      }
    return r.back().eps_time;
  }
};

struct Comparison {
  int n = 0;
  Vec3 mean = Vec3::Zero(), sd = Vec3::Zero();
};

/// Difference SCA1B -> fused (small rotation in body axes, arcsec) with the fused attitude taken at
/// each SCA1B tag + shift_s (slerp between the two rows around it; row tags mapped to GPS time).
Comparison compareAt(const std::vector<std::pair<double, Quat>>& fused, const std::vector<io::Sca1bRecord>& ref,
                     double shift_s) {
  Comparison c;
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  for (const auto& s : ref) {
    double t = toSeconds(s.t) + shift_s;
    auto it = std::lower_bound(fused.begin(), fused.end(), t,
                               [](const std::pair<double, Quat>& a, double v) { return a.first < v; });
    if (it == fused.begin() || it == fused.end()) continue;
    auto prev = it - 1;
    if (it->first - prev->first > 1.5) continue;
    double f = (t - prev->first) / (it->first - prev->first);
    Quat q = prev->second.slerp(f, it->second);
    Quat q_ref = quatFromScalarFirst(s.q).normalized();
    Eigen::AngleAxisd d(q.conjugate() * q_ref);
    double ang = d.angle() > kPi ? d.angle() - 2 * kPi : d.angle();
    Vec3 e = ang * d.axis() * kArcsecPerRad;
    sum += e;
    sum2 += e.cwiseProduct(e);
    ++c.n;
  }
  if (c.n > 0) {
    c.mean = sum / c.n;
    c.sd = ((sum2 / c.n - c.mean.cwiseProduct(c.mean)).cwiseMax(0.0) * (c.n / std::max(1.0, c.n - 1.0))).cwiseSqrt();
  }
  return c;
}

void compareSca1b(const std::vector<core::PipelineRow>& rows, const std::string& path, const ClockMap& clk) {
  auto p = io::readProduct<io::Sca1bRecord>(path);
  if (!p.ok) {
    std::fprintf(stderr, "boresight process: %s\n", p.error.c_str());
    return;
  }
  std::vector<std::pair<double, Quat>> fused;
  for (const auto& r : rows)
    if (r.heads_used > 0) fused.emplace_back(toSeconds(r.t) + clk.epsAt(r.t), r.q_I_B);
  Comparison c0 = compareAt(fused, p.records, 0.0);
  if (c0.n == 0) {
    std::printf("SCA1B comparison: no common epochs\n");
    return;
  }
  const char* ax = "xyz";
  std::printf("\nFused attitude versus SCA1B (%s), %d epochs, rotation SCA1B->fused in body axes%s:\n",
              path.c_str(), c0.n, clk.r.empty() ? " (receiver time taken as GPS time)" : " (CLK1B applied)");
  std::printf("  axis   mean [arcsec]   scatter [arcsec]\n");
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], c0.mean[i], c0.sd[i]);
  // Which time shift explains the difference best? Scan +-1 s in 10 ms steps (fused taken at t + shift).
  double best_shift = 0, best = c0.mean.norm();
  Comparison cb = c0;
  for (int k = -100; k <= 100; ++k) {
    Comparison c = compareAt(fused, p.records, k * 0.01);
    if (c.n >= c0.n / 2 && c.mean.norm() < best) {
      best = c.mean.norm();
      best_shift = k * 0.01;
      cb = c;
    }
  }
  std::printf("  smallest mean difference with the fused attitude taken at SCA1B time %+.2f s: %d epochs\n",
              best_shift, cb.n);
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], cb.mean[i], cb.sd[i]);
}

}  // namespace

int runProcess(int argc, char** argv) {
  Args a(argc, argv, {"--config", "--out", "--compare-sca1b", "--clk1b"}, {"--help", "-h", "--strict"});
  if (a.help()) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!a.ok() || !a.has("--config") || !a.has("--out") || a.positional().empty()) {
    std::fprintf(stderr, "boresight process: %s\n\n%s",
                 !a.ok() ? a.error().c_str()
                         : !a.has("--config") ? "--config is required"
                                              : !a.has("--out") ? "--out is required" : "no INPUT given",
                 kUsage);
    return 2;
  }
  io::PlatformConfig pc;
  std::string err;
  if (!io::loadPlatformConfig(a.get("--config"), pc, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  Input in;
  if (!readInputs(a, in)) return 1;
  if (in.sca.empty()) {
    std::fprintf(stderr, "boresight process: no star sensor samples in the inputs\n");
    return 1;
  }
  std::stable_sort(in.sca.begin(), in.sca.end(), [](const io::Sca1aRecord& x, const io::Sca1aRecord& y) { return x.t < y.t; });
  std::stable_sort(in.acc.begin(), in.acc.end(), [](const io::FlaggedRecord& x, const io::FlaggedRecord& y) { return x.t < y.t; });
  if (pc.mounting_from_qsa1b) {
    if (in.qsa.empty()) {
      std::fprintf(stderr, "boresight process: %s takes the mountings from QSA1B (heads.mounting: qsa1b): give a QSA1B file\n",
                   a.get("--config").c_str());
      return 1;
    }
    if (!io::applyQsa1bMounting(pc, in.qsa, in.sca.front().t, &err)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
  }
  if (in.acc.empty()) pc.pipeline.use_accelerometer = false;

  auto pipe = std::make_unique<core::Pipeline>();  // large fixed-size state: keep it off the stack
  core::Status st = pipe->configure(pc.pipeline);
  if (st != core::Status::kOk) {
    std::fprintf(stderr, "boresight process: the core rejected the configuration: %s\n", core::statusName(st));
    return 1;
  }

  std::vector<core::PipelineRow> rows;
  auto drain = [&] {
    core::PipelineRow r;
    while (pipe->popRow(r)) rows.push_back(r);
  };
  // Merge: head epochs (records with one tag) and accelerometer samples, in time order.
  std::size_t i = 0, j = 0;
  std::size_t acc_no_ang = 0, heads_over = 0;
  while (i < in.sca.size() || j < in.acc.size()) {
    bool take_head = j >= in.acc.size() || (i < in.sca.size() && in.sca[i].t <= in.acc[j].t);
    if (take_head) {
      core::HeadEpoch e;
      e.t = in.sca[i].t;
      while (i < in.sca.size() && in.sca[i].t == e.t) {
        if (e.n < core::kMaxHeads) {
          auto& s = e.sample[static_cast<std::size_t>(e.n++)];
          s.head_id = in.sca[i].head;
          s.q_I_Si = quatFromScalarFirst(in.sca[i].q);
        } else {
          ++heads_over;
        }
        ++i;
      }
      pipe->stepHeads(e);
    } else {
      const auto& r = in.acc[j++];
      if (!(r.has(io::acc_bits::kAngX) && r.has(io::acc_bits::kAngY) && r.has(io::acc_bits::kAngZ))) {
        ++acc_no_ang;
        continue;
      }
      pipe->stepAcc(r.t, Vec3(r.value[3], r.value[4], r.value[5]));
    }
    drain();
  }
  pipe->flush();
  drain();

  // CSV
  const std::string out = a.get("--out");
  std::FILE* f = std::fopen(out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "boresight process: cannot write %s\n", out.c_str());
    return 1;
  }
  const auto& hs = pc.pipeline.heads;
  std::fprintf(f, "time_s,q0,q1,q2,q3,w_x,w_y,w_z,a_sc_x,a_sc_y,a_sc_z,a_acc_x,a_acc_y,a_acc_z");
  for (int s1 = 0; s1 < hs.n_heads; ++s1)
    for (int s2 = s1 + 1; s2 < hs.n_heads; ++s2)
      std::fprintf(f, ",iba_%d%d_deg,iba_%d%d_dev_arcsec", hs.head[std::size_t(s1)].id, hs.head[std::size_t(s2)].id,
                   hs.head[std::size_t(s1)].id, hs.head[std::size_t(s2)].id);
  std::fprintf(f, ",heads_used\n");
  auto num = [&](double v, const char* fmt) {
    if (std::isfinite(v)) std::fprintf(f, fmt, v);
    else std::fputc(',', f);
  };
  std::size_t with_rates = 0, with_acc = 0;
  for (const auto& r : rows) {
    std::int64_t sec = r.t / kUsPerSecond, us = r.t % kUsPerSecond;
    if (us < 0) us += kUsPerSecond, --sec;
    std::fprintf(f, "%lld.%06lld", static_cast<long long>(sec), static_cast<long long>(us));
    double q[4];
    quatToScalarFirst(r.q_I_B, q);
    for (double v : q) std::fprintf(f, ",%.17g", v);
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.w_B[k] : NAN, ",%.9e");
    for (int k = 0; k < 3; ++k) num(r.has_rates ? r.a_sc_B[k] : NAN, ",%.9e");
    for (int k = 0; k < 3; ++k) num(r.has_acc ? r.a_acc_B[k] : NAN, ",%.9e");
    for (int s1 = 0; s1 < hs.n_heads; ++s1)
      for (int s2 = s1 + 1; s2 < hs.n_heads; ++s2) {
        int p = core::pairIndex(s1, s2);
        num(r.iba_rad[std::size_t(p)] / kRadPerDeg, ",%.9f");
        num(r.iba_dev_rad[std::size_t(p)] * kArcsecPerRad, ",%.3f");
      }
    std::fprintf(f, ",%d\n", r.heads_used);
    with_rates += r.has_rates;
    with_acc += r.has_acc;
  }
  std::fclose(f);

  std::printf("\n%s: %zu rows (%zu with CRN rates, %zu with accelerometer values)\n", out.c_str(), rows.size(),
              with_rates, with_acc);
  if (rows.size() && !with_rates)
    std::printf("  no rates: the CRN needs about %.0f s of data before and after an epoch; the input spans %.1f s\n",
                pc.pipeline.crn_attitude.length_s / 2, toSeconds(in.sca.back().t - in.sca.front().t));
  core::Health h = pipe->health();
  std::printf("core health (inputs by outcome):\n");
  for (int s = 0; s < core::kStatusCount; ++s)
    if (h.by_status[std::size_t(s)]) std::printf("  %-22s %llu\n", core::statusName(core::Status(s)),
                                               static_cast<unsigned long long>(h.by_status[std::size_t(s)]));
  if (acc_no_ang) std::printf("  accelerometer records without angular acceleration: %zu (not used)\n", acc_no_ang);
  if (heads_over) std::printf("  head samples beyond kMaxHeads in one epoch: %zu (dropped)\n", heads_over);
  if (in.rejected_lines) std::printf("  input lines rejected by the readers: %zu\n", in.rejected_lines);

  if (a.has("--compare-sca1b")) {
    ClockMap clk;
    if (a.has("--clk1b")) {
      auto c = io::readProduct<io::ClkRecord>(a.get("--clk1b"));
      if (!c.ok) {
        std::fprintf(stderr, "boresight process: %s\n", c.error.c_str());
        return 1;
      }
      for (const auto& r : c.records)
        if (r.qualflg.value == 0) clk.r.push_back(r);
    }
    compareSca1b(rows, a.get("--compare-sca1b"), clk);
  }
  return 0;
}

}  // namespace boresight::cli

// boresight process --config FILE INPUT... --out FILE.csv: the real-time core over recorded telemetry.
#include <boresight/core/pipeline.h>
#include <boresight/io/core_config.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/level1.h>
#include <boresight/io/product_stream.h>
#include <boresight/io/time_format.h>
#include <boresight/stream/engine.h>
#include <boresight/stream/replay.h>
#include <boresight/stream/sources.h>

#include "cli_common.h"
#include "commands.h"
#include "replay_summary.h"

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
    "                         [--stars-out FILE.csv] [--lookahead S] [--strict]\n"
    "\n"
    "Runs the real-time core (head fusion, CRN rates and angular acceleration, accelerometer angular\n"
    "acceleration through the same CRN, inter-boresight monitor) over Level-1 files (SCA1A, ACC1A, and\n"
    "QSA1B for the mountings when the config says heads.mounting: qsa1b) or LCM logs (recognised by\n"
    "their content, whatever the extension), streamed in sensor-time order with constant memory, and\n"
    "writes one CSV row per output epoch:\n"
    "  time_s            GPS seconds past 2000-01-01 12:00:00 (receiver time for Level-1A input)\n"
    "  q0,q1,q2,q3       fused body attitude q_I_B (R(q) = C_I_B), scalar first, through the mountings\n"
    "  w_x,w_y,w_z       angular rate, rad/s, body frame (empty where the CRN has too little data)\n"
    "  a_sc_x..z         star-sensor angular acceleration, rad/s^2, body frame\n"
    "  a_acc_x..z        accelerometer angular acceleration, same CRN low-pass, rad/s^2, body frame\n"
    "  iba_<i><j>_deg, iba_<i><j>_dev_arcsec   per head pair: inter-boresight angle, deviation from ground\n"
    "  heads_used        heads fused at this epoch\n"
    "The CRN output is stamped at the centre tap: rates need Tf/2 (~35 s) of data on each side.\n"
    "Star vectors (SCV1A files, STAR_VECTORS messages) among the inputs go to the multi-head Wahba solver\n"
    "with the thermally corrected relative matrices (config: thermal.wahba_correction).\n"
    "\n"
    "  --config FILE         platform file (config/gracefo.yaml)\n"
    "  --out FILE.csv        output table\n"
    "  --compare-sca1b FILE  compare the fused attitude with the official SCA1B product: per-axis mean\n"
    "                        and scatter of the difference (arcsec, body axes)\n"
    "  --clk1b FILE          receiver-to-GPS clock offsets for that comparison (Level-1A tags are\n"
    "                        receiver time; without CLK1B they are compared as if they were GPS time)\n"
    "  --stars-out FILE.csv  the joint attitude of every solved star epoch: time_s, q0..q3 (q_I_B),\n"
    "                        sigma_x..z_arcsec (1-sigma about the body axes, with the relative matrices'\n"
    "                        uncertainty), stars_in, stars_used, residual_rms_arcsec, d_fused_x..z_arcsec\n"
    "                        (rotation from the fused attitude of the same tag to the star attitude)\n"
    "  --lookahead S         how far (seconds, default 2) samples may arrive out of time order and still be\n"
    "                        sorted in; older ones are counted as rejected (late)\n"
    "  --strict              stop at the first malformed input line\n"
    "\n"
    "Other Level-1 products among the inputs (GNV1B, SCA1B, CLK1B, ...) are listed as ignored. Level-1\n"
    "files and LCM logs are not mixed in one run. Every record read is reported as used or rejected\n"
    "with its reason.\n";

/// Receiver time -> GPS time from CLK1B (t_gps = t_rcv + eps_time, linear between records).
struct ClockMap {
  std::vector<io::ClkRecord> r;
  double epsAt(TimeUs t) const {
    if (r.empty()) return 0.0;
    if (t <= r.front().t) return r.front().eps_time;
    // First record at or after t (records in time order, as CLK1B files are).
    auto it = std::lower_bound(r.begin(), r.end(), t, [](const io::ClkRecord& c, TimeUs v) { return c.t < v; });
    if (it == r.end()) return r.back().eps_time;
    const auto& a = *(it - 1);
    const auto& b = *it;
    double f = double(t - a.t) / double(std::max<TimeUs>(1, b.t - a.t));
    return a.eps_time + f * (b.eps_time - a.eps_time);
  }
};

struct Comparison {
  int n = 0;
  Vec3 mean = Vec3::Zero(), sd = Vec3::Zero();
};

/// The SCA1B rows as the comparison needs them: GPS seconds and the normalised attitude.
struct RefRow {
  double t;
  Quat q;
};

/// Difference SCA1B -> fused (small rotation in body axes, arcsec) with the fused attitude taken at
/// each SCA1B tag + shift_s (slerp between the two rows around it; row tags mapped to GPS time).
Comparison compareAt(const std::vector<std::pair<double, Quat>>& fused, const std::vector<RefRow>& ref,
                     double shift_s) {
  Comparison c;
  Vec3 sum = Vec3::Zero(), sum2 = Vec3::Zero();
  for (const auto& s : ref) {
    double t = s.t + shift_s;
    auto it = std::lower_bound(fused.begin(), fused.end(), t,
                               [](const std::pair<double, Quat>& a, double v) { return a.first < v; });
    if (it == fused.begin() || it == fused.end()) continue;
    auto prev = it - 1;
    if (it->first - prev->first > 1.5) continue;
    double f = (t - prev->first) / (it->first - prev->first);
    Quat q = prev->second.slerp(f, it->second);
    Eigen::AngleAxisd d(q.conjugate() * s.q);
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

/// The fused attitude of each row with heads (40 bytes a row: what the SCA1B comparison needs).
class AttitudeTrack final : public stream::RowSink {
 public:
  bool write(const core::PipelineRow& r) override {
    if (r.heads_used > 0) rows.emplace_back(r.t, r.q_I_B);
    return true;
  }
  std::vector<std::pair<TimeUs, Quat>> rows;
};

/// Opens an SCA1B file as a check before the replay (so a wrong path fails fast): false with *error.
bool checkSca1b(const std::string& path, std::string* error) {
  io::LineStream probe;
  if (!probe.open(path, {}, error, 4096)) return false;
  if (probe.header().product != io::Product::SCA1B) {
    if (error) *error = path + ":1: " + probe.header().product_name + " is not an SCA1B product";
    return false;
  }
  return true;
}

/// Reads the SCA1B records (streamed: the text is not held; GRACE binary SCA1B is read whole).
bool readSca1b(const std::string& path, std::vector<io::Sca1bRecord>& out, std::string* error) {
  io::LineStream probe;
  if (!probe.open(path, {}, error, 4096)) return false;
  if (probe.header().binary) {
    auto p = io::readProduct<io::Sca1bRecord>(path);
    if (!p.ok) {
      if (error) *error = p.error;
      return false;
    }
    out = std::move(p.records);
    return true;
  }
  io::ProductStream<io::Sca1bRecord> st;
  if (!st.open(path, {}, error)) return false;
  io::Sca1bRecord rec;
  while (st.next(rec)) out.push_back(rec);
  if (!st.ok()) {
    if (error) *error = st.error();
    return false;
  }
  return true;
}

/// Prints the comparison. False with *error when the SCA1B file cannot be read.
bool compareSca1b(const std::vector<std::pair<TimeUs, Quat>>& rows, const std::string& path, const ClockMap& clk,
                  std::string* error) {
  std::vector<RefRow> ref;
  {
    std::vector<io::Sca1bRecord> recs;
    if (!readSca1b(path, recs, error)) return false;
    ref.reserve(recs.size());
    for (const auto& s : recs) ref.push_back({toSeconds(s.t), quatFromScalarFirst(s.q).normalized()});
  }
  std::vector<std::pair<double, Quat>> fused;
  fused.reserve(rows.size());
  for (const auto& r : rows) fused.emplace_back(toSeconds(r.first) + clk.epsAt(r.first), r.second);
  Comparison c0 = compareAt(fused, ref, 0.0);
  if (c0.n == 0) {
    std::printf("SCA1B comparison: no common epochs\n");
    return true;
  }
  const char* ax = "xyz";
  std::printf("\nFused attitude versus SCA1B (%s), %d epochs, rotation SCA1B->fused in body axes%s:\n",
              path.c_str(), c0.n, clk.r.empty() ? " (receiver time taken as GPS time)" : " (CLK1B applied)");
  std::printf("  axis   mean [arcsec]   scatter [arcsec]\n");
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], c0.mean[i], c0.sd[i]);
  // Which time shift explains the difference best, on a +-1 s grid of 10 ms (fused taken at t + shift)?
  // For small shifts the mean difference is close to linear in the shift (the rate about each axis
  // times the shift), so its norm is convex along the grid: a scan in 100 ms steps finds the
  // neighbourhood and a 10 ms scan within +-100 ms of the best coarse point finds the grid minimum
  // (42 evaluations instead of 201; same choice, same rule: smallest norm, at least half the epochs).
  std::map<int, Comparison> seen;
  seen[0] = c0;
  auto eval = [&](int k) {
    auto it = seen.find(k);
    if (it == seen.end()) it = seen.emplace(k, compareAt(fused, ref, k * 0.01)).first;
    return it->second;
  };
  auto pick = [&](int lo, int hi, int step, int& best_k) {
    double best = c0.mean.norm();
    for (int k = lo; k <= hi; k += step) {
      Comparison c = eval(k);
      if (c.n >= c0.n / 2 && c.mean.norm() < best) {
        best = c.mean.norm();
        best_k = k;
      }
    }
  };
  int coarse_k = 0, best_k = 0;
  pick(-100, 100, 10, coarse_k);
  pick(std::max(-100, coarse_k - 10), std::min(100, coarse_k + 10), 1, best_k);
  // The full scan's rule (first strict minimum in grid order) over every point evaluated.
  {
    double best = c0.mean.norm();
    best_k = 0;
    for (const auto& [k, c] : seen)
      if (c.n >= c0.n / 2 && c.mean.norm() < best) {
        best = c.mean.norm();
        best_k = k;
      }
  }
  const Comparison cb = seen[best_k];
  std::printf("  smallest mean difference with the fused attitude taken at SCA1B time %+.2f s: %d epochs\n",
              best_k * 0.01, cb.n);
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], cb.mean[i], cb.sd[i]);
  return true;
}

}  // namespace

int runProcess(int argc, char** argv) {
  CLI::App app{"boresight process"};
  std::string config, out, compare, clk1b, stars_out;
  std::vector<std::string> files;
  bool strict = false;
  double lookahead_s = 2.0;
  app.add_option("--config", config)->required();
  app.add_option("--out", out)->required();
  app.add_option("--compare-sca1b", compare);
  app.add_option("--clk1b", clk1b);
  app.add_option("--stars-out", stars_out);
  app.add_option("--lookahead", lookahead_s)->check(CLI::Range(0.0, 3600.0));
  app.add_flag("--strict", strict);
  app.add_option("inputs", files)->required();
  if (int st = parseCommandLine(app, argc, argv, "process", kUsage); st >= 0) return st;

  io::PlatformConfig pc;
  std::string err;
  if (!io::loadPlatformConfig(config, pc, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  // The comparison files are checked before the replay: a wrong path fails at once, not after it.
  if (!compare.empty() && !checkSca1b(compare, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  if (!clk1b.empty()) {
    if (compare.empty()) std::printf("%s: --clk1b is used only with --compare-sca1b: ignored\n", clk1b.c_str());
    io::LineStream probe;
    if (!probe.open(clk1b, {}, &err, 4096)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
    if (probe.header().product != io::Product::CLK1B) {
      std::fprintf(stderr, "boresight process: %s:1: %s is not a CLK1B product\n", clk1b.c_str(),
                   probe.header().product_name.c_str());
      return 1;
    }
  }
  stream::ReplayInputs in;
  if (!stream::classifyInputs(files, in, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  for (const auto& [f, product] : in.ignored)
    std::printf("%s: %s is not an input of process (SCA1A, ACC1A, SCV1A, QSA1B, LCM log): ignored\n", f.c_str(),
                product.c_str());
  io::ReadOptions opt;
  if (strict) opt.on_error = io::OnError::Stop;
  if (!stream::prepareConfig(in, opt, pc, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  stream::AssemblerConfig acfg;
  acfg.lookahead_us = static_cast<TimeUs>(std::llround(lookahead_s * 1e6));
  stream::Engine engine(acfg);
  if (!engine.configure(pc.pipeline, &err) || !stream::addSources(in, opt, true, engine, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  stream::CsvRowSink csv(out);
  stream::CsvStarSink stars_csv(stars_out);
  AttitudeTrack track;
  engine.addSink(&csv);
  if (!stars_out.empty()) engine.addSink(&stars_csv);
  if (!compare.empty()) engine.addSink(&track);
  if (engine.run() != stream::Engine::Result::kDone) {
    std::fprintf(stderr, "boresight process: %s\n", engine.error().c_str());
    return 1;
  }

  // Every input record is used or rejected with a reason.
  printSourceCounters(engine);
  const auto& tot = engine.counters();
  if (tot.used_heads == 0) {
    std::fprintf(stderr, "boresight process: no star sensor samples in the inputs\n");
    return 1;
  }
  std::printf("\n%s: %zu rows (%zu with CRN rates, %zu with accelerometer values)\n", out.c_str(), csv.rows(),
              csv.withRates(), csv.withAcc());
  if (csv.rows() && !csv.withRates())
    std::printf("  no rates: the CRN needs about %.0f s of data before and after an epoch; the input spans %.1f s\n",
                pc.pipeline.crn_attitude.length_s / 2, toSeconds(engine.lastEpoch() - engine.firstEpoch()));
  std::printf("inputs: %llu read = %llu used (%llu head samples in %llu epochs, %llu accelerometer) + %llu rejected\n",
              static_cast<unsigned long long>(tot.read), static_cast<unsigned long long>(tot.used()),
              static_cast<unsigned long long>(tot.used_heads), static_cast<unsigned long long>(engine.epochs()),
              static_cast<unsigned long long>(tot.used_accel), static_cast<unsigned long long>(tot.rejectedTotal()));
  if (tot.used_stars > 0 || !stars_out.empty()) {
    std::printf("star vectors: %llu in %llu star epochs, %llu epochs solved (multi-head Wahba)%s%s\n",
                static_cast<unsigned long long>(tot.used_stars), static_cast<unsigned long long>(engine.starEpochs()),
                static_cast<unsigned long long>(engine.starSolutions()), stars_out.empty() ? "" : " -> ",
                stars_out.c_str());
    if (!stars_out.empty() && tot.used_stars == 0)
      std::printf("  no star vectors among the inputs (SCV1A files or STAR_VECTORS messages): %s has a header only\n",
                  stars_out.c_str());
  }
  printCoreHealth(engine.health());

  if (!compare.empty()) {
    ClockMap clk;
    if (!clk1b.empty()) {
      auto c = io::readProduct<io::ClkRecord>(clk1b);
      if (!c.ok) {
        std::fprintf(stderr, "boresight process: %s\n", c.error.c_str());
        return 1;
      }
      for (const auto& r : c.records)
        if (r.qualflg.value == 0) clk.r.push_back(r);
    }
    if (!compareSca1b(track.rows, compare, clk, &err)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace boresight::cli

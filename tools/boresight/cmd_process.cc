// boresight process --config FILE INPUT... --out FILE.csv: the real-time core over recorded telemetry.
#include <boresight/audit/reference.h>
#include <boresight/core/pipeline.h>
#include <boresight/io/core_config.h>
#include <boresight/io/files.h>
#include <boresight/io/lcm_log.h>
#include <boresight/io/overlay_apply.h>
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
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_process {
namespace {

const char* kUsage =
    "usage: boresight process --config FILE INPUT... --out FILE.csv [--compare-sca1b FILE] [--clk1b FILE]\n"
    "                         [--sca1b FILE [--satellite X]]\n"
    "                         [--stars-out FILE.csv] [--overlay FILE] [--lookahead S] [--strict]\n"
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
    "  q_sigma_x..z_arcsec, q_corr_xy..yz   the fused attitude's covariance P_B: 1-sigma about each body\n"
    "                    axis and the correlations (the rates' sigmas and bridged-sample columns before them)\n"
    "The CRN output is stamped at the centre tap: rates need Tf/2 (~35 s) of data on each side.\n"
    "Star vectors (SCV1A files, STAR_VECTORS messages) among the inputs go to the multi-head Wahba solver\n"
    "with the thermally corrected relative matrices (config: thermal.wahba_correction).\n"
    "\n"
    "  --config FILE         platform file (config/gracefo.yaml; config/gracefo_ideal.yaml for data simulated\n"
    "                        with the ideal noise preset)\n"
    "  --out FILE.csv        output table\n"
    "  --overlay FILE        a model overlay (README \"The model overlay\"): its noise models replace the\n"
    "                        platform file's (fusion weights), its mountings the platform file's or QSA1B's,\n"
    "                        its thermal terms predict the relative corrections of head pairs a head epoch\n"
    "                        does not see (with the orbit: GNI1B / GNV1B files or ORBIT messages among the\n"
    "                        inputs), its accelerometer terms correct every accelerometer sample; the parts\n"
    "                        process does not use are listed as not applied\n"
    "  --compare-sca1b FILE  compare the fused attitude with the official SCA1B product: per-axis mean\n"
    "                        and scatter of the difference (arcsec, body axes)\n"
    "  --clk1b FILE          receiver-to-GPS clock offsets for that comparison and for --sca1b (Level-1A\n"
    "                        tags are receiver time; without CLK1B they are taken as GPS time, and said so)\n"
    "  --sca1b FILE          the fused attitude as a GRACE-FO SCA1B product (for a Level-1B chain): q_I_B at\n"
    "                        every whole GPS second, slerp between the two rows around it; across a gap of\n"
    "                        more than 1.5 row periods no record (a hole, counted; never an interpolated\n"
    "                        value); sca_id from the heads fused (7: SCAs 1, 2 and 3), qual_rss the RSS of\n"
    "                        the quaternion components' formal errors, 0.5 sqrt(trace P_B) of the fused\n"
    "                        covariance; qualflg bit 3 where one head only was fused. Held in memory\n"
    "                        (about 72 bytes per second of data) and written when the run succeeds\n"
    "  --satellite X         the satellite letter of the SCA1B header and records (default C)\n"
    "  --stars-out FILE.csv  the joint attitude of every solved star epoch: time_s, q0..q3 (q_I_B),\n"
    "                        sigma_x..z_arcsec (1-sigma about the body axes, with the relative matrices'\n"
    "                        uncertainty), stars_in, stars_used, residual_rms_arcsec, d_fused_x..z_arcsec\n"
    "                        (rotation from the fused attitude of the same tag to the star attitude)\n"
    "  --lookahead S         how far (seconds, default 2) samples may arrive out of time order and still be\n"
    "                        sorted in; older ones are counted as rejected (late)\n"
    "  --strict              stop at the first malformed input line\n"
    "\n"
    "Other Level-1 products among the inputs (SCA1B, CLK1B, ...; GNV1B/GNI1B without thermal terms) are\n"
    "listed as ignored. Level-1\n"
    "files and LCM logs are not mixed in one run. Every record read is reported as used or rejected\n"
    "with its reason.\n";

/// The fused attitude of each row with heads (40 bytes a row: what the SCA1B comparison needs).
class AttitudeTrack final : public stream::RowSink {
 public:
  bool write(const core::PipelineRow& r) override {
    if (r.heads_used > 0) rows.emplace_back(r.t, r.q_I_B);
    return true;
  }
  std::vector<std::pair<TimeUs, Quat>> rows;
};

/// Prints the comparison. False with *error when the SCA1B file cannot be read.
bool compareSca1b(const std::vector<std::pair<TimeUs, Quat>>& rows, const std::string& path, const audit::ClockMap& clk,
                  std::string* error) {
  std::vector<audit::TimedAttitude> ref;
  {
    std::vector<io::Sca1bRecord> recs;
    if (!audit::readSca1b(path, recs, error)) return false;
    ref = audit::referenceSamples(recs);
  }
  std::vector<audit::TimedAttitude> fused;
  fused.reserve(rows.size());
  for (const auto& r : rows) fused.push_back({toSeconds(r.first) + clk.epsAt(r.first), r.second});
  // Which time shift explains the difference best, on a +-1 s grid of 10 ms (fused taken at t + shift)?
  const audit::ShiftScan scan = audit::scanTimeShift(fused, ref);
  const audit::AttitudeDifference& c0 = scan.at_zero;
  if (c0.n == 0) {
    std::printf("SCA1B comparison: no common epochs\n");
    return true;
  }
  const char* ax = "xyz";
  std::printf("\nFused attitude versus SCA1B (%s), %d epochs, rotation SCA1B->fused in body axes%s:\n",
              path.c_str(), c0.n, clk.empty() ? " (receiver time taken as GPS time)" : " (CLK1B applied)");
  std::printf("  axis   mean [arcsec]   scatter [arcsec]\n");
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], c0.mean[i], c0.sd[i]);
  const audit::AttitudeDifference& cb = scan.best;
  std::printf("  smallest mean difference with the fused attitude taken at SCA1B time %+.2f s: %d epochs\n",
              scan.best_shift_s, cb.n);
  for (int i = 0; i < 3; ++i) std::printf("  %c      %12.2f   %12.2f\n", ax[i], cb.mean[i], cb.sd[i]);
  return true;
}

}  // namespace

int runProcess(int argc, char** argv) {
  CLI::App app{"boresight process"};
  std::string config, out, compare, clk1b, stars_out, overlay, sca1b_out, satellite = "C";
  std::vector<std::string> files;
  bool strict = false;
  double lookahead_s = 2.0;
  app.add_option("--config", config)->required();
  app.add_option("--out", out)->required();
  app.add_option("--compare-sca1b", compare);
  app.add_option("--clk1b", clk1b);
  app.add_option("--stars-out", stars_out);
  app.add_option("--sca1b", sca1b_out);
  app.add_option("--satellite", satellite)->check(CLI::IsMember({"A", "B", "C", "D"}));
  app.add_option("--overlay", overlay);
  app.add_option("--lookahead", lookahead_s)->check(finiteRange(0.0, 3600.0));
  app.add_flag("--strict", strict);
  app.add_option("inputs", files)->required();
  if (int st = parseCommandLine(app, argc, argv, "process", kUsage); st >= 0) return st;

  std::string err;
  {  // outputs never destroy inputs, checked before anything is read or written
    std::vector<std::string> ins = files;
    for (const auto* p : {&config, &compare, &clk1b, &overlay}) ins.push_back(*p);
    if (!io::checkOutputs(ins, {{"--out", out}, {"--stars-out", stars_out}, {"--sca1b", sca1b_out}}, &err)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
  }
  // The comparison files are checked before the replay: a wrong path fails at once, not after it.
  if (!compare.empty() && !audit::checkSca1b(compare, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  audit::ClockMap clk;
  if (!clk1b.empty()) {
    if (compare.empty() && sca1b_out.empty())
      std::printf("%s: --clk1b is used only with --compare-sca1b or --sca1b: ignored\n", clk1b.c_str());
    else if (!audit::checkClk1b(clk1b, &err) || !audit::loadClk1b({clk1b}, clk, &err)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
  }
  stream::ReplayRequest rq;
  rq.program = "boresight process";
  rq.config = config;
  rq.overlay = overlay;
  rq.uses.thermal = true;
  rq.uses.accelerometer = true;
  rq.inputs = files;
  rq.strict = strict;
  rq.lookahead_s = lookahead_s;
  rq.thermal_in_core = true;
  stream::Replay rp;
  if (!stream::openReplay(rq, rp, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  const io::PlatformConfig& pc = rp.pc;
  const io::OverlayUse& ovu = rp.overlay;
  const stream::ReplayInputs& in = rp.in;
  stream::Engine& engine = *rp.engine;
  const bool thermal = ovu.thermal_model.has_value();
  for (const auto& [f, product] : in.ignored) {
    const bool orbit = product == "GNV1B" || product == "GNI1B";
    if (orbit && thermal) std::printf("%s: orbit for the thermal prediction (the overlay's thermal terms)\n", f.c_str());
    else if (orbit)
      std::printf("%s: %s is read only with thermal terms in an --overlay (the thermal prediction): ignored\n", f.c_str(),
                  product.c_str());
    else
      std::printf("%s: %s is not an input of process (SCA1A, ACC1A, SCV1A, QSA1B, GNV1B/GNI1B, LCM log): ignored\n",
                  f.c_str(), product.c_str());
  }
  for (const auto& l : io::modelInUseLines(pc, ovu)) std::printf("%s\n", l.c_str());
  stream::CsvRowSink csv(out);
  stream::CsvStarSink stars_csv(stars_out);
  // Both appear at their paths only when the run has succeeded (commit below).
  csv.deferCommit();
  stars_csv.deferCommit();
  AttitudeTrack track;
  const double row_period_s = toSeconds(pc.pipeline.crn_attitude.output_period_us);
  stream::Sca1bSink sca1b(sca1b_out, satellite[0], 1.5 * (row_period_s > 0 ? row_period_s : 1.0),
                          clk.empty() ? std::function<double(TimeUs)>() : [&clk](TimeUs t) { return clk.epsAt(t); });
  engine.addSink(&csv);
  if (!sca1b_out.empty()) engine.addSink(&sca1b);
  if (!stars_out.empty()) engine.addSink(&stars_csv);
  if (!compare.empty()) engine.addSink(&track);
  if (!stream::startReplay(rp, &err)) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }
  if (engine.run() != stream::Engine::Result::kDone) {
    std::fprintf(stderr, "boresight process: %s\n", engine.error().c_str());
    return 1;
  }

  // Every input record is used or rejected with a reason.
  printSourceCounters(engine);
  const auto& tot = engine.counters();
  if (tot.used_heads == 0) {
    std::fprintf(stderr, "boresight process: no star sensor samples in the inputs (every record rejected: see above); %s not written\n",
                 out.c_str());
    return 1;
  }
  std::printf("\n%s: %zu rows (%zu with CRN rates, %zu with accelerometer values)\n", out.c_str(), csv.rows(),
              csv.withRates(), csv.withAcc());
  if (csv.rows() && !csv.withRates())
    std::printf("  no rates: the CRN needs about %.0f s of data before and after an epoch; the input spans %.1f s\n",
                pc.pipeline.crn_attitude.length_s / 2, toSeconds(engine.lastEpoch() - engine.firstEpoch()));
  std::printf("inputs: %llu read = %llu used (%llu head samples in %llu epochs, %llu accelerometer%s%s) + %llu rejected\n",
              static_cast<unsigned long long>(tot.read), static_cast<unsigned long long>(tot.used()),
              static_cast<unsigned long long>(tot.used_heads), static_cast<unsigned long long>(engine.epochs()),
              static_cast<unsigned long long>(tot.used_accel), tot.used_orbit ? ", orbit " : "",
              tot.used_orbit ? std::to_string(tot.used_orbit).c_str() : "", static_cast<unsigned long long>(tot.rejectedTotal()));
  if (tot.used_stars > 0 || !stars_out.empty()) {
    std::printf("star vectors: %llu in %llu star epochs, %llu epochs solved (multi-head Wahba)%s%s\n",
                static_cast<unsigned long long>(tot.used_stars), static_cast<unsigned long long>(engine.starEpochs()),
                static_cast<unsigned long long>(engine.starSolutions()), stars_out.empty() ? "" : " -> ",
                stars_out.c_str());
    if (!stars_out.empty() && tot.used_stars == 0)
      std::printf("  no star vectors among the inputs (SCV1A files or STAR_VECTORS messages): %s has a header only\n",
                  stars_out.c_str());
  }
  if (thermal) {
    std::printf("orbit: %llu samples stepped the thermal prediction of the pairs a head epoch does not see\n",
                static_cast<unsigned long long>(engine.orbitSamples()));
    if (engine.orbitSamples() == 0)
      std::printf("warning: thermal terms without orbit input (GNI1B / GNV1B files, ORBIT messages): no pair was predicted\n");
  }
  printCoreHealth(engine.health());
  for (const auto& w : io::validityWarnings(ovu, engine.firstEpoch(), engine.lastEpoch())) std::printf("warning: %s\n", w.c_str());
  if (!csv.commit(&err) || (!stars_out.empty() && !stars_csv.commit(&err)) || (!sca1b_out.empty() && !sca1b.commit(&err))) {
    std::fprintf(stderr, "boresight process: %s\n", err.c_str());
    return 1;
  }

  if (!sca1b_out.empty()) {
    std::printf("%s: %zu SCA1B records at whole GPS seconds (%s)", sca1b_out.c_str(), sca1b.records(),
                clk.empty() ? (in.sca.empty() ? "the inputs' tags taken as GPS time"
                                              : "receiver time taken as GPS time: give --clk1b for Level-1A input")
                            : "receiver time through CLK1B");
    if (sca1b.holeSeconds())
      std::printf(", %llu seconds inside gaps not written", static_cast<unsigned long long>(sca1b.holeSeconds()));
    if (sca1b.rowsOutOfOrder())
      std::printf(", %llu rows not used (GPS time not after the previous row's)", static_cast<unsigned long long>(sca1b.rowsOutOfOrder()));
    std::printf("\n");
  }
  if (!compare.empty()) {
    if (!compareSca1b(track.rows, compare, clk, &err)) {
      std::fprintf(stderr, "boresight process: %s\n", err.c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace cmd_process

int runProcess(int argc, char** argv) { return cmd_process::runProcess(argc, argv); }

}  // namespace boresight::cli

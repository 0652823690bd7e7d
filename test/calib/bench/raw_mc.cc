// raw_mc: Monte Carlo of method A in the attitude domain (calib::estimateRaw) against the raw-data bound
// (calib::RawBound at the truth) on the project simulator, in memory. Per run: simulate the span, the
// bound from the truth, the estimate from what the instruments delivered; per head axis the error
// against the truth (accelerometer datum, head axes), over the bound. The simulator's measurement
// equation is not the estimator's (star-tracker attitude from star vectors, aberration, field-of-view
// error, thermal wander, tag jitter, thruster steps inside accelerometer samples); the estimator is
// given the true noise models of the heads and accelerometer (rawBoundConfig).
//
// usage: raw_mc --scenario FILE [--duration S] [--runs N] [--seed S0] [--effect SPEC]... [--drop NAME]...
//               [--scale] [--time-offset] [--harmonics K] [--passes P] [--correct-aberration]
// --correct-aberration: the head samples carry the observer velocity of the simulated aberration, which
// the estimator removes (the physics a processor applies with the orbit and the Earth's velocity).
// --fov-mean-in-truth: the field-of-view error's mean over the delivered samples (truth.yaml's
// realised_mean_arcsec) counted in the truth: no span can tell it from a mounting rotation.
// --white-model CROSS,ABOUT: the estimator is given white head noise only (arcsec per sample, every
// head) and the accelerometer's white levels only - what a platform file without a noise overlay
// gives: its sigmas at the model in use, after the variance components and from the score blocks
// (RawEstimate::robust_covariance) are compared with the errors.
// --no-slow-noise: with --fit-noise, the fitted models only (RawBoundOptions::keep_slow_noise off): the
// noise slower than the span resolves, stated in the model given to the estimator, is dropped.
// --passes P (default 3): passes of estimateRaw; --no-vce: no variance components applied.
// --drop NAME removes the scenario's effects of that name (e.g. aberration, thermal_periodic: a world
// inside the estimator's model, to see its efficiency apart from its model errors).
// --crn: the same runs through the CRN-domain solver as well (`calibrate --method crn`: the span builder
// fed by the stream engine, as calibrate feeds it from the files, and calib::solve with calibrate's
// defaults; scale and time offset free when --scale / --time-offset): the same seed simulated a second
// time through audit::feedSimulated, the core configuration a user of the scenario's files would run
// (audit::pipelineConfigFor). Its error over the same bound, its NEES under its own covariance and the
// ratio of its RMS error to the attitude domain's on the same runs. RAW_MC_DEBUG=1 in the environment
// prints each run's CRN angles, truth and sigmas per head.
#include <boresight/audit/simulated.h>
#include <boresight/calib/calibration.h>
#include <boresight/calib/raw_bound.h>
#include <boresight/calib/raw_bound_sim.h>
#include <boresight/core/rotation.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>
#include <boresight/stream/sinks.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

using namespace boresight;

namespace {

int usage() {
  std::fprintf(stderr, "usage: raw_mc --scenario FILE [--duration S] [--runs N] [--seed S0] [--effect SPEC]... "
                       "[--drop NAME]... [--scale] [--time-offset] [--harmonics K] [--passes P] [--correct-aberration]\n"
                       "              [--fov-mean-in-truth] [--white-model CROSS,ABOUT] [--no-vce] [--score-block S] [--fit-noise]\n"
                       "              [--no-slow-noise] [--crn]\n");
  return 2;
}

/// NEES of the error e (the first e.size() parameters) under a covariance, on the subspace it determines
/// (eigenvalues above 1e-12 of the largest); dof receives that subspace's dimension.
double neesOn(const Eigen::MatrixXd& full, const Eigen::VectorXd& e, int& dof) {
  const Eigen::MatrixXd C = full.topLeftCorner(e.size(), e.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (C + C.transpose()));
  const double top = es.eigenvalues().maxCoeff();
  double v = 0;
  dof = 0;
  for (Eigen::Index k = 0; k < e.size(); ++k) {
    const double lam = es.eigenvalues()(k);
    if (std::isfinite(lam) && lam > 1e-12 * top && lam > 0) {
      const double proj = es.eigenvectors().col(k).dot(e);
      v += proj * proj / lam;
      ++dof;
    }
  }
  return v;
}

/// The engine's inputs into the CRN solver's feed, as calibrate hands them over (cmd_calibrate.cc).
class CrnFeedObserver final : public stream::InputObserver {
 public:
  explicit CrnFeedObserver(calib::CalibrationFeed& f) : f_(f) {}
  void onHeads(const core::HeadEpoch& e, core::Status) override { f_.pushHeads(e); }
  void onAcc(TimeUs t, const Vec3& a_A, core::Status st) override {
    if (core::accepted(st)) f_.pushAcc(t, a_A);
  }
  void onEnd() override { f_.finish(); }

 private:
  calib::CalibrationFeed& f_;
};

/// The CRN solver on seed `seed`'s span (simulated again through the engine). False with *error.
bool crnSolve(const sim::Scenario& sc, unsigned long long seed, double duration, const calib::RawBoundConfig& cfg,
              const calib::RawBoundOptions& opt, calib::SolveResult& out, std::string* error) {
  audit::SimulatedOptions so;
  so.seed = seed;
  so.duration_s = duration;
  core::PipelineConfig pc;
  if (!audit::pipelineConfigFor(sc, so.base, pc, error)) return false;
  calib::SpanOptions spo;  // calibrate's defaults: 10 s decimation, the pipeline's CRNs
  for (int a = 0; a < 3; ++a) spo.acc_white_noise_radps2[a] = std::sqrt(cfg.acc_noise[static_cast<std::size_t>(a)].whiteVariance());
  calib::CalibrationFeed feed;
  if (!feed.configure(pc, spo, false, error)) return false;
  CrnFeedObserver obs(feed);
  const audit::SimulatedRun run = audit::feedSimulated(sc, so, pc, &obs, nullptr, {});
  if (!run.ok) {
    *error = run.error;
    return false;
  }
  calib::RunOptions ro;
  ro.solve.estimate_acc_scale = opt.scale;
  ro.solve.estimate_time_offset = opt.time_offset;
  ro.thermal_fit = false;
  const calib::CalibrationRun cr = calib::runCalibration(feed, ro);
  out = cr.result;
  if (!cr.ok) {
    *error = cr.refusal_text;
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario;
  double duration = 21600;
  int runs = 10, passes = 3;
  double white_cross = 0, white_about = 0;
  unsigned long long seed0 = 1000;
  std::vector<std::string> effects, drop;
  bool correct_aberration = false, fov_mean_in_truth = false, crn = false;
  calib::RawBoundOptions opt;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--scenario" && has) scenario = argv[++i];
    else if (a == "--duration" && has) duration = std::atof(argv[++i]);
    else if (a == "--runs" && has) runs = std::atoi(argv[++i]);
    else if (a == "--seed" && has) seed0 = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--effect" && has) effects.push_back(argv[++i]);
    else if (a == "--drop" && has) drop.push_back(argv[++i]);
    else if (a == "--harmonics" && has) opt.harmonics = std::atoi(argv[++i]);
    else if (a == "--passes" && has) passes = std::atoi(argv[++i]);
    else if (a == "--scale") opt.scale = true;
    else if (a == "--time-offset") opt.time_offset = true;
    else if (a == "--correct-aberration") correct_aberration = true;
    else if (a == "--fov-mean-in-truth") fov_mean_in_truth = true;
    else if (a == "--no-vce") opt.variance_components = false;
    else if (a == "--fit-noise") opt.fit_noise = true;
    else if (a == "--no-slow-noise") opt.keep_slow_noise = false;
    else if (a == "--crn") crn = true;
    else if (a == "--score-block" && has) opt.score_block_s = std::atof(argv[++i]);
    else if (a == "--white-model" && has) {
      if (std::sscanf(argv[++i], "%lf,%lf", &white_cross, &white_about) != 2 || !(white_cross > 0) || !(white_about > 0)) return usage();
    }
    else return usage();
  }
  if (scenario.empty() || runs < 1 || !(duration > 0)) return usage();
  std::printf("raw_mc: %s, %.0f s, %d runs from seed %llu, passes %d%s%s, harmonics %d\n", scenario.c_str(), duration, runs,
              seed0, passes, opt.scale ? ", scale" : "", opt.time_offset ? ", time offset" : "", opt.harmonics);
  double sum_z2_truth = 0, sum_nees = 0, sum_ratio_sigma = 0, sum_nees_r = 0, sum_ratio_r = 0;
  int n_axes = 0, n_within3 = 0, n_runs = 0, dof_total = 0, n_within3_r = 0, dof_total_r = 0;
  bool have_robust = true;
  // --crn: the CRN solver's error on the same runs (squared sums in bound units and in rad^2), its NEES.
  double crn_z2 = 0, crn_e2 = 0, raw_e2 = 0, crn_nees = 0;
  int crn_axes = 0, crn_within3 = 0, crn_dof = 0, crn_refused = 0, crn_undetermined = 0;
  std::vector<double> crn_ratios;  // per solved run: its RMS error over the attitude domain's
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const unsigned long long seed = seed0 + static_cast<unsigned long long>(r);
    sim::Scenario sc;
    std::string err;
    if (!sim::loadScenario(scenario, sc, &err) || !sim::addEffectArgs(sc, effects, &err)) {
      std::fprintf(stderr, "raw_mc: %s\n", err.c_str());
      return 1;
    }
    for (const auto& name : drop)
      sc.effects.erase(std::remove_if(sc.effects.begin(), sc.effects.end(), [&](const model::EffectSpec& x) { return x.name == name; }),
                       sc.effects.end());
    sim::Simulator simu;
    if (!simu.init(sc, seed, duration, &err)) {
      std::fprintf(stderr, "raw_mc: %s\n", err.c_str());
      return 1;
    }
    if (opt.harmonics > 0) {
      Vec3 r_I, v_I;
      simu.orbit().posVel(toSeconds(sc.start), r_I, v_I);
      opt.orbit_rate_rad_s = r_I.cross(v_I).norm() / r_I.squaredNorm();
    }
    const calib::RawBoundConfig cfg = calib::rawBoundConfig(simu.heads(), simu.accel(), opt);
    calib::RawBoundConfig cfg_est = cfg;  // what the estimator is told
    if (white_cross > 0) {
      for (auto& h : cfg_est.heads)
        for (int j = 0; j < 3; ++j) h.noise[static_cast<std::size_t>(j)] = model::NoiseModel::white((j == 2 ? white_about : white_cross) * kRadPerArcsec);
      for (auto& m : cfg_est.acc_noise) m = model::NoiseModel::white(std::sqrt(m.whiteVariance()));
    }
    calib::RawBound bound(cfg);
    calib::RawBoundSimSink bs(bound, simu);
    calib::RawDataSimSink rec(simu, correct_aberration);
    sim::TeeSink tee;
    tee.add(&bs);
    tee.add(&rec);
    simu.run(tee);
    const calib::RawBoundResult at_truth = bound.result();
    const calib::RawEstimate est = calib::estimateRaw(cfg_est, rec.data, simu.accel().config().bias_rad_s2, passes);
    const std::size_t nh = simu.heads().size();
    Eigen::VectorXd e(static_cast<Eigen::Index>(3 * nh));
    double max_z = 0, z2 = 0;
    std::vector<double> delivered(nh, 0.0);
    std::vector<Vec3> truths(nh, Vec3::Zero());
    double e2_run = 0;  // this run's squared attitude-domain errors (rad^2), for --crn's ratio
    for (const auto& ev : rec.data.heads) delivered[static_cast<std::size_t>(ev.head)] += 1;
    for (std::size_t i = 0; i < nh; ++i) {
      Vec3 truth = calib::trueErrorInDatum(simu.heads()[i], simu.accel());
      // The delivered attitude is q Exp(f), f the field-of-view error (Si): a mounting shifted by -f.
      if (fov_mean_in_truth && delivered[i] > 0)
        truth -= simu.heads()[i].fromHeadAxes(simu.stats().head_fov_sum[i] / delivered[i]);
      truths[i] = truth;
      const Vec3 ei = cfg.heads[i].axes_Si * (est.mounting_rad[i] - truth);
      e2_run += ei.squaredNorm();
      for (int j = 0; j < 3; ++j) {
        const double s_truth = at_truth.head_sigma_rad[i](j), s_est = est.bound.head_sigma_rad[i](j);
        const double z = ei(j) / s_truth;
        e(static_cast<Eigen::Index>(3 * i) + j) = -ei(j);  // the estimator's head-axis parameter is -r
        sum_z2_truth += z * z;
        z2 += z * z;
        max_z = std::max(max_z, std::abs(ei(j) / s_est));
        n_within3 += std::abs(ei(j)) < 3 * s_est ? 1 : 0;
        sum_ratio_sigma += s_est / s_truth;
        if (!est.robust_head_sigma_rad.empty()) {
          const double s_r = est.robust_head_sigma_rad[i](j);
          n_within3_r += std::abs(ei(j)) < 3 * s_r ? 1 : 0;
          sum_ratio_r += s_r / s_truth;
        }
        ++n_axes;
      }
    }
    int dof = 0, dof_r = 0;
    const double nees = neesOn(est.bound.covariance, e, dof);
    double nees_r = 0;
    if (est.robust_covariance.size() > 0) {
      nees_r = neesOn(est.robust_covariance, e, dof_r);
      sum_nees_r += nees_r;
      dof_total_r += dof_r;
    } else {
      have_robust = false;
    }
    sum_nees += nees;
    dof_total += dof;
    ++n_runs;
    raw_e2 += e2_run;
    std::string crn_line;
    if (crn) {
      calib::SolveResult cr;
      if (!crnSolve(sc, seed, duration, cfg, opt, cr, &err)) {
        ++crn_refused;
        crn_line = ", CRN refused: " + err.substr(0, err.find('\n'));
      } else {
        // The solver's angles r (C_Sh_B = Exp(r) M_h) in the head frame: the same quantity as the truth.
        // Its covariance (arcsec^2, S_h frames, 3n x 3n row-major) once per run, for the sigmas along the
        // head axes (rows of axes_Si) and the NEES.
        const auto n3 = static_cast<Eigen::Index>(3 * nh);
        const bool have_cov = cr.covariance_arcsec2.size() == static_cast<std::size_t>(n3 * n3);
        const Eigen::MatrixXd C = have_cov ? Eigen::MatrixXd(Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
                                                 cr.covariance_arcsec2.data(), n3, n3))
                                           : Eigen::MatrixXd();
        Eigen::VectorXd ec(n3);
        double z2c = 0, e2c = 0;
        bool all = true;
        for (std::size_t i = 0; i < nh; ++i) {
          const auto i3 = static_cast<Eigen::Index>(3 * i);
          const Vec3 ei = cfg.heads[i].axes_Si * (cr.estimate.r_S[i] - truths[i]);
          ec.segment<3>(i3) = cr.estimate.r_S[i] - truths[i];
          // Undetermined where the solver says so about any S_h axis of that head.
          bool det = have_cov && i < cr.heads.size();
          for (std::size_t a = 0; det && a < 3; ++a) det = cr.heads[i].sigma_arcsec[a].has_value();
          if (!det) all = false;
          for (int j = 0; j < 3; ++j) {
            const double z = ei(j) / at_truth.head_sigma_rad[i](j);
            crn_z2 += z * z;
            z2c += z * z;
            crn_e2 += ei(j) * ei(j);
            e2c += ei(j) * ei(j);
            ++crn_axes;
            if (!det) continue;
            const Vec3 row = cfg.heads[i].axes_Si.row(j).transpose();
            const double sg = std::sqrt(std::max(0.0, row.dot(Mat3(C.block<3, 3>(i3, i3)) * row)));
            crn_within3 += std::abs(ei(j)) < 3 * sg * kRadPerArcsec ? 1 : 0;
          }
        }
        if (!all) ++crn_undetermined;
        if (std::getenv("RAW_MC_DEBUG"))
          for (std::size_t i = 0; i < nh && i < cr.heads.size(); ++i) {
            const Vec3 rc = cr.estimate.r_S[i] / kRadPerArcsec, t = truths[i] / kRadPerArcsec;
            std::printf("  CRN head %d: r %.1f %.1f %.1f\" truth %.1f %.1f %.1f\" sigma %.1f %.1f %.1f\"\n", cr.heads[i].id, rc(0), rc(1), rc(2),
                        t(0), t(1), t(2), cr.heads[i].sigma_arcsec[0].value_or(-1), cr.heads[i].sigma_arcsec[1].value_or(-1),
                        cr.heads[i].sigma_arcsec[2].value_or(-1));
          }
        // NEES under its covariance on its determined subspace.
        double nees_c = 0;
        int dof_c = 0;
        if (have_cov) {
          nees_c = neesOn(C, Eigen::VectorXd(ec / kRadPerArcsec), dof_c);
          crn_nees += nees_c;
          crn_dof += dof_c;
        }
        const double ratio = std::sqrt(e2c / std::max(e2_run, 1e-300));
        crn_ratios.push_back(ratio);
        char b[256];
        std::snprintf(b, sizeof b, "; CRN RMS error/bound %.2f, RMS error %.2f\" against %.2f\" (x%.1f), NEES %.1f (%d dof)",
                      std::sqrt(z2c / static_cast<double>(3 * nh)), std::sqrt(e2c / static_cast<double>(3 * nh)) / kRadPerArcsec,
                      std::sqrt(e2_run / static_cast<double>(3 * nh)) / kRadPerArcsec, ratio, nees_c, dof_c);
        crn_line = b;
      }
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r == 0 && !est.fitted_noise.empty()) {  // the first run's fitted models against the generator's
      for (std::size_t i = 0; i < nh; ++i)
        for (std::size_t j = 0; j < 3; ++j)
          std::printf("  head %d axis %zu: fitted %s; generator %s\n", cfg.heads[i].id, j + 1,
                      est.fitted_noise[i][j].describe(1 / kRadPerArcsec, "\"").c_str(), cfg.heads[i].noise[j].describe(1 / kRadPerArcsec, "\"").c_str());
    }
    std::string vf;
    for (std::size_t i = 0; i < nh; ++i)
      vf += (i ? " " : "") + std::to_string(est.variance_factor[i][0]).substr(0, 5) + "/" + std::to_string(est.variance_factor[i][1]).substr(0, 5);
    std::printf("seed %llu: RMS error/bound %.2f, max |error|/sigma %.2f, NEES %.1f (%d dof), NEES from score blocks %.1f (%d dof, "
                "%zu blocks), variance factors %s, chi2/obs %.3f, rejected %llu, bound %.2f-%.2f\"%s, %.1f s\n",
                seed, std::sqrt(z2 / static_cast<double>(3 * nh)), max_z, nees, dof, nees_r, dof_r, est.score_blocks, vf.c_str(),
                est.chi2_per_obs,
                static_cast<unsigned long long>(est.head_samples_rejected),
                at_truth.head_sigma_rad[0].minCoeff() / kRadPerArcsec, at_truth.head_sigma_rad[0].maxCoeff() / kRadPerArcsec,
                crn_line.c_str(), secs);
    std::fflush(stdout);
  }
  // 95 % bounds of chi2(k) / k by the Wilson-Hilferty approximation.
  const auto bounds = [](double k, double& lo, double& hi) {
    const double zq = 1.959964;
    lo = std::pow(1 - 2 / (9 * k) - zq * std::sqrt(2 / (9 * k)), 3);
    hi = std::pow(1 - 2 / (9 * k) + zq * std::sqrt(2 / (9 * k)), 3);
  };
  double lo = 0, hi = 0;
  bounds(dof_total, lo, hi);
  std::printf("%d runs, %d head axes: RMS error over the bound at the truth %.3f\n"
              "  model in use (after variance components): sigma over the bound %.3f, within 3 sigma %d of %d, NEES/dof %.3f "
              "(95 %% bounds %.3f-%.3f)\n",
              n_runs, n_axes, std::sqrt(sum_z2_truth / n_axes), sum_ratio_sigma / n_axes, n_within3, n_axes, sum_nees / dof_total, lo, hi);
  if (have_robust && dof_total_r > 0) {
    bounds(dof_total_r, lo, hi);
    std::printf("  score blocks (robust_covariance): sigma over the bound %.3f, within 3 sigma %d of %d, NEES/dof %.3f "
                "(95 %% bounds %.3f-%.3f)\n",
                sum_ratio_r / n_axes, n_within3_r, n_axes, sum_nees_r / dof_total_r, lo, hi);
  }
  if (crn) {
    std::printf("  CRN solver (--method crn) on the same runs: %d solved, %d refused, %d with a head axis not determined\n",
                n_runs - crn_refused, crn_refused, crn_undetermined);
    if (crn_axes > 0) {
      // The attitude domain's RMS error is over every run (the CRN solver's over the runs it solved).
      std::printf("  CRN: RMS error over the bound %.3f; RMS error %.2f\" against the attitude domain's %.2f\" (ratio %.1f%s); "
                  "within 3 of its sigmas %d of %d",
                  std::sqrt(crn_z2 / crn_axes), std::sqrt(crn_e2 / crn_axes) / kRadPerArcsec, std::sqrt(raw_e2 / n_axes) / kRadPerArcsec,
                  std::sqrt((crn_e2 / crn_axes) / (raw_e2 / n_axes)), crn_refused > 0 ? ", attitude domain over all runs" : "",
                  crn_within3, crn_axes);
      if (crn_dof > 0) {
        bounds(crn_dof, lo, hi);
        std::printf(", NEES/dof %.3f (95 %% bounds %.3f-%.3f)", crn_nees / crn_dof, lo, hi);
      }
      std::sort(crn_ratios.begin(), crn_ratios.end());
      std::printf("; the ratio per run %.1f-%.1f, median %.1f\n", crn_ratios.front(), crn_ratios.back(), crn_ratios[crn_ratios.size() / 2]);
    }
  }
  return 0;
}

// Monte Carlo of the method A solver on synthetic spans (synthetic.h): the cases of issue 8, their
// Cramer-Rao bounds, and the statistics the bench tool prints and the small ctest version checks.
//
// Per case: the CRLB at the truth (cramerRao() on the first run's span), injected errors of at least
// 5 times it, then `runs` runs with seeds seed0, seed0 + 1, ...: per head axis the bias and RMS of the
// error, RMS / CRLB, mean reported sigma / CRLB; the NEES of all head angles (e^T P^-1 e with the
// reported covariance) averaged over the runs, with its two-sided 95 % bounds (chi-square with
// runs x dim degrees of freedom, Wilson-Hilferty).
#pragma once

#include "synthetic.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace boresight::calib::mc {

struct Case {
  std::string name, what;
  synth::Config cfg;
  SolveOptions opt;
  bool scale_errors_to_crlb = true;  ///< injected head errors = pattern x 6 x CRLB (per axis)
  bool expect_refusal = false;       ///< the quiet case: solve() must refuse (too quiet)
  RelativeMode second_mode = RelativeMode::kHardConstraint;
  bool compare_modes = false;        ///< also solve in the other relative mode and compare
};

struct AxisStats {
  double crlb_arcsec = 0;
  double truth_arcsec = 0;
  double bias_arcsec = 0, rms_arcsec = 0;
  double mean_sigma_arcsec = 0;
  int determined = 0;                 ///< runs where the axis was reported determined
};

struct Result {
  std::string name;
  int runs = 0, failed = 0, refused = 0;
  std::uint64_t seed0 = 0;
  int n_heads = 0;
  std::vector<AxisStats> axes;        ///< 3 n_heads
  double nees_mean = 0, nees_lo = 0, nees_hi = 0;
  int nees_dim = 0, nees_runs = 0;
  // optional parameters: z = (estimate - truth) / sigma
  std::vector<double> z_tau, z_scale, z_nonorth;
  std::vector<double> tau_err, tau_sigma;
  double mode_diff_max_sigma = 0;     ///< max |hard - prior| / sigma over runs and axes
  double closure_arcsec_max = 0;
  int small_sigma_in_unobservable = 0;  ///< quiet / single axis: a small sigma reported along a null direction
  std::vector<Vec3> unobservable_first;  ///< directions reported in the first run
  double seconds_per_run = 0;
};

/// Chi-square quantile (Wilson-Hilferty), k degrees of freedom, standard normal quantile z.
inline double chi2Quantile(double k, double z) {
  const double a = 2.0 / (9.0 * k);
  const double c = 1.0 - a + z * std::sqrt(a);
  return k * c * c * c;
}

inline synth::Config baseConfig() {
  synth::Config c;
  c.q_S_B_nominal = synth::gracefoMountings();
  c.duration_s = 3900;
  c.manoeuvres = synth::threeAxisManoeuvres(150.0, 1200.0);
  c.truth.acc_bias = Vec3(1.31e-5, 1.19e-4, -7.81e-4);  // config/sim_gracefo.yaml
  return c;
}

/// The committed cases. `runs` is only used for the description.
inline std::vector<Case> cases() {
  std::vector<Case> v;
  {
    Case c;
    c.name = "manoeuvre_hard";
    c.what = "3 heads 2 Hz, acc 10 Hz, 3900 s with 1-deg 100-s manoeuvres about x, y, z; hard constraint, bias";
    c.cfg = baseConfig();
    v.push_back(c);
  }
  {
    Case c = v.back();
    c.name = "manoeuvre_prior";
    c.what = "as manoeuvre_hard, relative attitude as a prior; also solved hard on the same data (agreement)";
    c.opt.relative = RelativeMode::kPrior;
    c.compare_modes = true;
    v.push_back(c);
  }
  {
    Case c = v.front();
    c.name = "manoeuvre_crn005";
    c.what = "as manoeuvre_hard with the calibration CRN of SpanOptions: B 0.05 Hz, Tf 100 s, decimation 20 s";
    c.cfg.crn_bandwidth_hz = 0.05;
    c.cfg.crn_length_s = 100.0;
    c.cfg.decimation_s = 20.0;
    v.push_back(c);
  }
  {
    Case c = v.front();
    c.name = "manoeuvre_moments";
    c.what = "as manoeuvre_hard solved from the sufficient statistics (constant memory, no robust loss)";
    c.opt.from_moments = true;
    v.push_back(c);
  }
  {
    Case c = v.front();
    c.name = "manoeuvre_no_whitening";
    c.what = "as manoeuvre_hard but epochs treated as independent (no temporal whitening): optimistic";
    c.opt.whiten = false;
    v.push_back(c);
  }
  {
    Case c;
    c.name = "offset_scale";
    c.what = "as manoeuvre_hard with a hidden time offset (0.1-0.5 s over the runs), accelerometer scale "
             "(2e-3, -1e-3, 5e-4) and non-orthogonality (200, -300, 150)\", all estimated";
    c.cfg = baseConfig();
    c.cfg.truth.acc_scale = Vec3(2e-3, -1e-3, 5e-4);
    c.cfg.truth.acc_nonorth = Vec3(200, -300, 150) * kRadPerArcsec;
    c.opt.estimate_acc_nonorthogonality = true;
    c.cfg.truth.time_offset_s = 0.3;
    c.opt.estimate_acc_scale = true;
    c.opt.estimate_time_offset = true;
    v.push_back(c);
  }
  {
    Case c;
    c.name = "single_axis";
    c.what = "one manoeuvre about x_B only: the rotation about x_B must be reported not observable";
    c.cfg = baseConfig();
    c.cfg.duration_s = 1300;
    c.cfg.manoeuvres.resize(1);
    c.scale_errors_to_crlb = false;
    for (int h = 0; h < 3; ++h) c.cfg.truth.r_S[static_cast<std::size_t>(h)] = Vec3(1500, -1000, 2000) * kRadPerArcsec;
    v.push_back(c);
  }
  {
    Case c;
    c.name = "quiet";
    c.what = "1 h without manoeuvres (orbital rate only): refused as too quiet, every direction not observable";
    c.cfg = baseConfig();
    c.cfg.manoeuvres.clear();
    c.cfg.duration_s = 3600;
    c.scale_errors_to_crlb = false;
    c.expect_refusal = true;
    for (int h = 0; h < 3; ++h) c.cfg.truth.r_S[static_cast<std::size_t>(h)] = Vec3(300, -200, 500) * kRadPerArcsec;
    v.push_back(c);
  }
  return v;
}

/// The committed case of that name (an empty name when there is none).
inline Case caseNamed(const std::string& name) {
  for (const Case& c : cases())
    if (c.name == name) return c;
  return {};
}

inline CalibrationSpan makeSpan(const synth::Config& c) {
  SpanBuilder b;
  std::string err;
  if (!synth::generate(c, b, &err)) return {};
  return b.span();
}

/// Injected error pattern: signs and sizes differ per head and axis, |pattern| in [1, 1.6].
inline double pattern(int h, int i) {
  static const double p[4][3] = {{1.0, -1.3, 1.6}, {-1.5, 1.2, -1.0}, {1.1, 1.4, -1.2}, {-1.0, -1.0, 1.0}};
  return p[h][i];
}

/// The CRLB of a case at its truth (first seed), arcsec per head axis; sets c.cfg.truth.r_S to 6x it
/// when the case scales its errors.
inline std::vector<double> prepareCase(Case& c, std::uint64_t seed0) {
  c.cfg.seed = seed0;
  if (c.scale_errors_to_crlb) {
    // CRLB at zero errors first (it barely depends on the errors), then errors of 6x (>= 5x) it
    synth::Config z = c.cfg;
    for (auto& r : z.truth.r_S) r = Vec3::Zero();
    const HeadCovariance b = cramerRao(makeSpan(z), c.opt, z.truth);
    for (int h = 0; h < c.cfg.n_heads; ++h)
      for (int i = 0; i < 3; ++i) {
        const int k = 3 * h + i;
        const double s = b.P.size() ? std::sqrt(b.P(k, k)) : 0.0;
        c.cfg.truth.r_S[static_cast<std::size_t>(h)][i] = pattern(h, i) * 6.0 * (std::isfinite(s) ? s : 0.0);
      }
  }
  const HeadCovariance b = cramerRao(makeSpan(c.cfg), c.opt, c.cfg.truth);
  std::vector<double> out;
  for (int k = 0; k < 3 * c.cfg.n_heads; ++k)
    out.push_back(b.P.size() && b.determined[static_cast<std::size_t>(k)] ? std::sqrt(b.P(k, k)) * kArcsecPerRad
                                                                            : std::numeric_limits<double>::infinity());
  return out;
}

inline Result run(Case c, int runs, std::uint64_t seed0, const std::function<void(int)>& progress = {}) {
  Result R;
  R.name = c.name;
  R.runs = runs;
  R.seed0 = seed0;
  R.n_heads = c.cfg.n_heads;
  const std::vector<double> crlb = prepareCase(c, seed0);
  const int n3 = 3 * c.cfg.n_heads;
  R.axes.resize(static_cast<std::size_t>(n3));
  for (int k = 0; k < n3; ++k) {
    R.axes[static_cast<std::size_t>(k)].crlb_arcsec = crlb[static_cast<std::size_t>(k)];
    R.axes[static_cast<std::size_t>(k)].truth_arcsec = c.cfg.truth.r_S[static_cast<std::size_t>(k / 3)][k % 3] * kArcsecPerRad;
  }
  std::vector<double> sum(static_cast<std::size_t>(n3), 0), sum2(static_cast<std::size_t>(n3), 0),
      sumsig(static_cast<std::size_t>(n3), 0);
  std::vector<int> nsum(static_cast<std::size_t>(n3), 0);
  double nees_sum = 0;
  const auto t_start = std::chrono::steady_clock::now();
  for (int r = 0; r < runs; ++r) {
    if (progress) progress(r);
    synth::Config cfg = c.cfg;
    cfg.seed = seed0 + static_cast<std::uint64_t>(r);
    if (c.opt.estimate_time_offset) cfg.truth.time_offset_s = 0.1 + 0.4 * (static_cast<double>(r % 9) / 8.0);
    const CalibrationSpan span = makeSpan(cfg);
    const SolveResult s = solve(span, c.opt);
    if (!s.ok) {
      ++R.refused;
      if (r == 0) R.unobservable_first = s.unobservable_directions_B;
      if (!c.expect_refusal) ++R.failed;
      // a refusal must never come with a small sigma
      for (const HeadResult& h : s.heads)
        for (const auto& sg : h.sigma_arcsec)
          if (sg && *sg < c.opt.unobservable_sigma_arcsec) ++R.small_sigma_in_unobservable;
      continue;
    }
    if (c.expect_refusal) ++R.failed;
    if (r == 0) R.unobservable_first = s.unobservable_directions_B;
    // errors and NEES over the determined axes
    std::vector<int> det;
    Eigen::VectorXd e(n3);
    for (int k = 0; k < n3; ++k) {
      const HeadResult& h = s.heads[static_cast<std::size_t>(k / 3)];
      const double err = h.error_angles_arcsec[static_cast<std::size_t>(k % 3)] - R.axes[static_cast<std::size_t>(k)].truth_arcsec;
      e[k] = err;
      if (!h.observable[static_cast<std::size_t>(k % 3)]) continue;
      det.push_back(k);
      sum[static_cast<std::size_t>(k)] += err;
      sum2[static_cast<std::size_t>(k)] += err * err;
      sumsig[static_cast<std::size_t>(k)] += *h.sigma_arcsec[static_cast<std::size_t>(k % 3)];
      ++nsum[static_cast<std::size_t>(k)];
      ++R.axes[static_cast<std::size_t>(k)].determined;
    }
    // along a reported-unobservable direction no head axis may have a small sigma
    for (const Vec3& u : s.unobservable_directions_B)
      for (int h = 0; h < c.cfg.n_heads; ++h) {
        const Vec3 uS = c.cfg.q_S_B_nominal[static_cast<std::size_t>(h)].toRotationMatrix() * u;
        for (int i = 0; i < 3; ++i)
          if (std::abs(uS[i]) > 0.3 && s.heads[static_cast<std::size_t>(h)].observable[static_cast<std::size_t>(i)])
            ++R.small_sigma_in_unobservable;
      }
    if (!det.empty()) {
      Eigen::MatrixXd P(det.size(), det.size());
      Eigen::VectorXd ed(det.size());
      for (std::size_t a = 0; a < det.size(); ++a) {
        ed[static_cast<Eigen::Index>(a)] = e[det[a]];
        for (std::size_t b = 0; b < det.size(); ++b)
          P(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) =
              s.covariance_arcsec2[static_cast<std::size_t>(det[a] * n3 + det[b])];
      }
      nees_sum += ed.dot(P.ldlt().solve(ed));
      R.nees_dim = static_cast<int>(det.size());
      ++R.nees_runs;
    }
    if (c.opt.estimate_time_offset && s.time_offset_s && s.time_offset_sigma_s) {
      R.tau_err.push_back(*s.time_offset_s - cfg.truth.time_offset_s);
      R.tau_sigma.push_back(*s.time_offset_sigma_s);
      R.z_tau.push_back((*s.time_offset_s - cfg.truth.time_offset_s) / *s.time_offset_sigma_s);
    }
    if (c.opt.estimate_acc_scale && s.acc_scale)
      for (int i = 0; i < 3; ++i)
        if (s.acc_scale->sigma[static_cast<std::size_t>(i)])
          R.z_scale.push_back((s.acc_scale->value[static_cast<std::size_t>(i)] - cfg.truth.acc_scale[i]) /
                              *s.acc_scale->sigma[static_cast<std::size_t>(i)]);
    if (c.opt.estimate_acc_nonorthogonality && s.acc_nonorthogonality_arcsec)
      for (int i = 0; i < 3; ++i)
        if (s.acc_nonorthogonality_arcsec->sigma[static_cast<std::size_t>(i)])
          R.z_nonorth.push_back((s.acc_nonorthogonality_arcsec->value[static_cast<std::size_t>(i)] -
                                 cfg.truth.acc_nonorth[i] * kArcsecPerRad) /
                                *s.acc_nonorthogonality_arcsec->sigma[static_cast<std::size_t>(i)]);
    R.closure_arcsec_max = std::max(R.closure_arcsec_max, s.closure_arcsec);
    if (c.compare_modes) {
      SolveOptions o2 = c.opt;
      o2.relative = c.opt.relative == RelativeMode::kPrior ? RelativeMode::kHardConstraint : RelativeMode::kPrior;
      const SolveResult s2 = solve(span, o2);
      if (s2.ok)
        for (int k = 0; k < n3; ++k) {
          const HeadResult& a = s.heads[static_cast<std::size_t>(k / 3)];
          const HeadResult& b = s2.heads[static_cast<std::size_t>(k / 3)];
          if (!a.sigma_arcsec[static_cast<std::size_t>(k % 3)]) continue;
          R.mode_diff_max_sigma =
              std::max(R.mode_diff_max_sigma, std::abs(a.error_angles_arcsec[static_cast<std::size_t>(k % 3)] -
                                                       b.error_angles_arcsec[static_cast<std::size_t>(k % 3)]) /
                                                  *a.sigma_arcsec[static_cast<std::size_t>(k % 3)]);
        }
      else
        ++R.failed;
    }
  }
  R.seconds_per_run =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() / std::max(runs, 1);
  for (int k = 0; k < n3; ++k) {
    AxisStats& a = R.axes[static_cast<std::size_t>(k)];
    const int n = nsum[static_cast<std::size_t>(k)];
    if (n == 0) continue;
    a.bias_arcsec = sum[static_cast<std::size_t>(k)] / n;
    a.rms_arcsec = std::sqrt(sum2[static_cast<std::size_t>(k)] / n);
    a.mean_sigma_arcsec = sumsig[static_cast<std::size_t>(k)] / n;
  }
  if (R.nees_runs > 0) {
    R.nees_mean = nees_sum / R.nees_runs;
    const double dof = static_cast<double>(R.nees_runs) * R.nees_dim;
    R.nees_lo = chi2Quantile(dof, -1.959964) / R.nees_runs;
    R.nees_hi = chi2Quantile(dof, 1.959964) / R.nees_runs;
  }
  return R;
}

inline void print(const Case& c, const Result& R, std::FILE* f = stdout) {
  std::fprintf(f, "\n== %s: %s\n", R.name.c_str(), c.what.c_str());
  std::fprintf(f, "   runs %d (seeds %llu..%llu), failed %d, refused %d, %.3f s per run\n", R.runs,
               static_cast<unsigned long long>(R.seed0), static_cast<unsigned long long>(R.seed0 + R.runs - 1), R.failed,
               R.refused, R.seconds_per_run);
  std::fprintf(f, "   head axis | CRLB\"   | truth\"   | bias\"   | RMS\"    | RMS/CRLB | sigma/CRLB | determined\n");
  for (std::size_t k = 0; k < R.axes.size(); ++k) {
    const AxisStats& a = R.axes[k];
    std::fprintf(f, "   %4zu  %c   | %7.1f | %8.1f | %7.1f | %7.1f | %8.3f | %10.3f | %d/%d\n", k / 3 + 1, "xyz"[k % 3],
                 a.crlb_arcsec, a.truth_arcsec, a.bias_arcsec, a.rms_arcsec,
                 a.determined ? a.rms_arcsec / a.crlb_arcsec : 0.0, a.determined ? a.mean_sigma_arcsec / a.crlb_arcsec : 0.0,
                 a.determined, R.runs);
  }
  if (R.nees_runs > 0)
    std::fprintf(f, "   NEES (dim %d, %d runs): mean %.3f, 95%% bounds [%.3f, %.3f] -> %s\n", R.nees_dim, R.nees_runs,
                 R.nees_mean, R.nees_lo, R.nees_hi, R.nees_mean >= R.nees_lo && R.nees_mean <= R.nees_hi ? "inside" : "OUTSIDE");
  auto zline = [&](const char* name, const std::vector<double>& z) {
    if (z.empty()) return;
    double s2 = 0, mx = 0;
    int in3 = 0;
    for (double x : z) {
      s2 += x * x;
      mx = std::max(mx, std::abs(x));
      in3 += std::abs(x) <= 3.0 ? 1 : 0;
    }
    std::fprintf(f, "   %s: z = (estimate - truth)/sigma over %zu: RMS %.3f, max |z| %.2f, within 3 sigma %d/%zu\n", name,
                 z.size(), std::sqrt(s2 / static_cast<double>(z.size())), mx, in3, z.size());
  };
  zline("time offset", R.z_tau);
  zline("acc scale", R.z_scale);
  zline("acc non-orthogonality", R.z_nonorth);
  if (!R.tau_sigma.empty()) {
    double ms = 0;
    for (double s : R.tau_sigma) ms += s;
    std::fprintf(f, "   time offset sigma (mean) %.4f s\n", ms / static_cast<double>(R.tau_sigma.size()));
  }
  if (c.compare_modes) std::fprintf(f, "   hard vs prior on the same data: max |difference| %.3f sigma\n", R.mode_diff_max_sigma);
  if (R.closure_arcsec_max > 0) std::fprintf(f, "   closure of the three pair means: max %.4f\"\n", R.closure_arcsec_max);
  std::fprintf(f, "   unobservable directions (B) reported in the first run: %zu", R.unobservable_first.size());
  for (const Vec3& u : R.unobservable_first) std::fprintf(f, " (%.3f %.3f %.3f)", u.x(), u.y(), u.z());
  std::fprintf(f, "\n   small sigma along an unobservable direction: %d\n", R.small_sigma_in_unobservable);
}

}  // namespace boresight::calib::mc

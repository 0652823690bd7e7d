// Method A window after window, and the windows combined (include/boresight/calib/windows.h).
#include "boresight/calib/windows.h"

#include "boresight/model/stats.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace boresight::calib {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The pseudo-inverse of a symmetric positive semi-definite matrix (eigenvalues below rel x the largest
/// taken as zero), and its rank.
Eigen::MatrixXd pinvSym(const Eigen::MatrixXd& m, int* rank, double rel = 1e-12) {
  *rank = 0;
  if (m.rows() == 0) return m;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (m + m.transpose()));
  const Eigen::VectorXd& l = es.eigenvalues();
  const double top = l.maxCoeff();
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(l.size());
  if (top > 0)
    for (Eigen::Index i = 0; i < l.size(); ++i)
      if (l(i) > rel * top) {
        inv(i) = 1.0 / l(i);
        ++*rank;
      }
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}

/// 2000-01-01 00:00:00 GPS on the TimeUs axis (the GRACE epoch is noon): windows count from there.
constexpr TimeUs kMidnight = -43200 * kUsPerSecond;

}  // namespace

double randomEffectsTau(const std::vector<double>& x, const std::vector<double>& s, double q) {
  const std::size_t n = x.size();
  if (n < 2 || s.size() != n) return kNaN;
  const auto Q = [&](double tau2) {
    double sw = 0, swx = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = 1.0 / (s[i] * s[i] + tau2);
      sw += w;
      swx += w * x[i];
    }
    const double m = swx / sw;
    double r = 0;
    for (std::size_t i = 0; i < n; ++i) r += (x[i] - m) * (x[i] - m) / (s[i] * s[i] + tau2);
    return r;
  };
  if (Q(0.0) <= q) return 0.0;
  // Q falls monotonically in tau^2: bracket, then bisect.
  double spread = 0, mean = 0;
  for (double v : x) mean += v / static_cast<double>(n);
  for (double v : x) spread += (v - mean) * (v - mean);
  double lo = 0, hi = std::max(spread, 1e-300);
  for (int i = 0; i < 200 && Q(hi) > q; ++i) hi *= 4;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (Q(mid) > q ? lo : hi) = mid;
    if (hi - lo <= 1e-12 * hi) break;
  }
  return std::sqrt(0.5 * (lo + hi));
}

Eigen::MatrixXd mountingInformation(const RawEstimate& est, const RawBoundConfig& cfg) {
  const std::size_t n = cfg.heads.size();
  const auto n3 = static_cast<Eigen::Index>(3 * n);
  const Eigen::MatrixXd& I = est.bound.information;
  if (I.rows() < n3) return {};
  // The other parameters out: I_mm - I_mo I_oo^+ I_om (a parameter the span does not determine - a time
  // offset without angular jerk - has no information to lend).
  Eigen::MatrixXd M = I.topLeftCorner(n3, n3);
  const Eigen::Index no = I.rows() - n3;
  if (no > 0) {
    int rank = 0;
    const Eigen::MatrixXd Ioo_inv = pinvSym(I.bottomRightCorner(no, no), &rank);
    M -= I.topRightCorner(n3, no) * Ioo_inv * I.bottomLeftCorner(no, n3);
  }
  // A body direction u the estimate held at its nominal value (too little information about the common
  // rotation about it) fixed c_u = (R_1 u)^T e_1, head 1's error about u, and moved every other angle
  // with it along v = C n (n that functional, C = M^+: the regression of the angles on c_u). The held
  // angles are therefore the data's estimate only modulo v: the information along v goes
  // (M - M v v^T M / v^T M v), so that a window's held value never counts in a combination.
  for (const Vec3& u : est.bound.unobservable_B) {
    Eigen::VectorXd nf = Eigen::VectorXd::Zero(n3);
    nf.head<3>() = cfg.heads[0].R_axes_B * u;
    int rank = 0;
    const Eigen::VectorXd v = pinvSym(M, &rank) * nf;
    const Eigen::VectorXd Mv = M * v;
    const double q = v.dot(Mv);
    if (q > 0 && std::isfinite(q)) M -= Mv * Mv.transpose() / q;
  }
  // Head axes -> Si, per head (orthogonal: information transforms as the covariance).
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n3, n3);
  for (std::size_t i = 0; i < n; ++i)
    T.block<3, 3>(static_cast<Eigen::Index>(3 * i), static_cast<Eigen::Index>(3 * i)) = cfg.heads[i].axes_Si.transpose();
  Eigen::MatrixXd out = T * M * T.transpose();
  return 0.5 * (out + out.transpose());
}

JointMountings combineWindows(const std::vector<WindowSolution>& windows, std::size_t n_heads, double not_determined_rad) {
  JointMountings j;
  const auto n3 = static_cast<Eigen::Index>(3 * n_heads);
  Eigen::MatrixXd I = Eigen::MatrixXd::Zero(n3, n3);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(n3);
  struct Used {
    Eigen::VectorXd r;
    Eigen::MatrixXd info, cov;  ///< the window's information and its pseudo-inverse
    std::vector<bool> det;      ///< axes the window alone determines
  };
  std::vector<Used> used;
  double rank_sum = 0;
  // Axes that the null space of a (pseudo-inverted) information touches: not determined by it.
  const auto determinedAxes = [&](const Eigen::MatrixXd& info, std::vector<bool>& det) {
    det.assign(static_cast<std::size_t>(info.rows()), false);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(info);
    const double top = es.eigenvalues().maxCoeff();
    if (!(top > 0)) return;
    for (Eigen::Index k = 0; k < info.rows(); ++k) {
      double touch = 0;
      for (Eigen::Index e = 0; e < info.rows(); ++e)
        if (!(es.eigenvalues()(e) > 1e-12 * top)) touch = std::max(touch, std::abs(es.eigenvectors()(k, e)));
      det[static_cast<std::size_t>(k)] = touch < 1e-6 && info(k, k) > 0;
    }
  };
  for (const WindowSolution& w : windows) {
    if (!w.estimated || w.mountings.r_Si.size() != n_heads) continue;
    Used u;
    u.r.resize(n3);
    for (Eigen::Index k = 0; k < n3; ++k) u.r(k) = w.mountings.r_Si[static_cast<std::size_t>(k / 3)](k % 3);
    if (w.information_Si.rows() == n3) {
      u.info = w.information_Si;
    } else if (w.mountings.covariance_Si.rows() == n3) {
      // From the covariance: its pseudo-inverse on the axes the window reports determined.
      std::vector<Eigen::Index> idx;
      for (Eigen::Index k = 0; k < n3; ++k)
        if (std::isfinite(w.mountings.sigma_Si[static_cast<std::size_t>(k / 3)](k % 3))) idx.push_back(k);
      const auto m = static_cast<Eigen::Index>(idx.size());
      Eigen::MatrixXd Cd(m, m);
      for (Eigen::Index a = 0; a < m; ++a)
        for (Eigen::Index c = 0; c < m; ++c) Cd(a, c) = w.mountings.covariance_Si(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(c)]);
      int rank = 0;
      const Eigen::MatrixXd Id = pinvSym(Cd, &rank);
      u.info = Eigen::MatrixXd::Zero(n3, n3);
      for (Eigen::Index a = 0; a < m; ++a)
        for (Eigen::Index c = 0; c < m; ++c) u.info(idx[static_cast<std::size_t>(a)], idx[static_cast<std::size_t>(c)]) = Id(a, c);
    } else {
      continue;
    }
    int rank = 0;
    u.cov = pinvSym(u.info, &rank);
    if (rank == 0) continue;
    determinedAxes(u.info, u.det);
    I += u.info;
    b += u.info * u.r;
    rank_sum += rank;
    used.push_back(std::move(u));
  }
  j.windows = used.size();
  j.r_Si.assign(n_heads, Vec3::Zero());
  j.sigma_Si.assign(n_heads, Vec3::Constant(kNaN));
  for (auto* v : {&j.axis_chi2_per_dof, &j.tau, &j.tau_lo, &j.tau_hi, &j.sigma_with_tau, &j.r_with_tau})
    v->assign(n_heads, Vec3::Constant(kNaN));
  j.axis_windows.assign(n_heads, Vec3::Zero());
  j.sigma_written.assign(n_heads, Vec3::Constant(kNaN));
  j.covariance_Si = Eigen::MatrixXd::Zero(n3, n3);
  if (used.empty()) return j;
  int rank_j = 0;
  const Eigen::MatrixXd C = pinvSym(I, &rank_j);
  const Eigen::VectorXd r = C * b;
  j.covariance_Si = C;
  std::vector<bool> det_j;
  determinedAxes(I, det_j);
  for (Eigen::Index k = 0; k < n3; ++k) {
    const auto h = static_cast<std::size_t>(k / 3);
    j.r_Si[h](k % 3) = r(k);
    const double s = std::sqrt(std::max(0.0, C(k, k)));
    if (det_j[static_cast<std::size_t>(k)] && s > 0 && s < not_determined_rad) j.sigma_Si[h](k % 3) = s;
  }
  for (const Used& u : used) {
    const Eigen::VectorXd d = u.r - r;
    j.chi2 += d.dot(u.info * d);
  }
  j.dof = rank_sum - rank_j;
  // Per head axis: the windows' scatter, and the spread beyond their sigmas.
  for (Eigen::Index k = 0; k < n3; ++k) {
    const auto h = static_cast<std::size_t>(k / 3);
    const int a = static_cast<int>(k % 3);
    if (!std::isfinite(j.sigma_Si[h](a))) continue;
    std::vector<double> x, s;
    for (const Used& u : used) {
      if (!u.det[static_cast<std::size_t>(k)]) continue;
      x.push_back(u.r(k));
      s.push_back(std::sqrt(std::max(0.0, u.cov(k, k))));
    }
    j.axis_windows[h](a) = static_cast<double>(x.size());
    if (x.size() < 2) continue;
    // Cochran's Q: the windows about their weighted mean on this axis, over their own variances;
    // chi-square with windows - 1 degrees of freedom when the sigmas explain the scatter.
    double sw = 0, swx = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      sw += 1.0 / (s[i] * s[i]);
      swx += x[i] / (s[i] * s[i]);
    }
    double q = 0;
    for (std::size_t i = 0; i < x.size(); ++i) q += std::pow(x[i] - swx / sw, 2) / (s[i] * s[i]);
    const double df = static_cast<double>(x.size() - 1);
    j.axis_chi2_per_dof[h](a) = q / df;
    const double tau = randomEffectsTau(x, s, df);
    j.tau[h](a) = tau;
    // The Q-profile interval: the tau at which the weighted scatter equals the chi-square quantiles.
    j.tau_lo[h](a) = randomEffectsTau(x, s, model::stats::chi2Quantile(0.025, df));
    j.tau_hi[h](a) = randomEffectsTau(x, s, model::stats::chi2Quantile(0.975, df));
    sw = swx = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double w = 1.0 / (s[i] * s[i] + tau * tau);
      sw += w;
      swx += w * x[i];
    }
    j.r_with_tau[h](a) = swx / sw;
    j.sigma_with_tau[h](a) = 1.0 / std::sqrt(sw);
  }
  for (std::size_t h = 0; h < n_heads; ++h)
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(j.sigma_Si[h](a)))
        j.sigma_written[h](a) = std::isfinite(j.sigma_with_tau[h](a)) ? std::max(j.sigma_Si[h](a), j.sigma_with_tau[h](a)) : j.sigma_Si[h](a);
  return j;
}

BetaModulation fitBetaModulation(const std::vector<WindowSolution>& windows, double min_range_rad) {
  BetaModulation m;
  // The windows with harmonics and a beta, and the terms the first of them has.
  std::vector<const WindowSolution*> ws;
  for (const WindowSolution& w : windows)
    if (w.estimated && w.beta_rad && !w.harmonics.empty()) ws.push_back(&w);
  m.windows = ws.size();
  if (ws.size() < 3) {
    m.note = "fewer than 3 windows with orbit harmonics and a beta angle (" + std::to_string(ws.size()) + ")";
    return m;
  }
  m.beta_min_rad = m.beta_max_rad = *ws.front()->beta_rad;
  for (const auto* w : ws) {
    m.beta_min_rad = std::min(m.beta_min_rad, *w->beta_rad);
    m.beta_max_rad = std::max(m.beta_max_rad, *w->beta_rad);
  }
  if (m.beta_max_rad - m.beta_min_rad < min_range_rad) {
    char b[160];
    std::snprintf(b, sizeof b, "beta moved %.2f deg over the windows (%.0f deg needed, about 1 deg a day: weeks of data)",
                  (m.beta_max_rad - m.beta_min_rad) / kRadPerDeg, min_range_rad / kRadPerDeg);
    m.note = b;
    return m;
  }
  m.determined = true;
  for (const auto* w : ws) m.cos_ref += std::cos(*w->beta_rad) / static_cast<double>(ws.size());
  {
    double tm = 0, stt = 0, scc = 0, stc = 0;
    for (const auto* w : ws) tm += toSeconds(w->from) / static_cast<double>(ws.size());
    for (const auto* w : ws) {
      const double dt = toSeconds(w->from) - tm, dc = std::cos(*w->beta_rad) - m.cos_ref;
      stt += dt * dt;
      scc += dc * dc;
      stc += dt * dc;
    }
    m.time_correlation = stt > 0 && scc > 0 ? stc / std::sqrt(stt * scc) : 0.0;
    if (std::abs(m.time_correlation) > 0.9) {
      char b[200];
      std::snprintf(b, sizeof b,
                    "cos beta follows time over these windows (correlation %.2f): a drift of the harmonics over the record "
                    "cannot be told from a beta modulation",
                    m.time_correlation);
      m.caution = b;
    }
  }
  for (const OrbitHarmonicTerm& t0 : ws.front()->harmonics)
    for (int c = 0; c < 2; ++c) {
      BetaModulation::Component comp;
      comp.head = t0.head;
      comp.harmonic = t0.harmonic;
      comp.sine = c == 1;
      for (int a = 0; a < 3; ++a) {
        std::vector<double> x, y, s;
        for (const auto* w : ws)
          for (const OrbitHarmonicTerm& t : w->harmonics)
            if (t.head == t0.head && t.harmonic == t0.harmonic) {
              const double sg = std::sqrt(std::max(0.0, (c == 0 ? t.cov_cos_Si : t.cov_sin_Si)(a, a)));
              if (!(sg > 0)) continue;
              x.push_back(std::cos(*w->beta_rad));
              y.push_back((c == 0 ? t.cos_Si : t.sin_Si)(a));
              s.push_back(sg);
            }
        if (x.size() < 3) continue;
        // Weighted line y = a + b (x - cos_ref), by its 2x2 normal equations.
        double n00 = 0, n01 = 0, n11 = 0, r0 = 0, r1 = 0;
        for (std::size_t i = 0; i < x.size(); ++i) {
          const double w = 1 / (s[i] * s[i]), dx = x[i] - m.cos_ref;
          n00 += w;
          n01 += w * dx;
          n11 += w * dx * dx;
          r0 += w * y[i];
          r1 += w * dx * y[i];
        }
        const double det = n00 * n11 - n01 * n01;
        if (!(det > 0)) continue;
        const double av = (n11 * r0 - n01 * r1) / det, bv = (n00 * r1 - n01 * r0) / det;
        double chi2 = 0;
        for (std::size_t i = 0; i < x.size(); ++i) chi2 += std::pow((y[i] - av - bv * (x[i] - m.cos_ref)) / s[i], 2);
        const double cpd = chi2 / static_cast<double>(x.size() - 2);
        const double f = std::sqrt(std::max(1.0, cpd));
        comp.a(a) = av;
        comp.b(a) = bv;
        comp.sigma_a(a) = f * std::sqrt(n11 / det);
        comp.sigma_b(a) = f * std::sqrt(n00 / det);
        comp.chi2_per_dof(a) = cpd;
      }
      m.terms.push_back(comp);
    }
  return m;
}

// ------------------------------------------------------------------------------------------------
std::pair<TimeUs, TimeUs> WindowedCalibration::windowOf(TimeUs t, double window_s) {
  const auto w = static_cast<TimeUs>(std::llround(window_s * 1e6));
  const TimeUs d = t - kMidnight;
  const TimeUs k = d >= 0 ? d / w : -((-d + w - 1) / w);
  return {kMidnight + k * w, kMidnight + (k + 1) * w};
}

bool WindowedCalibration::configure(const core::PipelineConfig& cfg, const SpanOptions& so, double window_s, const RunOptions& run,
                                    double not_determined_rad, std::string* error, unsigned concurrent) {
  while (collect(true)) {
  }
  windows_.clear();
  concurrent_ = std::max(1u, concurrent);
  beta_.clear();
  late_ = 0;
  open_ = finished_ = false;
  peak_raw_ = 0;
  if (!(window_s >= 1.0) || !std::isfinite(window_s)) {
    if (error) *error = "the window must be at least 1 s";
    return false;
  }
  if (!run.raw) {
    if (error) *error = "windows need the attitude-domain estimate's configuration";
    return false;
  }
  window_s_ = window_s;
  not_determined_rad_ = not_determined_rad;
  run_ = run;
  run_.thermal_fit = false;  // the thermal harmonic fit belongs to a whole record, not to its windows
  return feed_.configure(cfg, so, false, error, true, false);  // the raw samples alone: no CRN rows
}

void WindowedCalibration::advance(TimeUs t) {
  if (open_ && t < to_) return;
  const auto [from, to] = windowOf(t, window_s_);
  if (open_) close(from - 120 * kUsPerSecond);  // the orbit segment across the new window's start kept
  from_ = from;
  to_ = to;
  open_ = true;
  head_epochs_ = acc_samples_ = 0;
}

void WindowedCalibration::pushHeads(const core::HeadEpoch& e) {
  if (finished_) return;
  if (open_ && e.t < from_) {  // a window already estimated: not taken, counted
    ++late_;
    return;
  }
  advance(e.t);
  if (head_epochs_ == 0) first_ = e.t;
  last_ = e.t;
  ++head_epochs_;
  feed_.pushHeads(e);
}

void WindowedCalibration::pushAcc(TimeUs t, const Vec3& a_A) {
  if (finished_) return;
  if (open_ && t < from_) {
    ++late_;
    return;
  }
  advance(t);
  ++acc_samples_;
  feed_.pushAcc(t, a_A);
}

void WindowedCalibration::pushOrbit(const model::OrbitSample& o) {
  if (finished_) return;
  feed_.pushOrbit(o);  // the orbit does not open a window; it may run ahead of the heads
  const TimeUs start = windowOf(o.t, window_s_).first;
  auto it = std::find_if(beta_.begin(), beta_.end(), [start](const auto& e) { return e.first == start; });
  if (it == beta_.end()) it = beta_.insert(beta_.end(), {start, {0.0, 0}});
  it->second.first += o.beta_rad;
  ++it->second.second;
}

namespace {

/// One window's estimate (w holds the window's times and counts; the feed its data).
WindowSolution estimateWindow(CalibrationFeed& feed, WindowSolution w, const RunOptions& ro, double not_determined_rad) {
  const auto t0 = std::chrono::steady_clock::now();
  const CalibrationRun run = runCalibration(feed, ro);
  if (run.raw_estimated) {
    w.estimated = true;
    w.mountings = rawMountings(run.raw, run.raw_config, not_determined_rad);
    w.information_Si = mountingInformation(run.raw, run.raw_config);
    w.chi2_per_obs = run.raw.chi2_per_obs;
    w.bias_rad_s2 = run.raw.bias_rad_s2;
    const double sg = parameterSigma(run.raw.bound, "acc_time_offset");
    if (sg > 0) {  // 0: not determined; NaN: not estimated
      w.time_offset_s = run.raw.time_offset_s;
      w.time_offset_sigma_s = sg;
    }
    w.harmonics = orbitHarmonicTerms(run.raw, run.raw_config);
  } else {
    w.note = run.raw_note.empty() ? std::string("not estimated") : run.raw_note;
  }
  w.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return w;
}

}  // namespace

void WindowedCalibration::close(TimeUs keep_orbit_from) {
  WindowSolution w;
  w.from = from_;
  w.to = to_;
  w.first = first_;
  w.last = last_;
  w.head_epochs = head_epochs_;
  w.acc_samples = acc_samples_;
  peak_raw_ = std::max(peak_raw_, feed_.raw().size());
  for (const auto& e : beta_)
    if (e.first == from_ && e.second.second > 0) w.beta_rad = e.second.first / static_cast<double>(e.second.second);
  beta_.erase(std::remove_if(beta_.begin(), beta_.end(), [this](const auto& e) { return e.first <= from_; }), beta_.end());
  if (concurrent_ <= 1) {
    windows_.push_back(estimateWindow(feed_, std::move(w), run_, not_determined_rad_));
    feed_.restart(keep_orbit_from);
    report();
    return;
  }
  auto job = std::make_unique<CalibrationFeed>(feed_.handOver(keep_orbit_from));
  if (!finished_) feed_.reserveRaw(job->raw().heads.size(), job->raw().acc.size());
  pending_.push_back(std::async(std::launch::async, [job = std::move(job), w = std::move(w), ro = run_, nd = not_determined_rad_]() mutable {
    return estimateWindow(*job, std::move(w), ro, nd);
  }));
  while (collect(false)) {
  }
  // At most concurrent_ windows' samples held: the next window is fed only when a place is free.
  while (pending_.size() >= concurrent_) collect(true);
}

bool WindowedCalibration::collect(bool wait) {
  if (pending_.empty()) return false;
  if (!wait && pending_.front().wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
  std::future<WindowSolution> f = std::move(pending_.front());
  pending_.pop_front();
  windows_.push_back(f.get());  // an estimate's exception comes out here, on the caller's thread
  report();
  return true;
}

void WindowedCalibration::report() {
  if (on_window_) on_window_(windows_.back());
}

void WindowedCalibration::finish() {
  if (finished_) return;
  finished_ = true;
  if (open_) close(to_);
  open_ = false;
  while (collect(true)) {
  }
}

}  // namespace boresight::calib

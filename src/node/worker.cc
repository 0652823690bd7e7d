// The node's calibration worker (worker.h).
#include "worker.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <limits>
#include <string>

namespace boresight::node {

bool CalibrationWorker::check(const core::PipelineConfig& pcfg, const calib::SpanOptions& so, std::string* error) {
  calib::CalibrationFeed f;
  if (f.configure(pcfg, so, false, error)) return true;
  if (error) *error = "the calibration worker cannot run this configuration: " + *error;
  return false;
}

bool CalibrationWorker::start(const core::PipelineConfig& pcfg, const calib::SpanOptions& so,
                              std::function<void()> idle, std::string* error) {
  if (!check(pcfg, so, error)) return false;
  cfg_ = pcfg;
  so_ = so;
  idle_ = std::move(idle);
  done_.store(false, std::memory_order_relaxed);
  thread_ = std::thread([this] { workerLoop(); });
  return true;
}

// The worker keeps the feed fed from the ring; a solve request copies the feed and hands the copy to the
// solver thread, so the ring keeps draining while Ceres runs (the real-time thread then
// rarely finds the ring full). One job at a time, in request order.
void CalibrationWorker::workerLoop() {
  calib::CalibrationFeed feed;
  std::string err;
  std::uint64_t gen = 0;
  bool ok = feed.configure(cfg_, so_, false, &err, raw_.has_value());  // start() checked it
  std::thread solver([this] { solverLoop(); });
  WorkItem it;
  int idle = 0;
  for (;;) {
    if (!ring_.pop(it)) {  // nothing to do: yield a while, then sleep (the worker is not real time)
      if (idle_) idle_();
      if (++idle < 64) std::this_thread::yield();
      else std::this_thread::sleep_for(std::chrono::microseconds(200));
      continue;
    }
    idle = 0;
    if (it.kind == WorkItem::kStop) break;
    if (it.kind == WorkItem::kMountings) {
      // New nominal mountings: the span starts again with them (its observations were of the old
      // ones), and the change is logged here, off the real-time thread.
      std::string what;
      for (int k = 0; k < cfg_.heads.n_heads; ++k) {
        auto& h = cfg_.heads.head[static_cast<std::size_t>(k)];
        const double d = h.q_Si_B.angularDistance(it.q_Si_B[static_cast<std::size_t>(k)]) / kRadPerArcsec;
        char b[64];
        std::snprintf(b, sizeof b, "%shead %d %.2f", k ? ", " : "", h.id, d);
        what += b;
        h.q_Si_B = it.q_Si_B[static_cast<std::size_t>(k)];
      }
      gen = it.solve_id;
      ok = feed.configure(cfg_, so_, false, &err, raw_.has_value());
      std::fprintf(stderr,
                   "boresightd: new nominal mountings applied from data time %lld us (moved: %s arcsec); the "
                   "calibration span starts again, the published frame is the heads' datum again\n",
                   static_cast<long long>(it.t), what.c_str());
      continue;
    }
    if (!ok) continue;
    if (it.kind == WorkItem::kHeads) {
      feed.pushHeads(it.heads);
    } else if (it.kind == WorkItem::kAcc) {
      feed.pushAcc(it.t, it.a_A);
    } else if (it.kind == WorkItem::kOrbit) {
      feed.pushOrbit(it.orbit);
    } else {
      auto j = std::make_unique<SolveJob>();
      j->feed = std::make_unique<calib::CalibrationFeed>(feed);
      j->req = it;
      for (int k = 0; k < core::kMaxHeads; ++k) j->nominal[static_cast<std::size_t>(k)] = cfg_.heads.head[static_cast<std::size_t>(k)].q_Si_B;
      j->nominal_gen = gen;
      std::unique_lock<std::mutex> lk(job_m_);
      job_cv_.wait(lk, [this] { return !job_; });
      job_ = std::move(j);
      job_cv_.notify_all();
    }
  }
  {
    std::unique_lock<std::mutex> lk(job_m_);
    job_cv_.wait(lk, [this] { return !job_; });
    job_stop_ = true;
    job_cv_.notify_all();
  }
  solver.join();
  done_.store(true, std::memory_order_release);
}

void CalibrationWorker::solverLoop() {
  for (;;) {
    std::unique_ptr<SolveJob> j;
    {
      std::unique_lock<std::mutex> lk(job_m_);
      job_cv_.wait(lk, [this] { return job_ || job_stop_; });
      if (!job_) return;
      j = std::move(job_);
    }
    calib::RunOptions opt;
    opt.solve.threads = 1;
    if (raw_) {  // the attitude-domain estimate about the nominal mountings the span was built with
      opt.raw = *raw_;
      for (std::size_t i = 0; i < opt.raw->heads.size(); ++i) {
        calib::RawBoundHead& h = opt.raw->heads[i];
        const int slot = core::slotOf(cfg_.heads, h.id);
        if (slot < 0) continue;
        h.C_Si_B = j->nominal[static_cast<std::size_t>(slot)].toRotationMatrix();
        h.R_axes_B = h.axes_Si * h.C_Si_B;
      }
      opt.raw_passes = raw_passes_;
      opt.raw_harmonics = raw_harmonics_;
    }
    timespec c0{}, c1{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    const auto w0 = std::chrono::steady_clock::now();
    const calib::CalibrationRun run = calib::runCalibration(*j->feed, opt);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    const double cpu = static_cast<double>(c1.tv_sec - c0.tv_sec) + 1e-9 * static_cast<double>(c1.tv_nsec - c0.tv_nsec);
    // One slot: wait until the real-time thread has taken the previous result.
    MailState expected = MailState::kEmpty;
    while (!mail_.state.compare_exchange_weak(expected, MailState::kWriting, std::memory_order_acq_rel)) {
      expected = MailState::kEmpty;
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    fillResult(j->feed->span(), run, *j);
    mail_.cpu_s = cpu;
    mail_.wall_s = wall;
    mail_.observations = j->feed->span().obs.size();
    mail_.observation_bytes = j->feed->span().obs.size() * sizeof(calib::Observation);
    mail_.state.store(MailState::kReady, std::memory_order_release);
    {
      std::lock_guard<std::mutex> lk(job_m_);  // the job slot is free once this one is published
      job_cv_.notify_all();
    }
  }
}

void CalibrationWorker::fillResult(const calib::CalibrationSpan& sp, const calib::CalibrationRun& run,
                                   const SolveJob& j) {
  const calib::SolveResult& r = run.result;
  boresight_lcm::calibration_t& m = mail_.msg;
  m = boresight_lcm::calibration_t{};
  mail_.solve_id = j.req.solve_id;
  mail_.nominal_gen = j.nominal_gen;
  // With method attitude the result is the attitude-domain estimate, which needs no CRN row: a window
  // the CRN solver refuses (too short for its filter, too few epochs) is still calibrated.
  const bool attitude = raw_ && run.raw_estimated;
  mail_.ok = run.ok || attitude;
  mail_.method_attitude = false;
  mail_.chi2_per_dof_max = std::numeric_limits<double>::quiet_NaN();
  // The reason without the leading "refused: " (the node's summary says it was refused).
  std::string why = run.refusal_text;
  if (!run.raw_note.empty()) why += (why.empty() ? "" : "; ") + run.raw_note;
  if (why.rfind("refused: ", 0) == 0) why.erase(0, 9);
  const std::size_t n = mail_.ok ? 0 : std::min(why.size(), mail_.reason.size() - 1);
  std::copy(why.begin(), why.begin() + static_cast<std::ptrdiff_t>(n), mail_.reason.begin());
  mail_.reason[n] = '\0';
  if (!run.ok)  // the solver's own thread, never the real-time one
    std::fprintf(stderr, "boresightd: calibration at data time %lld us %s: %s\n", static_cast<long long>(j.req.t),
                 attitude ? "by the attitude-domain estimate; the CRN solver refused" : "refused", why.c_str());
  m.utime = j.req.t;
  m.span_start_utime = sp.t_first;
  m.span_end_utime = sp.t_last;
  m.epochs = static_cast<int32_t>(r.epochs);
  m.status = mail_.ok ? 0 : 1;
  const int n_heads = cfg_.heads.n_heads;
  m.n_heads = static_cast<int8_t>(n_heads);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < core::kMaxHeads; ++k) {
    const auto u = static_cast<std::size_t>(k);
    mail_.q_Si_B[u] = j.nominal[u];
    if (k >= n_heads) continue;
    m.head_id[k] = static_cast<int8_t>(cfg_.heads.head[u].id);
    if (!r.ok) continue;
    mail_.q_Si_B[u] = (core::quatExp(r.estimate.r_S[u]) * j.nominal[u]).normalized();
    if (u < r.heads.size()) {
      const auto& h = r.heads[u];
      for (int a = 0; a < 3; ++a) {
        const auto ua = static_cast<std::size_t>(a);
        m.error_angles_arcsec[k][a] = h.error_angles_arcsec[ua];
        m.sigma_arcsec[k][a] = h.sigma_arcsec[ua] ? *h.sigma_arcsec[ua] : nan;
        m.crlb_arcsec[k][a] = h.crlb_arcsec[ua];
        m.observable[k][a] = h.observable[ua] ? 1 : 0;
      }
    }
  }
  const std::size_t n3 = static_cast<std::size_t>(3 * n_heads);
  if (r.ok && r.covariance_arcsec2.size() == n3 * n3)
    for (std::size_t i = 0; i < n3; ++i)
      for (std::size_t k = 0; k < n3; ++k) m.covariance_arcsec2[i][k] = r.covariance_arcsec2[i * n3 + k];
  m.residual_rms_radps2 = r.residual_rms_radps2;
  mail_.common_determined = r.ok && r.unobservable_directions_B.empty();
  if (run.raw_estimated && raw_) {
    // The attitude-domain estimate replaces the CRN solver's mountings, sigmas (its bound at the
    // estimate, the variance factors applied), covariance and observability (calib::rawMountings, as
    // `boresight calibrate --raw` reports them); crlb_arcsec carries the same sigmas.
    const calib::RawMountings rm = calib::rawMountings(run.raw, *raw_, raw_not_determined_rad_);
    for (std::size_t i = 0; i < raw_->heads.size() && i < rm.r_Si.size(); ++i) {
      const int slot = core::slotOf(cfg_.heads, raw_->heads[i].id);
      if (slot < 0) continue;
      const auto u = static_cast<std::size_t>(slot);
      mail_.q_Si_B[u] = (core::quatExp(rm.r_Si[i]) * j.nominal[u]).normalized();
      for (int a = 0; a < 3; ++a) {
        m.error_angles_arcsec[slot][a] = rm.r_Si[i](a) * kArcsecPerRad;
        m.sigma_arcsec[slot][a] = rm.sigma_Si[i](a) * kArcsecPerRad;  // NaN: not determined
        m.crlb_arcsec[slot][a] = m.sigma_arcsec[slot][a];
        m.observable[slot][a] = std::isfinite(rm.sigma_Si[i](a)) ? 1 : 0;
      }
    }
    for (std::size_t i = 0; i < n3 && static_cast<Eigen::Index>(i) < rm.covariance_Si.rows(); ++i)
      for (std::size_t k = 0; k < n3; ++k)
        m.covariance_arcsec2[i][k] = rm.covariance_Si(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) * kArcsecPerRad * kArcsecPerRad;
    mail_.common_determined = rm.common_determined;
    mail_.method_attitude = true;
    double chi2 = 0;
    for (const auto& g : run.raw.chi2_per_dof) chi2 = std::max({chi2, g[0], g[1]});
    mail_.chi2_per_dof_max = run.raw.chi2_per_dof.empty() ? std::numeric_limits<double>::quiet_NaN() : chi2;
  }
}

}  // namespace boresight::node

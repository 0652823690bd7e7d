#include "boresight/calib/thermal_fit.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

namespace boresight::calib {

namespace {
using MatX = Eigen::MatrixXd;
using VecX = Eigen::VectorXd;

constexpr double kTwoPi = 2.0 * kPi;

/// Regressors at (u, x): [1, cos m1 u, sin m1 u, ..., x cos m1 u, x sin m1 u, ...] (length 1 + 4H).
void regressors(const std::vector<int>& harm, double u, double x, VecX& f) {
  const int H = static_cast<int>(harm.size());
  f.resize(1 + 4 * H);
  f(0) = 1.0;
  for (int n = 0; n < H; ++n) {
    const double a = harm[static_cast<std::size_t>(n)] * u, c = std::cos(a), s = std::sin(a);
    f(1 + 2 * n) = c;
    f(2 + 2 * n) = s;
    f(1 + 2 * H + 2 * n) = x * c;
    f(2 + 2 * H + 2 * n) = x * s;
  }
}
}  // namespace

/// Normal equations of one head (columns of the full model, beta terms included; the fit takes the
/// leading block when the beta modulation is not determined).
struct ThermalCollector::Sums {
  int P = 0;                 ///< 1 + 4H
  std::uint64_t n = 0;       ///< epochs
  bool have_W1 = false;
  Mat3 W1 = Mat3::Zero();    ///< information of a nominal epoch (sigma scales 1)
  MatX S_nom, Y_nom;         ///< nominal epochs: sum f f^T (P x P), sum f y^T (P x 3)
  Mat3 yy_nom = Mat3::Zero();  ///< sum y y^T of the nominal epochs
  MatX N_gen;                ///< other epochs: sum F^T W F (3P x 3P)
  VecX b_gen;                ///< sum F^T W y
  double ywy_gen = 0;        ///< sum y^T W y
  MatX S_all, Y_all;         ///< all epochs, unweighted: sum f f^T, sum f y^T
  Vec3 y_sum = Vec3::Zero(), y2_sum = Vec3::Zero();
  Mat3 cov_sum = Mat3::Zero();

  void init(int p) {
    P = p;
    S_nom = MatX::Zero(P, P);
    Y_nom = MatX::Zero(P, 3);
    N_gen = MatX::Zero(3 * P, 3 * P);
    b_gen = VecX::Zero(3 * P);
    S_all = MatX::Zero(P, P);
    Y_all = MatX::Zero(P, 3);
  }
};

ThermalCollector::ThermalCollector() = default;
ThermalCollector::~ThermalCollector() = default;
ThermalCollector::ThermalCollector(const ThermalCollector&) = default;
ThermalCollector& ThermalCollector::operator=(const ThermalCollector&) = default;

bool ThermalCollector::configure(const core::HeadSetConfig& heads, const ThermalFitConfig& cfg, std::string* error) {
  configured_ = false;
  auto fail = [&](const std::string& m) {
    if (error) *error = "thermal fit: " + m;
    return false;
  };
  if (heads.n_heads < 2) return fail("needs at least 2 heads (head 1 is the datum), got " + std::to_string(heads.n_heads));
  if (validator_.configure(heads) != core::Status::kOk || monitor_.configure(heads) != core::Status::kOk)
    return fail("invalid head set (ids, mountings, boresights, sigmas)");
  if (cfg.harmonics.empty() || static_cast<int>(cfg.harmonics.size()) > core::kMaxThermalHarmonics)
    return fail("1.." + std::to_string(core::kMaxThermalHarmonics) + " harmonics needed, got " +
                std::to_string(cfg.harmonics.size()));
  std::set<int> seen;
  for (int m : cfg.harmonics)
    if (m < 1 || !seen.insert(m).second) return fail("harmonics must be distinct and >= 1 cycle per revolution");
  if (!(cfg.orbit_decimation_s >= 0) || !(cfg.max_orbit_gap_s > 0) || !(cfg.min_beta_range_deg >= 0) ||
      !(cfg.min_revolutions >= 0))
    return fail("orbit_decimation_s >= 0, max_orbit_gap_s > 0, min_beta_range_deg >= 0, min_revolutions >= 0 required");
  heads_ = heads;
  cfg_ = cfg;
  track_.clear();
  pending_.clear();
  sums_.assign(static_cast<std::size_t>(heads.n_heads), Sums{});
  for (Sums& s : sums_) s.init(1 + 4 * static_cast<int>(cfg.harmonics.size()));
  have_beta_ref_ = any_used_ = earth_fixed_ = false;
  counts_ = ThermalFitResult{};
  configured_ = true;
  return true;
}

bool ThermalCollector::orbitAt(double t, bool final_pass, double& u, double& beta, bool& pending) const {
  pending = false;
  if (track_.empty()) {
    pending = !final_pass;
    return false;
  }
  const double half = 0.5 * cfg_.max_orbit_gap_s;
  auto extrapolate = [&](const Node& n) {
    if (std::fabs(t - n.t_s) > half) return false;
    u = n.u + n.u_rate * (t - n.t_s);
    beta = n.beta;
    return true;
  };
  const auto it = std::upper_bound(track_.begin(), track_.end(), t, [](double v, const Node& n) { return v < n.t_s; });
  if (it == track_.end()) {
    const Node& last = track_.back();
    if (t == last.t_s) return extrapolate(last);
    if (!final_pass) {
      pending = true;
      return false;
    }
    return extrapolate(last);
  }
  if (it == track_.begin()) return extrapolate(*it);
  const Node& n0 = *(it - 1);
  const Node& n1 = *it;
  const double h = n1.t_s - n0.t_s;
  if (h > cfg_.max_orbit_gap_s) return extrapolate(t - n0.t_s < n1.t_s - t ? n0 : n1);
  const double s = (t - n0.t_s) / h, s2 = s * s, s3 = s2 * s;
  u = (2 * s3 - 3 * s2 + 1) * n0.u + (s3 - 2 * s2 + s) * h * n0.u_rate + (-2 * s3 + 3 * s2) * n1.u +
      (s3 - s2) * h * n1.u_rate;
  beta = n0.beta + s * (n1.beta - n0.beta);
  return true;
}

void ThermalCollector::use(const Sample& smp, double u, double beta) {
  if (!have_beta_ref_) {
    have_beta_ref_ = true;
    beta_ref_ = beta;
    cos_beta_ref_ = std::cos(beta);
  }
  if (!any_used_) {
    any_used_ = true;
    t_min_ = t_max_ = smp.t_s;
    u_min_ = u_max_ = u;
    beta_min_ = beta_max_ = beta;
  }
  t_min_ = std::min(t_min_, smp.t_s);
  t_max_ = std::max(t_max_, smp.t_s);
  u_min_ = std::min(u_min_, u);
  u_max_ = std::max(u_max_, u);
  beta_min_ = std::min(beta_min_, beta);
  beta_max_ = std::max(beta_max_, beta);
  VecX& f = f_;
  regressors(cfg_.harmonics, u, std::cos(beta) - cos_beta_ref_, f);
  MatX& ff = ff_;
  ff.noalias() = f * f.transpose();
  for (int k = 1; k < heads_.n_heads; ++k) {
    if (!((smp.mask >> k) & 1u)) continue;
    Sums& S = sums_[static_cast<std::size_t>(k)];
    const auto i = static_cast<std::size_t>(k);
    const Vec3& y = smp.delta[i];
    ++S.n;
    S.S_all += ff;
    S.Y_all.noalias() += f * y.transpose();
    S.y_sum += y;
    S.y2_sum += y.cwiseProduct(y);
    S.cov_sum += smp.cov[i];
    Mat3 W;
    if (!core::invertSpd3(smp.cov[i], W)) W = smp.cov[i].inverse();
    if (smp.nominal[i] && !S.have_W1) {
      S.have_W1 = true;
      S.W1 = W;
    }
    if (smp.nominal[i]) {
      S.S_nom += ff;
      S.Y_nom.noalias() += f * y.transpose();
      S.yy_nom += y * y.transpose();
    } else {
      const int P = S.P;
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) S.N_gen.block(a * P, b * P, P, P) += W(a, b) * ff;
        S.b_gen.segment(a * P, P) += (W.row(a) * y) * f;
      }
      S.ywy_gen += y.dot(W * y);
    }
  }
}

void ThermalCollector::pushHeads(const core::HeadEpoch& e) {
  if (!configured_) return;
  ++counts_.head_epochs;
  if (validator_.step(e) != core::Status::kOk) {
    ++counts_.head_epochs_rejected;
    return;
  }
  const core::ValidHeads& v = validator_.output();
  monitor_.step(v);
  Sample smp;
  smp.t_s = toSeconds(v.t);
  for (int k = 1; k < heads_.n_heads; ++k) {
    const core::PairDeformation& d = monitor_.pair(0, k);
    if (!d.valid) continue;
    const auto i = static_cast<std::size_t>(k);
    smp.mask |= 1u << k;
    smp.delta[i] = d.delta_Si;
    smp.cov[i] = d.cov_delta_Si;
    smp.nominal[i] = v.sigma_scale[0] == 1.0 && v.sigma_scale[i] == 1.0;
  }
  if (smp.mask == 0) return;  // head 1 or every other head missing: nothing relative to the datum
  if (pending_.empty()) {
    double u = 0, beta = 0;
    bool pend = false;
    if (orbitAt(smp.t_s, false, u, beta, pend)) {
      use(smp, u, beta);
      return;
    }
    if (!pend) {
      ++counts_.epochs_without_orbit;
      return;
    }
  }
  if (pending_.size() >= cfg_.max_pending) {
    pending_.pop_front();
    ++counts_.pending_dropped;
  }
  pending_.push_back(smp);
}

void ThermalCollector::resolvePending(bool final_pass) {
  while (!pending_.empty()) {
    double u = 0, beta = 0;
    bool pend = false;
    if (orbitAt(pending_.front().t_s, final_pass, u, beta, pend)) {
      use(pending_.front(), u, beta);
    } else if (pend) {
      return;
    } else {
      ++counts_.epochs_without_orbit;
    }
    pending_.pop_front();
  }
}

void ThermalCollector::pushOrbit(const io::GnvRecord& r) {
  if (!configured_) return;
  model::OrbitSample s;
  const Vec3 p(r.pos[0], r.pos[1], r.pos[2]), v(r.vel[0], r.vel[1], r.vel[2]);
  if (!model::orbitSampleFromRecord(r.t, r.coord_ref, p, v, s)) {
    ++counts_.orbit_records_rejected;
    return;
  }
  pushOrbit(s);
}

void ThermalCollector::pushOrbit(const model::OrbitSample& s) {
  if (!configured_) return;
  const double t = toSeconds(s.t);
  if (!std::isfinite(s.u_rad) || !std::isfinite(s.u_rate_rad_s) || !std::isfinite(s.beta_rad) ||
      !(s.u_rate_rad_s > 0) || (!track_.empty() && !(t > track_.back().t_s))) {
    ++counts_.orbit_records_rejected;
    return;
  }
  ++counts_.orbit_records;
  earth_fixed_ = earth_fixed_ || s.from_earth_fixed;
  // the newest record is always the last node; the one before it is kept once it is a decimation
  // interval older than the newest
  const bool replace = track_.size() >= 2 && t - track_[track_.size() - 2].t_s < cfg_.orbit_decimation_s;
  if (replace) track_.pop_back();
  Node n{t, s.u_rad, s.u_rate_rad_s, s.beta_rad};
  if (!track_.empty()) {  // unwrap u against the previous node's prediction
    const Node& p = track_.back();
    const double pred = p.u + p.u_rate * (t - p.t_s);
    n.u += kTwoPi * std::round((pred - n.u) / kTwoPi);
  }
  track_.push_back(n);
  resolvePending(false);
}

ThermalFitResult ThermalCollector::fit() {
  ThermalFitResult r = counts_;
  r.harmonics = cfg_.harmonics;
  if (!configured_) {
    r.error = "thermal fit: not configured";
    return r;
  }
  resolvePending(true);
  r = counts_;
  r.harmonics = cfg_.harmonics;
  const int H = static_cast<int>(cfg_.harmonics.size());
  const int datum_id = heads_.head[0].id;
  r.datum_note = "head " + std::to_string(datum_id) +
                 " (slot 0) is the datum: the deformations are those of the other heads relative to it, "
                 "as rotation vectors in its frame (axes x, y, z of head " + std::to_string(datum_id) +
                 "); a rotation common to all heads is not observable here";
  r.u_from_earth_fixed = earth_fixed_;
  if (any_used_) {
    r.span_s = t_max_ - t_min_;
    r.revolutions = (u_max_ - u_min_) / kTwoPi;
    r.beta_min_deg = beta_min_ / kRadPerDeg;
    r.beta_max_deg = beta_max_ / kRadPerDeg;
    r.beta_ref_deg = beta_ref_ / kRadPerDeg;
  }
  const double beta_range = r.beta_max_deg - r.beta_min_deg;
  r.beta_determined = any_used_ && beta_range >= cfg_.min_beta_range_deg;
  {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "beta moved %.2f deg over %.2f days (%s %.1f deg needed, about 1 deg a day: weeks of data)%s",
                  beta_range, r.span_s / 86400.0, r.beta_determined ? ">=" : "<", cfg_.min_beta_range_deg,
                  r.beta_determined ? ": beta modulation fitted" : ": beta modulation not determined");
    r.beta_note = buf;
  }
  const int P = r.beta_determined ? 1 + 4 * H : 1 + 2 * H;
  for (int k = 1; k < heads_.n_heads; ++k) {
    const Sums& S = sums_[static_cast<std::size_t>(k)];
    ThermalHeadFit h;
    h.id = heads_.head[static_cast<std::size_t>(k)].id;
    h.slot = k;
    h.datum_id = datum_id;
    h.datum_slot = 0;
    h.epochs = S.n;
    h.beta_determined = r.beta_determined;
    auto refuse = [&](const std::string& why) {
      h.reason = why;
      r.heads.push_back(h);
    };
    std::string why;
    if (r.revolutions < cfg_.min_revolutions) {
      // the revolution period from the data itself when it moved at all
      const double period = r.revolutions > 0 ? r.span_s / r.revolutions : 5400.0;
      char buf[200];
      std::snprintf(buf, sizeof buf, "u covers %.4f revolutions in %.0f s, %.2f needed: at least %.0f s of data",
                    r.revolutions, r.span_s, cfg_.min_revolutions, cfg_.min_revolutions * period);
      why = buf;
    }
    if (S.n < cfg_.min_epochs) {
      if (!why.empty()) why += "; ";
      why += std::to_string(S.n) + " epochs with head " + std::to_string(datum_id) + " and u known, " +
             std::to_string(cfg_.min_epochs) + " needed";
    }
    if (!why.empty()) {
      refuse(why);
      continue;
    }
    const int Pf = S.P;
    MatX N = MatX::Zero(3 * P, 3 * P);
    VecX b = VecX::Zero(3 * P);
    const MatX YW = S.Y_nom * S.W1;  // (P x 3): column a = sum_b W1(a, b) f y_b (W1 symmetric)
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c)
        N.block(a * P, c * P, P, P) = S.W1(a, c) * S.S_nom.topLeftCorner(P, P) + S.N_gen.block(a * Pf, c * Pf, P, P);
      b.segment(a * P, P) = YW.col(a).head(P) + S.b_gen.segment(a * Pf, P);
    }
    const double ywy = (S.W1 * S.yy_nom).trace() + S.ywy_gen;
    Eigen::SelfAdjointEigenSolver<MatX> es(N);
    if (es.info() != Eigen::Success || !(es.eigenvalues()(0) > 1e-12 * es.eigenvalues()(3 * P - 1))) {
      refuse("the harmonics are not separable over this span (singular normal equations)");
      continue;
    }
    const MatX Ninv = es.eigenvectors() * es.eigenvalues().cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
    const VecX x = Ninv * b;
    const double chi2 = std::max(0.0, ywy - 2.0 * x.dot(b) + x.dot(N * x));
    const double dof = 3.0 * static_cast<double>(S.n) - 3.0 * P;
    h.chi2_per_dof = dof > 0 ? chi2 / dof : 0.0;
    const double scale = cfg_.scale_sigmas_by_chi2 ? std::max(1.0, h.chi2_per_dof) : 1.0;
    const MatX cov = scale * Ninv;
    h.n_params = 3 * P;
    h.covariance_arcsec2.resize(static_cast<std::size_t>(9 * P * P));
    for (int i = 0; i < 3 * P; ++i)
      for (int j = 0; j < 3 * P; ++j)
        h.covariance_arcsec2[static_cast<std::size_t>(i * 3 * P + j)] = cov(i, j) * kArcsecPerRad * kArcsecPerRad;
    const double nd = static_cast<double>(S.n);
    Mat3 excess = Mat3::Zero();
    for (int a = 0; a < 3; ++a) {
      ThermalAxisFit& A = h.axis[static_cast<std::size_t>(a)];
      const VecX xa = x.segment(a * P, P);
      auto val = [&](int j) { return x(a * P + j) * kArcsecPerRad; };
      auto sig = [&](int j) { return std::sqrt(std::max(0.0, cov(a * P + j, a * P + j))) * kArcsecPerRad; };
      A.constant_arcsec = val(0);
      A.sigma_constant_arcsec = sig(0);
      for (int n = 0; n < H; ++n) {
        ThermalHarmonicTerm t;
        t.harmonic = cfg_.harmonics[static_cast<std::size_t>(n)];
        t.cos_arcsec = val(1 + 2 * n);
        t.sin_arcsec = val(2 + 2 * n);
        t.sigma_cos_arcsec = sig(1 + 2 * n);
        t.sigma_sin_arcsec = sig(2 + 2 * n);
        A.terms.push_back(t);
        if (r.beta_determined) {
          ThermalHarmonicTerm tb;
          tb.harmonic = t.harmonic;
          tb.cos_arcsec = val(1 + 2 * H + 2 * n);
          tb.sin_arcsec = val(2 + 2 * H + 2 * n);
          tb.sigma_cos_arcsec = sig(1 + 2 * H + 2 * n);
          tb.sigma_sin_arcsec = sig(2 + 2 * H + 2 * n);
          A.beta_terms.push_back(tb);
        }
      }
      const double mean = S.y_sum(a) / nd;
      A.rms_before_arcsec = std::sqrt(std::max(0.0, S.y2_sum(a) / nd - mean * mean)) * kArcsecPerRad;
      const double rss = S.y2_sum(a) - 2.0 * xa.dot(S.Y_all.col(a).head(P)) + xa.dot(S.S_all.topLeftCorner(P, P) * xa);
      A.rms_after_arcsec = std::sqrt(std::max(0.0, rss / nd)) * kArcsecPerRad;
      const double noise2 = S.cov_sum(a, a) / nd;
      A.noise_rms_arcsec = std::sqrt(std::max(0.0, noise2)) * kArcsecPerRad;
      excess(a, a) = std::max(0.0, rss / nd - noise2);
    }
    // prediction covariance: the fit's, averaged over u (at beta_ref), plus what the model leaves unexplained
    Mat3 Pc = Mat3::Zero();
    constexpr int kU = 72;
    VecX f;
    for (int i = 0; i < kU; ++i) {
      regressors(cfg_.harmonics, kTwoPi * i / kU, 0.0, f);
      MatX F = MatX::Zero(3, 3 * P);
      for (int a = 0; a < 3; ++a) F.block(a, a * P, 1, P) = f.head(P).transpose();
      Pc += F * cov * F.transpose();
    }
    h.prediction_cov_rad2 = Pc / kU + excess;
    h.determined = true;
    r.heads.push_back(h);
  }
  r.ok = false;
  for (const ThermalHeadFit& h : r.heads) r.ok = r.ok || h.determined;
  if (!r.ok) {
    std::ostringstream o;
    o << "thermal fit: no head determined";
    for (const ThermalHeadFit& h : r.heads) o << "; head " << h.id << ": " << h.reason;
    if (counts_.orbit_records == 0) o << " (no orbit records: give GNI1B or GNV1B)";
    r.error = o.str();
  }
  return r;
}

core::ThermalHarmonicModel ThermalFitResult::coreModel(core::ThermalPredictionMode mode) const {
  core::ThermalHarmonicModel m;
  m.datum_slot = 0;
  m.mode = mode;
  m.n_harmonics = std::min(static_cast<int>(harmonics.size()), core::kMaxThermalHarmonics);
  for (int n = 0; n < m.n_harmonics; ++n)
    m.order[static_cast<std::size_t>(n)] = harmonics[static_cast<std::size_t>(n)];
  m.beta_terms = beta_determined;
  m.cos_beta_ref = std::cos(beta_ref_deg * kRadPerDeg);
  for (const ThermalHeadFit& h : heads) {
    if (!h.determined || h.slot <= 0 || h.slot >= core::kMaxHeads) continue;
    core::ThermalHeadModel& hm = m.head[static_cast<std::size_t>(h.slot)];
    hm.valid = true;
    for (int a = 0; a < 3; ++a) {
      const ThermalAxisFit& A = h.axis[static_cast<std::size_t>(a)];
      hm.constant_rad(a) = A.constant_arcsec * kRadPerArcsec;
      for (int n = 0; n < m.n_harmonics && n < static_cast<int>(A.terms.size()); ++n) {
        const auto i = static_cast<std::size_t>(n);
        hm.cos_rad[i](a) = A.terms[i].cos_arcsec * kRadPerArcsec;
        hm.sin_rad[i](a) = A.terms[i].sin_arcsec * kRadPerArcsec;
        if (i < A.beta_terms.size()) {
          hm.beta_cos_rad[i](a) = A.beta_terms[i].cos_arcsec * kRadPerArcsec;
          hm.beta_sin_rad[i](a) = A.beta_terms[i].sin_arcsec * kRadPerArcsec;
        }
      }
    }
    hm.cov_rad2 = 0.5 * (h.prediction_cov_rad2 + h.prediction_cov_rad2.transpose());
  }
  return m;
}

ThermalFitResult fitThermal(const core::HeadSetConfig& heads, const ThermalFitConfig& cfg,
                            const std::vector<core::HeadEpoch>& epochs, const std::vector<io::GnvRecord>& orbit) {
  ThermalCollector c;
  std::string err;
  if (!c.configure(heads, cfg, &err)) {
    ThermalFitResult r;
    r.error = err;
    return r;
  }
  for (const io::GnvRecord& o : orbit) c.pushOrbit(o);
  for (const core::HeadEpoch& e : epochs) c.pushHeads(e);
  return c.fit();
}

std::string formatThermalFit(const ThermalFitResult& r) {
  std::ostringstream o;
  char buf[256];
  o << "thermal harmonic model (METHODS 2.5)\n  " << r.datum_note << "\n";
  std::snprintf(buf, sizeof buf, "  span %.0f s, %.2f revolutions of u (%s), beta %.2f..%.2f deg\n", r.span_s,
                r.revolutions, r.u_from_earth_fixed ? "from GNV1B by the Earth rotation angle, ~0.1 deg" : "from GNI1B",
                r.beta_min_deg, r.beta_max_deg);
  o << buf << "  " << r.beta_note << "\n";
  if (!r.ok) o << "  " << r.error << "\n";
  static const char* kAxis[3] = {"x", "y", "z"};
  for (const ThermalHeadFit& h : r.heads) {
    o << "  head " << h.id << " relative to head " << h.datum_id << ": ";
    if (!h.determined) {
      o << "not determined (" << h.reason << ")\n";
      continue;
    }
    std::snprintf(buf, sizeof buf, "%llu epochs, chi2/dof %.2f\n", static_cast<unsigned long long>(h.epochs),
                  h.chi2_per_dof);
    o << buf;
    for (int a = 0; a < 3; ++a) {
      const ThermalAxisFit& A = h.axis[static_cast<std::size_t>(a)];
      std::snprintf(buf, sizeof buf, "    %s: const %8.2f +- %.2f\"", kAxis[a], A.constant_arcsec, A.sigma_constant_arcsec);
      o << buf;
      for (const ThermalHarmonicTerm& t : A.terms) {
        std::snprintf(buf, sizeof buf, " | %d/rev cos %7.2f +- %.2f sin %7.2f +- %.2f", t.harmonic, t.cos_arcsec,
                      t.sigma_cos_arcsec, t.sin_arcsec, t.sigma_sin_arcsec);
        o << buf;
      }
      std::snprintf(buf, sizeof buf, " | rms %.2f -> %.2f\" (noise %.2f\")\n", A.rms_before_arcsec, A.rms_after_arcsec,
                    A.noise_rms_arcsec);
      o << buf;
      if (!A.beta_terms.empty()) {
        o << "       beta terms (per unit of cos(beta) - cos(beta_ref))";
        for (const ThermalHarmonicTerm& t : A.beta_terms) {
          std::snprintf(buf, sizeof buf, " | %d/rev cos %7.2f +- %.2f sin %7.2f +- %.2f", t.harmonic, t.cos_arcsec,
                        t.sigma_cos_arcsec, t.sin_arcsec, t.sigma_sin_arcsec);
          o << buf;
        }
        o << "\n";
      }
    }
  }
  return o.str();
}

}  // namespace boresight::calib

#include "boresight/core/rates.h"

#include "boresight/core/rotation.h"

#include <cmath>

namespace boresight::core {

namespace {
Quat quatOf(const Eigen::Vector4d& v) { return Quat(v[0], v[1], v[2], v[3]); }  // v = (w, x, y, z)
}  // namespace

Status AttitudeRates::configure(const CrnConfig& cfg) {
  configured_ = false;
  CrnConfig c = cfg;
  c.max_order = 2;
  const Status s = crn_.configure(c);
  if (s != Status::kOk) return s;
  configured_ = true;
  reset();
  return Status::kOk;
}

void AttitudeRates::reset() {
  crn_.reset();
  have_prev_ = false;
  prev_ = Quat::Identity();
  n_out_ = 0;
}

RateOutput AttitudeRates::fromFiltered(const CrnStream<4>::Output& o) {
  const Quat q = quatOf(o.y[0]), qd = quatOf(o.y[1]), qdd = quatOf(o.y[2]);
  const double n2 = o.y[0].squaredNorm();
  RateOutput r;
  r.t = o.t;
  r.q_I_X = q.normalized();
  r.w_X = 2.0 * (q.conjugate() * qd).vec() / n2;
  r.alpha_X = (2.0 * (q.conjugate() * qdd).vec() - 2.0 * o.y[0].dot(o.y[1]) * r.w_X) / n2;
  r.bridged = o.bridged;
  if (o.bridged > 0) {  // first order in the bridged values' errors e0, e1, e2 (value, rate, accel.)
    const double e0 = o.sigma_bridge[0].norm(), e1 = o.sigma_bridge[1].norm(), e2 = o.sigma_bridge[2].norm();
    const double w = r.w_X.norm(), qn = std::sqrt(n2);
    // w = 2 vec(q* q')/|q|^2: |d w| <= 2 (e1 + e0 |q'|) / |q|^2 + 2 |w| e0 / |q|
    r.w_sigma_bridge = 2.0 * (e1 + e0 * o.y[1].norm()) / n2 + 2.0 * w * e0 / qn;
    // alpha: the same for q'' and the term 2 (q . q') w / |q|^2
    r.alpha_sigma_bridge = 2.0 * (e2 + e0 * o.y[2].norm()) / n2 + 2.0 * w * (e1 + e0 * o.y[1].norm()) / n2 +
                           2.0 * std::abs(o.y[0].dot(o.y[1])) * r.w_sigma_bridge / n2 +
                           2.0 * r.alpha_X.norm() * e0 / qn;
  }
  return r;
}

double AttitudeRates::noiseGain(int order) const {
  if (order < 0 || order > 2) return 0;
  const CrnKernel& k = crn_.kernel();
  double s = 0;
  for (int j = 0; j < k.nf; ++j) s += k.g[static_cast<std::size_t>(order)][static_cast<std::size_t>(j)] *
                                      k.g[static_cast<std::size_t>(order)][static_cast<std::size_t>(j)];
  return std::sqrt(s);
}

Status AttitudeRates::step(TimeUs t, const Quat& q_I_X) {
  n_out_ = 0;
  if (!configured_) return crn_.step(t, Eigen::Vector4d::Constant(std::nan("")));  // counted by the stream
  Quat q = q_I_X;
  if (have_prev_) q = continuous(q, prev_);
  const Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
  const Status s = crn_.step(t, v);
  if (accepted(s)) {
    prev_ = q;
    have_prev_ = true;
  }
  for (int i = 0; i < crn_.numOutputs(); ++i) out_[static_cast<std::size_t>(n_out_++)] = fromFiltered(crn_.output(i));
  return s;
}

Status AttitudeRates::evaluateAt(TimeUs t, RateOutput& out) const {
  CrnStream<4>::Output o;
  const Status s = crn_.evaluateAt(t, o);
  if (s == Status::kOk) out = fromFiltered(o);
  return s;
}

Status AccAngularFilter::configure(const CrnConfig& cfg, const Mat3& C_X_A) {
  configured_ = false;
  if (!C_X_A.allFinite() || !(C_X_A * C_X_A.transpose()).isApprox(Mat3::Identity(), 1e-9) ||
      C_X_A.determinant() < 0)
    return Status::kInvalidConfig;
  CrnConfig c = cfg;
  c.max_order = 1;  // order 1 serves the Taylor step in evaluateAt (|dt| <= half an interval: the
                    // omitted second-order term is below 5e-4 of the signal at 0.1 Hz, 10 Hz input)
  const Status s = crn_.configure(c);
  if (s != Status::kOk) return s;
  C_X_A_ = C_X_A;
  configured_ = true;
  return Status::kOk;
}

void AccAngularFilter::reset() { crn_.reset(); }

AccOutput AccAngularFilter::output(int i) const {
  const auto& o = crn_.output(i);
  return AccOutput{o.t, C_X_A_ * o.y[0]};
}

Status AccAngularFilter::evaluateAt(TimeUs t, AccOutput& out) const {
  Vec3 y, sb;
  int bridged = 0;
  const Status s = crn_.evaluateValueAt(t, y, &bridged, &sb);
  if (s == Status::kOk) out = AccOutput{t, C_X_A_ * y, bridged, bridged > 0 ? sb.norm() : 0.0};
  return s;
}

}  // namespace boresight::core

// Method A solver: see include/boresight/calib/solver.h for the model, the whitening and the bound.
#include "boresight/calib/solver.h"

#include "whitening.h"
#include "boresight/core/rotation.h"
#include "boresight/core/rotation_t.h"
#include "boresight/model/jacobian_check.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

namespace boresight::calib {

namespace {

using Vec3T = Eigen::Matrix<double, 3, 1>;

// ---- cost functors -------------------------------------------------------------------------------

// One whitened epoch of one head. With u = zA + tau zJ - zc b (the whitened accelerometer value on
// the star-camera instant, bias removed), v = K^-1 u in A, w = C_B_A v in B:
//   hard:  y = Exp(psi_h) M_h Exp(-phi) w     (rot = phi, the common rotation in B; G = Exp(psi_h) M_h)
//   prior: y = Exp(r_h) M_h w                  (rot = r_h in S_h; G = M_h)
// residual = sqrt_info (zS - y).
class EpochCost {
 public:
  // References (not copies): the rows and matrices live in the solver's Model for the problem's
  // lifetime; a functor is then 32 bytes (a day at 10 s with three heads: 26 000 of them).
  EpochCost(const WhitenedRow* row, const Mat3* G, const Mat3* C_B_A, bool hard)
      : row_(*row), G_(*G), C_B_A_(*C_B_A), hard_(hard) {}

  template <typename T>
  bool operator()(const T* rot, const T* bias, const T* scale, const T* nonorth, const T* tau, T* res) const {
    return eval(rot, bias, scale, nonorth, tau, res);
  }

  // T: the differentiated type of the rotation and the bias; S: T, or double for the accelerometer
  // parameters that are held constant (EpochCostReduced: jets of 6 instead of 13 derivatives).
  template <typename T, typename S>
  bool eval(const T* rot, const T* bias, const S* scale, const S* nonorth, const S* tau, T* res) const {
    using M3 = Eigen::Matrix<S, 3, 3>;
    using V3 = Eigen::Matrix<T, 3, 1>;
    V3 u;
    for (int i = 0; i < 3; ++i) u[i] = T(row_.zA[i]) + T(tau[0]) * T(row_.zJ[i]) - T(row_.zc) * bias[i];
    M3 K;
    K << S(1.0) + scale[0], nonorth[2], nonorth[1],  //
        nonorth[2], S(1.0) + scale[1], nonorth[0],   //
        nonorth[1], nonorth[0], S(1.0) + scale[2];
    const M3 Ki = K.inverse();
    V3 v;
    for (int i = 0; i < 3; ++i) v[i] = T(Ki(i, 0)) * u[0] + T(Ki(i, 1)) * u[1] + T(Ki(i, 2)) * u[2];
    const V3 w = C_B_A_.cast<T>() * v;
    T y[3];
    if (hard_) {
      const T mphi[3] = {-rot[0], -rot[1], -rot[2]};
      T q[4];
      rot::quatExp(mphi, q);
      const T wb[3] = {w[0], w[1], w[2]};
      T wr[3];
      rot::quatRotate(q, wb, wr);
      for (int i = 0; i < 3; ++i) y[i] = T(G_(i, 0)) * wr[0] + T(G_(i, 1)) * wr[1] + T(G_(i, 2)) * wr[2];
    } else {
      T ms[3];
      for (int i = 0; i < 3; ++i) ms[i] = T(G_(i, 0)) * w[0] + T(G_(i, 1)) * w[1] + T(G_(i, 2)) * w[2];
      T q[4];
      rot::quatExp(rot, q);
      rot::quatRotate(q, ms, y);
    }
    T e[3];
    for (int i = 0; i < 3; ++i) e[i] = T(row_.zS[i]) - y[i];
    for (int i = 0; i < 3; ++i)
      res[i] = T(row_.sqrt_info(i, 0)) * e[0] + T(row_.sqrt_info(i, 1)) * e[1] + T(row_.sqrt_info(i, 2)) * e[2];
    return true;
  }

  static ceres::CostFunction* create(const WhitenedRow* row, const Mat3* G, const Mat3* C_B_A, bool hard) {
    return new ceres::AutoDiffCostFunction<EpochCost, 3, 3, 3, 3, 3, 1>(new EpochCost(row, G, C_B_A, hard));
  }

 private:
  const WhitenedRow& row_;
  const Mat3& G_;
  const Mat3& C_B_A_;
  const bool hard_;
};

// The same residual when neither scale, non-orthogonality nor time offset is estimated: only the
// rotation and the bias are parameter blocks, the others are read as constants (the model's values).
class EpochCostReduced {
 public:
  EpochCostReduced(const WhitenedRow* row, const Mat3* G, const Mat3* C_B_A, bool hard, const double* scale,
                   const double* nonorth, const double* tau)
      : full_(row, G, C_B_A, hard), scale_(scale), nonorth_(nonorth), tau_(tau) {}

  template <typename T>
  bool operator()(const T* rot, const T* bias, T* res) const {
    return full_.eval(rot, bias, scale_, nonorth_, tau_, res);
  }

  static ceres::CostFunction* create(const WhitenedRow* row, const Mat3* G, const Mat3* C_B_A, bool hard,
                                     const double* scale, const double* nonorth, const double* tau) {
    return new ceres::AutoDiffCostFunction<EpochCostReduced, 3, 3, 3>(
        new EpochCostReduced(row, G, C_B_A, hard, scale, nonorth, tau));
  }

 private:
  const EpochCost full_;
  const double* scale_;
  const double* nonorth_;
  const double* tau_;
};

// All epochs of one head at once from their sufficient statistics (HeadMoments): with the 3x10 matrix
// A = S [I, -W, -tau W, W b] (W = the epoch model's matrix from K^-1 to the head frame, S the epochs'
// square-root information) the whitened residual of an epoch is A d, so sum |A d|^2 = |A L|_F^2 with
// D = L L^T: residual vec(A L), 30 values, exactly the per-epoch least-squares cost.
class MomentCost {
 public:
  MomentCost(const Eigen::Matrix<double, 10, 10>* L, const Mat3* S, const Mat3* G, const Mat3* C_B_A, bool hard)
      : L_(*L), S_(*S), G_(*G), C_B_A_(*C_B_A), hard_(hard) {}

  template <typename T>
  bool operator()(const T* rot, const T* bias, const T* scale, const T* nonorth, const T* tau, T* res) const {
    using M3 = Eigen::Matrix<T, 3, 3>;
    M3 K;
    K << T(1.0) + scale[0], nonorth[2], nonorth[1],  //
        nonorth[2], T(1.0) + scale[1], nonorth[0],   //
        nonorth[1], nonorth[0], T(1.0) + scale[2];
    M3 R;  // rotation part: hard G Exp(-phi), prior Exp(r) M
    T q[4], Rq[9];
    if (hard_) {
      const T mphi[3] = {-rot[0], -rot[1], -rot[2]};
      rot::quatExp(mphi, q);
    } else {
      rot::quatExp(rot, q);
    }
    rot::quatToMatrix(q, Rq);
    M3 E;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) E(i, j) = Rq[3 * i + j];
    R = hard_ ? M3(G_.cast<T>() * E) : M3(E * G_.cast<T>());
    const M3 W = R * C_B_A_.cast<T>() * K.inverse();
    const Eigen::Matrix<T, 3, 1> b(bias[0], bias[1], bias[2]);
    Eigen::Matrix<T, 3, 10> A;
    A.template block<3, 3>(0, 0) = M3::Identity();
    A.template block<3, 3>(0, 3) = -W;
    A.template block<3, 3>(0, 6) = -tau[0] * W;
    A.template block<3, 1>(0, 9) = W * b;
    const Eigen::Matrix<T, 3, 10> AL = S_.cast<T>() * A * L_.cast<T>();
    for (int c = 0; c < 10; ++c)
      for (int r = 0; r < 3; ++r) res[3 * c + r] = AL(r, c);
    return true;
  }

  static ceres::CostFunction* create(const Eigen::Matrix<double, 10, 10>* L, const Mat3* S, const Mat3* G,
                                     const Mat3* C_B_A, bool hard) {
    return new ceres::AutoDiffCostFunction<MomentCost, 30, 3, 3, 3, 3, 1>(new MomentCost(L, S, G, C_B_A, hard));
  }

 private:
  const Eigen::Matrix<double, 10, 10>& L_;
  const Mat3& S_;
  const Mat3& G_;
  const Mat3& C_B_A_;
  const bool hard_;
};

// Relative alignment prior (prior mode). The estimate of RelativeNormal says C_Sh_B = A_h Exp(-dhat_h)
// Exp(-phi) for every linked head with one common phi and dhat_datum = 0. With C_Sh_B = Exp(r_h) M_h the
// same quantity of the parameters is delta_h(r) = -Log(A_h^T C_Sh_B(r) C_B_Sd(r) A_d) (exact, no
// small-angle step between heads); residual L (delta(r) - dhat) over the linked heads h != d.
class RelativeCost {
 public:
  static constexpr int kRes = 3 * (kMaxHeads - 1);
  RelativeCost(const std::array<Quat, kMaxHeads>& M, const std::array<Quat, kMaxHeads>& A, const std::vector<int>& heads,
               int datum, const Eigen::VectorXd& dhat, const Eigen::MatrixXd& L)
      : M_(M), A_(A), heads_(heads), datum_(datum), dhat_(dhat), L_(L) {}

  // q = C_Sh_B(r_h) C_B_Sd(r_d) A_d as a quaternion, then A_h^T q
  template <typename T>
  void delta(const T* rh, const T* rd, int h, T out[3]) const {
    const auto hs = static_cast<std::size_t>(h), ds = static_cast<std::size_t>(datum_);
    T eh[4], ed[4];
    rot::quatExp(rh, eh);
    const T mrd[3] = {-rd[0], -rd[1], -rd[2]};
    rot::quatExp(mrd, ed);
    const T ac[4] = {T(A_[hs].w()), T(-A_[hs].x()), T(-A_[hs].y()), T(-A_[hs].z())};
    const T mh[4] = {T(M_[hs].w()), T(M_[hs].x()), T(M_[hs].y()), T(M_[hs].z())};
    const T mdc[4] = {T(M_[ds].w()), T(-M_[ds].x()), T(-M_[ds].y()), T(-M_[ds].z())};
    const T ad[4] = {T(A_[ds].w()), T(A_[ds].x()), T(A_[ds].y()), T(A_[ds].z())};
    T q[4];
    rot::quatProduct(ac, eh, q);
    rot::quatProduct(q, mh, q);
    rot::quatProduct(q, mdc, q);
    rot::quatProduct(q, ed, q);
    rot::quatProduct(q, ad, q);
    rot::quatLog(q, out);
    out[0] = -out[0];
    out[1] = -out[1];
    out[2] = -out[2];
  }

  template <typename T>
  bool operator()(const T* r0, const T* r1, const T* r2, const T* r3, T* res) const {
    const T* r[4] = {r0, r1, r2, r3};
    static_assert(kMaxHeads == 4, "RelativeCost takes kMaxHeads rotation blocks");
    T v[kRes];
    for (int i = 0; i < kRes; ++i) v[i] = T(0.0);
    for (std::size_t k = 0; k < heads_.size(); ++k) {
      T dh[3];
      delta(r[heads_[k]], r[datum_], heads_[k], dh);
      for (int i = 0; i < 3; ++i)
        v[3 * k + static_cast<std::size_t>(i)] = dh[i] - T(dhat_[static_cast<Eigen::Index>(3 * k) + i]);
    }
    const int nr = static_cast<int>(L_.rows());
    for (int i = 0; i < kRes; ++i) {
      res[i] = T(0.0);
      if (i >= nr) continue;
      for (int j = 0; j < nr; ++j) res[i] += T(L_(i, j)) * v[j];
    }
    return true;
  }

  static ceres::CostFunction* create(const std::array<Quat, kMaxHeads>& M, const std::array<Quat, kMaxHeads>& A,
                                     const std::vector<int>& heads, int datum, const Eigen::VectorXd& dhat,
                                     const Eigen::MatrixXd& L) {
    return new ceres::AutoDiffCostFunction<RelativeCost, kRes, 3, 3, 3, 3>(new RelativeCost(M, A, heads, datum, dhat, L));
  }

 private:
  const std::array<Quat, kMaxHeads> M_, A_;
  const std::vector<int> heads_;
  const int datum_;
  const Eigen::VectorXd dhat_;
  const Eigen::MatrixXd L_;
};

// ---- helpers --------------------------------------------------------------------------------------

Mat3 rotM(const Quat& q) { return q.normalized().toRotationMatrix(); }

// The moment form: asked for, or the only data the span kept.
bool useMoments(const CalibrationSpan& span, const SolveOptions& opt) {
  return opt.from_moments || (span.obs.empty() && span.epochs_total > 0);
}

// Checks every input the solver relies on; an empty string when usable (*why: the refusal's kind).
std::string checkSpan(const CalibrationSpan& span, const SolveOptions& opt, Refusal* why = nullptr) {
  if (why) *why = Refusal::kInvalidSpan;
  std::ostringstream m;
  if (span.n_heads < 1 || span.n_heads > kMaxHeads) {
    m << "the span has " << span.n_heads << " heads (1.." << kMaxHeads << " are handled)";
    return m.str();
  }
  for (int a = 0; a < span.n_heads; ++a) {
    if (span.head_ids[static_cast<std::size_t>(a)] <= 0) {
      m << "head slot " << a << " has no valid id (" << span.head_ids[static_cast<std::size_t>(a)] << ")";
      return m.str();
    }
    for (int b = a + 1; b < span.n_heads; ++b)
      if (span.head_ids[static_cast<std::size_t>(a)] == span.head_ids[static_cast<std::size_t>(b)]) {
        m << "head id " << span.head_ids[static_cast<std::size_t>(a)] << " is given to slots " << a << " and " << b;
        return m.str();
      }
    const Quat& q = span.q_S_B_nominal[static_cast<std::size_t>(a)];
    if (!core::allFinite(q) || std::abs(q.norm() - 1.0) > 1e-6) {
      m << "head " << span.head_ids[static_cast<std::size_t>(a)] << ": the nominal mounting is not a unit quaternion";
      return m.str();
    }
  }
  const Mat3& C = span.C_B_A;
  if (!C.allFinite() || !(C * C.transpose()).isApprox(Mat3::Identity(), 1e-9) || C.determinant() < 0)
    return "C_B_A is not a proper rotation";
  if (!(span.decimation_s > 0) || span.noise_correlation.empty() || span.noise_correlation[0] != 1.0)
    return "the span has no decimation interval or noise correlation (not built by SpanBuilder?)";
  const double need_each_side = span.crn_half_length_s > 0 ? span.crn_half_length_s : 35.3;
  const double span_s = toSeconds(span.t_last - span.t_first);
  const std::size_t min_epochs = std::max<std::size_t>(opt.min_epochs, 3);  // 0 would let an empty span through
  const bool moments = useMoments(span, opt);
  const std::size_t n_epochs = moments ? static_cast<std::size_t>(span.epochs_total) : span.obs.size();
  if (n_epochs < min_epochs) {
    if (why) *why = Refusal::kTooFewEpochs;
    m << "too few epochs: " << n_epochs << " calibration epochs (one per " << span.decimation_s
      << " s with head and accelerometer data) from " << span_s << " s of head data; at least "
      << min_epochs << " are needed, i.e. "
      << 2.0 * need_each_side + static_cast<double>(min_epochs) * span.decimation_s
      << " s of continuous head and accelerometer data (the CRN needs " << need_each_side
      << " s each side of an epoch), and excitation (manoeuvres or thruster activity) during it";
    return m.str();
  }
  if (moments) {
    for (int h = 0; h < span.n_heads; ++h) {
      const HeadMoments& hm = span.moments[static_cast<std::size_t>(h)];
      if (!hm.whitened.allFinite() || !hm.raw.allFinite() || !hm.cov.allFinite()) return "non-finite moments";
      Mat3 inv;
      if (hm.n > 0 && !core::invertSpd3(hm.cov, inv)) return "the moments' covariance is not positive definite";
    }
    if (!span.acc_moments.allFinite()) return "non-finite accelerometer moments";
  }
  for (std::size_t k = 0; k < (moments ? 0 : span.obs.size()); ++k) {
    const Observation& o = span.obs[k];
    if (k > 0 && o.t <= span.obs[k - 1].t) {
      m << "observation " << k << " (t = " << toSeconds(o.t) << " s) is not later than the one before";
      return m.str();
    }
    bool any = false;
    for (int h = 0; h < kMaxHeads; ++h) {
      if (!o.has_head[static_cast<std::size_t>(h)]) continue;
      if (h >= span.n_heads) {
        m << "observation " << k << " (t = " << toSeconds(o.t) << " s) has head slot " << h << " but the span has "
          << span.n_heads << " heads (inconsistent head ids)";
        return m.str();
      }
      any = true;
      if (!o.alpha_S[static_cast<std::size_t>(h)].allFinite() || !o.cov_alpha_S[static_cast<std::size_t>(h)].allFinite()) {
        m << "observation " << k << " (t = " << toSeconds(o.t) << " s): non-finite head "
          << span.head_ids[static_cast<std::size_t>(h)] << " acceleration or covariance";
        return m.str();
      }
      Mat3 inv;
      if (!core::invertSpd3(o.cov_alpha_S[static_cast<std::size_t>(h)] + 1e-300 * Mat3::Identity(), inv)) {
        m << "observation " << k << ": the covariance of head " << span.head_ids[static_cast<std::size_t>(h)]
          << " is not positive definite";
        return m.str();
      }
    }
    if (!any) {
      m << "observation " << k << " (t = " << toSeconds(o.t) << " s) has no head";
      return m.str();
    }
    if (!o.alpha_A.allFinite() || !o.jerk_A.allFinite() || !o.cov_alpha_A.allFinite()) {
      m << "observation " << k << " (t = " << toSeconds(o.t) << " s): non-finite accelerometer value";
      return m.str();
    }
  }
  for (const RelativeMean& r : span.relative) {
    if (r.slot_i < 0 || r.slot_j <= r.slot_i || r.slot_j >= span.n_heads) {
      m << "pair mean of slots " << r.slot_i << ", " << r.slot_j << " does not match the " << span.n_heads << " heads";
      return m.str();
    }
    if (!core::allFinite(r.q_Si_Sj) || !r.cov_Sj.allFinite()) return "non-finite pair mean";
  }
  return {};
}

// Everything one problem needs; the parameter blocks live here (Ceres keeps pointers to them).
struct Model {
  bool hard = true;
  int n = 0;
  std::array<Mat3, kMaxHeads> M{};       // nominal C_Sh_B
  std::array<Quat, kMaxHeads> qM{};
  // relative alignment (RelativeNormal): anchors, the estimate delta_h (B, delta_datum = 0), its
  // covariance over `rel_heads` (the linked heads other than the datum), the reduced sqrt information
  std::array<Quat, kMaxHeads> qA{};
  std::array<Vec3, kMaxHeads> delta{};
  int datum = 0;
  std::vector<int> rel_heads;
  Eigen::VectorXd dhat;
  Eigen::MatrixXd P_delta, L_delta;
  std::array<std::array<double, 3>, kMaxHeads> rot{};  // hard: rot[0] = phi; prior: r_h
  std::array<double, 3> bias{}, scale{}, nonorth{};
  double tau = 0;
  Whitened data;
  std::array<Mat3, kMaxHeads> G{};       // per head, the constant matrix of EpochCost (it points here)
  bool moments = false;                  // MomentCost from span.moments instead of the epochs
  std::array<Eigen::Matrix<double, 10, 10>, kMaxHeads> Lm{};  // square roots of the whitened moments
  std::array<Mat3, kMaxHeads> Sm{};      // their square-root information
  Mat3 C_B_A = Mat3::Identity();
};

// The relative alignment of the heads from the span's normal equations. false with *msg when the
// hard mode needs a head that is not linked to the others.
bool fitRelative(const CalibrationSpan& span, Model& m, std::string* msg) {
  const RelativeNormal& rn = span.relative_normal;
  m.delta.fill(Vec3::Zero());
  m.rel_heads.clear();
  for (int h = 0; h < m.n; ++h)
    m.qA[static_cast<std::size_t>(h)] = rn.anchored[static_cast<std::size_t>(h)] ? rn.q_S_B_anchor[static_cast<std::size_t>(h)]
                                                                                  : m.qM[static_cast<std::size_t>(h)];
  m.datum = 0;
  while (m.datum < m.n && !rn.anchored[static_cast<std::size_t>(m.datum)]) ++m.datum;
  if (m.datum >= m.n) m.datum = 0;
  // heads linked to the datum through epochs with both
  std::vector<bool> linked(static_cast<std::size_t>(m.n), false);
  linked[static_cast<std::size_t>(m.datum)] = true;
  for (int pass = 0; pass < m.n; ++pass)
    for (int a = 0; a < m.n; ++a)
      for (int b = 0; b < m.n; ++b)
        if (linked[static_cast<std::size_t>(a)] && rn.together[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)])
          linked[static_cast<std::size_t>(b)] = true;
  for (int h = 0; h < m.n; ++h) {
    if (h == m.datum) continue;
    if (linked[static_cast<std::size_t>(h)]) {
      m.rel_heads.push_back(h);
    } else if (m.hard) {
      if (msg)
        *msg = "head " + std::to_string(span.head_ids[static_cast<std::size_t>(h)]) +
               " was never observed together with the other heads: the hard relative constraint needs every head "
               "linked to the others (use the prior mode)";
      return false;
    }
  }
  const int nr = 3 * static_cast<int>(m.rel_heads.size());
  Eigen::MatrixXd I(nr, nr);
  Eigen::VectorXd b(nr);
  for (std::size_t a = 0; a < m.rel_heads.size(); ++a) {
    b.segment<3>(static_cast<Eigen::Index>(3 * a)) = rn.info_x.segment<3>(3 * m.rel_heads[a]);
    for (std::size_t c = 0; c < m.rel_heads.size(); ++c)
      I.block<3, 3>(static_cast<Eigen::Index>(3 * a), static_cast<Eigen::Index>(3 * c)) =
          rn.info.block<3, 3>(3 * m.rel_heads[a], 3 * m.rel_heads[c]);
  }
  m.dhat = Eigen::VectorXd::Zero(nr);
  m.P_delta = Eigen::MatrixXd::Zero(nr, nr);
  m.L_delta = Eigen::MatrixXd::Zero(nr, nr);
  if (nr == 0) return true;
  Eigen::LLT<Eigen::MatrixXd> llt(I);
  if (llt.info() != Eigen::Success) {
    if (msg) *msg = "the relative alignment of the heads is singular (heads never observed together long enough)";
    return false;
  }
  m.dhat = llt.solve(b);
  m.P_delta = llt.solve(Eigen::MatrixXd::Identity(nr, nr));
  m.L_delta = llt.matrixU();
  for (std::size_t a = 0; a < m.rel_heads.size(); ++a)
    m.delta[static_cast<std::size_t>(m.rel_heads[a])] = m.dhat.segment<3>(static_cast<Eigen::Index>(3 * a));
  return true;
}

// Relative mounting of head h in hard mode: G_h = A_h Exp(-delta_h) (C_Sh_B up to the common rotation).
Mat3 relativeMounting(const Model& m, int h) {
  const auto hs = static_cast<std::size_t>(h);
  return m.qA[hs].toRotationMatrix() * core::so3Exp(-m.delta[hs]);
}

// Head angles r_h (rad, S_h) of the model's current parameters.
// Hard mode, head h at a given common rotation phi and relative correction delta_h.
Vec3 hardHeadAngle(const Model& m, int h, const Vec3& phi, const Vec3& delta_h) {
  const auto hs = static_cast<std::size_t>(h);
  // C_Sh_B = A_h Exp(-delta_h) Exp(-phi) = Exp(r_h) M_h
  return core::so3Log(m.qA[hs].toRotationMatrix() * core::so3Exp(-delta_h) * core::so3Exp(-phi) * m.M[hs].transpose());
}

Vec3 headAngle(const Model& m, int h) {
  const auto hs = static_cast<std::size_t>(h);
  if (!m.hard) return Vec3(m.rot[hs][0], m.rot[hs][1], m.rot[hs][2]);
  return hardHeadAngle(m, h, Vec3(m.rot[0][0], m.rot[0][1], m.rot[0][2]), m.delta[hs]);
}

// The problem over the model's parameter blocks. Blocks not estimated are constant.
struct Built {
  std::unique_ptr<ceres::Problem> problem;
  std::vector<double*> free_blocks;        // in the order of the information matrix
  std::vector<int> free_sizes;
  std::vector<ceres::ResidualBlockId> epoch_blocks;
  const char* epoch_functor = "";          // the functor of the epoch blocks (checkJacobians)
  ceres::ResidualBlockId relative_block = nullptr;  // RelativeCost (prior mode)
};

Built buildProblem(const CalibrationSpan& span, const SolveOptions& opt, Model& m, bool robust) {
  Built b;
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  b.problem = std::make_unique<ceres::Problem>(po);
  ceres::Problem& P = *b.problem;
  const int nrot = m.hard ? 1 : m.n;
  for (int h = 0; h < nrot; ++h) P.AddParameterBlock(m.rot[static_cast<std::size_t>(h)].data(), 3);
  P.AddParameterBlock(m.bias.data(), 3);
  P.AddParameterBlock(m.scale.data(), 3);
  P.AddParameterBlock(m.nonorth.data(), 3);
  P.AddParameterBlock(&m.tau, 1);
  const bool reduced = !opt.estimate_acc_scale && !opt.estimate_acc_nonorthogonality && !opt.estimate_time_offset;
  b.epoch_functor = m.moments ? "MomentCost" : reduced ? "EpochCostReduced" : "EpochCost";
  for (int h = 0; h < m.n; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    m.G[hs] = m.hard ? relativeMounting(m, h) : m.M[hs];
    m.C_B_A = span.C_B_A;
    double* rot = m.hard ? m.rot[0].data() : m.rot[hs].data();
    if (m.moments) {
      if (span.moments[hs].n > 0)
        b.epoch_blocks.push_back(P.AddResidualBlock(MomentCost::create(&m.Lm[hs], &m.Sm[hs], &m.G[hs], &m.C_B_A, m.hard),
                                                    nullptr, rot, m.bias.data(), m.scale.data(), m.nonorth.data(),
                                                    &m.tau));
      continue;
    }
    for (const WhitenedRow& row : m.data.rows[hs]) {
      ceres::LossFunction* loss = robust && opt.huber_sigma > 0 ? new ceres::HuberLoss(opt.huber_sigma) : nullptr;
      if (reduced)
        b.epoch_blocks.push_back(P.AddResidualBlock(
            EpochCostReduced::create(&row, &m.G[hs], &m.C_B_A, m.hard, m.scale.data(), m.nonorth.data(), &m.tau), loss,
            rot, m.bias.data()));
      else
        b.epoch_blocks.push_back(P.AddResidualBlock(EpochCost::create(&row, &m.G[hs], &m.C_B_A, m.hard), loss, rot,
                                                    m.bias.data(), m.scale.data(), m.nonorth.data(), &m.tau));
    }
  }
  if (!m.hard && !m.rel_heads.empty()) {
    // unused rotation blocks (fewer than kMaxHeads heads) are constant dummies
    for (int h = m.n; h < kMaxHeads; ++h) {
      P.AddParameterBlock(m.rot[static_cast<std::size_t>(h)].data(), 3);
      P.SetParameterBlockConstant(m.rot[static_cast<std::size_t>(h)].data());
    }
    b.relative_block = P.AddResidualBlock(RelativeCost::create(m.qM, m.qA, m.rel_heads, m.datum, m.dhat, m.L_delta), nullptr,
                                          m.rot[0].data(), m.rot[1].data(), m.rot[2].data(), m.rot[3].data());
  }
  for (int h = 0; h < nrot; ++h) {
    b.free_blocks.push_back(m.rot[static_cast<std::size_t>(h)].data());
    b.free_sizes.push_back(3);
  }
  auto opt_block = [&](double* p, int size, bool on) {
    if (on) {
      b.free_blocks.push_back(p);
      b.free_sizes.push_back(size);
    } else {
      P.SetParameterBlockConstant(p);
    }
  };
  opt_block(m.bias.data(), 3, opt.estimate_acc_bias);
  opt_block(m.scale.data(), 3, opt.estimate_acc_scale);
  opt_block(m.nonorth.data(), 3, opt.estimate_acc_nonorthogonality);
  opt_block(&m.tau, 1, opt.estimate_time_offset);
  return b;
}

// J^T J of the free blocks (loss applied or not), accumulated residual block by residual block (no
// Jacobian of the whole problem in memory).
Eigen::MatrixXd information(Built& b, bool apply_loss) {
  std::vector<std::pair<const double*, int>> off;
  int np = 0;
  for (std::size_t i = 0; i < b.free_blocks.size(); ++i) {
    off.emplace_back(b.free_blocks[i], np);
    np += b.free_sizes[i];
  }
  auto offsetOf = [&](const double* p) {
    for (const auto& o : off)
      if (o.first == p) return o.second;
    return -1;
  };
  Eigen::MatrixXd I = Eigen::MatrixXd::Zero(np, np);
  std::vector<ceres::ResidualBlockId> ids;
  b.problem->GetResidualBlocks(&ids);
  std::vector<double*> params;
  std::vector<std::vector<double>> jac;
  std::vector<double*> jp;
  std::vector<double> res;
  Eigen::MatrixXd Jr;
  for (ceres::ResidualBlockId id : ids) {
    b.problem->GetParameterBlocksForResidualBlock(id, &params);
    const ceres::CostFunction* cf = b.problem->GetCostFunctionForResidualBlock(id);
    const int nres = cf->num_residuals();
    const std::vector<int32_t>& sizes = cf->parameter_block_sizes();
    jac.resize(params.size());
    jp.assign(params.size(), nullptr);
    std::vector<int> offs(params.size(), -1);
    for (std::size_t k = 0; k < params.size(); ++k) {
      offs[k] = offsetOf(params[k]);
      if (offs[k] < 0) continue;
      jac[k].resize(static_cast<std::size_t>(nres * sizes[k]));
      jp[k] = jac[k].data();
    }
    res.resize(static_cast<std::size_t>(nres));
    double cost = 0;
    b.problem->EvaluateResidualBlock(id, apply_loss, &cost, res.data(), jp.data());
    Jr.setZero(nres, np);
    for (std::size_t k = 0; k < params.size(); ++k) {
      if (offs[k] < 0) continue;
      for (int r = 0; r < nres; ++r)
        for (int c = 0; c < sizes[k]; ++c) Jr(r, offs[k] + c) = jac[k][static_cast<std::size_t>(r * sizes[k] + c)];
    }
    I.noalias() += Jr.transpose() * Jr;
  }
  return I;
}

// Head-angle covariance from the information of the free parameters (rotation blocks first).
HeadCovariance headCovariance(const Model& m, const Eigen::MatrixXd& I, const SolveOptions& opt) {
  HeadCovariance out;
  const int np = static_cast<int>(I.rows());
  const int nr = m.hard ? 3 : 3 * m.n;  // rotation parameters
  // Jacobi scaling, then eigen-decomposition: exactly degenerate directions have no information.
  Eigen::VectorXd d(np);
  for (int i = 0; i < np; ++i) d[i] = I(i, i) > 0 ? 1.0 / std::sqrt(I(i, i)) : 1.0;
  const Eigen::MatrixXd S = d.asDiagonal() * I * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
  const Eigen::VectorXd lam = es.eigenvalues();
  const double lmax = lam.size() ? std::max(lam.maxCoeff(), 1e-300) : 1.0;
  Eigen::MatrixXd Pp = Eigen::MatrixXd::Zero(np, np);
  std::vector<Eigen::VectorXd> nulls;
  for (int k = 0; k < np; ++k) {
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    if (lam[k] > 1e-12 * lmax) {
      Pp += v * v.transpose() / lam[k];
    } else {
      nulls.push_back(d.asDiagonal() * v);  // a direction of the parameters with no information
    }
  }
  Pp = d.asDiagonal() * Pp * d.asDiagonal();
  // head angles as linear functions of the rotation parameters (and psi in hard mode)
  const int n3 = 3 * m.n;
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n3, np);
  Eigen::MatrixXd Td = Eigen::MatrixXd::Zero(n3, m.P_delta.rows());
  if (m.hard) {
    // numerical derivatives of r_h(phi, delta_h) (no copy of the model: it holds the data)
    const double h = 1e-7;
    const Vec3 phi(m.rot[0][0], m.rot[0][1], m.rot[0][2]);
    for (int c = 0; c < 3; ++c) {
      Vec3 pa = phi, pb = phi;
      pa[c] += h;
      pb[c] -= h;
      for (int k = 0; k < m.n; ++k)
        T.block<3, 1>(3 * k, c) = (hardHeadAngle(m, k, pa, m.delta[static_cast<std::size_t>(k)]) -
                                   hardHeadAngle(m, k, pb, m.delta[static_cast<std::size_t>(k)])) /
                                  (2 * h);
    }
    for (std::size_t j = 0; j < m.rel_heads.size(); ++j) {
      const int k = m.rel_heads[j];
      for (int c = 0; c < 3; ++c) {
        Vec3 da = m.delta[static_cast<std::size_t>(k)], db = da;
        da[c] += h;
        db[c] -= h;
        Td.block<3, 1>(3 * k, static_cast<Eigen::Index>(3 * j) + c) =
            (hardHeadAngle(m, k, phi, da) - hardHeadAngle(m, k, phi, db)) / (2 * h);
      }
    }
  } else {
    T.leftCols(nr) = Eigen::MatrixXd::Identity(n3, nr);
  }
  out.P = T * Pp * T.transpose();
  if (m.hard && m.P_delta.size() > 0) out.P += Td * m.P_delta * Td.transpose();
  out.determined.assign(static_cast<std::size_t>(n3), true);
  const double thr = opt.unobservable_sigma_arcsec * kRadPerArcsec;
  for (int i = 0; i < n3; ++i) {
    const Eigen::VectorXd f = T.row(i).transpose();
    bool det = true;
    for (const Eigen::VectorXd& nv : nulls)
      if (std::abs(f.dot(nv)) > 1e-6 * f.norm() * nv.norm()) det = false;
    if (!(out.P(i, i) < thr * thr)) det = false;
    out.determined[static_cast<std::size_t>(i)] = det;
    if (!det) out.P(i, i) = std::numeric_limits<double>::infinity();
  }
  // information of a common rotation u (B) of all heads: head angles move by -M_h u
  Eigen::MatrixXd U(n3, 3);
  for (int k = 0; k < m.n; ++k) U.block<3, 3>(3 * k, 0) = -m.M[static_cast<std::size_t>(k)];
  // marginal information of the rotation parameters: Schur complement over the nuisance block
  const Eigen::MatrixXd Irr = I.topLeftCorner(nr, nr);
  Eigen::MatrixXd Imarg = Irr;
  if (np > nr) {
    const Eigen::MatrixXd Ira = I.topRightCorner(nr, np - nr);
    const Eigen::MatrixXd Iaa = I.bottomRightCorner(np - nr, np - nr);
    Eigen::VectorXd da(np - nr);
    for (int i = 0; i < np - nr; ++i) da[i] = Iaa(i, i) > 0 ? 1.0 / std::sqrt(Iaa(i, i)) : 1.0;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ea(da.asDiagonal() * Iaa * da.asDiagonal());
    Eigen::MatrixXd Ainv = Eigen::MatrixXd::Zero(np - nr, np - nr);
    const double am = std::max(ea.eigenvalues().maxCoeff(), 1e-300);
    for (int k = 0; k < np - nr; ++k)
      if (ea.eigenvalues()[k] > 1e-12 * am)
        Ainv += ea.eigenvectors().col(k) * ea.eigenvectors().col(k).transpose() / ea.eigenvalues()[k];
    Ainv = da.asDiagonal() * Ainv * da.asDiagonal();
    Imarg = Irr - Ira * Ainv * Ira.transpose();
  }
  if (m.hard) {
    out.common_info_B = Imarg;  // phi is the common rotation in B
  } else {
    out.common_info_B = U.transpose() * Imarg * U;
  }
  return out;
}

Whitened prepare(const CalibrationSpan& span, const SolveOptions& opt, const std::vector<std::uint8_t>* reject = nullptr) {
  std::array<Mat3, kMaxHeads> R{};
  for (int h = 0; h < span.n_heads; ++h)
    R[static_cast<std::size_t>(h)] = rotM(span.q_S_B_nominal[static_cast<std::size_t>(h)]) * span.C_B_A;
  const std::vector<double> unit{1.0};
  return whiten(span, R, opt.whiten ? span.noise_correlation : unit, reject);
}

// Square roots of the whitened moments (D = L L^T by eigen-decomposition: D may be rank-deficient,
// e.g. the jerk columns of a quiet span) and the square-root information of each head's epochs.
void prepareMoments(const CalibrationSpan& span, Model& m) {
  for (int h = 0; h < m.n; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    const HeadMoments& hm = span.moments[hs];
    m.Lm[hs].setZero();
    m.Sm[hs].setZero();
    if (hm.n == 0) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 10, 10>> es(0.5 * (hm.whitened + hm.whitened.transpose()));
    const Eigen::Matrix<double, 10, 1> lam = es.eigenvalues().cwiseMax(0.0);
    m.Lm[hs] = es.eigenvectors() * lam.cwiseSqrt().asDiagonal();
    Mat3 W;
    if (core::invertSpd3(hm.cov, W)) m.Sm[hs] = Eigen::LLT<Mat3>(W).matrixU();
  }
}

void initModel(const CalibrationSpan& span, const SolveOptions& opt, Model& m) {
  m.hard = opt.relative == RelativeMode::kHardConstraint;
  m.n = span.n_heads;
  m.moments = useMoments(span, opt);
  for (int h = 0; h < m.n; ++h) {
    m.qM[static_cast<std::size_t>(h)] = span.q_S_B_nominal[static_cast<std::size_t>(h)].normalized();
    m.M[static_cast<std::size_t>(h)] = rotM(span.q_S_B_nominal[static_cast<std::size_t>(h)]);
  }
}

void setParameters(Model& m, const ModelParameters& p) {
  for (int i = 0; i < 3; ++i) {
    m.bias[static_cast<std::size_t>(i)] = p.acc_bias[i];
    m.scale[static_cast<std::size_t>(i)] = p.acc_scale[i];
    m.nonorth[static_cast<std::size_t>(i)] = p.acc_nonorth[i];
  }
  m.tau = p.time_offset_s;
  if (m.hard) {
    // phi from the datum head: G_d Exp(-phi) = Exp(r_d) M_d
    const auto d = static_cast<std::size_t>(m.datum);
    const Vec3 phi = -core::so3Log(relativeMounting(m, m.datum).transpose() * core::so3Exp(p.r_S[d]) * m.M[d]);
    for (int i = 0; i < 3; ++i) m.rot[0][static_cast<std::size_t>(i)] = phi[i];
  } else {
    for (int h = 0; h < m.n; ++h)
      for (int i = 0; i < 3; ++i) m.rot[static_cast<std::size_t>(h)][static_cast<std::size_t>(i)] = p.r_S[static_cast<std::size_t>(h)][i];
  }
}

}  // namespace

const char* refusalName(Refusal r) {
  switch (r) {
    case Refusal::kNone: return "none";
    case Refusal::kInvalidSpan: return "invalid span";
    case Refusal::kTooFewEpochs: return "too few epochs";
    case Refusal::kHeadsNotLinked: return "heads not linked";
    case Refusal::kSolverFailed: return "solver failed";
    case Refusal::kTooQuiet: return "too quiet";
  }
  return "?";
}

namespace {

/// The problem without robust loss at the parameters `at` (the relative alignment fitted first, as
/// solve() does): what cramerRao and checkJacobians evaluate. False with *message on refusal. The
/// model must outlive the problem (its functors point into it).
bool problemAt(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at, Model& m, Built& b,
               std::string* message) {
  const std::string err = checkSpan(span, opt);
  if (!err.empty()) {
    if (message) *message = err;
    return false;
  }
  initModel(span, opt, m);
  if (!fitRelative(span, m, message)) return false;
  setParameters(m, at);
  if (m.moments)
    prepareMoments(span, m);
  else
    m.data = prepare(span, opt);
  b = buildProblem(span, opt, m, false);
  return true;
}

}  // namespace

HeadCovariance cramerRao(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at,
                         std::string* message) {
  Model m;
  Built b;
  if (!problemAt(span, opt, at, m, b, message)) return {};
  return headCovariance(m, information(b, false), opt);
}

std::vector<model::JacobianCheck> checkJacobians(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at,
                                                 std::size_t max_blocks, double relative_precision, std::string* message) {
  std::vector<model::JacobianCheck> out;
  Model m;
  Built b;
  if (!problemAt(span, opt, at, m, b, message)) return out;
  model::probeJacobians(*b.problem, b.epoch_blocks, b.epoch_functor, max_blocks, relative_precision, &out);
  if (b.relative_block != nullptr) model::probeJacobians(*b.problem, {b.relative_block}, "RelativeCost", 1, relative_precision, &out);
  return out;
}

SolveResult solve(const CalibrationSpan& span, const SolveOptions& opt) {
  SolveResult res;
  res.epochs = span.obs.size();
  res.span_s = toSeconds(span.t_last - span.t_first);
  const std::string err = checkSpan(span, opt, &res.refusal);
  if (!err.empty()) {
    res.message = err;
    return res;
  }
  res.refusal = Refusal::kNone;
  // excitation: scatter of the accelerometer's acceleration in B about its mean
  {
    const Eigen::Matrix4d& E = span.acc_moments;
    Mat3 S = Mat3::Zero();
    if (E(3, 3) > 0) {
      const Vec3 sum = E.block<3, 1>(0, 3);
      S = span.C_B_A * (E.block<3, 3>(0, 0) - sum * sum.transpose() / E(3, 3)) * span.C_B_A.transpose();
    } else {  // a span made by hand: from the observations
      Vec3 mean = Vec3::Zero();
      for (const Observation& o : span.obs) mean += span.C_B_A * o.alpha_A;
      mean /= static_cast<double>(std::max<std::size_t>(span.obs.size(), 1));
      for (const Observation& o : span.obs) {
        const Vec3 a = span.C_B_A * o.alpha_A - mean;
        S += a * a.transpose();
      }
    }
    Eigen::SelfAdjointEigenSolver<Mat3> es(0.5 * (S + S.transpose()));
    for (int i = 0; i < 3; ++i) res.excitation_eigenvalues.push_back(es.eigenvalues()[i]);
  }
  Model m;
  initModel(span, opt, m);
  std::string msg;
  if (!fitRelative(span, m, &msg)) {
    res.refusal = Refusal::kHeadsNotLinked;
    res.message = msg;
    return res;
  }
  // closure of the pair means (three or more heads): Log(B_ik^T B_ij B_jk), largest over triples
  for (const RelativeMean& a : span.relative)
    for (const RelativeMean& b : span.relative)
      for (const RelativeMean& c : span.relative)
        if (a.slot_i == c.slot_i && a.slot_j == b.slot_i && b.slot_j == c.slot_j)
          res.closure_arcsec = std::max(res.closure_arcsec,
                                        core::quatLog(c.q_Si_Sj.conjugate() * a.q_Si_Sj * b.q_Si_Sj).norm() * kArcsecPerRad);
  // robust start for the bias: the median of the accelerometer's values (the angular acceleration of a
  // span averages to about zero; the bias is often far larger than the manoeuvres)
  if (opt.estimate_acc_bias && m.moments && span.acc_moments(3, 3) > 0) {
    for (int i = 0; i < 3; ++i) m.bias[static_cast<std::size_t>(i)] = span.acc_moments(i, 3) / span.acc_moments(3, 3);
  } else if (opt.estimate_acc_bias) {
    for (int i = 0; i < 3; ++i) {
      std::vector<double> v;
      v.reserve(span.obs.size());
      for (const Observation& o : span.obs) v.push_back(o.alpha_A[i]);
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      m.bias[static_cast<std::size_t>(i)] = v[v.size() / 2];
    }
  }
  std::vector<std::uint8_t> reject(span.obs.size(), 0);
  if (m.moments)
    prepareMoments(span, m);
  else
    m.data = prepare(span, opt);
  Built b = buildProblem(span, opt, m, true);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = opt.max_iterations;
  so.num_threads = opt.threads;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  ceres::Solver::Summary sum;
  ceres::Solve(so, b.problem.get(), &sum);
  int total_iterations = static_cast<int>(sum.iterations.size());
  for (int round = 0; round < opt.outlier_rounds && opt.outlier_sigma > 0 && !m.moments && sum.IsSolutionUsable();
       ++round) {
    // raw residual of every head epoch at the current parameters, normalised by its covariance
    const Mat3 Kinv = accAxes(Vec3(m.scale[0], m.scale[1], m.scale[2]), Vec3(m.nonorth[0], m.nonorth[1], m.nonorth[2])).inverse();
    const Vec3 bias(m.bias[0], m.bias[1], m.bias[2]);
    std::size_t added = 0;
    for (std::size_t k = 0; k < span.obs.size(); ++k) {
      const Observation& o = span.obs[k];
      const Vec3 w = span.C_B_A * Kinv * (o.alpha_A + m.tau * o.jerk_A - bias);
      for (int h = 0; h < m.n; ++h) {
        const auto hs = static_cast<std::size_t>(h);
        if (!o.has_head[hs] || ((reject[k] >> h) & 1u)) continue;
        const Mat3 C = core::so3Exp(headAngle(m, h)) * m.M[hs];
        const Vec3 e = o.alpha_S[hs] - C * w;
        const Mat3 R = C * span.C_B_A;
        const Mat3 cov = o.cov_alpha_S[hs] + R * o.cov_alpha_A * R.transpose();
        if (e.dot(cov.ldlt().solve(e)) > opt.outlier_sigma * opt.outlier_sigma) {
          reject[k] = static_cast<std::uint8_t>(reject[k] | (1u << h));
          ++added;
        }
      }
    }
    if (added == 0) break;
    res.rejected_head_epochs += added;
    m.data = prepare(span, opt, &reject);
    b = buildProblem(span, opt, m, true);  // starts from the current parameters
    ceres::Solve(so, b.problem.get(), &sum);
    total_iterations += static_cast<int>(sum.iterations.size());
  }
  res.iterations = total_iterations;
  if (!sum.IsSolutionUsable()) {
    res.refusal = Refusal::kSolverFailed;
    res.message = "the solver failed: " + sum.BriefReport();
    return res;
  }
  // estimate
  for (int h = 0; h < m.n; ++h) res.estimate.r_S[static_cast<std::size_t>(h)] = headAngle(m, h);
  res.estimate.acc_bias = Vec3(m.bias[0], m.bias[1], m.bias[2]);
  res.estimate.acc_scale = Vec3(m.scale[0], m.scale[1], m.scale[2]);
  res.estimate.acc_nonorth = Vec3(m.nonorth[0], m.nonorth[1], m.nonorth[2]);
  res.estimate.time_offset_s = m.tau;
  const Eigen::MatrixXd Icov = information(b, true);
  const Eigen::MatrixXd Ifis = information(b, false);
  res.covariance = headCovariance(m, Icov, opt);
  res.crlb = headCovariance(m, Ifis, opt);

  // nuisance sigmas from the robust information (pseudo-inverse of the Jacobi-scaled matrix)
  const int np = static_cast<int>(Icov.rows());
  Eigen::MatrixXd Pfull = Eigen::MatrixXd::Zero(np, np);
  {
    Eigen::VectorXd d(np);
    for (int i = 0; i < np; ++i) d[i] = Icov(i, i) > 0 ? 1.0 / std::sqrt(Icov(i, i)) : 1.0;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d.asDiagonal() * Icov * d.asDiagonal());
    const double lm = std::max(es.eigenvalues().maxCoeff(), 1e-300);
    for (int k = 0; k < np; ++k)
      if (es.eigenvalues()[k] > 1e-12 * lm)
        Pfull += es.eigenvectors().col(k) * es.eigenvectors().col(k).transpose() / es.eigenvalues()[k];
      else
        for (int i = 0; i < np; ++i)
          if (std::abs(es.eigenvectors()(i, k)) > 1e-6) Pfull(i, i) = std::numeric_limits<double>::infinity();
    Pfull = d.asDiagonal() * Pfull * d.asDiagonal();
  }
  int col = m.hard ? 3 : 3 * m.n;
  auto est3 = [&](const std::array<double, 3>& v, double unit) {
    Estimate3 e;
    for (int i = 0; i < 3; ++i) {
      e.value[static_cast<std::size_t>(i)] = v[static_cast<std::size_t>(i)] * unit;
      const double var = Pfull(col + i, col + i);
      if (std::isfinite(var) && var >= 0) e.sigma[static_cast<std::size_t>(i)] = std::sqrt(var) * unit;
    }
    col += 3;
    return e;
  };
  if (opt.estimate_acc_bias) res.acc_bias_radps2 = est3(m.bias, 1.0);
  if (opt.estimate_acc_scale) res.acc_scale = est3(m.scale, 1.0);
  if (opt.estimate_acc_nonorthogonality) res.acc_nonorthogonality_arcsec = est3(m.nonorth, kArcsecPerRad);
  if (opt.estimate_time_offset) {
    res.time_offset_s = m.tau;
    const double var = Pfull(col, col);
    if (std::isfinite(var) && var >= 0) res.time_offset_sigma_s = std::sqrt(var);
  }

  // per head results
  const double thr = opt.unobservable_sigma_arcsec;
  for (int h = 0; h < m.n; ++h) {
    HeadResult hr;
    hr.id = span.head_ids[static_cast<std::size_t>(h)];
    for (int i = 0; i < 3; ++i) {
      const auto is = static_cast<std::size_t>(i);
      const int k = 3 * h + i;
      hr.error_angles_arcsec[is] = res.estimate.r_S[static_cast<std::size_t>(h)][i] * kArcsecPerRad;
      const double crlb = std::sqrt(res.crlb.P(k, k)) * kArcsecPerRad;
      hr.crlb_arcsec[is] = res.crlb.determined[static_cast<std::size_t>(k)] ? crlb : std::numeric_limits<double>::infinity();
      const bool det = res.covariance.determined[static_cast<std::size_t>(k)];
      hr.observable[is] = det;
      if (det) hr.sigma_arcsec[is] = std::sqrt(res.covariance.P(k, k)) * kArcsecPerRad;
      (void)thr;
    }
    res.heads.push_back(hr);
  }
  const int n3 = 3 * m.n;
  res.covariance_arcsec2.resize(static_cast<std::size_t>(n3 * n3));
  for (int i = 0; i < n3; ++i)
    for (int j = 0; j < n3; ++j) {
      const bool det = res.covariance.determined[static_cast<std::size_t>(i)] && res.covariance.determined[static_cast<std::size_t>(j)];
      res.covariance_arcsec2[static_cast<std::size_t>(i * n3 + j)] =
          det ? res.covariance.P(i, j) * kArcsecPerRad * kArcsecPerRad : std::numeric_limits<double>::quiet_NaN();
    }
  // unobservable directions of a common rotation, in B
  {
    Eigen::SelfAdjointEigenSolver<Mat3> es(0.5 * (res.covariance.common_info_B + res.covariance.common_info_B.transpose()));
    const double thr_rad = opt.unobservable_sigma_arcsec * kRadPerArcsec;
    for (int i = 0; i < 3; ++i)
      if (!(es.eigenvalues()[i] > 1.0 / (thr_rad * thr_rad))) res.unobservable_directions_B.push_back(es.eigenvectors().col(i));
  }
  // residual RMS (unwhitened, all heads and axes) at the estimate
  {
    double ss = 0;
    std::size_t n = 0;
    const Mat3 Kinv = accAxes(Vec3(m.scale[0], m.scale[1], m.scale[2]), Vec3(m.nonorth[0], m.nonorth[1], m.nonorth[2])).inverse();
    if (m.moments) {  // sum |A0 d|^2 = tr(A0 D_raw A0^T), A0 = [I, -W, -tau W, W b]
      for (int h = 0; h < m.n; ++h) {
        const auto hs = static_cast<std::size_t>(h);
        const Mat3 W = core::so3Exp(res.estimate.r_S[hs]) * m.M[hs] * span.C_B_A * Kinv;
        Eigen::Matrix<double, 3, 10> A0;
        A0 << Mat3::Identity(), -W, -m.tau * W, W * res.estimate.acc_bias;
        ss += (A0 * span.moments[hs].raw * A0.transpose()).trace();
        n += 3 * span.moments[hs].n;
      }
    }
    for (std::size_t k = 0; k < (m.moments ? 0 : span.obs.size()); ++k) {
      const Observation& o = span.obs[k];
      const Vec3 w = span.C_B_A * Kinv * (o.alpha_A + m.tau * o.jerk_A - res.estimate.acc_bias);
      for (int h = 0; h < m.n; ++h) {
        if (!o.has_head[static_cast<std::size_t>(h)]) continue;
        const Vec3 y = core::so3Exp(res.estimate.r_S[static_cast<std::size_t>(h)]) * m.M[static_cast<std::size_t>(h)] * w;
        ss += (o.alpha_S[static_cast<std::size_t>(h)] - y).squaredNorm();
        n += 3;
      }
    }
    res.residual_rms_radps2 = n ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
  }
  bool any_det = false;
  for (const HeadResult& hr : res.heads)
    for (bool o : hr.observable) any_det = any_det || o;
  if (!any_det) {
    std::ostringstream s;
    s << "too quiet: no head axis is determined (sigma above " << opt.unobservable_sigma_arcsec
      << "\" everywhere); excitation eigenvalues of the angular acceleration in B: " << res.excitation_eigenvalues[0]
      << ", " << res.excitation_eigenvalues[1] << ", " << res.excitation_eigenvalues[2]
      << " rad^2/s^4; a determined axis needs angular accelerations about at least two body axes "
         "(calibration manoeuvres: e.g. 1 deg at 100 s period for 1000 s per axis)";
    res.refusal = Refusal::kTooQuiet;
    res.message = s.str();
    return res;
  }
  res.ok = true;
  res.message = sum.BriefReport();
  return res;
}

Mat3 accAxes(const Vec3& scale, const Vec3& nonorth) {
  Mat3 K;
  K << 1 + scale[0], nonorth[2], nonorth[1],  //
      nonorth[2], 1 + scale[1], nonorth[0],   //
      nonorth[1], nonorth[0], 1 + scale[2];
  return K;
}

SpanResiduals residuals(const CalibrationSpan& span, const ModelParameters& p) {
  const Mat3 Kinv = accAxes(p.acc_scale, p.acc_nonorth).inverse();
  SpanResiduals out;
  std::array<Mat3, kMaxHeads> C{};
  for (int s = 0; s < span.n_heads && s < kMaxHeads; ++s) {
    const auto us = static_cast<std::size_t>(s);
    C[us] = core::so3Exp(p.r_S[us]) * span.q_S_B_nominal[us].toRotationMatrix() * span.C_B_A * Kinv;
  }
  const TimeUs t0 = span.obs.empty() ? 0 : span.obs.front().t;
  out.t_s.reserve(span.obs.size());
  out.r_S.reserve(span.obs.size());
  for (const auto& ob : span.obs) {
    out.t_s.push_back(toSeconds(ob.t - t0));
    std::array<Vec3, kMaxHeads> row = core::filled<Vec3, kMaxHeads>(Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
    const Vec3 a = ob.alpha_A + p.time_offset_s * ob.jerk_A - p.acc_bias;
    for (int s = 0; s < span.n_heads && s < kMaxHeads; ++s) {
      const auto us = static_cast<std::size_t>(s);
      if (ob.has_head[us]) row[us] = ob.alpha_S[us] - C[us] * a;
    }
    out.r_S.push_back(row);
  }
  return out;
}

}  // namespace boresight::calib

// Method A solver: see include/boresight/calib/solver.h for the model, the whitening and the bound.
#include "boresight/calib/solver.h"

#include "whitening.h"
#include "boresight/core/rotation.h"
#include "boresight/core/rotation_t.h"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>

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
  EpochCost(const WhitenedRow& row, const Mat3& G, const Mat3& C_B_A, bool hard)
      : row_(row), G_(G), C_B_A_(C_B_A), hard_(hard) {}

  template <typename T>
  bool operator()(const T* rot, const T* bias, const T* scale, const T* nonorth, const T* tau, T* res) const {
    using M3 = Eigen::Matrix<T, 3, 3>;
    using V3 = Eigen::Matrix<T, 3, 1>;
    V3 u;
    for (int i = 0; i < 3; ++i) u[i] = T(row_.zA[i]) + tau[0] * T(row_.zJ[i]) - T(row_.zc) * bias[i];
    M3 K;
    K << T(1.0) + scale[0], nonorth[2], nonorth[1],  //
        nonorth[2], T(1.0) + scale[1], nonorth[0],   //
        nonorth[1], nonorth[0], T(1.0) + scale[2];
    const V3 v = K.inverse() * u;
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

  static ceres::CostFunction* create(const WhitenedRow& row, const Mat3& G, const Mat3& C_B_A, bool hard) {
    return new ceres::AutoDiffCostFunction<EpochCost, 3, 3, 3, 3, 3, 1>(new EpochCost(row, G, C_B_A, hard));
  }

 private:
  const WhitenedRow row_;
  const Mat3 G_;
  const Mat3 C_B_A_;
  const bool hard_;
};

// Pair mean residual: with C_Sa_B = Exp(r_a) M_a, the model relative attitude C_Si_Sj = C_Si_B C_B_Sj
// against the measured mean B_ij: e = Log(B_ij^T C_Si_Sj) in Sj, weighted by the mean's covariance.
class PairCost {
 public:
  PairCost(const Quat& q_meas_Si_Sj, const Quat& q_Mi, const Quat& q_Mj, const Mat3& sqrt_info)
      : qb_(q_meas_Si_Sj), qi_(q_Mi), qj_(q_Mj), L_(sqrt_info) {}

  template <typename T>
  bool operator()(const T* ri, const T* rj, T* res) const {
    T ei[4], ej[4];
    rot::quatExp(ri, ei);
    rot::quatExp(rj, ej);
    const T bc[4] = {T(qb_.w()), T(-qb_.x()), T(-qb_.y()), T(-qb_.z())};
    const T mi[4] = {T(qi_.w()), T(qi_.x()), T(qi_.y()), T(qi_.z())};
    const T mjc[4] = {T(qj_.w()), T(-qj_.x()), T(-qj_.y()), T(-qj_.z())};
    T ejc[4];
    rot::quatConjugate(ej, ejc);
    T a[4];
    rot::quatProduct(bc, ei, a);
    rot::quatProduct(a, mi, a);
    rot::quatProduct(a, mjc, a);
    rot::quatProduct(a, ejc, a);
    T e[3];
    rot::quatLog(a, e);
    for (int i = 0; i < 3; ++i) res[i] = T(L_(i, 0)) * e[0] + T(L_(i, 1)) * e[1] + T(L_(i, 2)) * e[2];
    return true;
  }

  static ceres::CostFunction* create(const Quat& qb, const Quat& qi, const Quat& qj, const Mat3& L) {
    return new ceres::AutoDiffCostFunction<PairCost, 3, 3, 3>(new PairCost(qb, qi, qj, L));
  }

 private:
  const Quat qb_, qi_, qj_;
  const Mat3 L_;
};

// ---- helpers --------------------------------------------------------------------------------------

Mat3 sqrtInformation(const Mat3& cov) {
  Mat3 W;
  if (!core::invertSpd3(cov, W)) return Mat3::Zero();
  Eigen::LLT<Mat3> llt(W);
  if (llt.info() != Eigen::Success) return Mat3::Zero();
  return llt.matrixU();  // U^T U = W
}

Mat3 rotM(const Quat& q) { return q.normalized().toRotationMatrix(); }

// Checks every input the solver relies on; an empty string when usable.
std::string checkSpan(const CalibrationSpan& span, const SolveOptions& opt) {
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
  const double need_each_side = span.crn_half_length_s > 0 ? span.crn_half_length_s : 35.4;
  const double span_s = toSeconds(span.t_last - span.t_first);
  if (span.obs.size() < opt.min_epochs) {
    m << "too few epochs: " << span.obs.size() << " calibration epochs (one per " << span.decimation_s
      << " s with head and accelerometer data) from " << span_s << " s of head data; at least "
      << opt.min_epochs << " are needed, i.e. "
      << 2.0 * need_each_side + static_cast<double>(opt.min_epochs) * span.decimation_s
      << " s of continuous head and accelerometer data (the CRN needs " << need_each_side
      << " s each side of an epoch), and excitation (manoeuvres or thruster activity) during it";
    return m.str();
  }
  for (std::size_t k = 0; k < span.obs.size(); ++k) {
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
  std::array<Vec3, kMaxHeads> psi{};     // hard: relative alignment (psi_0 = 0)
  Eigen::MatrixXd P_psi;                 // hard: covariance of psi_1..psi_{n-1} (rad^2)
  std::array<std::array<double, 3>, kMaxHeads> rot{};  // hard: rot[0] = phi; prior: r_h
  std::array<double, 3> bias{}, scale{}, nonorth{};
  double tau = 0;
  Whitened data;
};

// Fits psi (hard mode) to the pair means. false with *msg when some head is not linked to slot 0.
bool fitRelative(const CalibrationSpan& span, Model& m, std::string* msg) {
  m.psi.fill(Vec3::Zero());
  m.P_psi = Eigen::MatrixXd::Zero(3 * (m.n - 1 > 0 ? m.n - 1 : 0), 3 * (m.n - 1 > 0 ? m.n - 1 : 0));
  if (m.n == 1) return true;
  // linked to slot 0 through pairs?
  std::vector<bool> linked(static_cast<std::size_t>(m.n), false);
  linked[0] = true;
  for (int pass = 0; pass < m.n; ++pass)
    for (const RelativeMean& r : span.relative)
      if (linked[static_cast<std::size_t>(r.slot_i)] || linked[static_cast<std::size_t>(r.slot_j)])
        linked[static_cast<std::size_t>(r.slot_i)] = linked[static_cast<std::size_t>(r.slot_j)] = true;
  for (int h = 1; h < m.n; ++h)
    if (!linked[static_cast<std::size_t>(h)]) {
      if (msg)
        *msg = "head " + std::to_string(span.head_ids[static_cast<std::size_t>(h)]) +
               " has no pair mean linking it to the other heads (never observed together): the hard relative "
               "constraint needs one; use the prior mode";
      return false;
    }
  std::array<std::array<double, 3>, kMaxHeads> p{};
  ceres::Problem::Options po;
  ceres::Problem prob(po);
  for (int h = 0; h < m.n; ++h) prob.AddParameterBlock(p[static_cast<std::size_t>(h)].data(), 3);
  prob.SetParameterBlockConstant(p[0].data());
  for (const RelativeMean& r : span.relative) {
    const Mat3 L = sqrtInformation(r.cov_Sj);
    prob.AddResidualBlock(PairCost::create(r.q_Si_Sj, span.q_S_B_nominal[static_cast<std::size_t>(r.slot_i)],
                                           span.q_S_B_nominal[static_cast<std::size_t>(r.slot_j)], L),
                          nullptr, p[static_cast<std::size_t>(r.slot_i)].data(), p[static_cast<std::size_t>(r.slot_j)].data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  so.function_tolerance = 1e-14;
  so.parameter_tolerance = 1e-14;
  so.gradient_tolerance = 1e-16;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &prob, &sum);
  if (!sum.IsSolutionUsable()) {
    if (msg) *msg = "the relative alignment of the heads from the pair means failed: " + sum.BriefReport();
    return false;
  }
  ceres::Problem::EvaluateOptions eo;
  for (int h = 1; h < m.n; ++h) eo.parameter_blocks.push_back(p[static_cast<std::size_t>(h)].data());
  ceres::CRSMatrix J;
  prob.Evaluate(eo, nullptr, nullptr, nullptr, &J);
  Eigen::MatrixXd Jd = Eigen::MatrixXd::Zero(J.num_rows, J.num_cols);
  for (int r = 0; r < J.num_rows; ++r)
    for (int k = J.rows[static_cast<std::size_t>(r)]; k < J.rows[static_cast<std::size_t>(r) + 1]; ++k)
      Jd(r, J.cols[static_cast<std::size_t>(k)]) = J.values[static_cast<std::size_t>(k)];
  const Eigen::MatrixXd I = Jd.transpose() * Jd;
  m.P_psi = I.ldlt().solve(Eigen::MatrixXd::Identity(I.rows(), I.cols()));
  for (int h = 1; h < m.n; ++h)
    m.psi[static_cast<std::size_t>(h)] = Vec3(p[static_cast<std::size_t>(h)][0], p[static_cast<std::size_t>(h)][1],
                                              p[static_cast<std::size_t>(h)][2]);
  return true;
}

// Head angles r_h (rad, S_h) of the model's current parameters.
Vec3 headAngle(const Model& m, int h) {
  const auto hs = static_cast<std::size_t>(h);
  if (!m.hard) return Vec3(m.rot[hs][0], m.rot[hs][1], m.rot[hs][2]);
  const Vec3 phi(m.rot[0][0], m.rot[0][1], m.rot[0][2]);
  // C_Sh_B = Exp(psi_h) M_h Exp(-phi) = Exp(r_h) M_h  ->  Exp(r_h) = Exp(psi_h) Exp(-M_h phi)
  return core::quatLog(core::quatExp(m.psi[hs]) * core::quatExp(-(m.M[hs] * phi)));
}

// The problem over the model's parameter blocks. Blocks not estimated are constant.
struct Built {
  std::unique_ptr<ceres::Problem> problem;
  std::vector<double*> free_blocks;        // in the order of the information matrix
  std::vector<int> free_sizes;
  std::vector<ceres::ResidualBlockId> epoch_blocks;
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
  for (int h = 0; h < m.n; ++h) {
    const auto hs = static_cast<std::size_t>(h);
    const Mat3 G = m.hard ? Mat3(core::so3Exp(m.psi[hs]) * m.M[hs]) : m.M[hs];
    double* rot = m.hard ? m.rot[0].data() : m.rot[hs].data();
    for (const WhitenedRow& row : m.data.rows[hs]) {
      ceres::LossFunction* loss = robust && opt.huber_sigma > 0 ? new ceres::HuberLoss(opt.huber_sigma) : nullptr;
      b.epoch_blocks.push_back(P.AddResidualBlock(EpochCost::create(row, G, span.C_B_A, m.hard), loss, rot,
                                                  m.bias.data(), m.scale.data(), m.nonorth.data(), &m.tau));
    }
  }
  if (!m.hard)
    for (const RelativeMean& r : span.relative)
      P.AddResidualBlock(PairCost::create(r.q_Si_Sj, span.q_S_B_nominal[static_cast<std::size_t>(r.slot_i)],
                                          span.q_S_B_nominal[static_cast<std::size_t>(r.slot_j)], sqrtInformation(r.cov_Sj)),
                         nullptr, m.rot[static_cast<std::size_t>(r.slot_i)].data(),
                         m.rot[static_cast<std::size_t>(r.slot_j)].data());
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

// J^T J of the free blocks (loss applied or not).
Eigen::MatrixXd information(Built& b, bool apply_loss) {
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = b.free_blocks;
  eo.apply_loss_function = apply_loss;
  ceres::CRSMatrix J;
  b.problem->Evaluate(eo, nullptr, nullptr, nullptr, &J);
  Eigen::MatrixXd I = Eigen::MatrixXd::Zero(J.num_cols, J.num_cols);
  for (int r = 0; r < J.num_rows; ++r) {
    const int k0 = J.rows[static_cast<std::size_t>(r)], k1 = J.rows[static_cast<std::size_t>(r) + 1];
    for (int a = k0; a < k1; ++a)
      for (int c = k0; c < k1; ++c)
        I(J.cols[static_cast<std::size_t>(a)], J.cols[static_cast<std::size_t>(c)]) +=
            J.values[static_cast<std::size_t>(a)] * J.values[static_cast<std::size_t>(c)];
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
  Eigen::MatrixXd Tpsi = Eigen::MatrixXd::Zero(n3, m.P_psi.rows());
  if (m.hard) {
    Model mm = m;
    const double h = 1e-7;
    for (int c = 0; c < 3; ++c) {
      Model a = m, b = m;
      a.rot[0][static_cast<std::size_t>(c)] += h;
      b.rot[0][static_cast<std::size_t>(c)] -= h;
      for (int k = 0; k < m.n; ++k) T.block<3, 1>(3 * k, c) = (headAngle(a, k) - headAngle(b, k)) / (2 * h);
    }
    for (int k = 1; k < m.n; ++k)
      for (int c = 0; c < 3; ++c) {
        Model a = m, b = m;
        a.psi[static_cast<std::size_t>(k)][c] += h;
        b.psi[static_cast<std::size_t>(k)][c] -= h;
        Tpsi.block<3, 1>(3 * k, 3 * (k - 1) + c) = (headAngle(a, k) - headAngle(b, k)) / (2 * h);
      }
    (void)mm;
  } else {
    T.leftCols(nr) = Eigen::MatrixXd::Identity(n3, nr);
  }
  out.P = T * Pp * T.transpose();
  if (m.hard && m.P_psi.size() > 0) out.P += Tpsi * m.P_psi * Tpsi.transpose();
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

Whitened prepare(const CalibrationSpan& span, const SolveOptions& opt) {
  std::array<Mat3, kMaxHeads> R{};
  for (int h = 0; h < span.n_heads; ++h)
    R[static_cast<std::size_t>(h)] = rotM(span.q_S_B_nominal[static_cast<std::size_t>(h)]) * span.C_B_A;
  const std::vector<double> unit{1.0};
  return whiten(span, R, opt.whiten ? span.noise_correlation : unit);
}

void initModel(const CalibrationSpan& span, const SolveOptions& opt, Model& m) {
  m.hard = opt.relative == RelativeMode::kHardConstraint;
  m.n = span.n_heads;
  for (int h = 0; h < m.n; ++h) m.M[static_cast<std::size_t>(h)] = rotM(span.q_S_B_nominal[static_cast<std::size_t>(h)]);
}

void setParameters(Model& m, const ModelParameters& p) {
  for (int i = 0; i < 3; ++i) {
    m.bias[static_cast<std::size_t>(i)] = p.acc_bias[i];
    m.scale[static_cast<std::size_t>(i)] = p.acc_scale[i];
    m.nonorth[static_cast<std::size_t>(i)] = p.acc_nonorth[i];
  }
  m.tau = p.time_offset_s;
  if (m.hard) {
    // phi from head 0: Exp(r_0) = Exp(-M_0 phi)  ->  phi = -M_0^T r_0
    const Vec3 phi = -m.M[0].transpose() * p.r_S[0];
    for (int i = 0; i < 3; ++i) m.rot[0][static_cast<std::size_t>(i)] = phi[i];
  } else {
    for (int h = 0; h < m.n; ++h)
      for (int i = 0; i < 3; ++i) m.rot[static_cast<std::size_t>(h)][static_cast<std::size_t>(i)] = p.r_S[static_cast<std::size_t>(h)][i];
  }
}

}  // namespace

HeadCovariance cramerRao(const CalibrationSpan& span, const SolveOptions& opt, const ModelParameters& at,
                         std::string* message) {
  const std::string err = checkSpan(span, opt);
  if (!err.empty()) {
    if (message) *message = err;
    return {};
  }
  Model m;
  initModel(span, opt, m);
  if (m.hard && !fitRelative(span, m, message)) return {};
  setParameters(m, at);
  m.data = prepare(span, opt);
  Built b = buildProblem(span, opt, m, false);
  return headCovariance(m, information(b, false), opt);
}

SolveResult solve(const CalibrationSpan& span, const SolveOptions& opt) {
  SolveResult res;
  res.epochs = span.obs.size();
  res.span_s = toSeconds(span.t_last - span.t_first);
  const std::string err = checkSpan(span, opt);
  if (!err.empty()) {
    res.message = err;
    return res;
  }
  // excitation: scatter of the accelerometer's acceleration in B about its mean
  {
    Vec3 mean = Vec3::Zero();
    for (const Observation& o : span.obs) mean += span.C_B_A * o.alpha_A;
    mean /= static_cast<double>(span.obs.size());
    Mat3 S = Mat3::Zero();
    for (const Observation& o : span.obs) {
      const Vec3 a = span.C_B_A * o.alpha_A - mean;
      S += a * a.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Mat3> es(S);
    for (int i = 0; i < 3; ++i) res.excitation_eigenvalues.push_back(es.eigenvalues()[i]);
  }
  Model m;
  initModel(span, opt, m);
  std::string msg;
  if (m.hard && !fitRelative(span, m, &msg)) {
    res.message = msg;
    return res;
  }
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
  res.iterations = static_cast<int>(sum.iterations.size());
  if (!sum.IsSolutionUsable()) {
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
    Eigen::Matrix3d K;
    K << 1 + m.scale[0], m.nonorth[2], m.nonorth[1], m.nonorth[2], 1 + m.scale[1], m.nonorth[0], m.nonorth[1],
        m.nonorth[0], 1 + m.scale[2];
    const Mat3 Kinv = K.inverse();
    for (const Observation& o : span.obs) {
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
    res.message = s.str();
    return res;
  }
  res.ok = true;
  res.message = sum.BriefReport();
  return res;
}

}  // namespace boresight::calib

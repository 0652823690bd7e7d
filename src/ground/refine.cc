// The joint Ceres refinement of method C, its covariance and the bias/tilt observability decision
// (model and decision rule in solver.h).
#include <boresight/core/rotation.h>
#include <boresight/ground/solver.h>
#include <boresight/model/jacobian_check.h>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>

namespace boresight::ground {
namespace {

void storeRowMajor(const Mat3& M, double* out) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] = M(r, c);
}

/// A target centroid. w_t = C_t_m(ref) r_m is precomputed; the model is
///   d_s = Exp(e) C_s_t(design) Exp(rho) w_t,  (u, v) = project(d_s; f, u0, v0, Sx, k1)
/// residual = (model - measured) / sigma (pixels over pixels).
class TargetCost {
 public:
  TargetCost(const Vec3& w_t, const Mat3& C_design, double u, double v, double su, double sv, double k1)
      : w_{w_t.x(), w_t.y(), w_t.z()}, u_(u), v_(v), su_(su), sv_(sv), k1_(k1) {
    storeRowMajor(C_design, C_);
  }
  template <typename T>
  bool operator()(const T* e, const T* rho, const T* intr, const T* k1, T* res) const {
    return eval(e, rho, intr, k1[0], res);
  }
  template <typename T>
  bool operator()(const T* e, const T* rho, const T* intr, T* res) const {
    return eval(e, rho, intr, T(k1_), res);
  }

 private:
  template <typename T>
  bool eval(const T* e, const T* rho, const T* intr, const T& k1, T* res) const {
    const T w[3] = {T(w_[0]), T(w_[1]), T(w_[2])};
    T w1[3], w2[3], d[3], uv[2];
    ceres::AngleAxisRotatePoint(rho, w, w1);
    for (int i = 0; i < 3; ++i) w2[i] = C_[3 * i] * w1[0] + C_[3 * i + 1] * w1[1] + C_[3 * i + 2] * w1[2];
    ceres::AngleAxisRotatePoint(e, w2, d);
    if (!project(d, intr, k1, uv)) return false;
    res[0] = (uv[0] - u_) / su_;
    res[1] = (uv[1] - v_) / sv_;
    return true;
  }
  double w_[3], C_[9];
  double u_, v_, su_, sv_, k1_;
};

/// A prism normal: n_m = C_t_m(ref)^T Exp(-rho) axis_t; residual = (e_az . n, e_el . n) / sigma,
/// the tangent angles of the model direction away from the measured one.
class PrismCost {
 public:
  PrismCost(const Vec3& axis_t, const Mat3& C_ref, double az, double el, double sigma)
      : a_{axis_t.x(), axis_t.y(), axis_t.z()}, sigma_(sigma) {
    storeRowMajor(C_ref.transpose(), CT_);
    Vec3 e_az, e_el;
    tangentBasis(az, el, e_az, e_el);
    for (int i = 0; i < 3; ++i) {
      eaz_[i] = e_az[i];
      eel_[i] = e_el[i];
    }
  }
  template <typename T>
  bool operator()(const T* rho, T* res) const {
    const T a[3] = {T(a_[0]), T(a_[1]), T(a_[2])};
    const T minus[3] = {-rho[0], -rho[1], -rho[2]};
    T p[3], n[3];
    ceres::AngleAxisRotatePoint(minus, a, p);
    for (int i = 0; i < 3; ++i) n[i] = CT_[3 * i] * p[0] + CT_[3 * i + 1] * p[1] + CT_[3 * i + 2] * p[2];
    res[0] = (eaz_[0] * n[0] + eaz_[1] * n[1] + eaz_[2] * n[2]) / sigma_;
    res[1] = (eel_[0] * n[0] + eel_[1] * n[1] + eel_[2] * n[2]) / sigma_;
    return true;
  }

 private:
  double a_[3], CT_[9], eaz_[3], eel_[3];
  double sigma_;
};

/// The mean specific force of a position: f = Exp(rho) C_t_m(ref) (0, 0, g) + b, per axis over the
/// sigma of the mean.
class AccelCost {
 public:
  AccelCost(const Vec3& g_t_ref, const Vec3& f_mean, const Vec3& sigma)
      : g_{g_t_ref.x(), g_t_ref.y(), g_t_ref.z()}, f_{f_mean.x(), f_mean.y(), f_mean.z()},
        s_{sigma.x(), sigma.y(), sigma.z()} {}
  template <typename T>
  bool operator()(const T* rho, const T* b, T* res) const {
    const T g[3] = {T(g_[0]), T(g_[1]), T(g_[2])};
    T p[3];
    ceres::AngleAxisRotatePoint(rho, g, p);
    for (int i = 0; i < 3; ++i) res[i] = (p[i] + b[i] - f_[i]) / s_[i];
    return true;
  }

 private:
  double g_[3], f_[3], s_[3];
};

/// A Gaussian prior on N parameters: residual_i = w_i (x_i - x0_i) (w_i = 1/sigma_i, 0 = none).
template <int N>
class PriorCost {
 public:
  PriorCost(const double* x0, const double* w) {
    for (int i = 0; i < N; ++i) {
      x0_[i] = x0[i];
      w_[i] = w[i];
    }
  }
  template <typename T>
  bool operator()(const T* x, T* res) const {
    for (int i = 0; i < N; ++i) res[i] = w_[i] * (x[i] - x0_[i]);
    return true;
  }

 private:
  double x0_[N], w_[N];
};

struct Blocks {
  double e[3] = {0, 0, 0};
  double intr[4] = {0, 0, 0, 0};
  double k1 = 0;
  std::vector<std::array<double, 3>> rho;
  double b[3] = {0, 0, 0};
};

/// Per-position sigma of the mean specific force.
Vec3 accelMeanSigma(const Position& p, const NoiseModel& noise) {
  const double n = static_cast<double>(p.accel_mps2.size());
  if (noise.accel_sigma_mps2 > 0) return Vec3::Constant(noise.accel_sigma_mps2 / std::sqrt(n));
  if (p.accel_mps2.size() < 2) return Vec3::Constant(50e-6 * 9.80665);  // one sample: 50 ug
  Vec3 mean = Vec3::Zero(), sq = Vec3::Zero();
  for (const Vec3& f : p.accel_mps2) mean += f;
  mean /= n;
  for (const Vec3& f : p.accel_mps2) sq += (f - mean).cwiseAbs2();
  const Vec3 sd = (sq / (n - 1)).cwiseSqrt();
  return (sd.cwiseMax(Vec3::Constant(1e-6)) / std::sqrt(n)).eval();  // floor 0.1 ug per sample
}

class Problem {
 public:
  Problem(const Measurement& m, const SeedResult& seed) : m_(m), seed_(seed) {
    C_design_ = m.q_s_t_design.toRotationMatrix();
    const CameraPrior& cam = m.camera;
    blocks_.intr[0] = cam.nominal.f;
    blocks_.intr[1] = cam.nominal.u0;
    blocks_.intr[2] = cam.nominal.v0;
    blocks_.intr[3] = cam.nominal.sx;
    blocks_.k1 = cam.nominal.k1;
    const Vec3 e0 = seed.error_angles_rad;
    for (int i = 0; i < 3; ++i) blocks_.e[i] = e0[i];
    blocks_.rho.assign(m.positions.size(), {0.0, 0.0, 0.0});
  }

  /// Builds the problem with a bias prior of weight w_bias (1/sigma per axis, 0 = none).
  void build(const double* w_bias) {
    problem_ = std::make_unique<ceres::Problem>();
    data_blocks_.clear();
    by_functor_.clear();
    const auto add = [this](const char* functor, ceres::ResidualBlockId id) {
      data_blocks_.push_back(id);
      by_functor_[functor].push_back(id);
    };
    const CameraPrior& cam = m_.camera;
    const NoiseModel& nz = m_.noise;
    const double fth = cam.nominal.f * nz.theodolite_sigma_rad;
    const double su = std::hypot(nz.centroid_sigma_px, fth);
    const double sv = std::hypot(nz.centroid_sigma_px, fth * cam.nominal.sx);
    for (std::size_t k = 0; k < m_.positions.size(); ++k) {
      const Position& p = m_.positions[k];
      const Mat3& C_ref = seed_.C_t_m[k];
      double* rho = blocks_.rho[k].data();
      for (const TargetReading& t : p.targets) {
        const Vec3 w = C_ref * directionFromAzEl(t.az_rad, t.el_rad);
        auto* f = new TargetCost(w, C_design_, t.u_px, t.v_px, su, sv, cam.nominal.k1);
        if (cam.estimate_k1)
          add("TargetCost (k1 free)", problem_->AddResidualBlock(
              new ceres::AutoDiffCostFunction<TargetCost, 2, 3, 3, 4, 1>(f), nullptr, blocks_.e, rho, blocks_.intr,
              &blocks_.k1));
        else
          add("TargetCost", problem_->AddResidualBlock(
              new ceres::AutoDiffCostFunction<TargetCost, 2, 3, 3, 4>(f), nullptr, blocks_.e, rho, blocks_.intr));
      }
      for (const PrismReading& r : p.prisms)
        add("PrismCost", problem_->AddResidualBlock(
            new ceres::AutoDiffCostFunction<PrismCost, 2, 3>(
                new PrismCost(r.axis_t, C_ref, r.az_rad, r.el_rad, nz.theodolite_sigma_rad)),
            nullptr, rho));
      Vec3 mean = Vec3::Zero();
      for (const Vec3& f : p.accel_mps2) mean += f;
      mean /= static_cast<double>(p.accel_mps2.size());
      add("AccelCost", problem_->AddResidualBlock(
          new ceres::AutoDiffCostFunction<AccelCost, 3, 3, 3>(
              new AccelCost(C_ref.col(2) * m_.gravity_mps2, mean, accelMeanSigma(p, nz))),
          nullptr, rho, blocks_.b));
    }
    const double x0[4] = {cam.nominal.f, cam.nominal.u0, cam.nominal.v0, cam.nominal.sx};
    const double wi[4] = {1.0 / cam.f_sigma_px, 1.0 / cam.pp_sigma_px, 1.0 / cam.pp_sigma_px, 1.0 / cam.sx_sigma};
    add("PriorCost<4>", problem_->AddResidualBlock(
        new ceres::AutoDiffCostFunction<PriorCost<4>, 4, 4>(new PriorCost<4>(x0, wi)), nullptr, blocks_.intr));
    if (cam.estimate_k1) {
      const double k0 = cam.nominal.k1, wk = 1.0 / cam.k1_sigma;
      add("PriorCost<1>", problem_->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PriorCost<1>, 1, 1>(new PriorCost<1>(&k0, &wk)), nullptr, &blocks_.k1));
    }
    const double zero[3] = {0, 0, 0};
    if (w_bias[0] > 0 || w_bias[1] > 0 || w_bias[2] > 0)
      by_functor_["PriorCost<3>"].push_back(problem_->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PriorCost<3>, 3, 3>(new PriorCost<3>(zero, w_bias)), nullptr, blocks_.b));
    // parameter order of the covariance: e, intrinsics, [k1], rho_1..rho_K, b
    order_ = {blocks_.e, blocks_.intr};
    if (cam.estimate_k1) order_.push_back(&blocks_.k1);
    for (auto& r : blocks_.rho) order_.push_back(r.data());
    order_.push_back(blocks_.b);
  }

  bool solve(int max_iterations, int& iterations, bool& converged) {
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::DENSE_QR;
    o.logging_type = ceres::SILENT;
    o.minimizer_progress_to_stdout = false;
    o.max_num_iterations = max_iterations;
    o.function_tolerance = 1e-14;
    o.gradient_tolerance = 1e-14;
    o.parameter_tolerance = 1e-12;
    o.num_threads = 1;
    ceres::Solver::Summary s;
    ceres::Solve(o, problem_.get(), &s);
    iterations += static_cast<int>(s.iterations.size());
    converged = s.termination_type == ceres::CONVERGENCE;
    return s.IsSolutionUsable();
  }

  /// Jacobian of the data residuals (and intrinsic priors) at the current point, dense, columns in
  /// order_ (e, intrinsics, [k1], rho..., b).
  Eigen::MatrixXd dataJacobian() {
    ceres::Problem::EvaluateOptions eo;
    eo.parameter_blocks = order_;
    eo.residual_blocks = data_blocks_;
    eo.apply_loss_function = false;
    double cost = 0;
    ceres::CRSMatrix crs;
    problem_->Evaluate(eo, &cost, nullptr, nullptr, &crs);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int r = 0; r < crs.num_rows; ++r)
      for (int i = crs.rows[static_cast<std::size_t>(r)]; i < crs.rows[static_cast<std::size_t>(r) + 1]; ++i)
        J(r, crs.cols[static_cast<std::size_t>(i)]) = crs.values[static_cast<std::size_t>(i)];
    return J;
  }

  /// Every functor's Jacobian at the current point (model/jacobian_check.h).
  std::vector<model::JacobianCheck> checkJacobians(std::size_t max_blocks, double relative_precision) const {
    std::vector<model::JacobianCheck> out;
    for (const auto& [name, ids] : by_functor_) model::probeJacobians(*problem_, ids, name, max_blocks, relative_precision, &out);
    return out;
  }

  int biasIndex() const { return nParams() - 3; }
  int rhoIndex(std::size_t k) const { return 7 + (m_.camera.estimate_k1 ? 1 : 0) + 3 * static_cast<int>(k); }
  int nParams() const { return 7 + (m_.camera.estimate_k1 ? 1 : 0) + 3 * static_cast<int>(m_.positions.size()) + 3; }

  Blocks blocks_;
  Mat3 C_design_;

 private:
  const Measurement& m_;
  const SeedResult& seed_;
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<ceres::ResidualBlockId> data_blocks_;
  std::map<std::string, std::vector<ceres::ResidualBlockId>> by_functor_;  ///< every block, by functor
  std::vector<double*> order_;
};

Mat3 expRot(const double* r) { return core::so3Exp(Vec3(r[0], r[1], r[2])); }

}  // namespace

std::vector<model::JacobianCheck> checkJacobians(const Measurement& m, const RefineOptions& opt, double relative_precision,
                                                 std::string* error) {
  GroundResult g;
  if (!validateMeasurement(m, opt.source_name, error)) return {};
  if (!solveSeed(m, g.seed, error)) return {};
  Problem pr(m, g.seed);
  const double w_bias[3] = {1.0, 2.0, 3.0};
  pr.build(w_bias);
  // Away from zero and from the seed: small rotations of the positions, a bias, intrinsics off nominal.
  for (std::size_t k = 0; k < pr.blocks_.rho.size(); ++k)
    pr.blocks_.rho[k] = {1e-3 * static_cast<double>(k + 1), -2e-3, 1.5e-3};
  for (int i = 0; i < 3; ++i) {
    pr.blocks_.e[i] += 1e-3 * (i + 1);
    pr.blocks_.b[i] = 1e-3 * (3 - i);
  }
  pr.blocks_.intr[0] *= 1.001;
  pr.blocks_.intr[1] += 0.5;
  pr.blocks_.intr[2] -= 0.3;
  pr.blocks_.intr[3] *= 0.999;
  pr.blocks_.k1 += 1e-3;
  return pr.checkJacobians(20, relative_precision);
}

bool solveGround(const Measurement& m, const RefineOptions& opt, GroundResult& out, std::string* error) {
  out = GroundResult{};
  if (!validateMeasurement(m, opt.source_name, error)) return false;
  if (!solveSeed(m, out.seed, error)) return false;
  // The error angles are a small rotation from the design: a seed far from it means a convention
  // error (design_q_s_t transposed, azimuths clockwise, a wrong prism axis), not a measurement.
  const double dev_deg = out.seed.error_angles_rad.norm() / kRadPerDeg;
  if (dev_deg > opt.max_design_deviation_deg) {
    if (error)
      *error = opt.source_name + ": the seed mounting is " + std::to_string(dev_deg) +
               " deg from design_q_s_t (is it C_s_t, IMU to sensor? azimuths counterclockwise? the prism axis_t?)";
    return false;
  }

  Problem pr(m, out.seed);
  const double ba = opt.assumed_bias_mps2;
  const int nb = pr.nParams();
  const int ib = pr.biasIndex();

  // 1. Regularised solve (prior of the assumed size on every bias axis) and the observability test.
  const double w_all[3] = {1.0 / ba, 1.0 / ba, 1.0 / ba};
  pr.build(w_all);
  if (!pr.solve(opt.max_iterations, out.iterations, out.converged)) {
    if (error) *error = "the refinement failed numerically (Ceres: solution not usable)";
    return false;
  }
  Eigen::MatrixXd J = pr.dataJacobian();
  Eigen::MatrixXd H = J.transpose() * J;
  {
    // rank and conditioning of the data information (bias unconstrained), Jacobi-scaled
    Eigen::VectorXd d = H.diagonal();
    Eigen::VectorXd s(nb);
    for (int i = 0; i < nb; ++i) s[i] = d[i] > 0 ? 1.0 / std::sqrt(d[i]) : 0.0;
    const Eigen::MatrixXd Hs = s.asDiagonal() * H * s.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hs);
    const double lmax = es.eigenvalues().maxCoeff();
    out.parameters = nb;
    out.rank = 0;
    for (int i = 0; i < nb; ++i)
      if (es.eigenvalues()[i] > 1e-10 * lmax) ++out.rank;
    // rank deficient: infinite; otherwise the ratio of the extreme eigenvalues
    out.condition = out.rank < nb ? std::numeric_limits<double>::infinity() : lmax / es.eigenvalues().minCoeff();
  }
  Eigen::MatrixXd Hreg = H;
  for (int j = 0; j < 3; ++j) Hreg(ib + j, ib + j) += 1.0 / (ba * ba);
  const Eigen::MatrixXd Creg = Hreg.ldlt().solve(Eigen::MatrixXd::Identity(nb, nb));
  double w_final[3] = {0, 0, 0};
  for (int j = 0; j < 3; ++j) {
    out.bias_observable[j] = std::sqrt(std::max(0.0, Creg(ib + j, ib + j))) <= ba / opt.separation_ratio;
    if (!out.bias_observable[j]) w_final[j] = 1.0 / ba;
  }

  // 2. Final solve: the prior stays only on the axes the set-up cannot separate.
  pr.build(w_final);
  if (!pr.solve(opt.max_iterations, out.iterations, out.converged)) {
    if (error) *error = "the refinement failed numerically (Ceres: solution not usable)";
    return false;
  }
  J = pr.dataJacobian();
  H = J.transpose() * J;
  for (int j = 0; j < 3; ++j) H(ib + j, ib + j) += w_final[j] * w_final[j];
  Eigen::LDLT<Eigen::MatrixXd> ldlt(H);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
    if (error) *error = "the information matrix is singular even with the priors";
    return false;
  }
  const Eigen::MatrixXd C = ldlt.solve(Eigen::MatrixXd::Identity(nb, nb));

  const Blocks& b = pr.blocks_;
  out.error_angles_rad = Vec3(b.e[0], b.e[1], b.e[2]);
  out.C_s_t = expRot(b.e) * pr.C_design_;
  out.error_cov_rad2 = C.block<3, 3>(0, 0);
  out.bias_mps2 = Vec3(b.b[0], b.b[1], b.b[2]);
  for (int j = 0; j < 3; ++j) out.bias_sigma_mps2[j] = std::sqrt(C(ib + j, ib + j));
  // the shift of e that a bias of the assumed size along each unseparated axis causes (regression of
  // e on b_j in the posterior), root-sum-squared over those axes
  Vec3 hidden2 = Vec3::Zero();
  for (int j = 0; j < 3; ++j) {
    if (out.bias_observable[j]) continue;
    const Vec3 shift = C.block<3, 1>(0, ib + j) / C(ib + j, ib + j) * ba;
    hidden2 += shift.cwiseAbs2();
  }
  out.hidden_tilt_rad = hidden2.cwiseSqrt();
  out.camera = Intrinsics{b.intr[0], b.intr[1], b.intr[2], b.intr[3], b.k1};
  out.camera_sigma = Intrinsics{std::sqrt(C(3, 3)), std::sqrt(C(4, 4)), std::sqrt(C(5, 5)), std::sqrt(C(6, 6)),
                                m.camera.estimate_k1 ? std::sqrt(C(7, 7)) : 0.0};

  // residuals per position (in pixels, arcsec, m/s^2)
  double sum2 = 0;
  std::size_t n2 = 0;
  for (std::size_t k = 0; k < m.positions.size(); ++k) {
    const Position& p = m.positions[k];
    PositionResult r;
    r.name = p.name;
    r.C_t_m = expRot(b.rho[k].data()) * out.seed.C_t_m[k];
    const Mat3 C_s_m = out.C_s_t * r.C_t_m;
    double s2 = 0;
    for (const TargetReading& t : p.targets) {
      double u = 0, v = 0;
      projectPoint(C_s_m * directionFromAzEl(t.az_rad, t.el_rad), out.camera, u, v);
      s2 += (u - t.u_px) * (u - t.u_px) + (v - t.v_px) * (v - t.v_px);
    }
    sum2 += s2;
    n2 += 2 * p.targets.size();
    r.residual_rms_px = std::sqrt(s2 / (2.0 * static_cast<double>(p.targets.size())));
    double q2 = 0;
    for (const PrismReading& q : p.prisms) {
      Vec3 e_az, e_el;
      tangentBasis(q.az_rad, q.el_rad, e_az, e_el);
      const Vec3 n = r.C_t_m.transpose() * q.axis_t;
      q2 += e_az.dot(n) * e_az.dot(n) + e_el.dot(n) * e_el.dot(n);
    }
    r.prism_rms_arcsec = std::sqrt(q2 / (2.0 * static_cast<double>(p.prisms.size()))) * kArcsecPerRad;
    Vec3 mean = Vec3::Zero();
    for (const Vec3& f : p.accel_mps2) mean += f;
    mean /= static_cast<double>(p.accel_mps2.size());
    r.accel_mean_mps2 = mean;
    r.accel_residual_mps2 = mean - (r.C_t_m.col(2) * m.gravity_mps2 + out.bias_mps2);
    r.accel_sample_sigma_mps2 = accelMeanSigma(p, m.noise) * std::sqrt(static_cast<double>(p.accel_mps2.size()));
    r.targets = static_cast<int>(p.targets.size());
    r.prisms = static_cast<int>(p.prisms.size());
    r.accel_samples = static_cast<int>(p.accel_mps2.size());
    out.positions.push_back(r);
  }
  out.residual_rms_px = std::sqrt(sum2 / static_cast<double>(n2));

  // plain-language statements
  static const char* kAxis[3] = {"x", "y", "z"};
  char buf[512];
  for (int j = 0; j < 3; ++j) {
    if (out.bias_observable[j]) continue;
    std::snprintf(buf, sizeof buf,
                  "accelerometer bias along IMU %s is NOT separated from the tilt by this set-up (one prism face "
                  "and positions turned only about the vertical?): an assumed bias of %.0f ug may hide a tilt of "
                  "%.1f arcsec; add a second prism face or a position tilted about a horizontal axis",
                  kAxis[j], ba / 9.80665e-6, ba / m.gravity_mps2 * kArcsecPerRad);
    out.notes.emplace_back(buf);
  }
  std::snprintf(buf, sizeof buf,
                "cross-boresight mounting angles cannot be better than the principal point sigma over the focal "
                "length: %.2f px / %.1f px = %.1f arcsec",
                m.camera.pp_sigma_px, m.camera.nominal.f, m.camera.pp_sigma_px / m.camera.nominal.f * kArcsecPerRad);
  out.notes.emplace_back(buf);
  return true;
}

}  // namespace boresight::ground

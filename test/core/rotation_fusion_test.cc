// Property tests: quaternion and rotation identities; head fusion against the brute-force weighted
// least-squares optimum; Monte Carlo: the fused error is smaller than every head's, axis by axis.
#include "boresight/core/head_fusion.h"

#include "core_test_util.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#ifdef BORESIGHT_HAVE_CERES
#include <ceres/jet.h>
#endif

namespace boresight::core {
namespace {

using test::Rng;

constexpr int kRuns = 10000;

TEST(RotationProperty, ExpLogRoundTripAndConventions) {
  Rng rng(1);
  std::uniform_real_distribution<double> ang(0.0, 3.1);
  for (int i = 0; i < kRuns; ++i) {
    const Vec3 axis = test::randomUnit(rng);
    const Vec3 phi = ang(rng) * axis;
    const Quat q = quatExp(phi);
    EXPECT_NEAR(q.norm(), 1.0, 1e-14);
    EXPECT_LT((quatLog(q) - phi).norm(), 1e-12) << "run " << i;
    // q and -q are the same attitude: the log is the same
    const Quat mq(-q.w(), -q.x(), -q.y(), -q.z());
    EXPECT_LT((quatLog(mq) - phi).norm(), 1e-12);
    // R(q) v = q (0,v) q*, and R(q) equals the matrix exponential of skew(phi)
    const Vec3 v = test::randomVec(rng, 1.0);
    const Quat pv = q * Quat(0, v.x(), v.y(), v.z()) * q.conjugate();
    EXPECT_LT((q.toRotationMatrix() * v - pv.vec()).norm(), 1e-12);
    // Rodrigues
    const double th = phi.norm();
    const Mat3 K = skew(axis);
    const Mat3 R = Mat3::Identity() + std::sin(th) * K + (1 - std::cos(th)) * K * K;
    EXPECT_LT((R - so3Exp(phi)).norm(), 1e-12);
    EXPECT_LT((so3Log(R) - phi).norm(), 1e-9);
    // composition: R(a b) = R(a) R(b); scalar-first boundary round trip
    const Quat a = test::randomQuat(rng), b = test::randomQuat(rng);
    EXPECT_LT(((a * b).toRotationMatrix() - a.toRotationMatrix() * b.toRotationMatrix()).norm(), 1e-12);
    double s[4];
    quatToScalarFirst(a, s);
    EXPECT_EQ(s[0], a.w());
    EXPECT_TRUE(quatFromScalarFirst(s).coeffs() == a.coeffs());
    // continuous() picks the sign nearest to the previous
    EXPECT_GE(continuous(mq, q).coeffs().dot(q.coeffs()), 0.0);
  }
}

TEST(RotationProperty, SmallAngleBranchIsAccurate) {
  Rng rng(2);
  for (int i = 0; i < kRuns; ++i) {
    const Vec3 phi = test::randomVec(rng, 1e-9);
    EXPECT_LT((quatLog(quatExp(phi)) - phi).norm(), 1e-20 + 1e-12 * phi.norm());
  }
}

// Brute force: minimise J(x) = sum_i |Log(Exp(-x) q_ref^-1 q_i)|^2_{W_i} by many Gauss-Newton
// iterations with a numerically differentiated Jacobian (independent of the fusion's algebra).
Quat bruteForceFusion(const std::array<Quat, kMaxHeads>& q_I_B, const std::array<Mat3, kMaxHeads>& W, int n) {
  Quat q = q_I_B[0];
  for (int it = 0; it < 30; ++it) {
    Eigen::Matrix<double, 3, 3> H = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (int k = 0; k < n; ++k) {
      const auto u = static_cast<std::size_t>(k);
      const Vec3 r = quatLog(q.conjugate() * q_I_B[u]);
      Mat3 J;
      const double h = 1e-7;
      for (int c = 0; c < 3; ++c) {
        Vec3 d = Vec3::Zero();
        d[c] = h;
        J.col(c) = (quatLog((q * quatExp(d)).conjugate() * q_I_B[u]) - quatLog((q * quatExp(-d)).conjugate() * q_I_B[u])) / (2 * h);
      }
      H += J.transpose() * W[u] * J;
      g += J.transpose() * W[u] * r;
    }
    q = (q * quatExp(-H.ldlt().solve(g))).normalized();
  }
  return q;
}

TEST(FusionProperty, EqualsBruteForceWeightedLeastSquares) {
  constexpr int kFusionRuns = 2000;
  Rng rng(3);
  std::uniform_int_distribution<int> nh(1, kMaxHeads);
  std::uniform_real_distribution<double> sig(0.5, 20.0);
  for (int run = 0; run < kFusionRuns; ++run) {
    HeadSetConfig cfg;
    cfg.n_heads = kMaxHeads;
    for (int k = 0; k < kMaxHeads; ++k) {
      HeadConfig& h = cfg.head[static_cast<std::size_t>(k)];
      h.id = 10 + k;
      h.q_Si_B = test::randomQuat(rng);
      h.boresight_Si = test::randomUnit(rng);
      h.sigma_cross_rad = sig(rng) * kRadPerArcsec;
      h.sigma_roll_rad = h.sigma_cross_rad * sig(rng);
    }
    HeadFusion fusion;
    ASSERT_EQ(fusion.configure(cfg), Status::kOk);
    const Quat q_I_B = test::randomQuat(rng);
    ValidHeads v;
    v.t = 1;
    const int n = nh(rng);
    std::array<Quat, kMaxHeads> q_I_B_i{};
    std::array<Mat3, kMaxHeads> W{};
    int m = 0;
    for (int k = 0; k < kMaxHeads; ++k) {
      if (k >= n) continue;
      const auto u = static_cast<std::size_t>(k);
      const HeadConfig& h = cfg.head[u];
      const Quat meas = test::noisyHead(rng, q_I_B * h.q_Si_B.conjugate(), h);
      v.q_I_Si[u] = meas;
      v.sigma_scale[u] = 1.0;
      v.mask |= 1u << k;
      q_I_B_i[static_cast<std::size_t>(m)] = meas * h.q_Si_B;
      W[static_cast<std::size_t>(m)] = fusion.information_B(k);
      ++m;
    }
    ASSERT_EQ(fusion.step(v), Status::kOk);
    const Quat bf = bruteForceFusion(q_I_B_i, W, m);
    const double d = angleBetween(bf, fusion.output().q_I_B);
    // both converge to the same optimum; two Gauss-Newton steps leave a third-order residual
    const double noise = std::sqrt(fusion.output().P_B.trace());
    EXPECT_LT(d, 1e-6 * noise + 1e-13) << "run " << run << " heads " << m;
  }
}

TEST(FusionMonteCarlo, FusedErrorSmallerThanEveryHeadAxisByAxis) {
  constexpr int kMcRuns = 4000;  // stated Monte Carlo size
  Rng rng(4);
  const HeadSetConfig cfg = test::graceLikeHeads(3);
  HeadFusion fusion;
  ASSERT_EQ(fusion.configure(cfg), Status::kOk);
  Eigen::Array3d var_fused = Eigen::Array3d::Zero();
  std::array<Eigen::Array3d, 3> var_head{};
  for (auto& a : var_head) a.setZero();
  Mat3 P_model = Mat3::Zero();
  for (int run = 0; run < kMcRuns; ++run) {
    const Quat q_I_B = test::randomQuat(rng);
    ValidHeads v;
    v.t = run + 1;
    for (int k = 0; k < 3; ++k) {
      const auto u = static_cast<std::size_t>(k);
      v.q_I_Si[u] = test::noisyHead(rng, q_I_B * cfg.head[u].q_Si_B.conjugate(), cfg.head[u]);
      v.sigma_scale[u] = 1.0;
      v.mask |= 1u << k;
      const Vec3 e = quatLog(q_I_B.conjugate() * v.q_I_Si[u] * cfg.head[u].q_Si_B);
      var_head[u] += e.array().square();
    }
    ASSERT_EQ(fusion.step(v), Status::kOk);
    const Vec3 e = quatLog(q_I_B.conjugate() * fusion.output().q_I_B);
    var_fused += e.array().square();
    P_model = fusion.output().P_B;
  }
  var_fused /= kMcRuns;
  for (auto& a : var_head) a /= kMcRuns;
  for (int ax = 0; ax < 3; ++ax) {
    for (int k = 0; k < 3; ++k)
      EXPECT_LT(var_fused[ax], var_head[static_cast<std::size_t>(k)][ax]) << "axis " << ax << " head " << k;
    // and the empirical variance agrees with the model covariance (4000 runs: ~2.2 % sigma of a variance)
    EXPECT_NEAR(var_fused[ax] / P_model(ax, ax), 1.0, 0.1) << "axis " << ax;
  }
  std::printf("fused 1-sigma (arcsec, B axes): %.2f %.2f %.2f; best single head: %.2f %.2f %.2f\n",
              std::sqrt(var_fused[0]) * kArcsecPerRad, std::sqrt(var_fused[1]) * kArcsecPerRad,
              std::sqrt(var_fused[2]) * kArcsecPerRad,
              std::sqrt(std::min({var_head[0][0], var_head[1][0], var_head[2][0]})) * kArcsecPerRad,
              std::sqrt(std::min({var_head[0][1], var_head[1][1], var_head[2][1]})) * kArcsecPerRad,
              std::sqrt(std::min({var_head[0][2], var_head[1][2], var_head[2][2]})) * kArcsecPerRad);
}

TEST(FusionMonteCarlo, NaiveQuaternionAveragingIsWorse) {
  // The documented failure mode (METHODS 1.3): averaging the heads' body quaternions ignores the
  // anisotropy; the information-weighted fusion must beat it on every axis.
  constexpr int kMcRuns = 4000;
  Rng rng(5);
  const HeadSetConfig cfg = test::graceLikeHeads(3);
  HeadFusion fusion;
  ASSERT_EQ(fusion.configure(cfg), Status::kOk);
  Eigen::Array3d vf = Eigen::Array3d::Zero(), vn = Eigen::Array3d::Zero();
  for (int run = 0; run < kMcRuns; ++run) {
    const Quat q_I_B = test::randomQuat(rng);
    ValidHeads v;
    v.t = run + 1;
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (int k = 0; k < 3; ++k) {
      const auto u = static_cast<std::size_t>(k);
      v.q_I_Si[u] = test::noisyHead(rng, q_I_B * cfg.head[u].q_Si_B.conjugate(), cfg.head[u]);
      v.sigma_scale[u] = 1.0;
      v.mask |= 1u << k;
      const Quat qb = continuous(v.q_I_Si[u] * cfg.head[u].q_Si_B, q_I_B);
      sum += Eigen::Vector4d(qb.w(), qb.x(), qb.y(), qb.z());
    }
    ASSERT_EQ(fusion.step(v), Status::kOk);
    const Quat naive = Quat(sum[0], sum[1], sum[2], sum[3]).normalized();
    vf += quatLog(q_I_B.conjugate() * fusion.output().q_I_B).array().square();
    vn += quatLog(q_I_B.conjugate() * naive).array().square();
  }
  for (int ax = 0; ax < 3; ++ax) EXPECT_LT(vf[ax], vn[ax]) << "axis " << ax;
  std::printf("RMS ratio naive/fused per axis: %.2f %.2f %.2f\n", std::sqrt(vn[0] / vf[0]), std::sqrt(vn[1] / vf[1]),
              std::sqrt(vn[2] / vf[2]));
}

// ---- the templated rotation functions (rotation_t.h) with double against Eigen's own ----

TEST(RotationTemplated, AgreesWithEigenOverRandomRotationsIncludingTinyAngles) {
  Rng rng(11);
  std::uniform_real_distribution<double> ang(0.0, 3.14159);
  std::uniform_real_distribution<double> lg(-14.0, -1.0);
  int tiny = 0;
  for (int i = 0; i < kRuns; ++i) {
    // half the angles anywhere in (0, pi), half log-uniform in (1e-14, 0.1) rad: the series branches
    const double th = (i % 2 == 0) ? ang(rng) : std::pow(10.0, lg(rng));
    tiny += th < 1e-2 ? 1 : 0;
    const Vec3 axis = test::randomUnit(rng);
    const Vec3 phi = th * axis;
    const Quat ref(Eigen::AngleAxisd(th, axis));  // Eigen's exponential
    const double p[3] = {phi.x(), phi.y(), phi.z()};
    double q[4];
    rot::quatExp(p, q);
    const Quat qt(q[0], q[1], q[2], q[3]);
    ASSERT_LT((qt.coeffs() - ref.coeffs()).norm(), 2e-16 * 8) << "Exp, angle " << th;
    // Log against Eigen's AngleAxis (angle times axis), relative to the angle
    double back[3];
    const double qa[4] = {ref.w(), ref.x(), ref.y(), ref.z()};
    rot::quatLog(qa, back);
    const Eigen::AngleAxisd aa(ref);
    const Vec3 phi_ref = aa.angle() * aa.axis();
    ASSERT_LT((Vec3(back[0], back[1], back[2]) - phi_ref).norm(), 1e-15 + 1e-13 * th) << "Log, angle " << th;
    ASSERT_LT((Vec3(back[0], back[1], back[2]) - phi).norm(), 1e-15 + 1e-13 * th);
    // product, rotation of a vector, quaternion <-> matrix
    const Quat a = test::randomQuat(rng), b = test::randomQuat(rng);
    const double aw[4] = {a.w(), a.x(), a.y(), a.z()}, bw[4] = {b.w(), b.x(), b.y(), b.z()};
    double ab[4];
    rot::quatProduct(aw, bw, ab);
    const Quat abe = a * b;
    ASSERT_LT((Quat(ab[0], ab[1], ab[2], ab[3]).coeffs() - abe.coeffs()).norm(), 1e-15);
    const Vec3 v = test::randomVec(rng, 1.0);
    const double vv[3] = {v.x(), v.y(), v.z()};
    double rv[3];
    rot::quatRotate(aw, vv, rv);
    ASSERT_LT((Vec3(rv[0], rv[1], rv[2]) - a * v).norm(), 1e-14);
    double R[9];
    rot::quatToMatrix(aw, R);
    const Mat3 Re = a.toRotationMatrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(R[3 * r + c], Re(r, c), 1e-15);
    double qm[4];
    rot::matrixToQuat(R, qm);
    const Quat qme(qm[0], qm[1], qm[2], qm[3]);
    ASSERT_LT(std::min((qme.coeffs() - a.coeffs()).norm(), (qme.coeffs() + a.coeffs()).norm()), 1e-14);
    ASSERT_GE(qm[0], 0.0);
  }
  EXPECT_GT(tiny, kRuns / 3);
  // the core's Eigen wrappers are these functions
  const Vec3 phi(1e-9, -2e-9, 3e-10);
  EXPECT_LT((quatLog(quatExp(phi)) - phi).norm(), 1e-24);
  // a rotation by 180 degrees through the matrix path
  double R[9] = {1, 0, 0, 0, -1, 0, 0, 0, -1}, q[4];
  rot::matrixToQuat(R, q);
  EXPECT_NEAR(std::abs(q[1]), 1.0, 1e-15);
}

#ifdef BORESIGHT_HAVE_CERES
TEST(RotationTemplated, JetDerivativesOfExpAndLogAreFiniteAtZeroAndMatchFiniteDifferences) {
  using J = ceres::Jet<double, 4>;
  Rng rng(12);
  // points: exactly zero, tiny, at the series/closed-form switch, and ordinary
  for (double th : {0.0, 1e-12, 1e-6, 0.00999, 0.01001, 0.3, 2.0}) {
    const Vec3 axis = th == 0.0 ? Vec3::UnitX() : test::randomUnit(rng);
    const Vec3 phi0 = th * axis;
    // Exp: d q / d phi
    J p[3];
    for (int k = 0; k < 3; ++k) p[k] = J(phi0[k], k);
    J q[4];
    rot::quatExp(p, q);
    const double h = 1e-7;
    for (int k = 0; k < 3; ++k) {
      double pp[3] = {phi0[0], phi0[1], phi0[2]}, pm[3] = {phi0[0], phi0[1], phi0[2]}, qp[4], qm[4];
      pp[k] += h;
      pm[k] -= h;
      rot::quatExp(pp, qp);
      rot::quatExp(pm, qm);
      for (int c = 0; c < 4; ++c) {
        ASSERT_TRUE(std::isfinite(q[c].v[k]));
        EXPECT_NEAR(q[c].v[k], (qp[c] - qm[c]) / (2 * h), 1e-7) << "Exp angle " << th << " d q" << c << "/d phi" << k;
      }
    }
    // Log: d phi / d q at q = Exp(phi0) (4 inputs: w, x, y, z)
    double q0[4];
    rot::quatExp(&phi0[0], q0);
    J qj[4];
    for (int c = 0; c < 4; ++c) qj[c] = J(q0[c], c);
    J l[3];
    rot::quatLog(qj, l);
    for (int c = 0; c < 4; ++c) {
      double qp[4] = {q0[0], q0[1], q0[2], q0[3]}, qm[4] = {q0[0], q0[1], q0[2], q0[3]}, lp[3], lm[3];
      qp[c] += h;
      qm[c] -= h;
      rot::quatLog(qp, lp);
      rot::quatLog(qm, lm);
      for (int k = 0; k < 3; ++k) {
        ASSERT_TRUE(std::isfinite(l[k].v[c]));
        EXPECT_NEAR(l[k].v[c], (lp[k] - lm[k]) / (2 * h), 1e-6) << "Log angle " << th << " d phi" << k << "/d q" << c;
      }
    }
  }
  // at zero the derivative of Exp is 1/2 on the vector part, of Log 2 on the vector part
  J z[3] = {J(0.0, 0), J(0.0, 1), J(0.0, 2)}, qz[4];
  rot::quatExp(z, qz);
  EXPECT_DOUBLE_EQ(qz[1].v[0], 0.5);
  EXPECT_DOUBLE_EQ(qz[0].v[0], 0.0);
}
#endif

}  // namespace
}  // namespace boresight::core

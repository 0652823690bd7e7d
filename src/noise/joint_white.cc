// The white levels of every head axis from one likelihood: see include/boresight/noise/joint_white.h.
#include <boresight/noise/joint_white.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace boresight::noise {

namespace {

/// An orthonormal basis of a head frame with the boresight last: (u, v, b). For a +z boresight it is
/// the head's own x, y, z.
Mat3 headAxes(const Vec3& boresight) {
  const Vec3 b = boresight.normalized();
  Vec3 u = std::abs(b.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  u = (u - u.dot(b) * b).normalized();
  const Vec3 v = b.cross(u);
  Mat3 E;
  E.col(0) = u;
  E.col(1) = v;
  E.col(2) = b;
  return E;
}

}  // namespace

HeadSeriesGeometry headSeriesGeometry(const core::HeadSetConfig& hs) {
  HeadSeriesGeometry g;
  const int n = g.heads = hs.n_heads;
  for (int i = 0; i < n; ++i) {
    const auto& h = hs.head[static_cast<std::size_t>(i)];
    const Mat3 E = g.E[static_cast<std::size_t>(i)] = headAxes(h.boresight_Si);
    const Vec3 s2(h.sigma_cross_rad * h.sigma_cross_rad, h.sigma_cross_rad * h.sigma_cross_rad,
                  h.sigma_roll_rad * h.sigma_roll_rad);
    const Mat3 C_B_S = h.q_Si_B.toRotationMatrix().transpose();
    // information of the head's body-frame attitude error: C_B_S E diag(1/s2) E^T C_S_B
    g.W[static_cast<std::size_t>(i)] = C_B_S * E * s2.cwiseInverse().asDiagonal() * E.transpose() * C_B_S.transpose();
  }
  // residual_i = n_i - E_i^T C_Si_B nu_o with nu_o = (sum_j W_j)^-1 sum_j W_j C_B_Sj E_j n_j over j != i
  g.G = Eigen::MatrixXd::Identity(3 * n, 3 * n);
  for (int i = 0; i < n; ++i) {
    Mat3 Wsum = Mat3::Zero();
    for (int j = 0; j < n; ++j)
      if (j != i) Wsum += g.W[static_cast<std::size_t>(j)];
    if (n < 2) break;
    const Mat3 Winv = Wsum.inverse();
    const Mat3 C_Si_B = hs.head[static_cast<std::size_t>(i)].q_Si_B.toRotationMatrix();
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      const Mat3 C_B_Sj = hs.head[static_cast<std::size_t>(j)].q_Si_B.toRotationMatrix().transpose();
      g.G.block<3, 3>(3 * i, 3 * j) = -g.E[static_cast<std::size_t>(i)].transpose() * C_Si_B * Winv *
                                      g.W[static_cast<std::size_t>(j)] * C_B_Sj * g.E[static_cast<std::size_t>(j)];
    }
  }
  return g;
}

double JointWhite::level(int a) const { return std::sqrt(std::max(0.0, variance[a])); }

double JointWhite::levelSigma(int a) const {
  const double se = std::sqrt(std::max(0.0, cov(a, a)));
  const double l = level(a);
  // the delta method fails at zero: there the level's uncertainty is the square root of the variance's
  return l > std::sqrt(se) ? se / (2 * l) : std::sqrt(se);
}

JointWhite fitJointWhite(const Eigen::MatrixXd& diff_sum, double K, const Eigen::MatrixXd& G, const Eigen::VectorXd& start,
                         bool overlapping) {
  JointWhite out;
  const Eigen::Index n = G.cols();
  out.variance = start;
  out.cov = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  out.determined.assign(static_cast<std::size_t>(n), false);
  if (n == 0 || G.rows() != n || diff_sum.rows() != n || diff_sum.cols() != n || start.size() != n) {
    out.message = "inconsistent sizes";
    return out;
  }
  if (!(K >= 2) || !diff_sum.allFinite()) {
    out.message = "fewer than two differences";
    return out;
  }
  // The range of G: the combinations of the noise the series carry (the attitude cancels).
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(G, Eigen::ComputeFullU);
  const Eigen::VectorXd& sv = svd.singularValues();
  Eigen::Index r = 0;
  while (r < sv.size() && sv[r] > 1e-9 * sv[0]) ++r;
  if (r == 0) {
    out.message = "the series carry no noise combination";
    return out;
  }
  const Eigen::MatrixXd U = svd.matrixU().leftCols(r);
  const Eigen::MatrixXd S = U.transpose() * diff_sum * U / K;  // sample covariance of the projected differences
  const Eigen::MatrixXd H = U.transpose() * G;                 // columns h_a
  const double Keff = overlapping ? K / 1.5 : K;
  out.effective_pairs = Keff;

  Eigen::VectorXd s = start.cwiseMax(0.0);
  // scale the start to the data (its split between the axes is what undetermined directions keep)
  {
    const double model_tr = 2 * (H * s.asDiagonal() * H.transpose()).trace();
    if (model_tr > 0) {
      s *= S.trace() / model_tr;
    } else {
      s.setConstant(S.trace() / (2 * H.squaredNorm()));
    }
  }
  const double floor = 1e-12 * std::max(s.maxCoeff(), 1e-300);

  struct Eval {
    double ll = -std::numeric_limits<double>::infinity();
    Eigen::VectorXd score;
    Eigen::MatrixXd F;
  };
  auto evaluate = [&](const Eigen::VectorXd& v, bool derivatives) {
    Eval e;
    const Eigen::MatrixXd C = 2 * H * v.asDiagonal() * H.transpose();
    Eigen::LLT<Eigen::MatrixXd> llt(C);
    if (llt.info() != Eigen::Success) return e;
    const Eigen::MatrixXd L = llt.matrixL();
    double logdet = 0;
    for (Eigen::Index i = 0; i < r; ++i) logdet += 2 * std::log(L(i, i));
    const Eigen::MatrixXd Ci = llt.solve(Eigen::MatrixXd::Identity(r, r));
    e.ll = -0.5 * Keff * (logdet + (Ci * S).trace());
    if (!derivatives) return e;
    const Eigen::MatrixXd CiH = Ci * H;                 // C^-1 h_a
    const Eigen::MatrixXd P = H.transpose() * CiH;       // h_a^T C^-1 h_b
    const Eigen::MatrixXd Q = CiH.transpose() * S * CiH; // h_a^T C^-1 S C^-1 h_b
    e.score = Keff * (Q.diagonal() - P.diagonal());
    e.F = 2 * Keff * P.cwiseAbs2();
    return e;
  };

  // Pseudo-inverse solve on the free components (directions the data do not determine get no step).
  auto solveFree = [&](const Eigen::MatrixXd& F, const Eigen::VectorXd& g, const std::vector<bool>& free) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index a = 0; a < n; ++a)
      if (free[static_cast<std::size_t>(a)]) idx.push_back(a);
    Eigen::VectorXd step = Eigen::VectorXd::Zero(n);
    const auto m = static_cast<Eigen::Index>(idx.size());
    if (m == 0) return step;
    Eigen::MatrixXd Ff(m, m);
    Eigen::VectorXd gf(m), d(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      gf[i] = g[idx[static_cast<std::size_t>(i)]];
      d[i] = std::sqrt(std::max(F(idx[static_cast<std::size_t>(i)], idx[static_cast<std::size_t>(i)]), 1e-300));
      for (Eigen::Index j = 0; j < m; ++j) Ff(i, j) = F(idx[static_cast<std::size_t>(i)], idx[static_cast<std::size_t>(j)]);
    }
    const Eigen::MatrixXd Fn = d.cwiseInverse().asDiagonal() * Ff * d.cwiseInverse().asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Fn);
    const Eigen::VectorXd& ev = es.eigenvalues();
    const double tol = 1e-9 * std::max(ev.maxCoeff(), 1e-300);
    Eigen::VectorXd y = es.eigenvectors().transpose() * d.cwiseInverse().asDiagonal() * gf;
    for (Eigen::Index i = 0; i < m; ++i) y[i] = ev[i] > tol ? y[i] / ev[i] : 0.0;
    const Eigen::VectorXd sf = d.cwiseInverse().asDiagonal() * es.eigenvectors() * y;
    for (Eigen::Index i = 0; i < m; ++i) step[idx[static_cast<std::size_t>(i)]] = sf[i];
    return step;
  };

  Eval cur = evaluate(s, true);
  if (!std::isfinite(cur.ll)) {
    out.message = "the starting covariance is singular";
    return out;
  }
  for (int it = 0; it < 200; ++it) {
    out.iterations = it + 1;
    std::vector<bool> free(static_cast<std::size_t>(n));
    for (Eigen::Index a = 0; a < n; ++a) free[static_cast<std::size_t>(a)] = s[a] > floor * 1.0001 || cur.score[a] > 0;
    const Eigen::VectorXd step = solveFree(cur.F, cur.score, free);
    double t = 1;
    Eval next;
    Eigen::VectorXd s_new;
    for (int h = 0; h < 40; ++h, t *= 0.5) {
      s_new = (s + t * step).cwiseMax(floor);
      next = evaluate(s_new, true);
      if (std::isfinite(next.ll) && next.ll >= cur.ll - 1e-12 * std::abs(cur.ll)) break;
    }
    if (!std::isfinite(next.ll)) break;
    const double change = ((s_new - s).cwiseAbs().array() / (s.cwiseAbs().array() + s.maxCoeff() * 1e-9)).maxCoeff();
    s = s_new;
    cur = next;
    if (change < 1e-9) {
      out.converged = true;
      break;
    }
  }
  if (!out.converged) out.message = "no convergence in " + std::to_string(out.iterations) + " iterations";
  out.variance = s;

  // Covariance: the inverse Fisher information where the data determine it.
  Eigen::VectorXd d = cur.F.diagonal().cwiseMax(1e-300).cwiseSqrt();
  const Eigen::MatrixXd Fn = d.cwiseInverse().asDiagonal() * cur.F * d.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Fn);
  const Eigen::VectorXd& ev = es.eigenvalues();
  const double tol = 1e-8 * std::max(ev.maxCoeff(), 1e-300);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd null_weight = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (ev[i] > tol) inv[i] = 1 / ev[i];
    else null_weight += es.eigenvectors().col(i).cwiseAbs2();
  }
  out.cov = d.cwiseInverse().asDiagonal() * es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose() *
            d.cwiseInverse().asDiagonal();
  for (Eigen::Index a = 0; a < n; ++a) {
    out.determined[static_cast<std::size_t>(a)] = null_weight[a] < 1e-2;
    if (!out.determined[static_cast<std::size_t>(a)]) out.cov(a, a) = std::numeric_limits<double>::infinity();
  }
  return out;
}

}  // namespace boresight::noise

// The white levels of every head axis at once, from the covariance of the first differences of the
// heads' residual series (see noise/run.h for the series).
//
// Each head axis a has white noise n_a (variance s_a). A head's residual series mixes its own noise
// with the other heads' (the fused attitude it is compared with): r = G n, G = I + M (M from the
// fusion weights). The attitude cancels, so with H heads G has rank 3 (H - 1): the 3 H series carry
// 3 (H - 1) independent combinations. One series' variance alone is its own level plus what the other
// heads add, and fitting the series one at a time, each with the others' levels of the previous fit
// subtracted, is a Jacobi iteration on a system whose coupling between the cross-boresight axes of
// different heads is strong: it need not converge (seen: 3-15 % high, or 0 from a poor start).
//
// Here all levels come from one likelihood. First differences of consecutive samples d = r_k - r_{k-1}
// hold the white parts (2 G diag(s) G^T) and almost nothing of what changes slower than an interval
// (a misalignment, a drift, a Gauss-Markov term of correlation time tau adds 2 sigma^2 dt / tau).
// Projected on an orthonormal basis U of G's range, the differences are Gaussian with covariance
//   C(s) = 2 sum_a s_a h_a h_a^T,   h_a = U^T G e_a,
// a linear covariance structure: the variance components s are fitted by Fisher scoring on the
// Wishart likelihood of the differences' sum of squares (the scoring step of a REML / Foerstner
// variance-component estimation), s >= 0 by an active set. Overlapping differences (every
// consecutive pair) are correlated -1/2 at lag one; the point estimate is the same, and their
// information is that of K / 1.5 independent ones (the sum of squared lag correlations, 1 + 2/4).
//
// Identifiability: the 3 H levels are determined when the matrices h_a h_a^T are linearly independent
// (geometry: two heads that share an axis direction cannot tell their noise on it apart). Directions of
// the Fisher information that the data do not determine keep the starting point's split (the
// configured levels) and the axes they involve are flagged not determined.
#pragma once

#include <boresight/core/heads.h>

#include <Eigen/Dense>

#include <array>
#include <string>
#include <vector>

namespace boresight::noise {

/// The geometry of the head residual series (noise/run.h): head i's axes (u, v, b) as the columns of
/// E[i] (head coordinates, boresight last), its information in B at its configured sigmas W[i], and
/// the mixing G (3 H x 3 H): series (i, k) = sum_(j, l) G(3 i + k, 3 j + l) n_j[l], with n_j[l] head
/// j's noise along its axis l (G's diagonal blocks are the identity; the off-diagonal ones are minus
/// what the fused attitude of the other heads passes on).
struct HeadSeriesGeometry {
  int heads = 0;
  std::array<Mat3, core::kMaxHeads> E{}, W{};
  Eigen::MatrixXd G;
};
HeadSeriesGeometry headSeriesGeometry(const core::HeadSetConfig& hs);

struct JointWhite {
  Eigen::VectorXd variance;          ///< per noise axis, units^2 per sample
  Eigen::MatrixXd cov;               ///< covariance of `variance` (inverse Fisher information)
  std::vector<bool> determined;      ///< false: the data cannot separate this axis from another
  double effective_pairs = 0;        ///< independent difference samples the information counts
  int iterations = 0;
  bool converged = false;
  std::string message;               ///< why not, when !converged
  /// 1-sigma level (sqrt of the variance) of axis a and its standard error (delta method).
  double level(int a) const;
  double levelSigma(int a) const;
};

/// diff_sum: sum over K difference vectors d of d d^T (n x n); G: the n x n mixing of the series;
/// start: starting variances (n, > 0), e.g. the configured levels squared; overlapping: the
/// differences share samples (information divided by 1.5).
JointWhite fitJointWhite(const Eigen::MatrixXd& diff_sum, double K, const Eigen::MatrixXd& G,
                         const Eigen::VectorXd& start, bool overlapping = true);

}  // namespace boresight::noise

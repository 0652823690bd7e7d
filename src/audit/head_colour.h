// Slow noise of the heads, seen through their pair residuals (the relative family; not installed).
//
// The relative family's rows are pair residuals rho_(ref,o) = e_o - e_ref in B of the heads' errors e_k.
// The rows of one time bin are whitened together for the heads' white noise (their covariance has the
// reference head's noise in every pair). Slow noise is a head's too: head k's error has, beside its
// white part, a slow part x_k (per sensor axis), and x_ref enters every pair of the bin, and every bin
// of the next half hour. A noise model fitted per pair component, independently, counts head k's slow
// error once in each pair it is in - twice for three heads - and tests of an effect on head k see
// coherent noise as independent evidence.
//
// Here the slow part is modelled where it lives: per head, a first-order Gauss-Markov error on each
// sensor axis (the cross-boresight axes x, y at one level, the axis about the boresight at its own),
// one correlation time for all heads, and a factor on the white covariances. One Kalman filter carries
// every head's state (3 per head); a block of pair rows is an observation D x + white with
// D = [... -C_B_Sref ... C_B_So ...]; its standardised innovations are the rows whitened jointly across
// pairs and in time, which is generalised least squares for every column put through the same filter.
// Held-out blocks are gaps to the filter (prediction only) when fitting; they are observed when the
// held-out likelihood is taken conditional on the fitting rows.
//
// Fitting: restricted (REML) likelihood with the given columns profiled out, maximised by BFGS over
// log levels, log time and log white factor, on blocks merged into super-bins (the slow state taken as
// constant over a super-bin; the correlation time is held at or above twice its length, so shorter
// correlation is white to this model).
#pragma once

#include "collector_impl.h"

#include <Eigen/Dense>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace boresight::audit::detail {

/// One observation of the relative family: the pair rows of one head mask at one time.
struct PairBlock {
  double t = 0;       ///< s since the start of the span
  unsigned mask = 0;  ///< head slots present; reference = lowest, pairs (ref, o) in slot order
  int row0 = 0, n = 0;  ///< rows row0 .. row0 + n - 1 (n = 3 (heads - 1))
  Eigen::MatrixXd S;  ///< white covariance of the rows (physical, rad^2)
  bool held = false;  ///< held-out block
};

struct HeadColourModel {
  int heads = 0;
  std::array<Mat3, kMaxHeads> C_B_S{};
  std::array<double, kMaxHeads> sigma_cross{}, sigma_about{};  ///< slow part per sensor axis, rad
  double tau_s = 600;        ///< correlation time, s
  double white_factor = 1;   ///< variance factor on the blocks' white covariances
  bool coloured() const;
  /// e.g. "head 1: 0.41"/0.02" (cross/about); ...; tau 610 s; white variance x1.02", heads named by
  /// `ids` (slot + 1 when not given)
  std::string describe(const std::vector<int>& ids = {}) const;
};

/// The filter over the blocks in time order: whiten() replaces a block's rows (n x columns, physical;
/// every column through the same gains: generalised least squares) by the standardised innovations.
class HeadColourFilter {
 public:
  HeadColourFilter(const HeadColourModel& m, int columns);
  /// Observes the block; returns log det of the innovation covariance (the block's -2 log-likelihood
  /// is that + n log 2 pi + |whitened data column|^2).
  double whiten(const PairBlock& b, Eigen::Ref<Eigen::MatrixXd> rows);
  /// Propagates to t without an observation (a held-out block while fitting).
  void skip(double t);

 private:
  void predict(double t);
  HeadColourModel m_;
  int ns_ = 0;
  Eigen::MatrixXd X_;  ///< state estimates, ns x columns
  Eigen::MatrixXd P_;
  Eigen::VectorXd q_;  ///< stationary variance per state
  double t_prev_ = 0;
  bool started_ = false;
};

/// The data a fit sees: fitting blocks merged into super-bins, a basis of the profiled columns.
struct HeadColourData {
  std::vector<PairBlock> blocks;
  Eigen::MatrixXd X;  ///< rows x q, the merged columns as given (physical)
  Eigen::MatrixXd B;  ///< rows x r, physical (orthonormal in the white metric): the profiled columns' span
  Eigen::VectorXd y;
  /// Restricted likelihood (the profiled columns' information term included); false: the ordinary
  /// likelihood maximised over their coefficients, whose differences between nested column sets are
  /// likelihood ratios (restricted likelihoods of different column sets are not comparable).
  bool reml = true;
  double superbin_s = 0;
  int rows = 0;
};

/// Fills a block's rows of the profiled columns and the data: v is n x (q + 1), data last (physical).
using BlockRows = std::function<void(const PairBlock&, Eigen::MatrixXd& v)>;

/// Merges the fitting blocks (not held) into super-bins of `superbin_s` (per mask, generalised means
/// with the white covariances) with q columns, the first `profiled` of them (every one when negative)
/// reduced to a basis of their span (setBasis).
HeadColourData mergeForFit(const std::vector<PairBlock>& blocks, int q, const BlockRows& rows, double superbin_s,
                           int profiled = -1);

/// Makes d.B the basis of the merged columns `cols` of d.X (the profiled set).
void setBasis(HeadColourData& d, const std::vector<int>& cols);

/// Steps under white noise (the blocks' covariances times white_factor): per time tau the reduction of
/// the data's weighted sum of squares by the g columns M (rows of the merged data) from tau on - the
/// blocks at or after tau - beyond the profiled basis d.B (a generalised-least-squares score statistic),
/// from running sums over the blocks. The blocks must be in super-bin order, as merged, and every tau a
/// super-bin boundary.
std::vector<double> stepReductions(double white_factor, const HeadColourData& d, const Eigen::MatrixXd& M,
                                   const std::vector<double>& taus);

/// -2 restricted log-likelihood of the data under the model (up to a constant of the data); the
/// ordinary one when d.reml is false.
double remlM2ll(const HeadColourModel& m, const HeadColourData& d);

struct HeadColourFit {
  HeadColourModel model;      ///< coloured (fitted) model
  HeadColourModel white;      ///< no slow part, white factor fitted
  double m2ll_white = 0, m2ll = 0;
  int params = 0;             ///< free parameters of the coloured model beyond the white one's
  int evaluations = 0;
  bool converged = false;
  /// The configured slow noise as the null (the platform file's or the overlay's Gauss-Markov parts):
  /// its levels and time fixed, the white factor fitted; the colour test then asks whether the data
  /// depart from it, not from white.
  bool configured_null = false;
  HeadColourModel configured;
  double m2ll_configured = 0;
};

/// The white factor alone fitted, the model's slow part as given; -2 log L at it in *m2ll.
HeadColourModel fitWhiteFactor(const HeadColourData& d, HeadColourModel m, double* m2ll);

/// Fits the white factor alone and the coloured model (heads' levels, one time) from `start`.
HeadColourFit fitHeadColour(const HeadColourData& d, const HeadColourModel& start);

}  // namespace boresight::audit::detail

// boresight::calib - the orbit-periodic thermal model of the relative head deformations (METHODS 2.5,
// issue 8 item 3). Batch side: allocates freely; the result goes to the core as a fixed-size
// core::ThermalHarmonicModel (ThermalFitResult::coreModel(), Pipeline::setThermalModel).
//
// Datum: head 1 = slot 0 of the head set. For every other head k the three-axis deformation of k relative
// to head 1 is the core's per-epoch estimate (core::BoresightMonitor::pair(0, k)):
//   C_S1_Sk(measured) = Exp(delta_k) C_S1_Sk^0,  delta_k in head 1's frame S1 (axes x, y, z of S1), rad,
// with covariance Sigma_1 + C0 Sigma_k C0^T from the head noise model (well known across both boresights,
// poorly about them: the boresight-roll part). A rotation common to all heads is not seen: the model is
// of relative deformations only, and says so (ThermalFitResult::datum_note).
//
// Model per head k and axis (one generalised least-squares problem per head, all three axes together,
// weighted by the inverse 3x3 covariance of every epoch):
//   delta_k(u) = c + sum_n [ A_n cos(m_n u) + B_n sin(m_n u) ]
//              + x(beta) sum_n [ A'_n cos(m_n u) + B'_n sin(m_n u) ]   (beta terms: only when determined)
//   u: argument of latitude (model/orbit_context.h: GNI1B directly, or GNV1B rotated by the Earth rotation
//   angle, ~0.1 deg); m_n the configured harmonics (default 1, 2, 3 cycles per revolution);
//   x(beta) = cos(beta) - cos(beta_ref), beta_ref the beta of the first used epoch.
// The beta modulation is fitted only when beta moves over the span by at least min_beta_range_deg (it
// moves by about 1 deg a day: weeks of data); otherwise it is reported as not determined and left out.
//
// Sigmas: from the inverse normal matrix, scaled by sqrt(chi2 / dof) when that exceeds 1 (the head noise
// model may be optimistic; a white-noise model is assumed: correlated head errors make them optimistic).
//
// Use (streaming, bounded memory apart from the decimated orbit track of ~30 bytes per 10 s):
//   ThermalCollector c;  c.configure(pipeline_cfg.heads, ThermalFitConfig{}, &err);
//   c.pushOrbit(gnv_record) ...;  c.pushHeads(head_epoch) ...   (each stream in time order; interleaved
//   freely as long as head epochs wait for a later orbit record at most max_pending at a time)
//   const ThermalFitResult r = c.fit();   // r.ok, r.error; r.heads[i] ...
//   pipeline.setThermalModel(r.coreModel());
// or in one call: fitThermal(heads, cfg, epochs, orbit_records).
#pragma once

#include "boresight/core/heads.h"
#include "boresight/core/thermal.h"
#include "boresight/core/thermal_harmonics.h"
#include "boresight/io/level1.h"
#include "boresight/model/orbit_context.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace boresight::calib {

struct ThermalFitConfig {
  /// Harmonics of u to fit, cycles per revolution (distinct, >= 1, at most core::kMaxThermalHarmonics).
  std::vector<int> harmonics{1, 2, 3};
  /// The beta modulation is fitted only when beta (max - min over the used epochs) spans this, deg.
  double min_beta_range_deg = 10.0;
  /// Fewest used epochs per head, and fewest revolutions of u over the span, for a fit.
  std::uint64_t min_epochs = 200;
  double min_revolutions = 1.0;
  /// Orbit track: one node kept per this interval, s (u is interpolated with its rate, cubic Hermite).
  double orbit_decimation_s = 10.0;
  /// A head epoch farther than this from the orbit nodes around it (or than half of it from the only
  /// node on one side) gets no u and is not used (counted in epochs_without_orbit), s.
  double max_orbit_gap_s = 120.0;
  /// Head epochs waiting for an orbit record later than them (interleaved streams), at most (about
  /// 0.4 kB each: 16384 = 2.3 h at 2 Hz). For long spans push the orbit records first (they are small).
  std::size_t max_pending = 1u << 14;
  /// Scale the sigmas by sqrt(chi2/dof) when it is above 1.
  bool scale_sigmas_by_chi2 = true;
};

/// One harmonic of one axis: delta = cos_arcsec cos(harmonic u) + sin_arcsec sin(harmonic u).
struct ThermalHarmonicTerm {
  int harmonic = 0;              ///< cycles per revolution
  double cos_arcsec = 0;         ///< cosine amplitude, arcsec
  double sin_arcsec = 0;         ///< sine amplitude, arcsec
  double sigma_cos_arcsec = 0;   ///< 1-sigma of cos_arcsec, arcsec
  double sigma_sin_arcsec = 0;   ///< 1-sigma of sin_arcsec, arcsec
};

/// One axis (x, y or z of the datum head's frame S1) of one head's deformation relative to the datum.
struct ThermalAxisFit {
  double constant_arcsec = 0;         ///< c: the mean relative misalignment, arcsec
  double sigma_constant_arcsec = 0;   ///< its 1-sigma, arcsec
  std::vector<ThermalHarmonicTerm> terms;       ///< one per configured harmonic, in config order
  /// Beta modulation, amplitudes per unit of x(beta) = cos(beta) - cos(beta_ref), arcsec; empty when
  /// the beta modulation is not determined.
  std::vector<ThermalHarmonicTerm> beta_terms;
  double rms_before_arcsec = 0;  ///< RMS of the deformation about its plain mean (constant model), arcsec
  double rms_after_arcsec = 0;   ///< RMS of the residual after the harmonic model, arcsec
  double noise_rms_arcsec = 0;   ///< RMS the head noise model alone predicts on this axis, arcsec
};

/// The fit of one non-datum head.
struct ThermalHeadFit {
  int id = 0;               ///< telemetry head id (SCA1A sca_id)
  int slot = 0;             ///< slot in the head set
  int datum_id = 0;         ///< the datum head's id (head 1 = slot 0)
  int datum_slot = 0;       ///< 0
  bool determined = false;  ///< a fit was made (enough epochs and revolutions; normal equations regular)
  std::string reason;       ///< why not, when !determined
  std::uint64_t epochs = 0;  ///< epochs used (both heads valid and u known)
  std::array<ThermalAxisFit, 3> axis{};  ///< x, y, z of S1 (the datum head's frame)
  bool beta_determined = false;  ///< the beta modulation was fitted (the span let beta move)
  double chi2_per_dof = 0;       ///< weighted residual chi2 / degrees of freedom (1 when the noise model holds)
  /// Full covariance of the coefficients (the sigmas above are the roots of its diagonal), arcsec^2,
  /// row-major, n_params x n_params, parameters ordered axis by axis (x, y, z), each axis as
  /// [constant, cos h1, sin h1, cos h2, sin h2, ..., then the beta terms in the same order when fitted].
  int n_params = 0;
  std::vector<double> covariance_arcsec2;
  /// Covariance of the predicted deformation (fit uncertainty averaged over u plus the variance left
  /// beyond the head noise), rad^2, in S1 (goes to the core with the coefficients).
  Mat3 prediction_cov_rad2 = Mat3::Zero();
};

struct ThermalFitResult {
  bool ok = false;          ///< at least one head determined
  std::string error;        ///< when !ok: what is wrong and what would be needed
  /// "head 1 (slot 0) is the datum: ..." - to be printed with the result.
  std::string datum_note;
  std::vector<int> harmonics;       ///< cycles per revolution, as configured
  std::vector<ThermalHeadFit> heads;  ///< heads 2..n (slots 1..n-1), in slot order
  bool beta_determined = false;     ///< same for every head
  std::string beta_note;            ///< why the beta modulation is (not) determined
  double beta_min_deg = 0, beta_max_deg = 0;  ///< beta angle over the used epochs, deg
  double beta_ref_deg = 0;          ///< beta_ref of x(beta), deg
  double span_s = 0;                ///< first to last used epoch, s
  double revolutions = 0;           ///< revolutions of u over the span
  bool u_from_earth_fixed = false;  ///< u from GNV1B by the Earth rotation angle (~0.1 deg), not GNI1B
  std::uint64_t head_epochs = 0;            ///< head epochs pushed
  std::uint64_t head_epochs_rejected = 0;   ///< rejected by the core's validator (bad data)
  std::uint64_t epochs_without_orbit = 0;   ///< valid epochs without u (orbit gap or no orbit data)
  std::uint64_t orbit_records = 0;          ///< orbit records accepted
  std::uint64_t orbit_records_rejected = 0; ///< non-finite, degenerate, out of time order
  std::uint64_t pending_dropped = 0;        ///< head epochs dropped because max_pending was reached

  /// The coefficients for the core (datum slot 0, orders, per head c, A, B (and A', B'), the
  /// prediction covariance), with the given prediction mode (core/thermal_harmonics.h: anchored by default). Heads not determined have no model.
  core::ThermalHarmonicModel coreModel(core::ThermalPredictionMode mode = core::ThermalPredictionMode::kAnchored) const;
};

/// Streaming collector and fit. Not for the real-time loop (allocates).
class ThermalCollector {
 public:
  /// False with *error on a bad head set (fewer than 2 heads) or configuration.
  bool configure(const core::HeadSetConfig& heads, const ThermalFitConfig& cfg, std::string* error);
  /// One head epoch (raw, as the core gets it); bad data is counted, never thrown.
  void pushHeads(const core::HeadEpoch& e);
  /// One orbit record: GNI1B ('I', used directly) or GNV1B ('E', by the Earth rotation angle).
  void pushOrbit(const io::GnvRecord& r);
  /// One orbit sample already converted (model/orbit_context.h).
  void pushOrbit(const model::OrbitSample& s);
  /// Fits what was collected (may be called more than once; later pushes add to the same sums).
  /// Epochs still waiting for a later orbit record are resolved by extrapolation first, where allowed.
  ThermalFitResult fit();

 private:
  struct Node {
    double t_s = 0;        ///< s past GPS J2000
    double u = 0;          ///< unwrapped, rad
    double u_rate = 0;     ///< rad/s
    double beta = 0;       ///< rad
  };
  struct Sample {
    double t_s = 0;
    std::uint32_t mask = 0;
    std::array<Vec3, core::kMaxHeads> delta{};
    std::array<Mat3, core::kMaxHeads> cov{};
    std::array<bool, core::kMaxHeads> nominal{};
  };
  struct Sums;  // normal equations per head (thermal_fit.cc)
  bool orbitAt(double t_s, bool final_pass, double& u, double& beta, bool& pending) const;
  void use(const Sample& s, double u, double beta);
  void resolvePending(bool final_pass);

  core::HeadSetConfig heads_{};
  ThermalFitConfig cfg_{};
  bool configured_ = false;
  core::HeadInputValidator validator_{};
  core::BoresightMonitor monitor_{};
  std::vector<Node> track_;
  std::deque<Sample> pending_;
  std::vector<Sums> sums_;  ///< by slot
  Eigen::VectorXd f_;       ///< regressors of the epoch being used (reused: no allocation per epoch)
  Eigen::MatrixXd ff_;      ///< f f^T
  bool have_beta_ref_ = false;
  double cos_beta_ref_ = 1, beta_ref_ = 0;
  double t_min_ = 0, t_max_ = 0, u_min_ = 0, u_max_ = 0, beta_min_ = 0, beta_max_ = 0;
  bool any_used_ = false;
  bool earth_fixed_ = false;
  ThermalFitResult counts_{};  ///< the counters only
 public:
  ThermalCollector();
  ~ThermalCollector();
  /// Copyable (a snapshot: the node's worker solves a copy of its feed while the original goes on).
  ThermalCollector(const ThermalCollector&);
  ThermalCollector& operator=(const ThermalCollector&);
};

/// One call over data in memory (tests, small spans): configure, push every orbit record and head epoch
/// in time order, fit. On a configuration error: ok false with the error.
ThermalFitResult fitThermal(const core::HeadSetConfig& heads, const ThermalFitConfig& cfg,
                            const std::vector<core::HeadEpoch>& epochs, const std::vector<io::GnvRecord>& orbit);

/// The result as text for people (datum, per head and axis the amplitudes with sigmas, RMS before/after).
std::string formatThermalFit(const ThermalFitResult& r);

}  // namespace boresight::calib

// Method C solvers: the seed (the published method) and the joint Ceres refinement.
//
// SEED (METHODS.md section 3): per position, level from the mean specific force (the gravity
// direction in IMU axes is z_m), yaw from the prism azimuth(s); the coefficient matrix P of the
// pinhole model by homogeneous linear least squares over the targets; rows normalised and
// orthogonalised to C_s_m; C_s_t = C_s_m C_t_m^T, averaged over positions on SO(3). The seed ignores
// the accelerometer bias b, which tilts its level by about b/g.
//
// REFINED: one least-squares problem over every position: C_s_t = Exp(e) C_s_t(design) (e: the
// mounting error angles, sensor axes, the reported quantity), the intrinsics f, u0, v0, Sx (and k1
// when the file gives its prior) under their laboratory priors, each position's
// C_t_m = Exp(rho_k) C_t_m(seed), and the accelerometer bias b. Residuals: target centroids (pixel
// sigma from the centroid and theodolite noise), prism normals (two tangent angles, theodolite
// sigma), the mean specific force per position (sigma of the mean).
// Observability: the information matrix of the data (and intrinsic priors) with a prior of the
// assumed bias size on b gives each bias axis's posterior sigma; an axis whose sigma is not at least
// 3x below the assumed bias is NOT separated from the tilt. Such axes keep that prior in the final
// solve (so the covariance of e carries the tilt the bias may hide, never a small sigma), and
// hidden_tilt is the shift of e that a bias of the assumed size along them causes.
#pragma once

#include <boresight/core/conventions.h>
#include <boresight/ground/measurement.h>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace boresight::model {
struct JacobianCheck;
}

namespace boresight::ground {

// ---- seed steps (each testable on its own) ----

/// C_t_m from the mean specific force (z_m in t = f/|f|) and the prism azimuths (yaw). With several
/// faces the yaw is their weighted circular mean (weight: squared horizontal length of the normal).
/// Returns false when no face has a horizontal component.
bool levelAndYaw(const Vec3& mean_f_t, const std::vector<PrismReading>& prisms, Mat3& C_t_m);

/// The 3x3 coefficient matrix P (rows p1, p2, p3, |P|_F = 1, p3 . r > 0) with
/// x_i = p1.r_i / p3.r_i, y_i = p2.r_i / p3.r_i for x = (u-u0)/f, y = (v-v0)/(f Sx).
/// r_m: lab directions. Returns false with fewer than 4 targets.
bool coefficientMatrix(const std::vector<Vec3>& r_m, const std::vector<Eigen::Vector2d>& xy, Mat3& P);

/// Rows normalised and orthogonalised (the non-orthogonality of rows 1 and 2 shared equally, row 3
/// = row1 x row2, since the perspective row p3 is the poorly determined one on a narrow field).
/// Returns false when P's third row points the other way (a mirror image).
bool orthonormalise(const Mat3& P, Mat3& C_s_m);

/// Chordal L2 mean of rotations (sum projected onto SO(3)).
Mat3 meanRotation(const std::vector<Mat3>& Cs);

struct SeedResult {
  Mat3 C_s_t = Mat3::Identity();
  Vec3 error_angles_rad = Vec3::Zero();  ///< Log(C_s_t C_s_t(design)^T), sensor axes
  std::vector<Mat3> C_t_m;               ///< per position
  std::vector<Mat3> C_s_m;
};

bool solveSeed(const Measurement& m, SeedResult& out, std::string* error);

// ---- refined ----

struct RefineOptions {
  double assumed_bias_mps2 = 100e-6 * 9.80665;  ///< the bias an unseparated axis may hide (100 ug)
  double separation_ratio = 3.0;  ///< an axis is separated when sigma_b <= assumed / ratio
  int max_iterations = 50;
  double max_design_deviation_deg = 5.0;    ///< a seed further from the design is a convention error
  std::string source_name = "measurement";  ///< the file name in "name:line: reason" messages
};

struct PositionResult {
  std::string name;
  Mat3 C_t_m = Mat3::Identity();
  double residual_rms_px = 0;        ///< targets, both axes
  double prism_rms_arcsec = 0;       ///< prism normal tangent residuals
  Vec3 accel_mean_mps2 = Vec3::Zero();
  Vec3 accel_residual_mps2 = Vec3::Zero();  ///< mean measured minus modelled
  Vec3 accel_sample_sigma_mps2 = Vec3::Zero();
  int targets = 0, accel_samples = 0, prisms = 0;
};

struct GroundResult {
  SeedResult seed;
  Mat3 C_s_t = Mat3::Identity();
  Vec3 error_angles_rad = Vec3::Zero();
  Mat3 error_cov_rad2 = Mat3::Zero();
  Vec3 bias_mps2 = Vec3::Zero();
  Vec3 bias_sigma_mps2 = Vec3::Zero();
  bool bias_observable[3] = {true, true, true};
  Vec3 hidden_tilt_rad = Vec3::Zero();  ///< sensor axes; zero where every bias axis is separated
  Intrinsics camera;
  Intrinsics camera_sigma;              ///< 1-sigma of each refined intrinsic (k1: 0 when held)
  double residual_rms_px = 0;
  std::vector<PositionResult> positions;
  // information-matrix diagnostics (data and intrinsic priors, bias unconstrained; Jacobi-scaled)
  int parameters = 0, rank = 0;
  double condition = 0;  ///< infinity when rank < parameters
  std::vector<std::string> notes;  ///< plain-language observability statements
  int iterations = 0;
  bool converged = false;
};

/// Seed, then the joint refinement with covariance and the observability decision.
bool solveGround(const Measurement& m, const RefineOptions& opt, GroundResult& out, std::string* error);

/// The refinement's cost functors against numerical derivatives (model/jacobian_check.h: every functor
/// the measurement's problem uses - targets with and without k1 free, prisms, the accelerometer, the
/// priors - up to 20 blocks each), at a point away from the seed (rotations of 1-3 mrad, a bias,
/// intrinsics off nominal). Empty with *error when the measurement or its seed is refused.
std::vector<model::JacobianCheck> checkJacobians(const Measurement& m, const RefineOptions& opt, double relative_precision,
                                                 std::string* error);

}  // namespace boresight::ground

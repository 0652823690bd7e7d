// The seed solver of method C (the published method, METHODS.md section 3 steps 1-4).
#include <boresight/core/rotation.h>
#include <boresight/ground/solver.h>

#include <Eigen/SVD>

#include <cmath>

namespace boresight::ground {

bool levelAndYaw(const Vec3& mean_f_t, const std::vector<PrismReading>& prisms, Mat3& C_t_m) {
  if (!(mean_f_t.norm() > 0)) return false;
  // At rest f_t = C_t_m (0, 0, g): the third column of C_t_m (z_m in IMU axes) is f / |f|.
  const Vec3 c3 = mean_f_t.normalized();
  // Each face: its horizontal part h in t must have the measured azimuth a in m, i.e.
  // h = cos a c1 + sin a c2 = Rot(c3, a) c1, so c1 = h cos a - (c3 x h) sin a.
  Vec3 sum = Vec3::Zero();
  for (const PrismReading& p : prisms) {
    const Vec3 h = p.axis_t - p.axis_t.dot(c3) * c3;
    const double w = h.squaredNorm();
    if (w < 1e-12) continue;  // a face normal along the vertical carries no yaw
    const Vec3 hu = h / std::sqrt(w);
    sum += w * (hu * std::cos(p.az_rad) - c3.cross(hu) * std::sin(p.az_rad));
  }
  const Vec3 c1h = sum - sum.dot(c3) * c3;
  if (c1h.norm() < 1e-9) return false;
  const Vec3 c1 = c1h.normalized();
  const Vec3 c2 = c3.cross(c1);
  C_t_m.col(0) = c1;
  C_t_m.col(1) = c2;
  C_t_m.col(2) = c3;
  return true;
}

bool coefficientMatrix(const std::vector<Vec3>& r_m, const std::vector<Eigen::Vector2d>& xy, Mat3& P) {
  const int n = static_cast<int>(r_m.size());
  if (n < 4 || xy.size() != r_m.size()) return false;
  // x (p3 . r) - p1 . r = 0 and y (p3 . r) - p2 . r = 0: a homogeneous system in p = (p1, p2, p3);
  // its least-squares solution with |p| = 1 is the right singular vector of the smallest value.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * n, 9);
  for (int i = 0; i < n; ++i) {
    const Vec3& r = r_m[static_cast<std::size_t>(i)];
    const Eigen::Vector2d& q = xy[static_cast<std::size_t>(i)];
    A.block<1, 3>(2 * i, 0) = -r.transpose();
    A.block<1, 3>(2 * i, 6) = q.x() * r.transpose();
    A.block<1, 3>(2 * i + 1, 3) = -r.transpose();
    A.block<1, 3>(2 * i + 1, 6) = q.y() * r.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 9, 1> p = svd.matrixV().col(8);
  for (int row = 0; row < 3; ++row) P.row(row) = p.segment<3>(3 * row).transpose();
  double s = 0;
  for (const Vec3& r : r_m) s += P.row(2).dot(r);
  if (s < 0) P = -P;
  return true;
}

bool orthonormalise(const Mat3& P, Mat3& C_s_m) {
  Vec3 r1 = P.row(0).transpose().normalized(), r2 = P.row(1).transpose().normalized();
  const double d = r1.dot(r2);
  const Vec3 a = (r1 - 0.5 * d * r2).normalized(), b = (r2 - 0.5 * d * r1).normalized();
  const Vec3 r3 = a.cross(b).normalized();
  if (r3.dot(P.row(2).transpose()) <= 0) return false;
  C_s_m.row(0) = a.transpose();
  C_s_m.row(1) = b.transpose();
  C_s_m.row(2) = r3.transpose();
  // one more symmetric step makes the result orthonormal to rounding
  Eigen::JacobiSVD<Mat3> svd(C_s_m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  C_s_m = svd.matrixU() * svd.matrixV().transpose();
  return C_s_m.determinant() > 0;
}

Mat3 meanRotation(const std::vector<Mat3>& Cs) {
  Mat3 S = Mat3::Zero();
  for (const Mat3& C : Cs) S += C;
  Eigen::JacobiSVD<Mat3> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

bool solveSeed(const Measurement& m, SeedResult& out, std::string* error) {
  out = SeedResult{};
  std::vector<Mat3> C_s_t_k;
  const Intrinsics& c = m.camera.nominal;
  for (const Position& p : m.positions) {
    Vec3 mean = Vec3::Zero();
    for (const Vec3& f : p.accel_mps2) mean += f;
    mean /= static_cast<double>(std::max<std::size_t>(1, p.accel_mps2.size()));
    Mat3 C_t_m;
    if (!levelAndYaw(mean, p.prisms, C_t_m)) {
      if (error) *error = "position '" + p.name + "': no prism face has a horizontal component (yaw undefined)";
      return false;
    }
    std::vector<Vec3> r;
    std::vector<Eigen::Vector2d> xy;
    for (const TargetReading& t : p.targets) {
      r.push_back(directionFromAzEl(t.az_rad, t.el_rad));
      // undo the nominal radial distortion (none unless the file gives radial_k1)
      const Vec3 d = unprojectPixel(t.u_px, t.v_px, c);
      xy.emplace_back(d.x() / d.z(), d.y() / d.z());
    }
    Mat3 P, C_s_m;
    if (!coefficientMatrix(r, xy, P) || !orthonormalise(P, C_s_m)) {
      if (error) *error = "position '" + p.name + "': the coefficient matrix P is degenerate or a mirror image (targets on a line? azimuths "
                 "clockwise? use azimuth_cw_deg for those)";
      return false;
    }
    out.C_t_m.push_back(C_t_m);
    out.C_s_m.push_back(C_s_m);
    C_s_t_k.push_back(C_s_m * C_t_m.transpose());
  }
  out.C_s_t = meanRotation(C_s_t_k);
  out.error_angles_rad = core::so3Log(out.C_s_t * m.q_s_t_design.toRotationMatrix().transpose());
  return true;
}

}  // namespace boresight::ground

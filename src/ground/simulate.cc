// Ground set-up simulator (model and noise in simulate.h).
#include <boresight/core/rotation.h>
#include <boresight/io/files.h>
#include <boresight/ground/simulate.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace boresight::ground {
namespace {

class Normal {
 public:
  explicit Normal(std::uint64_t seed) : gen_(seed ^ 0x6a09e667f3bcc908ULL) {}
  double uniform() { return (static_cast<double>(gen_() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  double operator()() {
    if (have_) {
      have_ = false;
      return next_;
    }
    const double r = std::sqrt(-2.0 * std::log(uniform())), a = 2.0 * kPi * uniform();
    next_ = r * std::sin(a);
    have_ = true;
    return r * std::cos(a);
  }
  Vec3 vec() {
    const double x = (*this)(), y = (*this)(), z = (*this)();
    return Vec3(x, y, z);
  }

 private:
  std::mt19937_64 gen_;
  bool have_ = false;
  double next_ = 0;
};

Mat3 rotAbout(const Vec3& axis, double angle_rad) { return core::so3Exp(axis.normalized() * angle_rad); }

}  // namespace

Quat defaultDesign() {
  // sensor z (boresight) at azimuth 30 deg, elevation 60 deg in IMU axes; sensor x horizontal.
  const double a = 30.0 * kRadPerDeg, e = 60.0 * kRadPerDeg;
  const Vec3 z(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
  const Vec3 x = Vec3::UnitZ().cross(z).normalized();
  const Vec3 y = z.cross(x);
  Mat3 C_s_t;  // rows: sensor axes in IMU coordinates
  C_s_t.row(0) = x.transpose();
  C_s_t.row(1) = y.transpose();
  C_s_t.row(2) = z.transpose();
  return Quat(C_s_t).normalized();
}

const char* setupNames() { return "single, turned, two-faces, tilted"; }

bool applySetup(const std::string& name, SimConfig& cfg) {
  cfg.turn_deg = 0;
  cfg.tilt_deg = 0;
  if (name == "single") {
    cfg.positions = 1;
    cfg.prism_faces = 1;
  } else if (name == "turned") {
    cfg.positions = 3;
    cfg.turn_deg = 120;
    cfg.prism_faces = 1;
  } else if (name == "two-faces") {
    cfg.positions = 1;
    cfg.prism_faces = 2;
  } else if (name == "tilted") {
    cfg.positions = 3;
    cfg.tilt_deg = 20;
    cfg.prism_faces = 1;
  } else {
    return false;
  }
  return true;
}

bool simulateGround(const SimConfig& cfg, Measurement& m, SimTruth& truth, std::string* error) {
  if (cfg.positions < 1 || cfg.targets < 4 || cfg.accel_samples < 1 || (cfg.prism_faces != 1 && cfg.prism_faces != 2)) {
    if (error) *error = "simulate-ground: positions >= 1, targets >= 4, accel samples >= 1, prism faces 1 or 2";
    return false;
  }
  Normal rn(cfg.seed);
  const double g = cfg.gravity_mps2;
  const double th = cfg.theodolite_sigma_arcsec * kRadPerArcsec;
  m = Measurement{};
  m.gravity_mps2 = g;
  m.camera = cfg.camera;
  m.q_s_t_design = cfg.q_s_t_design;
  // the file's noise block states the simulated noise; noise-free data keep the default weights
  if (cfg.centroid_sigma_px > 0) m.noise.centroid_sigma_px = cfg.centroid_sigma_px;
  if (th > 0) m.noise.theodolite_sigma_rad = th;
  truth = SimTruth{};

  // truth: mounting, bias, intrinsics
  const Mat3 C_design = cfg.q_s_t_design.toRotationMatrix();
  truth.error_angles_rad = rn.vec() * cfg.mounting_sigma_arcsec * kRadPerArcsec;
  const Mat3 C_s_t = core::so3Exp(truth.error_angles_rad) * C_design;
  truth.q_s_t = Quat(C_s_t).normalized();
  const double ug = 1e-6 * 9.80665;
  truth.bias_mps2 = cfg.fixed_bias ? Vec3(cfg.bias_ug * ug) : Vec3(rn.vec() * cfg.accel_bias_sigma_ug * ug);
  Intrinsics cam = cfg.camera.nominal;
  if (cfg.draw_intrinsics) {
    cam.f += rn() * cfg.camera.f_sigma_px;
    cam.u0 += rn() * cfg.camera.pp_sigma_px;
    cam.v0 += rn() * cfg.camera.pp_sigma_px;
    cam.sx += rn() * cfg.camera.sx_sigma;
  }
  cam.k1 = cfg.true_k1;
  truth.camera = cam;

  // the base position: near level, x near lab azimuth 0
  const double lv = cfg.level_sigma_deg * kRadPerDeg;
  const Mat3 C_m_t0 = rotAbout(Vec3::UnitZ(), rn() * lv) * rotAbout(Vec3::UnitY(), rn() * lv) *
                      rotAbout(Vec3::UnitX(), rn() * lv);
  const double margin = 24.0;
  for (int k = 0; k < cfg.positions; ++k) {
    Mat3 C_m_t = rotAbout(Vec3::UnitZ(), k * cfg.turn_deg * kRadPerDeg) * C_m_t0;
    if (k >= 1 && cfg.tilt_deg != 0.0)
      C_m_t = rotAbout((k % 2) ? Vec3::UnitX() : Vec3::UnitY(), cfg.tilt_deg * kRadPerDeg) * C_m_t;
    const Mat3 C_t_m = C_m_t.transpose();
    truth.C_t_m.push_back(C_t_m);
    Position p;
    p.name = "position " + std::to_string(k + 1);
    for (int face = 0; face < cfg.prism_faces; ++face) {
      PrismReading r;
      r.axis_t = face == 0 ? Vec3::UnitX() : Vec3::UnitY();
      double az = 0, el = 0;
      azElFromDirection(C_m_t * r.axis_t, az, el);
      r.el_rad = el + rn() * th;
      r.az_rad = az + rn() * th / std::cos(el);
      p.prisms.push_back(r);
    }
    const Mat3 C_s_m = C_s_t * C_t_m;
    for (int i = 0; i < cfg.targets; ++i) {
      TargetReading t;
      const double u = margin + rn.uniform() * (cfg.camera.width_px - 2 * margin);
      const double v = margin + rn.uniform() * (cfg.camera.height_px - 2 * margin);
      const Vec3 d_s = unprojectPixel(u, v, cam);
      double az = 0, el = 0;
      azElFromDirection(C_s_m.transpose() * d_s, az, el);
      t.el_rad = el + rn() * th;
      t.az_rad = az + rn() * th / std::cos(el);
      t.u_px = u + rn() * cfg.centroid_sigma_px;
      t.v_px = v + rn() * cfg.centroid_sigma_px;
      p.targets.push_back(t);
    }
    const Vec3 f_true = C_t_m * Vec3(0, 0, g) + truth.bias_mps2;
    const double an = cfg.accel_noise_ug * ug;
    p.accel_mps2.reserve(static_cast<std::size_t>(cfg.accel_samples));
    for (int i = 0; i < cfg.accel_samples; ++i) p.accel_mps2.push_back(f_true + rn.vec() * an);
    m.positions.push_back(std::move(p));
  }
  return true;
}

bool writeTruth(const std::string& path, const SimConfig& cfg, const SimTruth& t, std::string* error) {
  io::AtomicFile af;
  if (!af.open(path, error)) return false;
  std::FILE* f = af.file();
  double q[4];
  quatToScalarFirst(t.q_s_t, q);
  const double ug = 1e-6 * 9.80665;
  std::fprintf(f, "# truth of a simulated method C measurement (boresight simulate-ground)\n");
  std::fprintf(f, "seed: %llu\n", static_cast<unsigned long long>(cfg.seed));
  std::fprintf(f, "setup: {positions: %d, turn_deg: %g, tilt_deg: %g, prism_faces: %d, targets: %d, accel_samples: %d}\n",
               cfg.positions, cfg.turn_deg, cfg.tilt_deg, cfg.prism_faces, cfg.targets, cfg.accel_samples);
  std::fprintf(f, "q_s_t: [%.15g, %.15g, %.15g, %.15g]   # scalar first, R(q) = C_s_t\n", q[0], q[1], q[2], q[3]);
  std::fprintf(f, "error_angles_arcsec: [%.6f, %.6f, %.6f]   # C_s_t = Exp([r]x) C_s_t(design), sensor axes\n",
               t.error_angles_rad.x() * kArcsecPerRad, t.error_angles_rad.y() * kArcsecPerRad,
               t.error_angles_rad.z() * kArcsecPerRad);
  std::fprintf(f, "accel_bias_mps2: [%.9g, %.9g, %.9g]   # IMU axes\n", t.bias_mps2.x(), t.bias_mps2.y(), t.bias_mps2.z());
  std::fprintf(f, "accel_bias_ug: [%.3f, %.3f, %.3f]\n", t.bias_mps2.x() / ug, t.bias_mps2.y() / ug, t.bias_mps2.z() / ug);
  std::fprintf(f, "camera: {focal_length_px: %.9f, principal_point_px: [%.9f, %.9f], pixel_aspect: %.12f, radial_k1: %.9g}\n",
               t.camera.f, t.camera.u0, t.camera.v0, t.camera.sx, t.camera.k1);
  std::fprintf(f, "positions:\n");
  for (const Mat3& C : t.C_t_m) {
    double qq[4];
    quatToScalarFirst(Quat(C).normalized(), qq);
    std::fprintf(f, "  - {q_t_m: [%.15g, %.15g, %.15g, %.15g]}\n", qq[0], qq[1], qq[2], qq[3]);
  }
  return af.commit(error);
}

}  // namespace boresight::ground

// boresight ground: method C - the star sensor to IMU mounting from a ground measurement file.
#include "cli_common.h"
#include <boresight/io/files.h>
#include "commands.h"

#include <boresight/ground/measurement.h>
#include <boresight/ground/solver.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace boresight::cli {
// This file's own names, in a namespace of their own: the program builds as unity sources (several
// cmd_*.cc in one translation unit, tools/CMakeLists.txt), where anonymous namespaces would merge.
namespace cmd_ground {
namespace {

const char* kFooter =
    "JSON keys: q_s_t (scalar first, R(q) = C_s_t, IMU axes -> sensor axes), error_angles_arcsec[3]\n"
    "(rotation vector r in sensor axes, C_s_t = Exp([r]x) C_s_t(design)), sigma_arcsec[3],\n"
    "covariance_arcsec2 (3x3 row-major), accel_bias_mps2[3], accel_bias_sigma_mps2[3],\n"
    "accel_bias_observable[3] (per IMU axis), hidden_tilt_arcsec[3] (the tilt an unseparated bias of\n"
    "the assumed size may hide; zeros where separated), camera (refined intrinsics with sigmas),\n"
    "residual_rms_px, seed (the seed solver's error_angles_arcsec), positions[].\n"
    "The cross-boresight angles are no better than the principal point sigma over the focal length.\n"
    "--report DIR writes report.txt (residuals, observability, conventions) and targets.csv.\n";

using json = nlohmann::ordered_json;

json vec(const Vec3& v, double scale = 1.0) { return json::array({v.x() * scale, v.y() * scale, v.z() * scale}); }
json quat(const Mat3& C) {
  double q[4];
  quatToScalarFirst(Quat(C).normalized(), q);
  if (q[0] < 0)
    for (double& x : q) x = -x;
  return json::array({q[0], q[1], q[2], q[3]});
}

json toJson(const ground::GroundResult& r) {
  json j;
  j["q_s_t"] = quat(r.C_s_t);
  j["error_angles_arcsec"] = vec(r.error_angles_rad, kArcsecPerRad);
  const Vec3 sig = r.error_cov_rad2.diagonal().cwiseSqrt();
  j["sigma_arcsec"] = vec(sig, kArcsecPerRad);
  json cov = json::array();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) cov.push_back(r.error_cov_rad2(a, b) * kArcsecPerRad * kArcsecPerRad);
  j["covariance_arcsec2"] = cov;
  j["accel_bias_mps2"] = vec(r.bias_mps2);
  j["accel_bias_sigma_mps2"] = vec(r.bias_sigma_mps2);
  j["accel_bias_observable"] = json::array({r.bias_observable[0], r.bias_observable[1], r.bias_observable[2]});
  j["hidden_tilt_arcsec"] = vec(r.hidden_tilt_rad, kArcsecPerRad);
  json cam;
  cam["focal_length_px"] = r.camera.f;
  cam["focal_length_sigma_px"] = r.camera_sigma.f;
  cam["principal_point_px"] = json::array({r.camera.u0, r.camera.v0});
  cam["principal_point_sigma_px"] = json::array({r.camera_sigma.u0, r.camera_sigma.v0});
  cam["pixel_aspect"] = r.camera.sx;
  cam["pixel_aspect_sigma"] = r.camera_sigma.sx;
  cam["radial_k1"] = r.camera.k1;
  cam["radial_k1_sigma"] = r.camera_sigma.k1;
  j["camera"] = cam;
  j["residual_rms_px"] = r.residual_rms_px;
  json seed;
  seed["error_angles_arcsec"] = vec(r.seed.error_angles_rad, kArcsecPerRad);
  seed["q_s_t"] = quat(r.seed.C_s_t);
  j["seed"] = seed;
  json ps = json::array();
  for (const auto& p : r.positions) {
    json o;
    o["name"] = p.name;
    o["q_t_m"] = quat(p.C_t_m);
    o["targets"] = p.targets;
    o["prisms"] = p.prisms;
    o["accel_samples"] = p.accel_samples;
    o["residual_rms_px"] = p.residual_rms_px;
    o["prism_residual_rms_arcsec"] = p.prism_rms_arcsec;
    o["accel_mean_mps2"] = vec(p.accel_mean_mps2);
    o["accel_residual_mps2"] = vec(p.accel_residual_mps2);
    o["accel_sample_sigma_mps2"] = vec(p.accel_sample_sigma_mps2);
    ps.push_back(o);
  }
  j["positions"] = ps;
  return j;
}

bool writeReport(const std::string& dir, const std::string& input, const ground::Measurement& m,
                 const ground::GroundResult& r, std::string* err) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    *err = dir + ": " + ec.message();
    return false;
  }
  io::AtomicFile report_file;  // whole or not at all
  if (!report_file.open(dir + "/report.txt", err)) return false;
  std::FILE* f = report_file.file();
  const double as = kArcsecPerRad;
  std::fprintf(f, "boresight ground report for %s\n\n", std::filesystem::path(input).filename().c_str());
  std::fprintf(f, "Conventions: C_s_t maps IMU axes to sensor axes; error angles r in sensor axes with\n"
                  "C_s_t = Exp([r]x) C_s_t(design); at rest f_t = C_t_m (0,0,g) + b; lab frame m: x at azimuth 0,\n"
                  "z up, azimuth counterclockwise from above.\n\n");
  std::fprintf(f, "%-10s %12s %12s %12s\n", "", "x", "y", "z");
  std::fprintf(f, "%-10s %12.2f %12.2f %12.2f  arcsec\n", "seed", r.seed.error_angles_rad.x() * as,
               r.seed.error_angles_rad.y() * as, r.seed.error_angles_rad.z() * as);
  std::fprintf(f, "%-10s %12.2f %12.2f %12.2f  arcsec\n", "refined", r.error_angles_rad.x() * as,
               r.error_angles_rad.y() * as, r.error_angles_rad.z() * as);
  std::fprintf(f, "%-10s %12.2f %12.2f %12.2f  arcsec (1 sigma)\n", "sigma", std::sqrt(r.error_cov_rad2(0, 0)) * as,
               std::sqrt(r.error_cov_rad2(1, 1)) * as, std::sqrt(r.error_cov_rad2(2, 2)) * as);
  std::fprintf(f, "%-10s %12.2f %12.2f %12.2f  arcsec\n", "hidden", r.hidden_tilt_rad.x() * as,
               r.hidden_tilt_rad.y() * as, r.hidden_tilt_rad.z() * as);
  const double ug = 9.80665e-6;
  std::fprintf(f, "%-10s %12.1f %12.1f %12.1f  ug (IMU axes)\n", "bias", r.bias_mps2.x() / ug, r.bias_mps2.y() / ug,
               r.bias_mps2.z() / ug);
  std::fprintf(f, "%-10s %12.1f %12.1f %12.1f  ug\n", "bias sig", r.bias_sigma_mps2.x() / ug,
               r.bias_sigma_mps2.y() / ug, r.bias_sigma_mps2.z() / ug);
  std::fprintf(f, "%-10s %12s %12s %12s\n\n", "separated", r.bias_observable[0] ? "yes" : "NO",
               r.bias_observable[1] ? "yes" : "NO", r.bias_observable[2] ? "yes" : "NO");
  std::fprintf(f, "Information matrix (data and intrinsic priors, bias free, Jacobi-scaled): %d parameters, rank %d, ",
               r.parameters, r.rank);
  if (r.rank < r.parameters)
    std::fprintf(f, "condition infinite (%d direction%s not determined by the data)\n", r.parameters - r.rank,
                 r.parameters - r.rank > 1 ? "s" : "");
  else
    std::fprintf(f, "condition %.3g\n", r.condition);
  for (const auto& n : r.notes) std::fprintf(f, "NOTE: %s\n", n.c_str());
  std::fprintf(f, "\nCamera (lab prior -> refined +- sigma):\n");
  const auto& c0 = m.camera.nominal;
  std::fprintf(f, "  f   %.4f -> %.4f +- %.4f px\n", c0.f, r.camera.f, r.camera_sigma.f);
  std::fprintf(f, "  u0  %.4f -> %.4f +- %.4f px\n", c0.u0, r.camera.u0, r.camera_sigma.u0);
  std::fprintf(f, "  v0  %.4f -> %.4f +- %.4f px\n", c0.v0, r.camera.v0, r.camera_sigma.v0);
  std::fprintf(f, "  Sx  %.8f -> %.8f +- %.2g\n", c0.sx, r.camera.sx, r.camera_sigma.sx);
  std::fprintf(f, "  k1  %.6g -> %.6g +- %.2g%s\n", c0.k1, r.camera.k1, r.camera_sigma.k1,
               m.camera.estimate_k1 ? "" : " (held: no radial_k1_sigma in the file)");
  std::fprintf(f, "\nPositions:\n");
  for (const auto& p : r.positions)
    std::fprintf(f, "  %-16s targets %3d  rms %.4f px  prisms %d  prism rms %.2f arcsec  accel residual "
                 "(%.2f, %.2f, %.2f) ug  sample sigma (%.1f, %.1f, %.1f) ug\n",
                 p.name.c_str(), p.targets, p.residual_rms_px, p.prisms, p.prism_rms_arcsec,
                 p.accel_residual_mps2.x() / ug, p.accel_residual_mps2.y() / ug, p.accel_residual_mps2.z() / ug,
                 p.accel_sample_sigma_mps2.x() / ug, p.accel_sample_sigma_mps2.y() / ug,
                 p.accel_sample_sigma_mps2.z() / ug);
  std::fprintf(f, "  all targets: rms %.4f px (per axis)\n", r.residual_rms_px);
  if (!report_file.commit(err)) return false;
  // per-target residuals
  std::ostringstream csv;
  csv << "position,line,u_px,v_px,du_px,dv_px\n";
  for (std::size_t k = 0; k < m.positions.size(); ++k) {
    const Mat3 C_s_m = r.C_s_t * r.positions[k].C_t_m;
    for (const auto& t : m.positions[k].targets) {
      double u = 0, v = 0;
      ground::projectPoint(C_s_m * ground::directionFromAzEl(t.az_rad, t.el_rad), r.camera, u, v);
      char buf[200];
      std::snprintf(buf, sizeof buf, "%zu,%d,%.4f,%.4f,%.5f,%.5f\n", k + 1, t.line, t.u_px, t.v_px, t.u_px - u,
                    t.v_px - v);
      csv << buf;
    }
  }
  return io::writeFileAtomic(dir + "/targets.csv", csv.str(), err);
}

}  // namespace

int runGround(int argc, char** argv) {
  CLI::App app{"Star sensor to strapdown IMU mounting from a ground measurement (method C): seed solver and joint\n"
               "Ceres refinement with accelerometer bias, intrinsics under priors, covariance and observability.",
               "boresight ground"};
  std::string input, json_out, report;
  double assumed_bias_ug = 100.0;
  bool quiet = false;
  app.add_option("--input", input, "measurement file (YAML; format in include/boresight/ground/measurement.h)")
      ->type_name("FILE");
  app.add_option("--json", json_out, "result file (JSON)")->type_name("FILE");
  app.add_option("--report", report, "folder for report.txt and targets.csv (created)")->type_name("DIR");
  app.add_option("--assumed-bias-ug", assumed_bias_ug,
                 "accelerometer bias assumed where the set-up cannot separate it from the tilt (default 100)")
      ->check(finiteRange(1e-300, 1e300))
      ->type_name("UG");
  app.add_flag("--quiet", quiet, "no summary on stdout");
  app.footer(kFooter);
  if (const int rc = parseCommandLine(app, argc, argv); rc >= 0) return rc;
  if (input.empty() || json_out.empty()) {
    std::fprintf(stderr, "boresight ground: --input and --json are required (--help lists the options)\n");
    return 2;
  }
  ground::Measurement m;
  std::string err;
  if (!io::checkOutputs({input}, {{"--json", json_out}, {"--report", report, true}}, &err)) {
    std::fprintf(stderr, "boresight ground: %s\n", err.c_str());
    return 1;
  }
  if (!ground::loadMeasurement(input, m, &err)) {
    std::fprintf(stderr, "boresight ground: %s\n", err.c_str());
    return 1;
  }
  ground::RefineOptions opt;
  opt.assumed_bias_mps2 = assumed_bias_ug * 9.80665e-6;
  opt.source_name = input;
  ground::GroundResult r;
  if (!ground::solveGround(m, opt, r, &err)) {
    if (err.rfind(input, 0) != 0) err = input + ": " + err;  // the place of a solver refusal: the file
    std::fprintf(stderr, "boresight ground: %s\n", err.c_str());
    return 1;
  }
  if (!io::writeFileAtomic(json_out, toJson(r).dump(2) + "\n", &err)) {
    std::fprintf(stderr, "boresight ground: %s\n", err.c_str());
    return 1;
  }
  if (!report.empty() && !writeReport(report, input, m, r, &err)) {
    std::fprintf(stderr, "boresight ground: %s\n", err.c_str());
    return 1;
  }
  if (!quiet) {
    const double as = kArcsecPerRad;
    std::printf("error angles (sensor axes): %.2f %.2f %.2f arcsec, sigma %.2f %.2f %.2f (seed %.2f %.2f %.2f)\n",
                r.error_angles_rad.x() * as, r.error_angles_rad.y() * as, r.error_angles_rad.z() * as,
                std::sqrt(r.error_cov_rad2(0, 0)) * as, std::sqrt(r.error_cov_rad2(1, 1)) * as,
                std::sqrt(r.error_cov_rad2(2, 2)) * as, r.seed.error_angles_rad.x() * as,
                r.seed.error_angles_rad.y() * as, r.seed.error_angles_rad.z() * as);
    std::printf("accelerometer bias (IMU axes): %.1f %.1f %.1f ug, separated: %s %s %s; residual rms %.4f px\n",
                r.bias_mps2.x() / 9.80665e-6, r.bias_mps2.y() / 9.80665e-6, r.bias_mps2.z() / 9.80665e-6,
                r.bias_observable[0] ? "yes" : "NO", r.bias_observable[1] ? "yes" : "NO",
                r.bias_observable[2] ? "yes" : "NO", r.residual_rms_px);
    for (const auto& n : r.notes) std::printf("note: %s\n", n.c_str());
    std::printf("wrote %s\n", json_out.c_str());
  }
  return 0;
}

}  // namespace cmd_ground

int runGround(int argc, char** argv) { return cmd_ground::runGround(argc, argv); }

}  // namespace boresight::cli

// calib_sim: the method A solver on the project simulator's Level-1 output (`boresight simulate`), with
// the truth from its truth.yaml. Confirms on independently simulated data (attitude dynamics,
// thrusters, head tags, accelerometer averaging, Gauss-Markov noise, aberration, thermal effects) what
// the Monte Carlo shows on synthetic spans.
//
// Truth mapping (the accelerometer frame is the datum): the solver's B is the frame the configured
// (nominal) C_B_A puts A into, so for head h
//     C_Sh_B(solver, true) = C_Sh_B(true) C_B_A(true) C_B_A(nominal)^T
//     r_h(true) = Log(C_Sh_B(solver, true) M_h^T),   M_h = R(q_Si_B_nominal)
// with q_Si_B_true, C_B_A_true and C_B_A_nominal from truth.yaml: the simulator's acc_misalignment
// (C_B_A_true = C_B_A_nominal R(Exp(m))^T) enters every head's truth as a common rotation.
// Accelerometer scale: a_meas = (1 + s) ..., s = truth.yaml's scale_error; time offset: its
// time_offset_s (tags late: +).
#include "boresight/calib/solver.h"
#include "boresight/calib/span_builder.h"
#include "boresight/core/rotation.h"
#include "boresight/io/level1.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

namespace fs = std::filesystem;
using namespace boresight;
using namespace boresight::calib;

namespace {

Quat quatNode(const YAML::Node& n) {
  return quatFromScalarFirst(n[0].as<double>(), n[1].as<double>(), n[2].as<double>(), n[3].as<double>()).normalized();
}
Mat3 matNode(const YAML::Node& n) {
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = n[r][c].as<double>();
  return m;
}
Vec3 vecNode(const YAML::Node& n) { return Vec3(n[0].as<double>(), n[1].as<double>(), n[2].as<double>()); }

std::string findFile(const fs::path& dir, const std::string& prefix) {
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind(prefix, 0) == 0 && n.size() > 4 && n.substr(n.size() - 4) == ".txt") return e.path().string();
  }
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::string dir;
  SolveOptions opt;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: calib_sim --dir DIR [--prior] [--scale] [--offset] [--nonorth]\n"
                   "  DIR: the output of `boresight simulate` (SCA1A_*.txt, ACC1A_*.txt, truth.yaml).\n"
                   "  --prior    relative attitude as a prior (default: hard constraint)\n"
                   "  --scale    estimate the accelerometer scale; --offset the time offset; --nonorth the\n"
                   "             non-orthogonality\n"
                   "Prints per head axis: estimate, truth (mapped to the accelerometer datum), sigma, CRLB, z.\n";
      return 0;
    }
    if (a == "--dir" && i + 1 < argc) {
      dir = argv[++i];
    } else if (a == "--prior") {
      opt.relative = RelativeMode::kPrior;
    } else if (a == "--scale") {
      opt.estimate_acc_scale = true;
    } else if (a == "--offset") {
      opt.estimate_time_offset = true;
    } else if (a == "--nonorth") {
      opt.estimate_acc_nonorthogonality = true;
    } else {
      std::cerr << "calib_sim: unknown option " << a << " (see --help)\n";
      return 2;
    }
  }
  if (dir.empty()) {
    std::cerr << "calib_sim: --dir is required (see --help)\n";
    return 2;
  }
  const fs::path d(dir);
  YAML::Node truth;
  try {
    truth = YAML::LoadFile((d / "truth.yaml").string());
  } catch (const std::exception& e) {
    std::cerr << (d / "truth.yaml").string() << ": " << e.what() << "\n";
    return 1;
  }
  const std::string sca = findFile(d, "SCA1A_"), acc = findFile(d, "ACC1A_");
  if (sca.empty() || acc.empty()) {
    std::cerr << dir << ": no SCA1A_*.txt or ACC1A_*.txt\n";
    return 1;
  }
  core::PipelineConfig cfg;
  const YAML::Node heads = truth["heads"];
  cfg.heads.n_heads = static_cast<int>(heads.size());
  std::vector<Quat> q_true;
  for (std::size_t i = 0; i < heads.size(); ++i) {
    auto& h = cfg.heads.head[i];
    h.id = heads[i]["id"].as<int>();
    h.q_Si_B = quatNode(heads[i]["q_Si_B_nominal"]);
    h.boresight_Si = vecNode(heads[i]["boresight"]).normalized();
    h.sigma_cross_rad = heads[i]["noise_cross_arcsec"].as<double>() * kRadPerArcsec;
    h.sigma_roll_rad = heads[i]["noise_about_arcsec"].as<double>() * kRadPerArcsec;
    q_true.push_back(quatNode(heads[i]["q_Si_B_true"]));
  }
  const YAML::Node a = truth["accelerometer"];
  const Mat3 C_B_A_nom = matNode(a["C_B_A_nominal"]), C_B_A_true = matNode(a["C_B_A_true"]);
  cfg.C_B_A = C_B_A_nom;
  SpanOptions so;
  so.acc_white_noise_radps2 = vecNode(a["white_noise_rad_s2"]);
  SpanBuilder b;
  std::string err;
  if (!b.configure(cfg, so, &err)) {
    std::cerr << "calib_sim: " << err << "\n";
    return 1;
  }
  const auto S = io::readProduct<io::Sca1aRecord>(sca);
  const auto A = io::readProduct<io::Acc1aRecord>(acc);
  std::size_t ia = 0, is = 0;
  while (is < S.records.size()) {
    core::HeadEpoch e;
    e.t = S.records[is].t;
    while (is < S.records.size() && S.records[is].t == e.t) {
      if (e.n < kMaxHeads) {
        auto& s = e.sample[static_cast<std::size_t>(e.n++)];
        s.head_id = S.records[is].head;
        s.q_I_Si = quatFromScalarFirst(S.records[is].q);
      }
      ++is;
    }
    while (ia < A.records.size() && A.records[ia].t <= e.t) {
      b.pushAcc(A.records[ia].t, Vec3(A.records[ia].ang[0], A.records[ia].ang[1], A.records[ia].ang[2]));
      ++ia;
    }
    b.pushHeads(e);
  }
  for (; ia < A.records.size(); ++ia)
    b.pushAcc(A.records[ia].t, Vec3(A.records[ia].ang[0], A.records[ia].ang[1], A.records[ia].ang[2]));
  b.finish();
  const CalibrationSpan& span = b.span();
  std::printf("%s: %zu head records, %zu acc records -> %zu epochs (%llu dropped without acc), %.0f s\n", dir.c_str(),
              S.records.size(), A.records.size(), span.obs.size(), static_cast<unsigned long long>(span.dropped_no_acc),
              toSeconds(span.t_last - span.t_first));
  const SolveResult r = solve(span, opt);
  if (!r.ok) {
    std::printf("refused: %s\n", r.message.c_str());
    return 3;
  }
  std::printf("%s\n", r.message.c_str());
  ModelParameters tp;
  for (int h = 0; h < cfg.heads.n_heads; ++h) {
    const Mat3 C = q_true[static_cast<std::size_t>(h)].toRotationMatrix() * C_B_A_true * C_B_A_nom.transpose();
    tp.r_S[static_cast<std::size_t>(h)] =
        core::so3Log(C * cfg.heads.head[static_cast<std::size_t>(h)].q_Si_B.toRotationMatrix().transpose());
  }
  tp.acc_bias = vecNode(a["bias_rad_s2"]);
  tp.acc_scale = vecNode(a["scale_error"]);
  tp.time_offset_s = a["time_offset_s"].as<double>();
  const HeadCovariance crlb_truth = cramerRao(span, opt, tp);
  double nees = 0;
  int dim = 0;
  std::printf("head axis | estimate\" | truth\"    | sigma\" | CRLB(truth)\" | z\n");
  for (int h = 0; h < cfg.heads.n_heads; ++h)
    for (int i = 0; i < 3; ++i) {
      const HeadResult& hr = r.heads[static_cast<std::size_t>(h)];
      const double t = tp.r_S[static_cast<std::size_t>(h)][i] * kArcsecPerRad;
      const int k = 3 * h + i;
      const double cr = crlb_truth.determined[static_cast<std::size_t>(k)] ? std::sqrt(crlb_truth.P(k, k)) * kArcsecPerRad
                                                                          : INFINITY;
      if (hr.sigma_arcsec[static_cast<std::size_t>(i)]) {
        const double z = (hr.error_angles_arcsec[static_cast<std::size_t>(i)] - t) / *hr.sigma_arcsec[static_cast<std::size_t>(i)];
        std::printf("  %d  %c    | %9.1f | %9.1f | %6.1f | %11.1f | %+.2f\n", hr.id, "xyz"[i],
                    hr.error_angles_arcsec[static_cast<std::size_t>(i)], t, *hr.sigma_arcsec[static_cast<std::size_t>(i)], cr, z);
      } else {
        std::printf("  %d  %c    | %9.1f | %9.1f |   null | %11.1f | not observable\n", hr.id, "xyz"[i],
                    hr.error_angles_arcsec[static_cast<std::size_t>(i)], t, cr);
      }
    }
  {
    std::vector<int> det;
    const int n3 = 3 * cfg.heads.n_heads;
    for (int k = 0; k < n3; ++k)
      if (r.heads[static_cast<std::size_t>(k / 3)].observable[static_cast<std::size_t>(k % 3)]) det.push_back(k);
    Eigen::MatrixXd P(det.size(), det.size());
    Eigen::VectorXd e(det.size());
    for (std::size_t x = 0; x < det.size(); ++x) {
      e[static_cast<Eigen::Index>(x)] = r.heads[static_cast<std::size_t>(det[x] / 3)].error_angles_arcsec[static_cast<std::size_t>(det[x] % 3)] -
                                        tp.r_S[static_cast<std::size_t>(det[x] / 3)][det[x] % 3] * kArcsecPerRad;
      for (std::size_t y = 0; y < det.size(); ++y)
        P(static_cast<Eigen::Index>(x), static_cast<Eigen::Index>(y)) = r.covariance_arcsec2[static_cast<std::size_t>(det[x] * n3 + det[y])];
    }
    if (!det.empty()) {
      nees = e.dot(P.ldlt().solve(e));
      dim = static_cast<int>(det.size());
      // the common rotation alone: the three largest eigen-directions of the covariance (the relative
      // part's truth moves with the simulator's thermal effects; its sigma is that of the span mean)
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(P);
      double nc = 0;
      const auto nd = static_cast<int>(det.size());
      for (int k = std::max(0, nd - 3); k < nd; ++k) {
        const double p = es.eigenvectors().col(k).dot(e);
        nc += p * p / es.eigenvalues()[k];
      }
      std::printf("NEES of the common rotation %.2f (dim %d)\n", nc, std::min(3, nd));
    }
  }
  std::printf("NEES %.2f (dim %d)\n", nees, dim);
  if (r.acc_bias_radps2)
    for (int i = 0; i < 3; ++i)
      std::printf("bias %c: %.4e (truth %.4e, sigma %.1e)\n", "xyz"[i], r.acc_bias_radps2->value[static_cast<std::size_t>(i)],
                  tp.acc_bias[i], r.acc_bias_radps2->sigma[static_cast<std::size_t>(i)].value_or(NAN));
  if (r.acc_scale)
    for (int i = 0; i < 3; ++i)
      std::printf("scale %c: %.5f (truth %.5f, sigma %.5f)\n", "xyz"[i], r.acc_scale->value[static_cast<std::size_t>(i)],
                  tp.acc_scale[i], r.acc_scale->sigma[static_cast<std::size_t>(i)].value_or(NAN));
  if (r.time_offset_s)
    std::printf("time offset: %.4f s (truth %.4f, sigma %.4f)\n", *r.time_offset_s, tp.time_offset_s,
                r.time_offset_sigma_s.value_or(NAN));
  std::printf("unobservable directions: %zu; residual RMS %.3e rad/s^2; rejected head epochs %zu\n",
              r.unobservable_directions_B.size(), r.residual_rms_radps2, r.rejected_head_epochs);
  return 0;
}

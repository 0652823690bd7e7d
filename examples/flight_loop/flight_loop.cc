// flight_loop: steps boresight's real-time core from a host loop, as flight software would: one
// configure() at start-up (all memory sized there), then per cycle the star-sensor heads' epoch and the
// accelerometer samples in, and the completed output rows out. No files, no LCM, no heap after
// configure(). The inputs here are synthetic: a body turning slowly about y with a small wobble, seen by
// three heads with GRACE-FO-like mountings, and the matching angular acceleration in the accelerometer
// frame. Prints the last row and the health counters; exit status 1 if the core produced no usable rows.
#include <boresight/core/pipeline.h>

#include <cmath>
#include <cstdio>

using namespace boresight;
using namespace boresight::core;

namespace {

/// Body attitude q_I_B at time t (s): orbit-rate pitch plus a 100 s wobble about x.
Quat bodyAttitude(double t) {
  const double w0 = 2 * M_PI / 5400.0, a = 1e-3, wm = 2 * M_PI / 100.0;
  return Quat(Eigen::AngleAxisd(w0 * t, Vec3::UnitY())) * Quat(Eigen::AngleAxisd(a * std::sin(wm * t), Vec3::UnitX()));
}
/// Its angular acceleration in B (the wobble's), rad/s^2.
Vec3 bodyAngularAcceleration(double t) {
  const double a = 1e-3, wm = 2 * M_PI / 100.0;
  return Vec3(-a * wm * wm * std::sin(wm * t), 0, 0);
}

}  // namespace

int main() {
  PipelineConfig cfg;
  cfg.heads.n_heads = 3;
  const Vec3 axes[3] = {Vec3(0, 1, -1).normalized(), Vec3(0, -1, -1).normalized(), Vec3(1, 0, -1).normalized()};
  for (int k = 0; k < 3; ++k) {
    auto& h = cfg.heads.head[static_cast<std::size_t>(k)];
    h.id = k + 1;
    // The head's boresight +z along axes[k] (in B): q_Si_B rotates B coordinates into Si.
    h.q_Si_B = Quat::FromTwoVectors(axes[k], Vec3::UnitZ());
  }
  Pipeline pipe;  // a flight build would make this a static object
  if (pipe.configure(cfg) != Status::kOk) {
    std::fprintf(stderr, "flight_loop: the core refused its configuration\n");
    return 1;
  }
  const Mat3 C_A_B = cfg.C_B_A.transpose();
  const TimeUs t0 = 738849600LL * kUsPerSecond;  // 2023-06-01 00:00:00 GPS
  PipelineRow row, last;
  long rows = 0, with_rates = 0;
  // The host loop: 10 Hz cycles for 10 minutes; heads at 2 Hz, the accelerometer every cycle.
  for (int cycle = 0; cycle < 6000; ++cycle) {
    const TimeUs t = t0 + cycle * (kUsPerSecond / 10);
    const double ts = static_cast<double>(t - t0) * 1e-6;
    if (cycle % 5 == 0) {
      HeadEpoch e;
      e.t = t;
      e.n = 3;
      const Quat q_I_B = bodyAttitude(ts);
      for (int k = 0; k < 3; ++k) {
        auto& s = e.sample[static_cast<std::size_t>(k)];
        s.head_id = k + 1;
        s.q_I_Si = q_I_B * cfg.heads.head[static_cast<std::size_t>(k)].q_Si_B.conjugate();
      }
      pipe.stepHeads(e);
    }
    pipe.stepAcc(t, C_A_B * bodyAngularAcceleration(ts));
    while (pipe.popRow(row)) {
      ++rows;
      with_rates += row.has_rates && row.has_acc;
      last = row;
    }
  }
  pipe.flush();
  while (pipe.popRow(row)) ++rows;
  const Health h = pipe.health();
  std::printf("flight_loop: %ld rows, %ld with rate and accelerometer values; last complete row at +%.0f s:\n", rows,
              with_rates, static_cast<double>(last.t - t0) * 1e-6);
  std::printf("  w_B = (%.3e, %.3e, %.3e) rad/s, a_sc_B.x = %.3e, a_acc_B.x = %.3e rad/s^2\n", last.w_B.x(),
              last.w_B.y(), last.w_B.z(), last.a_sc_B.x(), last.a_acc_B.x());
  std::printf("  core health: %llu ok, %llu rejected\n", static_cast<unsigned long long>(h.count(Status::kOk)),
              static_cast<unsigned long long>(h.rejected()));
  // The star sensors' and the accelerometer's angular acceleration must agree on this noise-free input.
  const bool ok = with_rates > 400 && h.rejected() == 0 && std::abs(last.a_sc_B.x() - last.a_acc_B.x()) < 1e-7;
  return ok ? 0 : 1;
}

// Helpers for the simulator tests: the GRACE-FO scenario, a capturing sink, rotation residuals.
#pragma once

#include <boresight/model/rotation.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace boresight::simtest {

inline std::string sourceDir() { return BORESIGHT_SOURCE_DIR; }

inline sim::Scenario gracefo() {
  sim::Scenario sc;
  std::string err;
  EXPECT_TRUE(sim::loadScenario(sourceDir() + "/config/sim_gracefo.yaml", sc, &err)) << err;
  return sc;
}

/// Keeps every sample in memory (tests only: short runs).
struct Capture : sim::SimSink {
  std::vector<sim::HeadSampleOut> heads;  // delivered and blinded
  std::vector<sim::AccSampleOut> acc;
  std::vector<sim::OrbitSampleOut> orb;
  std::vector<sim::StarVectorsOut> sv;
  void stars(const sim::StarVectorsOut& s) override { sv.push_back(s); }
  void head(const sim::HeadSampleOut& s) override { heads.push_back(s); }
  void accel(const sim::AccSampleOut& a) override { acc.push_back(a); }
  void orbit(const sim::OrbitSampleOut& o) override { orb.push_back(o); }
  std::vector<sim::HeadSampleOut> head(int id, bool delivered_only = true) const {
    std::vector<sim::HeadSampleOut> v;
    for (const auto& h : heads)
      if (h.head == id && (!delivered_only || !h.blind)) v.push_back(h);
    return v;
  }
};

struct Run {
  sim::Simulator sim;
  Capture cap;
};

inline std::unique_ptr<Run> run(const sim::Scenario& sc, std::uint64_t seed, double duration_s) {
  auto r = std::make_unique<Run>();
  std::string err;
  EXPECT_TRUE(r->sim.init(sc, seed, duration_s, &err)) << err;
  r->sim.run(r->cap);
  return r;
}

inline sim::Scenario withEffects(sim::Scenario sc, const std::vector<std::string>& args) {
  std::string err;
  EXPECT_TRUE(sim::addEffectArgs(sc, args, &err)) << err;
  return sc;
}

/// Rotation vector (head frame) taking a to b: b = a (x) Exp(phi).
inline Vec3 rotBetween(const Quat& a, const Quat& b) { return model::quatLog(a.conjugate() * b); }

inline bool sameQuat(const Quat& a, const Quat& b) { return a.coeffs() == b.coeffs(); }

/// Inter-boresight angle between two head attitudes (boresight +z).
inline double iba(const Quat& q1, const Quat& q2) {
  const Vec3 b1 = q1 * Vec3::UnitZ(), b2 = q2 * Vec3::UnitZ();
  return std::atan2(b1.cross(b2).norm(), b1.dot(b2));
}

/// Least-squares amplitudes of cos/sin(k u), k = 0..kmax, for a series y(u): returns |c_k|.
inline std::vector<double> harmonicAmplitudes(const std::vector<double>& u, const std::vector<double>& y, int kmax) {
  const int m = 2 * kmax + 1;
  Eigen::MatrixXd A(static_cast<Eigen::Index>(u.size()), m);
  Eigen::VectorXd b(static_cast<Eigen::Index>(u.size()));
  for (std::size_t i = 0; i < u.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    A(r, 0) = 1;
    for (int k = 1; k <= kmax; ++k) {
      A(r, 2 * k - 1) = std::cos(k * u[i]);
      A(r, 2 * k) = std::sin(k * u[i]);
    }
    b(r) = y[i];
  }
  const Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
  std::vector<double> amp(static_cast<std::size_t>(kmax) + 1);
  amp[0] = std::abs(x(0));
  for (int k = 1; k <= kmax; ++k) amp[static_cast<std::size_t>(k)] = std::hypot(x(2 * k - 1), x(2 * k));
  return amp;
}

}  // namespace boresight::simtest

#include <boresight/io/level1.h>
#include <boresight/model/orbit_context.h>
#include <boresight/model/ephemeris.h>
#include <boresight/sim/orbit.h>

#include <algorithm>
#include <cmath>

namespace boresight::sim {

OrbitState Orbit::state(double t) const {
  OrbitState s;
  posVel(t, s.r_I, s.v_I);
  s.arg_lat_rad = model::argumentOfLatitude(s.r_I, s.v_I);
  s.sun_I = model::sunDirection(t);
  s.beta_rad = model::betaAngle(s.r_I, s.v_I, s.sun_I);
  return s;
}

CircularOrbit::CircularOrbit(const OrbitConfig& cfg, double t0)
    : a_(model::kEarthRadius_m + cfg.altitude_m),
      n_(std::sqrt(model::kEarthMu_m3_s2 / (a_ * a_ * a_))),
      inc_(cfg.inclination_rad),
      raan0_(cfg.raan_rad),
      raan_rate_(0),
      u0_(cfg.arg_lat0_rad),
      t0_(t0) {
  if (cfg.j2_nodal_precession) {
    const double p = model::kEarthRadius_m / a_;
    raan_rate_ = -1.5 * n_ * model::kJ2 * p * p * std::cos(inc_);
  }
}

void CircularOrbit::posVel(double t, Vec3& r, Vec3& v) const {
  const double dt = t - t0_;
  const double u = u0_ + n_ * dt, raan = raan0_ + raan_rate_ * dt;
  const double cO = std::cos(raan), sO = std::sin(raan), ci = std::cos(inc_), si = std::sin(inc_);
  const Vec3 P(cO, sO, 0), Q(-ci * sO, ci * cO, si);
  const double cu = std::cos(u), su = std::sin(u);
  r = a_ * (cu * P + su * Q);
  // The node's slow motion adds raan_rate * z x r to the velocity.
  v = a_ * n_ * (-su * P + cu * Q) + raan_rate_ * Vec3::UnitZ().cross(r);
}

void TabulatedOrbit::posVel(double t, Vec3& r, Vec3& v) const {
  if (nodes_.size() < 2) {
    r = v = Vec3::Zero();
    return;
  }
  auto it = std::upper_bound(nodes_.begin(), nodes_.end(), t, [](double x, const Node& n) { return x < n.t; });
  std::size_t i = it == nodes_.begin() ? 0 : static_cast<std::size_t>(it - nodes_.begin()) - 1;
  i = std::min(i, nodes_.size() - 2);
  const Node &a = nodes_[i], &b = nodes_[i + 1];
  const double h = b.t - a.t, s = (t - a.t) / h;
  const double s2 = s * s, s3 = s2 * s;
  const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
  r = h00 * a.r + h10 * h * a.v + h01 * b.r + h11 * h * b.v;
  const double d00 = (6 * s2 - 6 * s) / h, d10 = 3 * s2 - 4 * s + 1, d01 = (-6 * s2 + 6 * s) / h, d11 = 3 * s2 - 2 * s;
  v = d00 * a.r + d10 * a.v + d01 * b.r + d11 * b.v;
}

std::unique_ptr<Orbit> makeOrbit(const OrbitConfig& cfg, double t0, double duration_s, std::string* error) {
  if (cfg.type == OrbitConfig::Type::Circular) return std::make_unique<CircularOrbit>(cfg, t0);
  auto f = io::readProduct<io::GnvRecord>(cfg.gnv1b_file);
  if (!f.ok) {
    if (error) *error = f.error;
    return nullptr;
  }
  std::vector<TabulatedOrbit::Node> nodes;
  nodes.reserve(f.records.size());
  const Vec3 w(0, 0, model::kEarthRate_rad_s);
  for (const auto& g : f.records) {
    const double t = toSeconds(g.t);
    const Vec3 r(g.pos[0], g.pos[1], g.pos[2]), v(g.vel[0], g.vel[1], g.vel[2]);
    if (g.coord_ref == 'I') {
      nodes.push_back({t, r, v});
    } else {
      const Mat3 C_I_E = model::C_E_I(t).transpose();
      nodes.push_back({t, C_I_E * r, C_I_E * (v + w.cross(r))});
    }
  }
  std::sort(nodes.begin(), nodes.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
  if (nodes.size() < 2 || nodes.front().t > t0 + 1e-6 || nodes.back().t < t0 + duration_s - 1e-6) {
    if (error)
      *error = cfg.gnv1b_file + ": GNV1B records do not cover the simulated span (" + std::to_string(nodes.size()) +
               " records)";
    return nullptr;
  }
  return std::make_unique<TabulatedOrbit>(std::move(nodes));
}

}  // namespace boresight::sim

// Orbits for the simulator: a circular LEO (altitude, inclination, node, argument of latitude at the
// start epoch, optional J2 nodal precession), or positions tabulated from a GNV1B file.
// All positions and velocities are inertial (J2000 mean equator, see ephemeris.h), metres and m/s.
#pragma once

#include <boresight/core/conventions.h>

#include <memory>
#include <string>
#include <vector>

namespace boresight::sim {

struct OrbitConfig {
  enum class Type { Circular, Gnv1b } type = Type::Circular;
  double altitude_m = 490e3;
  double inclination_rad = 89.0 * kRadPerDeg;
  double raan_rad = 0;           ///< right ascension of the ascending node at the start epoch
  double arg_lat0_rad = 0;       ///< argument of latitude at the start epoch
  bool j2_nodal_precession = true;
  std::string gnv1b_file;        ///< Type::Gnv1b: GNV1B (Earth-fixed) or GNI1B (inertial) file
};

struct OrbitState {
  Vec3 r_I = Vec3::Zero();  ///< position, m
  Vec3 v_I = Vec3::Zero();  ///< velocity, m/s
  double arg_lat_rad = 0;   ///< argument of latitude (angle from the ascending node in the orbit plane)
  double beta_rad = 0;      ///< Sun elevation above the orbit plane
  Vec3 sun_I = Vec3::UnitX();  ///< unit vector to the Sun (geocentric)
};

class Orbit {
 public:
  virtual ~Orbit() = default;
  /// Position and velocity at GPS time t (s past the GPS J2000 epoch).
  virtual void posVel(double t_gps_s, Vec3& r_I, Vec3& v_I) const = 0;
  /// Full state with argument of latitude and beta angle.
  OrbitState state(double t_gps_s) const;
};

class CircularOrbit : public Orbit {
 public:
  CircularOrbit(const OrbitConfig& cfg, double t0_gps_s);
  void posVel(double t_gps_s, Vec3& r_I, Vec3& v_I) const override;
  double meanMotion() const { return n_; }

 private:
  double a_, n_, inc_, raan0_, raan_rate_, u0_, t0_;
};

/// Piecewise cubic Hermite interpolation of tabulated positions and velocities (inertial).
class TabulatedOrbit : public Orbit {
 public:
  struct Node {
    double t;
    Vec3 r, v;
  };
  explicit TabulatedOrbit(std::vector<Node> nodes) : nodes_(std::move(nodes)) {}
  void posVel(double t_gps_s, Vec3& r_I, Vec3& v_I) const override;
  double begin() const { return nodes_.empty() ? 0 : nodes_.front().t; }
  double end() const { return nodes_.empty() ? 0 : nodes_.back().t; }

 private:
  std::vector<Node> nodes_;
};

/// Builds the configured orbit. A GNV1B orbit is read through the io readers; Earth-fixed records
/// are rotated to inertial with the mean sidereal angle. Returns nullptr with *error on failure
/// (unreadable file, fewer than 2 records, or the simulation span not covered).
std::unique_ptr<Orbit> makeOrbit(const OrbitConfig& cfg, double t0_gps_s, double duration_s, std::string* error);

}  // namespace boresight::sim

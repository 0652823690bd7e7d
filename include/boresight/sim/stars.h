// Star catalogue (a bright subset of Hipparcos 2, config/stars_bright.csv, made by
// tools/extract_stars.py) and field-of-view queries for the simulated heads.
#pragma once

#include <boresight/core/conventions.h>

#include <string>
#include <vector>

namespace boresight::sim {

struct Star {
  int hip = 0;
  Vec3 u_I = Vec3::UnitX();  ///< unit direction, inertial (ICRS, J2000)
  double mag = 0;            ///< Hipparcos Hp
};

class StarCatalogue {
 public:
  /// Reads "hip,ra_deg,dec_deg,hp_mag" lines ('#' comments and one header line allowed).
  bool load(const std::string& path, std::string* error);
  const std::vector<Star>& stars() const { return stars_; }
  double faintest() const { return faintest_; }
  /// Indices of the stars within half_angle of dir (unit, inertial) and not fainter than max_mag.
  void inCone(const Vec3& dir, double half_angle_rad, double max_mag, std::vector<int>& out) const;
  std::size_t countInCone(const Vec3& dir, double half_angle_rad, double max_mag) const;

 private:
  std::vector<Star> stars_;
  std::vector<int> by_z_;      ///< star indices sorted by u_I.z (sin of declination)
  std::vector<double> z_sorted_;
  double faintest_ = -99;
};

/// Star vectors of a head: the catalogue stars in its field of view, in head coordinates
/// (s_Si = C_Si_I u_I), as a library call for tests and the audit.
std::vector<Vec3> starVectorsInHead(const StarCatalogue& cat, const Quat& q_I_Si, const Vec3& boresight_Si,
                                    double half_angle_rad, double max_mag);

/// Streaming counter: keeps the stars within half_angle + margin of the last refresh direction and
/// rescans the whole catalogue only when the boresight has moved more than the margin.
class FovStarCounter {
 public:
  FovStarCounter(const StarCatalogue* cat, double half_angle_rad, double max_mag, double margin_rad = 3 * kRadPerDeg)
      : cat_(cat), half_(half_angle_rad), mag_(max_mag), margin_(margin_rad) {}
  int count(const Vec3& boresight_I);
  /// The stars in the field of view (catalogue indices, ascending), from the same cached candidates.
  void select(const Vec3& boresight_I, std::vector<int>& out);
  std::uint64_t refreshes() const { return refreshes_; }

 private:
  void refresh(const Vec3& boresight_I);
  const StarCatalogue* cat_;
  double half_, mag_, margin_;
  Vec3 centre_ = Vec3::Zero();
  std::vector<int> cand_;
  std::uint64_t refreshes_ = 0;
};

}  // namespace boresight::sim

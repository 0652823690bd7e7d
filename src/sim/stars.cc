#include <boresight/sim/stars.h>
#include <boresight/io/files.h>
#include <sstream>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>

namespace boresight::sim {

bool StarCatalogue::load(const std::string& path, std::string* error) {
  std::string text;
  if (!io::readBounded(path, io::kMaxTableBytes, "star catalogue", text, error)) return false;
  std::istringstream in(text);
  stars_.clear();
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#' || line.rfind("hip,", 0) == 0) continue;
    const char* p = line.c_str();
    char* e = nullptr;
    double v[4];
    bool ok = true;
    for (int k = 0; k < 4 && ok; ++k) {
      v[k] = std::strtod(p, &e);
      ok = e != p && std::isfinite(v[k]);
      if (k < 3) ok = ok && *e == ',';
      p = e + 1;
    }
    if (!ok) {
      if (error) *error = path + ":" + std::to_string(line_no) + ": expected hip,ra_deg,dec_deg,hp_mag";
      return false;
    }
    const double ra = v[1] * kRadPerDeg, dec = v[2] * kRadPerDeg;
    stars_.push_back({static_cast<int>(v[0]), Vec3(std::cos(dec) * std::cos(ra), std::cos(dec) * std::sin(ra), std::sin(dec)), v[3]});
    faintest_ = std::max(faintest_, v[3]);
  }
  if (stars_.empty()) {
    if (error) *error = path + ": no stars";
    return false;
  }
  by_z_.resize(stars_.size());
  for (std::size_t i = 0; i < stars_.size(); ++i) by_z_[i] = static_cast<int>(i);
  std::sort(by_z_.begin(), by_z_.end(), [&](int a, int b) {
    return stars_[static_cast<std::size_t>(a)].u_I.z() < stars_[static_cast<std::size_t>(b)].u_I.z();
  });
  z_sorted_.resize(stars_.size());
  for (std::size_t i = 0; i < stars_.size(); ++i) z_sorted_[i] = stars_[static_cast<std::size_t>(by_z_[i])].u_I.z();
  return true;
}

void StarCatalogue::inCone(const Vec3& dir, double half_angle_rad, double max_mag, std::vector<int>& out) const {
  out.clear();
  const double c = std::cos(half_angle_rad);
  // Only the declination band that can hold the cone: z = sin(dec) within sin(dec0 -+ r).
  const double dec0 = std::asin(std::clamp(dir.z(), -1.0, 1.0));
  const double zlo = std::sin(std::max(-kPi / 2, dec0 - half_angle_rad)) - 1e-12;
  const double zhi = std::sin(std::min(kPi / 2, dec0 + half_angle_rad)) + 1e-12;
  auto it = std::lower_bound(z_sorted_.begin(), z_sorted_.end(), zlo);
  for (auto k = static_cast<std::size_t>(it - z_sorted_.begin()); k < z_sorted_.size() && z_sorted_[k] <= zhi; ++k) {
    const auto i = static_cast<std::size_t>(by_z_[k]);
    if (stars_[i].mag <= max_mag && stars_[i].u_I.dot(dir) >= c) out.push_back(static_cast<int>(i));
  }
  std::sort(out.begin(), out.end());
}

std::size_t StarCatalogue::countInCone(const Vec3& dir, double half_angle_rad, double max_mag) const {
  std::vector<int> v;
  inCone(dir, half_angle_rad, max_mag, v);
  return v.size();
}

std::vector<Vec3> starVectorsInHead(const StarCatalogue& cat, const Quat& q_I_Si, const Vec3& boresight_Si,
                                    double half_angle_rad, double max_mag) {
  std::vector<int> idx;
  cat.inCone((q_I_Si * boresight_Si).normalized(), half_angle_rad, max_mag, idx);
  std::vector<Vec3> out;
  out.reserve(idx.size());
  const Quat q_Si_I = q_I_Si.conjugate();
  for (int i : idx) out.push_back(q_Si_I * cat.stars()[static_cast<std::size_t>(i)].u_I);
  return out;
}

void FovStarCounter::refresh(const Vec3& b) {
  if (centre_.isZero() || b.dot(centre_) < std::cos(0.9 * margin_)) {
    cat_->inCone(b, half_ + margin_, mag_, cand_);
    centre_ = b;
    ++refreshes_;
  }
}

void FovStarCounter::select(const Vec3& b, std::vector<int>& out) {
  refresh(b);
  out.clear();
  const double c = std::cos(half_);
  for (int i : cand_)
    if (cat_->stars()[static_cast<std::size_t>(i)].u_I.dot(b) >= c) out.push_back(i);
}

int FovStarCounter::count(const Vec3& b) {
  refresh(b);
  const double c = std::cos(half_);
  int n = 0;
  for (int i : cand_) n += cat_->stars()[static_cast<std::size_t>(i)].u_I.dot(b) >= c;
  return n;
}

}  // namespace boresight::sim

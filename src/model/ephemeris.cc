#include <boresight/model/ephemeris.h>

#include <cmath>

namespace boresight::model {
namespace {
constexpr double kGpsMinusUtc = 18.0;
inline double deg(double d) { return d * kRadPerDeg; }
inline double daysTT(double t) { return (t + kTtMinusGps) / 86400.0; }
}  // namespace

Vec3 moonPosition(double t) {
  const double T = daysTT(t) / 36525.0;
  auto s = [](double a) { return std::sin(deg(a)); };
  auto c = [](double a) { return std::cos(deg(a)); };
  const double lam = 218.32 + 481267.881 * T + 6.29 * s(135.0 + 477198.87 * T) - 1.27 * s(259.3 - 413335.36 * T) +
                     0.66 * s(235.7 + 890534.22 * T) + 0.21 * s(269.9 + 954397.74 * T) -
                     0.19 * s(357.5 + 35999.05 * T) - 0.11 * s(186.5 + 966404.03 * T);
  const double bet = 5.13 * s(93.3 + 483202.02 * T) + 0.28 * s(228.2 + 960400.89 * T) -
                     0.28 * s(318.3 + 6003.15 * T) - 0.17 * s(217.6 - 407332.21 * T);
  const double par = 0.9508 + 0.0518 * c(135.0 + 477198.87 * T) + 0.0095 * c(259.3 - 413335.36 * T) +
                     0.0078 * c(235.7 + 890534.22 * T) + 0.0028 * c(269.9 + 954397.74 * T);
  const double r = 6378140.0 / std::sin(deg(par));
  const Vec3 ecl(c(bet) * c(lam), c(bet) * s(lam), s(bet));
  const double eps = deg(23.439 - 0.0000004 * daysTT(t));
  return r * Vec3(ecl.x(), std::cos(eps) * ecl.y() - std::sin(eps) * ecl.z(),
                  std::sin(eps) * ecl.y() + std::cos(eps) * ecl.z());
}

double gmst(double t) {
  const double d_ut = (t - kGpsMinusUtc) / 86400.0;
  double g = std::fmod(280.46061837 + 360.98564736629 * d_ut, 360.0);
  if (g < 0) g += 360.0;
  return deg(g);
}

Mat3 C_E_I(double t) {
  const double g = gmst(t), cg = std::cos(g), sg = std::sin(g);
  Mat3 m;
  m << cg, sg, 0, -sg, cg, 0, 0, 0, 1;
  return m;
}

}  // namespace boresight::model

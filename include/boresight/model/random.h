// Counter-based pseudo-random numbers: every draw is a pure function of (seed, stream, index).
//
// Why counter-based: a simulated effect must change what it should and nothing else. With one
// sequential generator, switching on (say) outliers would consume draws and shift every later noise
// sample. Here head 2's noise at epoch n is the same number whether or not any other effect is on,
// and the result does not depend on the standard library's distribution implementations.
#pragma once

#include <cmath>
#include <cstdint>

namespace boresight::model {

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// Named random streams. Values are part of the reproducibility contract: do not renumber.
enum class Stream : std::uint64_t {
  HeadNoise = 1, HeadOutlier = 2, HeadSignFlip = 3, HeadGap = 4, HeadTagJitter = 5, StarNoise = 6,
  HeadColouredNoise = 7, HeadFovField = 8, HeadThermalWander = 9,  // appended: coloured_noise, fov_error, thermal_wander
  AccNoise = 11, AccLowFreq = 12, AccGap = 13, AccTagJitter = 14,
  AccColouredNoise = 15, AccBiasWander = 16,                       // appended: acc_coloured_noise, acc_bias_wander
  Attitude = 21, MountingDraw = 22, Magnetic = 23,
};

class CounterRng {
 public:
  CounterRng(std::uint64_t seed, Stream stream, std::uint64_t sensor)
      : key_(mix64(mix64(seed) ^ mix64(static_cast<std::uint64_t>(stream) * 0x1000193ULL + sensor))) {}
  /// Another independent stream derived from this one (c > 0; c = 0 is this stream): for a consumer
  /// that needs more than the eight normals one index carries per sample.
  CounterRng derived(std::uint64_t c) const {
    CounterRng r = *this;
    if (c > 0) r.key_ = mix64(key_ ^ mix64(0x6a09e667f3bcc909ULL + c));
    return r;
  }
  /// sub must be < 8: bits(index, 8) is bits(index + 1, 0).
  std::uint64_t bits(std::uint64_t index, std::uint64_t sub = 0) const {
    return mix64(key_ ^ mix64(index * 8 + sub));
  }
  /// Uniform in (0, 1), never 0 or 1.
  double uniform(std::uint64_t index, std::uint64_t sub = 0) const {
    return (static_cast<double>(bits(index, sub) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }
  /// Standard normal (Box-Muller on two counter draws): subs 2k and 2k+1 share one pair of draws
  /// (cosine and sine branch), so normal2() gives both at the cost of one.
  double normal(std::uint64_t index, std::uint64_t sub = 0) const {
    const double u1 = uniform(index, 2 * (sub / 2)), u2 = uniform(index, 2 * (sub / 2) + 1);
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 6.283185307179586 * u2;
    return r * ((sub & 1) ? std::sin(a) : std::cos(a));
  }
  /// normal(index, 2k) and normal(index, 2k+1) together.
  void normal2(std::uint64_t index, std::uint64_t k, double& n0, double& n1) const {
    const double u1 = uniform(index, 2 * k), u2 = uniform(index, 2 * k + 1);
    const double r = std::sqrt(-2.0 * std::log(u1)), a = 6.283185307179586 * u2;
    n0 = r * std::cos(a);
    n1 = r * std::sin(a);
  }

 private:
  std::uint64_t key_;
};

}  // namespace boresight::model

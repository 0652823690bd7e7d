// Links the installed libraries and checks one convention and one reader call.
#include <boresight/core/conventions.h>
#include <boresight/io/level1.h>

#include <cmath>
#include <cstdio>

int main() {
  boresight::Quat q = boresight::quatFromScalarFirst(std::sqrt(0.5), 0, 0, std::sqrt(0.5));  // 90 deg about z
  boresight::Vec3 v = q * boresight::Vec3::UnitX();
  auto f = boresight::io::parseProduct<boresight::io::Sca1aRecord>("", "SCA1A_empty.txt");
  bool ok = std::abs(v.y() - 1.0) < 1e-12 && !f.ok;  // R(q) x = y; an empty file has no header
  std::printf("consumer: %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}

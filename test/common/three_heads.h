// A three-head set of the tests and benchmarks of the thermal model: heads 1-3 mounted at three
// well-separated rotations from the body (not GRACE-FO's, but as far apart), the core's default noise.
#pragma once

#include <boresight/core/heads.h>
#include <boresight/core/rotation.h>

namespace testutil {

inline boresight::core::HeadSetConfig threeTiltedHeads() {
  using namespace boresight;
  core::HeadSetConfig c;
  c.n_heads = 3;
  const Vec3 axes[3] = {Vec3(1.2, 0.3, -0.4), Vec3(-1.1, 0.9, 0.2), Vec3(0.1, -1.3, 1.0)};
  for (int k = 0; k < 3; ++k) {
    c.head[static_cast<std::size_t>(k)].id = k + 1;
    c.head[static_cast<std::size_t>(k)].q_Si_B = core::quatExp(axes[k]);
  }
  return c;
}

}  // namespace testutil

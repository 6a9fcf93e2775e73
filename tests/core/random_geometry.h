// Random geometry shared by the kernel tests.
#pragma once

#include <random>

#include "core/math.h"

namespace restir::test {

// A uniformly distributed unit vector (normalised Gaussian triple).
inline Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (;;) {
    const Vec3 v(n(rng), n(rng), n(rng));
    const float l = glm::length(v);
    if (l > 1e-3f) return v / l;
  }
}

}  // namespace restir::test

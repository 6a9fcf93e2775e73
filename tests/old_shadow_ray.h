// The shadow-ray rule before issue 13, kept for tests as the counter-example: origin offset 1e-4 (1 + max|x|)
// along the receiver's normal, direction kept from x to y, tmax 1e-3 short of y. At grazing emission the
// displaced ray crosses the emitter's own plane inside the emitter, and the offset grows with distance from the
// origin.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/shadow_ray.h"

namespace restir {

inline ShadowRaySegment OldShadowRaySetup(const Vec3& position, const Vec3& geometricNormal,
                                          const Vec3& lightPosition) {
  const Vec3 toLight = lightPosition - position;
  ShadowRaySegment ray;
  ray.dir = toLight / glm::length(toLight);
  const float scale = std::max(std::fabs(position.x), std::max(std::fabs(position.y), std::fabs(position.z)));
  const float side = glm::dot(geometricNormal, ray.dir) >= 0.0f ? 1.0f : -1.0f;
  ray.org = position + (side * 1e-4f * (1.0f + scale)) * geometricNormal;
  ray.tmax = glm::length(lightPosition - ray.org) * (1.0f - 1e-3f);
  return ray;
}

}  // namespace restir

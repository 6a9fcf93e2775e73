// The reconnection shift of path reuse (ReSTIR GI: Ouyang et al. 2021 §4; shifts in general: Lin et al. 2022,
// GRIS, §7; DESIGN §4 "Path reuse"): a sample vertex x₂, found by a path from primary vertex x₁, is reused at
// another primary vertex y₁ by reconnecting y₁ to x₂, everything after x₂ kept. Pure functions, in the
// solid-angle measure at the primary vertex (ReSTIR GI's form; in area measure at x₂ the shift is the
// identity, Jacobian 1).
#pragma once

#include <cmath>

#include "core/math.h"

namespace restir {

// The direction the shifted path leaves y₁ in: towards x₂ (the shift T maps x₁'s direction to x₂ onto this
// one; its inverse is the same function from x₁).
inline Vec3 ReconnectionDirection(const Vec3& y1, const Vec3& x2) {
  return glm::normalize(x2 - y1);
}

// |∂ω_y / ∂ω_x| of the shift from x₁ to y₁ through x₂ (normal n₂), DESIGN §4 "Path reuse":
// (|cos φ_y| / |cos φ_x|) · (‖x₁ − x₂‖² / ‖y₁ − x₂‖²), φ the angle at x₂ between n₂ and the direction to the
// primary vertex. The solid angle a patch dA of x₂ subtends is |cos φ| dA / d², so the ratio of the two is
// the Jacobian. 0 where either primary vertex lies in x₂'s tangent plane (the patch subtends no solid angle
// from it) or coincides with x₂.
inline float ReconnectionJacobian(const Vec3& x1, const Vec3& y1, const Vec3& x2, const Vec3& n2) {
  const Vec3 dx = x1 - x2, dy = y1 - x2;
  const float lx2 = glm::dot(dx, dx), ly2 = glm::dot(dy, dy);
  const float cosX = std::fabs(glm::dot(n2, dx)), cosY = std::fabs(glm::dot(n2, dy));  // times ‖dx‖, ‖dy‖
  if (!(cosX > 0.0f) || !(ly2 > 0.0f)) return 0.0f;
  // (cosY / ‖dy‖) / (cosX / ‖dx‖) · lx2 / ly2 = cosY · ‖dx‖³ / (cosX · ‖dy‖³)
  const float lx = std::sqrt(lx2), ly = std::sqrt(ly2);
  return (cosY * lx2 * lx) / (cosX * ly2 * ly);
}

}  // namespace restir
